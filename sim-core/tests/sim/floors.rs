//! The floors of sim-core: every module of `src/` lives on one floor, the first segment of its
//! path (`src/body.rs` is `body`, `src/sensors/ir.rs` is `sensors`), and imports only from its
//! own floor and the floors below it. So the body can be read and tested without the scenario
//! compiler, and a change on a floor can only break the floors above it. The order is written
//! once, here ([`FLOORS`]); ARCHITECTURE.md names it. This reads the source: every `crate::`
//! and `super::` path outside comments and `#[cfg(test)]` items (a test may build whatever it
//! needs to try its module), with use trees expanded. `lib.rs`, the roof, re-exports the
//! surface and may name any floor.

use std::path::{Path, PathBuf};

/// The floors, lowest first.
const FLOORS: &[&str] = &[
    "math", "config", "geometry", "body", "sensors", "network", "outcome", "world", "scenario",
    "task", "episode",
];

/// An import a module may not make: the file, the path as written, and why.
#[derive(Debug, Clone, PartialEq, Eq)]
struct Violation {
    file: String,
    path: String,
    why: String,
}

impl std::fmt::Display for Violation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}: `{}` {}", self.file, self.path, self.why)
    }
}

/// `text` with comments, string and character literals blanked out (their length kept, so
/// nothing inside them reads as a path or a brace).
fn code_only(text: &str) -> String {
    let chars: Vec<char> = text.chars().collect();
    let mut out = String::with_capacity(text.len());
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        let next = chars.get(i + 1).copied();
        if c == '/' && next == Some('/') {
            while i < chars.len() && chars[i] != '\n' {
                i += 1;
            }
        } else if c == '/' && next == Some('*') {
            let mut depth = 0;
            while i < chars.len() {
                if chars[i] == '/' && chars.get(i + 1) == Some(&'*') {
                    depth += 1;
                    i += 2;
                } else if chars[i] == '*' && chars.get(i + 1) == Some(&'/') {
                    depth -= 1;
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    if chars[i] == '\n' {
                        out.push('\n');
                    }
                    i += 1;
                }
            }
        } else if c == 'r' && matches!(next, Some('#') | Some('"')) && !is_ident(prev(&chars, i)) {
            // A raw string: r"...", r#"..."#.
            let mut j = i + 1;
            let mut hashes = 0;
            while chars.get(j) == Some(&'#') {
                hashes += 1;
                j += 1;
            }
            if chars.get(j) != Some(&'"') {
                out.push(c);
                i += 1;
                continue;
            }
            j += 1;
            loop {
                match chars.get(j) {
                    None => break,
                    Some('"') if (1..=hashes).all(|h| chars.get(j + h) == Some(&'#')) => {
                        j += 1 + hashes;
                        break;
                    }
                    Some('\n') => out.push('\n'),
                    _ => {}
                }
                j += 1;
            }
            out.push_str("\"\"");
            i = j;
        } else if c == '"' {
            i += 1;
            while i < chars.len() && chars[i] != '"' {
                if chars[i] == '\\' {
                    i += 1;
                } else if chars[i] == '\n' {
                    out.push('\n');
                }
                i += 1;
            }
            out.push_str("\"\"");
            i += 1;
        } else if c == '\'' && char_literal_len(&chars[i..]).is_some() {
            i += char_literal_len(&chars[i..]).unwrap_or(1);
            out.push_str("' '");
        } else {
            out.push(c);
            i += 1;
        }
    }
    out
}

fn prev(chars: &[char], i: usize) -> char {
    if i == 0 { ' ' } else { chars[i - 1] }
}

fn is_ident(c: char) -> bool {
    c.is_alphanumeric() || c == '_'
}

/// The length of the character literal at the start of `chars` (`'a'`, `'\n'`, `'{'`), if it
/// is one and not a lifetime.
fn char_literal_len(chars: &[char]) -> Option<usize> {
    match chars {
        ['\'', '\\', ..] => chars[2..]
            .iter()
            .position(|&c| c == '\'')
            .map(|end| end + 3),
        ['\'', _, '\'', ..] => Some(3),
        _ => None,
    }
}

