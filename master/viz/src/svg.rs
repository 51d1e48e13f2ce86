//! A tiny SVG writer shared by every picture hevo draws: text escaping, compact number
//! formatting, an element builder and a document that keeps its tags balanced, plus the
//! colour palette and font settings both the replays and the fitness plots use, so the pictures
//! look like one family. It writes strings by hand on purpose: the pictures are simple, and a
//! hand-written writer keeps the crate free of a drawing dependency.

use std::fmt::Write as _;

/// The Okabe-Ito palette, reordered so the colours that read best as thin lines on white come
/// first; yellow is last because it is nearly invisible on white and is only reached when a
/// picture needs more than seven colours.
pub const PALETTE: [&str; 8] = [
    "#0072B2", // blue
    "#E69F00", // orange
    "#009E73", // bluish green
    "#CC79A7", // reddish purple
    "#D55E00", // vermillion
    "#56B4E9", // sky blue
    "#000000", // black
    "#F0E442", // yellow
];

/// The colour of the i-th series, wrapping around the palette.
pub fn palette_colour(index: usize) -> &'static str {
    PALETTE[index % PALETTE.len()]
}

/// Font stack for every text: sans-serif faces present on most systems and in browsers.
pub const FONT_FAMILY: &str = "DejaVu Sans, Helvetica, Arial, sans-serif";
/// Dark grey used for text, axes and walls.
pub const INK: &str = "#333333";

/// Escapes text for use in element content or in a double-quoted attribute value.
pub fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for ch in text.chars() {
        match ch {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            // XML 1.0 forbids most control characters even when escaped, so they are dropped
            // rather than allowed to make the whole picture unreadable.
            c if (c as u32) < 0x20 && c != '\n' && c != '\t' && c != '\r' => {}
            c => out.push(c),
        }
    }
    out
}

/// Formats a number with at most two decimals and no trailing zeros: a hundredth of a pixel
/// is finer than any screen, and short numbers keep long trajectories small. SVG has no
/// notation for NaN or infinity, so a non-finite value is written as 0; callers drop
/// non-finite data before it gets here, this is only the last line of defence.
pub fn num(value: f64) -> String {
    num_with(value, 2)
}

/// Like [`num`], with a chosen number of decimals (for data attributes that tests or tools
/// read back and that need more precision than a drawing does).
pub fn num_with(value: f64, decimals: usize) -> String {
    if !value.is_finite() {
        return "0".to_string();
    }
    let mut text = format!("{value:.decimals$}");
    if text.contains('.') {
        while text.ends_with('0') {
            text.pop();
        }
        if text.ends_with('.') {
            text.pop();
        }
    }
    if text == "-0" {
        text = "0".to_string();
    }
    text
}

/// A list of points in the `points` attribute syntax of `<polyline>` and `<polygon>`.
pub fn points(list: &[[f64; 2]]) -> String {
    let mut out = String::with_capacity(list.len() * 14);
    for (i, [x, y]) in list.iter().enumerate() {
        if i > 0 {
            out.push(' ');
        }
        let _ = write!(out, "{},{}", num(*x), num(*y));
    }
    out
}

/// One element's start tag: a name and its attributes, in the order they were added.
#[derive(Debug, Clone)]
pub struct Tag {
    name: &'static str,
    attributes: String,
}

impl Tag {
    /// A tag with no attributes yet.
    pub fn new(name: &'static str) -> Tag {
        Tag {
            name,
            attributes: String::new(),
        }
    }

    /// Adds a text attribute; the value is escaped.
    pub fn attr(mut self, key: &str, value: impl AsRef<str>) -> Tag {
        let _ = write!(self.attributes, " {key}=\"{}\"", escape(value.as_ref()));
        self
    }

    /// Adds a numeric attribute, formatted by [`num`].
    pub fn num(self, key: &str, value: f64) -> Tag {
        let text = num(value);
        self.attr(key, text)
    }

    /// Adds the `class` attribute.
    pub fn class(self, class: &str) -> Tag {
        self.attr("class", class)
    }

    /// Adds a `points` attribute.
    pub fn points(self, list: &[[f64; 2]]) -> Tag {
        let text = points(list);
        self.attr("points", text)
    }

    /// The element's name.
    pub fn name(&self) -> &'static str {
        self.name
    }
}

/// Path data (`d` attribute) built from commands in pixel coordinates.
#[derive(Debug, Clone, Default)]
pub struct PathData {
    text: String,
}

impl PathData {
    /// An empty path.
    pub fn new() -> PathData {
        PathData::default()
    }

