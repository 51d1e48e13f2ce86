//! Small helpers over YAML values (the compose file, the manifests, the kustomizations).

use serde_norway::Value;

/// A scalar as text (`50051`, `true`, `"x"` -> `50051`, `true`, `x`).
pub fn scalar(value: &Value) -> Option<String> {
    match value {
        Value::String(s) => Some(s.clone()),
        Value::Number(n) => Some(n.to_string()),
        Value::Bool(b) => Some(b.to_string()),
        _ => None,
    }
}

/// A sequence of scalars, or one scalar, as texts.
pub fn strings(value: Option<&Value>) -> Vec<String> {
    match value {
        Some(Value::Sequence(items)) => items.iter().filter_map(scalar).collect(),
        Some(other) => scalar(other).into_iter().collect(),
        None => Vec::new(),
    }
}

/// The value at a path of mapping keys.
pub fn at<'v>(value: &'v Value, path: &[&str]) -> Option<&'v Value> {
    path.iter().try_fold(value, |v, key| v.get(*key))
}

/// The scalar at a path of mapping keys.
pub fn str_at(value: &Value, path: &[&str]) -> Option<String> {
    at(value, path).and_then(scalar)
}

/// A sequence's items; none for anything else.
pub fn seq(value: Option<&Value>) -> &[Value] {
    match value {
        Some(Value::Sequence(items)) => items,
        _ => &[],
    }
}

/// Every document of a (multi-document) YAML text, empty ones left out, up to the first that
/// does not parse, whose error is returned.
pub fn parse_docs(text: &str) -> (Vec<Value>, Vec<String>) {
    use serde::Deserialize;
    let mut docs = Vec::new();
    let mut errors = Vec::new();
    for document in serde_norway::Deserializer::from_str(text) {
        match Value::deserialize(document) {
            Ok(Value::Null) => {}
            Ok(value) => docs.push(value),
            Err(e) => {
                // The deserializer does not get past a syntax error: it would yield it forever.
                errors.push(format!("invalid YAML: {e}"));
                break;
            }
        }
    }
    (docs, errors)
}

/// Whether a (non-empty) label selector selects pods with `labels`.
pub fn labels_match(selector: Option<&Value>, labels: Option<&Value>) -> bool {
    let (Some(Value::Mapping(selector)), Some(Value::Mapping(labels))) = (selector, labels) else {
        return false;
    };
    !selector.is_empty() && selector.iter().all(|(k, v)| labels.get(k) == Some(v))
}

/// Line numbers in a YAML text (or the Dockerfile), found by searching for what a parsed value
/// holds, since the parsed values carry none. 1-based; `None` when not found.
#[derive(Debug, Clone)]
pub struct Lines<'t> {
    lines: Vec<&'t str>,
}

impl<'t> Lines<'t> {
    /// The lines of `text`.
    pub fn new(text: &'t str) -> Lines<'t> {
        Lines {
            lines: text.lines().collect(),
        }
    }

    /// The first line at or after `from` for which `wanted` holds.
    pub fn find(&self, from: usize, wanted: impl Fn(&str) -> bool) -> Option<usize> {
        let start = from.max(1);
        self.lines
            .iter()
            .enumerate()
            .skip(start - 1)
            .find(|(_, line)| wanted(line))
            .map(|(at, _)| at + 1)
    }

    /// The first line at or after `from` whose text, without indentation, is `text`.
    pub fn line(&self, from: usize, text: &str) -> Option<usize> {
        self.find(from, |l| l.trim() == text)
    }

    /// The `kind:` line of the object of `kind` named `name` (its `metadata.name`, before the
    /// next document).
    pub fn object(&self, kind: &str, name: &str) -> Option<usize> {
        let kind_line = format!("kind: {kind}");
        let name_line = format!("name: {name}");
        let mut from = 1;
        while let Some(at) = self.find(from, |l| l == kind_line) {
            let end = self
                .find(at, |l| l == "---")
                .unwrap_or(self.lines.len() + 1);
            if self.line(at, &name_line).is_some_and(|n| n < end) {
                return Some(at);
            }
            from = at + 1;
        }
        None
    }

    /// The lines of `items` (a command line), each a sequence item (`- x` or in `[a, x]`),
    /// searched in order from `from`.
    pub fn items(&self, from: usize, items: &[String]) -> Vec<Option<usize>> {
        let mut at = from;
        items
            .iter()
            .map(|item| {
                let found = self.find(at, |l| sequence_items(l).contains(item));
                if let Some(line) = found {
                    at = line;
                }
                found
            })
            .collect()
    }
}

/// The scalars a line holds as sequence items: `- x` or `key: [a, "b"]` (quotes removed,
/// comments dropped).
fn sequence_items(line: &str) -> Vec<String> {
    let unquote = |s: &str| s.trim().trim_matches('"').trim_matches('\'').to_string();
    let code = line.split(" #").next().unwrap_or(line).trim();
    if let (Some(open), Some(close)) = (code.find('['), code.rfind(']'))
        && open < close
    {
        return code[open + 1..close].split(',').map(unquote).collect();
    }
    code.strip_prefix("- ").map(unquote).into_iter().collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_by_path() {
        let (docs, errors) =
            parse_docs("---\na:\n  b: [1, x, true]\n  c: 50051\n---\n---\nd: {}\n");
        assert!(errors.is_empty());
        assert_eq!(docs.len(), 2);
        assert_eq!(strings(at(&docs[0], &["a", "b"])), ["1", "x", "true"]);
        assert_eq!(str_at(&docs[0], &["a", "c"]).as_deref(), Some("50051"));
        assert_eq!(seq(at(&docs[0], &["a", "c"])).len(), 0);
        assert!(at(&docs[1], &["d", "e"]).is_none());
    }

    #[test]
    fn invalid_yaml_is_reported() {
        let (_, errors) = parse_docs("a: [1, 2\n");
        assert_eq!(errors.len(), 1);
        assert!(errors[0].starts_with("invalid YAML"), "{errors:?}");
    }

    #[test]
    fn lines_are_found_by_what_they_hold() {
        let text = "kind: Service\nmetadata:\n  name: a\n---\nkind: StatefulSet\nmetadata:\n  name: a\nspec:\n  containers:\n    - name: m\n      image: hevo\n      command: [hevo]\n      args:\n        - serve\n        - \"--listen\"  # a comment\n";
        let lines = Lines::new(text);
        assert_eq!(lines.object("StatefulSet", "a"), Some(5));
        assert_eq!(lines.object("Service", "a"), Some(1));
        assert_eq!(lines.object("Service", "b"), None);
        assert_eq!(lines.line(5, "- name: m"), Some(10));
        let argv = ["hevo", "serve", "--listen", "--x"].map(String::from);
        assert_eq!(lines.items(10, &argv), [Some(12), Some(14), Some(15), None]);
        assert_eq!(
            Lines::new("CMD [\"hevo\", \"--help\"]\n").items(1, &argv[..1]),
            [Some(1)]
        );
    }

    #[test]
    fn selectors() {
        let (docs, _) = parse_docs("s: {app: x}\nl: {app: x, tier: y}\nempty: {}\n");
        let doc = &docs[0];
        assert!(labels_match(doc.get("s"), doc.get("l")));
        assert!(!labels_match(doc.get("l"), doc.get("s")));
        assert!(!labels_match(doc.get("empty"), doc.get("l")));
    }
}
