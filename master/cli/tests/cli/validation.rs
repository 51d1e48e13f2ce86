//! `hevo run` checks what it is asked before it allocates or writes anything: each bad value
//! is an error naming it, with a non-zero exit, never a panic or an abort.

use crate::support::{SMALL, hevo};

fn run(dir: &std::path::Path, toml: &str, extra: &[&str]) -> (Option<i32>, String) {
    let file = dir.join("x.toml");
    std::fs::write(&file, toml).unwrap();
    let out = dir.join("out");
    let mut args = vec![
        "run",
        file.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--threads",
        "1",
    ];
    args.extend_from_slice(extra);
    let output = hevo(&args);
    (
        output.status.code(),
        String::from_utf8_lossy(&output.stderr).into_owned(),
    )
}

#[test]
fn bad_values_are_refused_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    let cases: Vec<(String, Vec<&str>, &str)> = vec![
        (
            SMALL.into(),
            vec!["--runs", "0"],
            "--runs must be between 1 and 1000, got 0",
        ),
        (
            SMALL.into(),
            vec!["--generations", "0"],
            "--generations must be between 1",
        ),
        (
            SMALL.into(),
            vec!["--node", ".."],
            "--node '..' is not a node name",
        ),
        (
            SMALL.replace("population = 12", "population = 4000000000"),
            vec![],
            "population",
        ),
        (
            SMALL.replace("samples = 6\n", "samples = 4000000000\n"),
            vec![],
            "node[0].samples",
        ),
        (
            SMALL.replace("name = \"exit_room\"", "name = \"..\""),
            vec![],
            "node[0].name",
        ),
    ];
    for (toml, extra, expected) in cases {
        let (code, stderr) = run(dir.path(), &toml, &extra);
        assert_eq!(code, Some(1), "{extra:?}: {stderr}");
        assert!(stderr.contains(expected), "{extra:?}: {stderr}");
        assert!(!stderr.contains("panicked"), "{stderr}");
    }
    // Nothing was written for any of them.
    assert!(!dir.path().join("out").exists());
}
