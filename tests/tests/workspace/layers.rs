//! The layers of ARCHITECTURE.md, enforced: each crate's normal (non-dev) dependency tree, as
//! `cargo tree` resolves it for that crate alone, holds none of the crates its layer may not
//! use, and sim-core's sources use no clock, file, environment or global randomness. A new
//! forbidden dependency (the engine importing tonic, say) fails here, naming the crate, the
//! dependency and the rule.

use std::collections::BTreeSet;
use std::process::Command;

/// A crate and what its layer may not depend on, directly or through another crate.
struct Rule {
    package: &'static str,
    forbidden: &'static [&'static str],
    why: &'static str,
}

const NETWORK_AND_COMMAND_LINE: [&str; 6] = ["tonic", "prost", "clap", "indicatif", "redb", "axum"];

const RULES: &[Rule] = &[
    Rule {
        package: "hevo-cli",
        forbidden: &["pyo3", "numpy", "hevo-python"],
        why: "the command line and the Python module are both at the top, beside each other",
    },
    Rule {
        package: "hevo-client",
        // (tonic's transport brings axum in for its router; the client serves nothing.)
        forbidden: &[
            "clap",
            "indicatif",
            "redb",
            "hevo-service",
            "hevo-viz",
            "hevo-dashboard",
            "hevo-cli",
            "hevo-worker",
            "pyo3",
            "hevo-python",
        ],
        why: "the client calls are a library over the wire format: no command line, terminal output, store or server",
    },
    Rule {
        package: "hevo-python",
        forbidden: &[
            "clap",
            "indicatif",
            "hevo-cli",
            "hevo-service",
            "hevo-dashboard",
        ],
        why: "the Python module builds on the engine and the client calls, not on the command line or the server",
    },
    Rule {
        package: "hevo-sim-core",
        forbidden: &[
            "tokio",
            "tonic",
            "prost",
            "clap",
            "indicatif",
            "redb",
            "axum",
            "hevo-scripted",
            "hevo-proto",
            "hevo-evolve",
            "hevo-engine",
            "hevo-service",
            "hevo-viz",
            "hevo-cli",
            "hevo-worker",
            "pyo3",
            "hevo-python",
        ],
        why: "sim-core is the pure simulator: no async runtime, network, command line or other hevo crate",
    },
    Rule {
        package: "hevo-scripted",
        forbidden: &[
            "tokio",
            "tonic",
            "hevo-evolve",
            "hevo-engine",
            "hevo-proto",
            "hevo-service",
            "hevo-viz",
            "hevo-cli",
            "hevo-worker",
        ],
        why: "the scripted policies are test support over sim-core alone",
    },
    Rule {
        package: "hevo-export",
        forbidden: &[
            "tokio",
            "tonic",
            "prost",
            "clap",
            "indicatif",
            "redb",
            "axum",
            "hevo-proto",
            "hevo-engine",
            "hevo-service",
            "hevo-viz",
            "hevo-cli",
            "hevo-worker",
            "hevo-dashboard",
        ],
        why: "the C export reads controllers and sim-core's model alone; the CLI drives it",
    },
    Rule {
        package: "hevo-evolve",
        forbidden: &[
            "tokio",
            "tonic",
            "prost",
            "clap",
            "indicatif",
            "redb",
            "axum",
            "hevo-proto",
            "hevo-engine",
            "hevo-service",
            "hevo-viz",
            "hevo-cli",
            "hevo-worker",
            "pyo3",
            "hevo-python",
        ],
        why: "the search strategies are pure: ask, tell and a state, over sim-core's seeds alone",
    },
    Rule {
        package: "hevo-engine",
        forbidden: &[
            "tonic",
            "prost",
            "clap",
            "indicatif",
            "redb",
            "axum",
            "hevo-scripted",
            "hevo-proto",
            "hevo-service",
            "hevo-viz",
            "hevo-cli",
            "hevo-worker",
            "pyo3",
            "hevo-python",
        ],
        why: "the engine has no network, command line, progress bars, store or pictures",
    },
    Rule {
        package: "hevo-viz",
        forbidden: &[
            "tonic",
            "prost",
            "clap",
            "indicatif",
            "redb",
            "axum",
            "tokio",
            "hevo-proto",
            "hevo-evolve",
            "hevo-engine",
            "hevo-report",
            "hevo-service",
            "hevo-cli",
            "hevo-worker",
            "pyo3",
            "hevo-python",
        ],
        why: "pictures read run directories through hevo-rundir's format, without the engine",
    },
    Rule {
        package: "hevo-report",
        forbidden: &[
            "tokio",
            "tonic",
            "prost",
            "clap",
            "indicatif",
            "redb",
            "axum",
            "hevo-proto",
            "hevo-evolve",
            "hevo-engine",
            "hevo-service",
            "hevo-dashboard",
            "hevo-cli",
            "hevo-worker",
            "pyo3",
            "hevo-python",
        ],
        why: "the paper's report reads run directories (hevo-rundir) and draws with hevo-viz; it runs nothing",
    },
    Rule {
        package: "hevo-rundir",
        forbidden: &[
            "tokio",
            "tonic",
            "prost",
            "clap",
            "indicatif",
            "redb",
            "axum",
            "hevo-proto",
            "hevo-evolve",
            "hevo-engine",
            "hevo-service",
            "hevo-viz",
            "hevo-dashboard",
            "hevo-cli",
            "hevo-worker",
            "pyo3",
            "hevo-python",
        ],
        why: "the run-directory format is plain data and files: no runtime, network, command line or other layer",
    },
    Rule {
        package: "hevo-proto",
        forbidden: &[
            "clap",
            "indicatif",
            "hevo-evolve",
            "hevo-engine",
            "hevo-service",
            "hevo-viz",
            "hevo-cli",
            "hevo-worker",
            "pyo3",
            "hevo-python",
        ],
        why: "the wire format depends on sim-core alone; its flags are behind the `cli` feature",
    },
    Rule {
        package: "hevo-dashboard",
        forbidden: &[
            "tonic",
            "prost",
            "clap",
            "indicatif",
            "redb",
            "hevo-proto",
            "hevo-evolve",
            "hevo-engine",
            "hevo-service",
            "hevo-cli",
            "hevo-worker",
            "pyo3",
            "hevo-python",
        ],
        why: "the dashboard reads a Source (run directories here, the master's jobs in the service); it knows no gRPC, store or command line",
    },
    Rule {
        package: "hevo-service",
        // (hevo-viz comes in through hevo-dashboard only: the service draws nothing itself.)
        forbidden: &[
            "clap",
            "indicatif",
            "hevo-cli",
            "hevo-worker",
            "pyo3",
            "hevo-python",
        ],
        why: "the service is a library over the engine; the command line is above it",
    },
    Rule {
        package: "hevo-worker",
        // (tonic's server half pulls in axum, so axum is no sign of the master here.)
        forbidden: &[
            "redb",
            "indicatif",
            "hevo-service",
            "hevo-viz",
            "hevo-cli",
            "pyo3",
            "hevo-python",
        ],
        why: "a worker is the remote loop over the engine's executor, nothing of the master",
    },
];