    fn command(&mut self, letter: char, values: &[f64]) {
        if !self.text.is_empty() {
            self.text.push(' ');
        }
        self.text.push(letter);
        for (i, value) in values.iter().enumerate() {
            if i > 0 {
                self.text.push(' ');
            }
            self.text.push_str(&num(*value));
        }
    }

    /// Starts a new sub-path at a point.
    pub fn move_to(mut self, x: f64, y: f64) -> PathData {
        self.command('M', &[x, y]);
        self
    }

    /// A straight line to a point.
    pub fn line_to(mut self, x: f64, y: f64) -> PathData {
        self.command('L', &[x, y]);
        self
    }

    /// A circular arc of radius `radius` to a point; `sweep_positive` is SVG's sweep flag
    /// (clockwise on screen), `large` its large-arc flag.
    pub fn arc_to(
        mut self,
        radius: f64,
        large: bool,
        sweep_positive: bool,
        x: f64,
        y: f64,
    ) -> PathData {
        let large = if large { 1.0 } else { 0.0 };
        let sweep = if sweep_positive { 1.0 } else { 0.0 };
        self.command('A', &[radius, radius, 0.0, large, sweep, x, y]);
        self
    }

    /// Closes the current sub-path.
    pub fn close(mut self) -> PathData {
        self.command('Z', &[]);
        self
    }

    /// The `d` attribute's text.
    pub fn as_str(&self) -> &str {
        &self.text
    }
}

/// An SVG document being written. Elements are opened and closed through it, so its output
/// always has balanced tags; [`SvgDocument::finish`] closes whatever is still open.
#[derive(Debug)]
pub struct SvgDocument {
    out: String,
    open: Vec<&'static str>,
}

impl SvgDocument {
    /// Starts a document of the given pixel size with a white background, so the picture
    /// reads the same on light and dark pages.
    pub fn new(width: f64, height: f64, class: &str) -> SvgDocument {
        let mut doc = SvgDocument {
            out: String::with_capacity(64 * 1024),
            open: Vec::new(),
        };
        let root = Tag::new("svg")
            .attr("xmlns", "http://www.w3.org/2000/svg")
            .attr("version", "1.1")
            .num("width", width)
            .num("height", height)
            .attr("viewBox", format!("0 0 {} {}", num(width), num(height)))
            .class(class)
            .attr("font-family", FONT_FAMILY);
        doc.open(root);
        doc.leaf(
            Tag::new("rect")
                .class("background")
                .num("x", 0.0)
                .num("y", 0.0)
                .num("width", width)
                .num("height", height)
                .attr("fill", "#ffffff"),
        );
        doc
    }

    /// Writes a start tag and keeps the element open until [`SvgDocument::close`].
    pub fn open(&mut self, tag: Tag) {
        self.indent();
        let _ = writeln!(self.out, "<{}{}>", tag.name, tag.attributes);
        self.open.push(tag.name);
    }

    /// Closes the innermost open element; does nothing when only the root is open, so a stray
    /// call cannot close the document early.
    pub fn close(&mut self) {
        if self.open.len() > 1 {
            self.close_one();
        }
    }

    fn close_one(&mut self) {
        if let Some(name) = self.open.pop() {
            self.indent();
            let _ = writeln!(self.out, "</{name}>");
        }
    }

    /// Writes an element without content.
    pub fn leaf(&mut self, tag: Tag) {
        self.indent();
        let _ = writeln!(self.out, "<{}{}/>", tag.name, tag.attributes);
    }

    /// Writes an element whose content is text (escaped).
    pub fn text(&mut self, tag: Tag, content: &str) {
        self.indent();
        let _ = writeln!(
            self.out,
            "<{}{}>{}</{}>",
            tag.name,
            tag.attributes,
            escape(content),
            tag.name
        );
    }

    /// Writes a `<title>` child, which browsers show as a tooltip and screen readers read.
    pub fn title(&mut self, content: &str) {
        self.text(Tag::new("title"), content);
    }

    /// Writes a chart's title twice: as its `<title>`, and as bold text at its top, `left`
    /// pixels in, where the fitness, QD and archive charts all put it.
    pub fn heading(&mut self, content: &str, left: f64, font_size: f64) {
        self.title(content);
        self.text(
            Tag::new("text")
                .class("title")
                .num("x", left)
                .num("y", 32.0)
                .num("font-size", font_size)
                .attr("font-weight", "bold")
                .attr("fill", INK),
            content,
        );
    }

    fn indent(&mut self) {
        for _ in 0..self.open.len() {
            self.out.push_str("  ");
        }
    }

    /// Closes every open element and returns the document.
    pub fn finish(mut self) -> String {
        while !self.open.is_empty() {
            self.close_one();
        }
        self.out
    }
}