/// `code` without its `#[cfg(test)]` items: from the attribute to the end of the item it
/// marks (its closing brace, or its semicolon).
fn without_test_items(code: &str) -> String {
    let mut out = String::with_capacity(code.len());
    let mut rest = code;
    while let Some(at) = rest.find("#[cfg(test)]") {
        out.push_str(&rest[..at]);
        let item = &rest[at + "#[cfg(test)]".len()..];
        let mut depth = 0i32;
        let mut end = item.len();
        for (idx, c) in item.char_indices() {
            match c {
                '{' => depth += 1,
                '}' => {
                    depth -= 1;
                    if depth == 0 {
                        end = idx + 1;
                        break;
                    }
                }
                ';' if depth == 0 => {
                    end = idx + 1;
                    break;
                }
                _ => {}
            }
        }
        // Keep the lines, so a violation's position stays findable by eye.
        out.extend(item[..end].chars().filter(|&c| c == '\n'));
        rest = &item[end..];
    }
    out.push_str(rest);
    out
}

/// Every path `code` names from `crate::` or `super::`, use trees expanded to their branches'
/// first segments: `crate::{a::X, b::Y}` is `crate::a` and `crate::b`.
fn paths(code: &str) -> Vec<String> {
    let mut found = Vec::new();
    let bytes = code.as_bytes();
    for start in ["crate::", "super::"] {
        let mut from = 0;
        while let Some(at) = code[from..].find(start).map(|at| at + from) {
            from = at + start.len();
            if at > 0 && (is_ident(bytes[at - 1] as char) || bytes[at - 1] == b'$') {
                continue;
            }
            expand(&code[at..], String::new(), &mut found);
        }
    }
    found
}

/// The paths of the use tree at the start of `text`, each after `prefix`.
fn expand(text: &str, prefix: String, found: &mut Vec<String>) {
    let mut path = prefix;
    let mut rest = text;
    loop {
        let name_len = rest
            .char_indices()
            .find(|&(_, c)| !is_ident(c))
            .map_or(rest.len(), |(idx, _)| idx);
        if name_len == 0 {
            break;
        }
        if !path.is_empty() {
            path.push_str("::");
        }
        path.push_str(&rest[..name_len]);
        rest = &rest[name_len..];
        let after = rest.trim_start();
        if let Some(tail) = after.strip_prefix("::") {
            let tail = tail.trim_start();
            if let Some(group) = tail.strip_prefix('{') {
                for branch in split_group(group) {
                    expand(branch.trim(), path.clone(), found);
                }
                return;
            }
            rest = tail;
        } else {
            break;
        }
    }
    if !path.is_empty() {
        found.push(path);
    }
}

/// The top-level comma-separated branches of a use group, up to its closing brace.
fn split_group(group: &str) -> Vec<&str> {
    let mut branches = Vec::new();
    let mut depth = 0;
    let mut start = 0;
    for (idx, c) in group.char_indices() {
        match c {
            '{' => depth += 1,
            '}' if depth == 0 => {
                branches.push(&group[start..idx]);
                return branches;
            }
            '}' => depth -= 1,
            ',' if depth == 0 => {
                branches.push(&group[start..idx]);
                start = idx + 1;
            }
            _ => {}
        }
    }
    branches.push(&group[start..]);
    branches
}

/// The module path of a file of `src/`: `sensors/ir.rs` is `[sensors, ir]`, `world/mod.rs` is
/// `[world]`.
fn module_path(relative: &Path) -> Vec<String> {
    let mut segments: Vec<String> = relative
        .iter()
        .map(|part| part.to_string_lossy().trim_end_matches(".rs").to_string())
        .collect();
    if segments.last().is_some_and(|last| last == "mod") {
        segments.pop();
    }
    segments
}