/// Every package in the crate's normal dependency tree, by name. The feature-unification crate
/// is left out where the crate depends on it: it asks for features, and its dependencies are not
/// the crate's to use (master/workspace-hack).
fn dependency_names(package: &str) -> BTreeSet<String> {
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let tree = |prune: bool| {
        let mut command = Command::new(&cargo);
        command.current_dir(hevo_tests::repo_root()).args([
            "tree", "--locked", "-p", package, "-e", "normal", "--prefix", "none", "--format",
            "{p}",
        ]);
        if prune {
            command.args(["--prune", "hevo-workspace-hack"]);
        }
        command.output().expect("cannot run cargo tree")
    };
    let mut output = tree(true);
    // `--prune` of a package not in the tree is an error: the crate does not depend on it.
    if !output.status.success()
        && String::from_utf8_lossy(&output.stderr).contains("did not match any packages")
    {
        output = tree(false);
    }
    assert!(
        output.status.success(),
        "cargo tree -p {package} failed: {}",
        String::from_utf8_lossy(&output.stderr)
    );
    String::from_utf8_lossy(&output.stdout)
        .lines()
        .filter_map(|line| line.split_whitespace().next())
        .map(str::to_string)
        .filter(|name| name != package)
        .collect()
}

#[test]
fn no_layer_depends_on_what_it_may_not() {
    let mut problems = Vec::new();
    for rule in RULES {
        let names = dependency_names(rule.package);
        assert!(
            names.contains("serde") || rule.package == "hevo-scripted",
            "cargo tree -p {} listed no serde: the listing is not what this check expects: {names:?}",
            rule.package
        );
        for forbidden in rule.forbidden {
            if names.contains(*forbidden) {
                problems.push(format!(
                    "{} depends on {forbidden}: {}",
                    rule.package, rule.why
                ));
            }
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

/// The check above would pass vacuously if the listing lost transitive dependencies: the
/// command line must be seen to pull in the network and command-line crates it does use.
#[test]
fn the_listing_sees_transitive_dependencies() {
    let cli = dependency_names("hevo-cli");
    for expected in NETWORK_AND_COMMAND_LINE.iter().chain(&[
        "hevo-engine",
        "hevo-evolve",
        "hevo-sim-core",
        "tokio",
    ]) {
        assert!(
            cli.contains(*expected),
            "hevo-cli without {expected}: {cli:?}"
        );
    }
    // Through sim-core only, never named by hevo-viz itself.
    assert!(dependency_names("hevo-viz").contains("rapier2d"));
}

/// sim-core is a function of its inputs: its sources name no clock, file system, environment
/// or global random generator (data files are embedded with `include_str!`).
#[test]
fn sim_core_does_no_io() {
    let forbidden = [
        "Instant::now",
        "SystemTime",
        "std::fs",
        "std::env",
        "std::net",
        "thread_rng",
        "rand::rng()",
        "std::thread",
    ];
    let src = hevo_tests::repo_root().join("sim-core/src");
    let mut problems = Vec::new();
    let mut stack = vec![src];
    let mut n_files = 0;
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
            } else if path.extension().is_some_and(|e| e == "rs") {
                n_files += 1;
                let text = std::fs::read_to_string(&path).unwrap();
                for (line_idx, line) in text.lines().enumerate() {
                    let code = line.split("//").next().unwrap_or("");
                    for word in forbidden {
                        if code.contains(word) {
                            problems.push(format!("{}:{}: {word}", path.display(), line_idx + 1));
                        }
                    }
                }
            }
        }
    }
    assert!(
        n_files > 10,
        "only {n_files} sources found under sim-core/src"
    );
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}