/// Approximate text width for layout: DejaVu Sans averages about 0.6 em per character.
pub fn text_width(text: &str, font_size: f64) -> f64 {
    text.chars().count() as f64 * font_size * 0.6
}

/// A minimal reader of the SVG this module writes, for the tests of every picture: it checks
/// that tags are balanced and well nested and that attributes are quoted, and returns each
/// element with its attributes and direct text.
#[cfg(test)]
pub(crate) mod read_back {
    use std::collections::HashMap;

    /// One element as read back.
    #[derive(Debug, Clone)]
    pub(crate) struct Element {
        pub name: String,
        pub attributes: HashMap<String, String>,
        pub text: String,
        /// Names of the enclosing elements, outermost first.
        pub ancestors: Vec<String>,
    }

    impl Element {
        /// The attribute's value, or an empty string.
        pub fn get(&self, key: &str) -> &str {
            self.attributes.get(key).map(String::as_str).unwrap_or("")
        }

        /// Whether the element's class list contains `class`.
        pub fn has_class(&self, class: &str) -> bool {
            self.get("class").split_whitespace().any(|c| c == class)
        }

        /// A numeric attribute.
        pub fn number(&self, key: &str) -> f64 {
            self.get(key)
                .parse()
                .unwrap_or_else(|_| panic!("attribute {key} of {self:?} is not a number"))
        }

        /// The `points` attribute as pairs.
        pub fn points(&self) -> Vec<[f64; 2]> {
            parse_points(self.get("points"))
        }
    }

    /// Parses a `points` attribute.
    pub(crate) fn parse_points(text: &str) -> Vec<[f64; 2]> {
        text.split_whitespace()
            .map(|pair| {
                let (x, y) = pair.split_once(',').expect("points are x,y pairs");
                [
                    x.parse().expect("x is a number"),
                    y.parse().expect("y is a number"),
                ]
            })
            .collect()
    }

    fn unescape(text: &str) -> Result<String, String> {
        let mut out = String::new();
        let mut rest = text;
        while let Some(amp) = rest.find('&') {
            out.push_str(&rest[..amp]);
            let semi = rest[amp..]
                .find(';')
                .ok_or_else(|| format!("unterminated entity in {text:?}"))?
                + amp;
            let entity = &rest[amp + 1..semi];
            out.push(match entity {
                "amp" => '&',
                "lt" => '<',
                "gt" => '>',
                "quot" => '"',
                "#39" | "apos" => '\'',
                other => return Err(format!("unknown entity &{other};")),
            });
            rest = &rest[semi + 1..];
        }
        if rest.contains('<') || rest.contains('>') {
            return Err(format!("unescaped angle bracket in {text:?}"));
        }
        out.push_str(rest);
        Ok(out)
    }

    fn parse_attributes(text: &str) -> Result<HashMap<String, String>, String> {
        let mut attributes = HashMap::new();
        let mut rest = text.trim();
        while !rest.is_empty() {
            let eq = rest
                .find('=')
                .ok_or_else(|| format!("attribute without value in {text:?}"))?;
            let key = rest[..eq].trim().to_string();
            if key.is_empty() || key.contains(char::is_whitespace) {
                return Err(format!("bad attribute name {key:?} in {text:?}"));
            }
            let after = &rest[eq + 1..];
            if !after.starts_with('"') {
                return Err(format!("attribute {key} is not double-quoted in {text:?}"));
            }
            let close = after[1..]
                .find('"')
                .ok_or_else(|| format!("unterminated value of {key}"))?
                + 1;
            let value = unescape(&after[1..close])?;
            if attributes.insert(key.clone(), value).is_some() {
                return Err(format!("duplicate attribute {key}"));
            }
            rest = after[close + 1..].trim_start();
        }
        Ok(attributes)
    }

