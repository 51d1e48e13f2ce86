//! Fuzzing the experiment-file parser, which takes outside input from `hevo run` and from every
//! submission to a master: random bytes, and the shipped experiment files cut, spliced and
//! with bytes changed. Parsing must never panic, and an error's message stays bounded however
//! long the input's lines are. The case count bounds the time (`PROPTEST_CASES` raises it).

use hevo_engine::experiment::Experiment;
use proptest::prelude::*;
use std::collections::BTreeMap;
use std::path::Path;

const SHIPPED: [&str; 3] = [
    include_str!("../../../../experiments/rescue.toml"),
    include_str!("../../../../experiments/maze_single.toml"),
    include_str!("../../../../tests/fixtures/three_nodes.toml"),
];

/// The longest error any input may produce: a bounded excerpt, never the whole input.
const MAX_ERROR_CHARS: usize = 8_000;

fn parse(text: &str) {
    // A fixed child from elsewhere reads through an empty set of files: never the disk.
    let files: BTreeMap<String, String> = BTreeMap::new();
    if let Err(error) = Experiment::parse_with(text, Path::new("fuzz.toml"), &files) {
        let message = error.to_string();
        assert!(
            message.chars().count() < MAX_ERROR_CHARS,
            "{} characters",
            message.chars().count()
        );
    }
}

/// A shipped file with a few edits: cut at a byte, a range replaced, a line duplicated.
fn mutated() -> impl Strategy<Value = String> {
    (
        0..SHIPPED.len(),
        prop::collection::vec((any::<u16>(), any::<u16>(), any::<u8>(), 0..4u8), 1..6),
    )
        .prop_map(|(file, edits)| {
            let mut bytes = SHIPPED[file].as_bytes().to_vec();
            for (at, len, byte, kind) in edits {
                if bytes.is_empty() {
                    break;
                }
                let at = usize::from(at) % bytes.len();
                let end = (at + usize::from(len) % 64).min(bytes.len());
                match kind {
                    0 => bytes.truncate(at),
                    1 => bytes[at..end].fill(byte),
                    2 => {
                        let copy = bytes[at..end].to_vec();
                        bytes.splice(at..at, copy);
                    }
                    _ => {
                        bytes.remove(at);
                    }
                }
            }
            String::from_utf8_lossy(&bytes).into_owned()
        })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 400, ..ProptestConfig::default() })]

    #[test]
    fn random_text_never_panics(text in "\\PC{0,400}") {
        parse(&text);
    }

    #[test]
    fn edited_experiment_files_never_panic(text in mutated()) {
        parse(&text);
    }

    #[test]
    fn huge_values_never_panic(
        key in prop::sample::select(vec!["population", "samples", "generations", "runs", "hidden", "cycles", "elites"]),
        value in prop::sample::select(vec!["0", "-1", "4294967295", "4294967296", "18446744073709551615", "1e308", "nan", "\"x\""]),
    ) {
        let text = SHIPPED[2]
            .lines()
            .map(|line| if line.starts_with(key) { format!("{key} = {value}") } else { line.to_string() })
            .collect::<Vec<_>>()
            .join("\n");
        parse(&text);
    }

    #[test]
    fn a_long_line_is_quoted_in_part(len in 1_000usize..40_000) {
        let text = format!("{}\nname = \"{}\" oops\n", SHIPPED[2], "a".repeat(len));
        let error = Experiment::parse(&text, Path::new("fuzz.toml")).unwrap_err().to_string();
        prop_assert!(error.len() < 2_000, "{} bytes", error.len());
    }
}