/// What is wrong with the imports of the file at `relative` (to `src/`), whose text is `text`.
fn check_file(relative: &Path, text: &str) -> Vec<Violation> {
    let file = relative.to_string_lossy().replace('\\', "/");
    let module = module_path(relative);
    let floor_of = |name: &str| FLOORS.iter().position(|&floor| floor == name);
    let Some(own) = module.first().and_then(|first| floor_of(first)) else {
        return vec![Violation {
            file,
            path: String::new(),
            why: format!("is on no floor: its first segment is none of {FLOORS:?}"),
        }];
    };
    let mut violations = Vec::new();
    for path in paths(&without_test_items(&code_only(text))) {
        let segments: Vec<&str> = path.split("::").collect();
        let absolute: Vec<&str> = match segments[0] {
            "crate" => segments[1..].to_vec(),
            _ => {
                let n_super = segments.iter().take_while(|&&s| s == "super").count();
                if n_super > module.len() {
                    violations.push(Violation {
                        file: file.clone(),
                        path: path.clone(),
                        why: "goes above the crate root".to_string(),
                    });
                    continue;
                }
                let base = module[..module.len() - n_super].iter().map(String::as_str);
                base.chain(segments[n_super..].iter().copied()).collect()
            }
        };
        let Some(&first) = absolute.first() else {
            continue;
        };
        match floor_of(first) {
            Some(floor) if floor > own => violations.push(Violation {
                file: file.clone(),
                path: path.clone(),
                why: format!(
                    "reaches up from floor `{}` to floor `{}`",
                    FLOORS[own], FLOORS[floor]
                ),
            }),
            Some(_) => {}
            None => violations.push(Violation {
                file: file.clone(),
                path: path.clone(),
                why: format!(
                    "names `{first}` at the crate root, which is on no floor: import it from \
                     its floor"
                ),
            }),
        }
    }
    violations
}

fn rust_files(dir: &Path, found: &mut Vec<PathBuf>) {
    let entries = std::fs::read_dir(dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
    for entry in entries {
        let path = entry.expect("a directory entry").path();
        if path.is_dir() {
            rust_files(&path, found);
        } else if path.extension().is_some_and(|ext| ext == "rs") {
            found.push(path);
        }
    }
}

#[test]
fn every_module_imports_only_its_own_floor_and_the_floors_below() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    files.sort();
    let mut violations = Vec::new();
    let mut n_checked = 0;
    for path in &files {
        let relative = path.strip_prefix(&src).expect("under src");
        if relative == Path::new("lib.rs") {
            continue;
        }
        let text = std::fs::read_to_string(path).expect("readable source");
        violations.extend(check_file(relative, &text));
        n_checked += 1;
    }
    assert!(n_checked > 30, "only {n_checked} files found under {src:?}");
    let listed: Vec<String> = violations.iter().map(Violation::to_string).collect();
    assert!(
        violations.is_empty(),
        "{} imports break the floors ({}):\n{}",
        violations.len(),
        FLOORS.join(" < "),
        listed.join("\n")
    );
}

#[test]
fn an_import_from_a_floor_above_is_caught_however_it_is_written() {
    let caught = |file: &str, text: &str| -> Vec<String> {
        check_file(Path::new(file), text)
            .into_iter()
            .map(|v| v.path)
            .collect()
    };
    assert_eq!(
        caught("body.rs", "use crate::task::TaskConfig;"),
        ["crate::task::TaskConfig"]
    );
    assert_eq!(
        caught(
            "sensors/frame.rs",
            "use crate::{math::rng::SimRng, scenario::{blocks::SENSORS, Scenario}};"
        ),
        [
            "crate::scenario::blocks::SENSORS",
            "crate::scenario::Scenario"
        ]
    );
    assert_eq!(
        caught(
            "world/room.rs",
            "fn f() -> super::super::episode::X { todo!() }"
        ),
        ["super::super::episode::X"]
    );
    assert_eq!(
        caught("geometry/scene.rs", "let e = crate::Evaluator::new(t);"),
        ["crate::Evaluator::new"]
    );
    assert_eq!(caught("lights.rs", "").len(), 1, "a file on no floor");
    // Down, sideways within a floor, in comments, strings and test items: all allowed.
    assert!(
        caught(
            "scenario/blocks/atoms.rs",
            "//! See [`crate::episode`].\n\
             use super::{Atom, CycleView};\n\
             use crate::geometry::rect_holds;\n\
             const S: &str = \"crate::episode\";\n\
             const C: char = '{';\n\
             #[cfg(test)]\n\
             mod tests {\n    use crate::episode::evaluator::Evaluator;\n}\n\
             fn after() -> crate::math::rng::SimRng { todo!() }"
        )
        .is_empty()
    );
}