    /// Reads a document; an error says what is malformed.
    pub(crate) fn parse(svg: &str) -> Result<Vec<Element>, String> {
        let mut elements: Vec<Element> = Vec::new();
        // Stack of (name, index into `elements`).
        let mut stack: Vec<(String, usize)> = Vec::new();
        let mut rest = svg;
        let mut roots = 0;
        while let Some(lt) = rest.find('<') {
            let between = &rest[..lt];
            if let Some(&(_, idx)) = stack.last() {
                elements[idx].text.push_str(unescape(between)?.trim());
            } else if !between.trim().is_empty() {
                return Err(format!("text outside the root: {between:?}"));
            }
            let gt = rest[lt..].find('>').ok_or("unterminated tag")? + lt;
            let inner = &rest[lt + 1..gt];
            rest = &rest[gt + 1..];
            if let Some(name) = inner.strip_prefix('/') {
                let (open, _) = stack
                    .pop()
                    .ok_or_else(|| format!("</{name}> closes nothing"))?;
                if open != name.trim() {
                    return Err(format!("</{name}> closes <{open}>"));
                }
                continue;
            }
            let self_closing = inner.ends_with('/');
            let inner = inner.trim_end_matches('/');
            let (name, attribute_text) =
                inner.split_once(char::is_whitespace).unwrap_or((inner, ""));
            if name.is_empty()
                || !name
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == ':')
            {
                return Err(format!("bad element name {name:?}"));
            }
            if stack.is_empty() {
                roots += 1;
                if roots > 1 {
                    return Err("more than one root element".into());
                }
            }
            elements.push(Element {
                name: name.to_string(),
                attributes: parse_attributes(attribute_text)?,
                text: String::new(),
                ancestors: stack.iter().map(|(n, _)| n.clone()).collect(),
            });
            if !self_closing {
                stack.push((name.to_string(), elements.len() - 1));
            }
        }
        if !rest.trim().is_empty() {
            return Err(format!("trailing text {rest:?}"));
        }
        if let Some((open, _)) = stack.last() {
            return Err(format!("<{open}> is never closed"));
        }
        if roots != 1 {
            return Err("no root element".into());
        }
        Ok(elements)
    }

    /// Elements with a given class.
    pub(crate) fn with_class<'a>(elements: &'a [Element], class: &str) -> Vec<&'a Element> {
        elements.iter().filter(|e| e.has_class(class)).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::read_back::parse;
    use super::*;

    #[test]
    fn escape_covers_markup_characters_and_drops_control_characters() {
        assert_eq!(
            escape(r#"a<b>&"c"'d'"#),
            "a&lt;b&gt;&amp;&quot;c&quot;&#39;d&#39;"
        );
        assert_eq!(escape("bell\u{7}here"), "bellhere");
        assert_eq!(escape("solve_maze / turn_left"), "solve_maze / turn_left");
    }

    #[test]
    fn numbers_are_short_and_finite() {
        assert_eq!(num(1.0), "1");
        assert_eq!(num(1.5), "1.5");
        assert_eq!(num(1.234_567), "1.23");
        assert_eq!(num(-0.001), "0");
        assert_eq!(num(-2.10), "-2.1");
        assert_eq!(num(100.0), "100");
        assert_eq!(num(f64::NAN), "0");
        assert_eq!(num(f64::INFINITY), "0");
        assert_eq!(num_with(0.123_456, 4), "0.1235");
    }

    #[test]
    fn document_is_balanced_even_with_open_elements_and_stray_closes() {
        let mut doc = SvgDocument::new(100.0, 50.0, "test");
        doc.open(Tag::new("g").class("outer"));
        doc.open(Tag::new("g").class("inner"));
        doc.leaf(
            Tag::new("polyline")
                .class("line")
                .points(&[[0.0, 1.0], [2.5, 3.0]]),
        );
        doc.text(Tag::new("text").class("label"), "a < b & \"c\"");
        doc.close();
        doc.close();
        doc.close();
        doc.close();
        doc.leaf(Tag::new("circle").class("after"));
        let svg = doc.finish();
        let elements = parse(&svg).expect("well-formed");
        assert_eq!(elements[0].name, "svg");
        let label = elements
            .iter()
            .find(|e| e.has_class("label"))
            .expect("label");
        assert_eq!(label.text, "a < b & \"c\"");
        let line = elements.iter().find(|e| e.has_class("line")).expect("line");
        assert_eq!(line.points(), vec![[0.0, 1.0], [2.5, 3.0]]);
        let after = elements
            .iter()
            .find(|e| e.has_class("after"))
            .expect("after");
        assert_eq!(after.ancestors, vec!["svg".to_string()]);
    }

    #[test]
    fn reader_rejects_malformed_documents() {
        assert!(parse("<svg><g></svg>").is_err());
        assert!(parse("<svg><g></g>").is_err());
        assert!(parse("<svg a=1></svg>").is_err());
        assert!(parse("<svg>a < b</svg>").is_err());
        assert!(parse("<svg/><svg/>").is_err());
        assert!(parse("<svg a=\"1\"><g/></svg>").is_ok());
    }

    #[test]
    fn path_data_reads_as_commands() {
        let d = PathData::new()
            .move_to(0.0, 0.0)
            .line_to(10.0, 0.0)
            .arc_to(10.0, false, true, 0.0, 10.0)
            .close();
        assert_eq!(d.as_str(), "M0 0 L10 0 A10 10 0 0 1 0 10 Z");
    }
}
