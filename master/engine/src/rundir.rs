//! The run-directory format, in one place: where a run output directory keeps each node and
//! run (`<out>/<node>/run-<k>/`), what its files are called, and what is in them (the fitness
//! log's rows, checkpoints, run and node summaries). The runner writes this format; the
//! service's fetch, the plots and the report read it through this module alone.
//!
//! ```text
//! <out>/<node>/best.json            the node's chosen controller (its best run's)
//! <out>/<node>/summary.json         NodeSummary: every run's post-evaluation, the best run
//! <out>/<node>/run-<k>/fitness.csv  one FitnessRow per generation
//! <out>/<node>/run-<k>/checkpoint.json   Checkpoint, while the run is in progress
//! <out>/<node>/run-<k>/best.json    the run's best controller
//! <out>/<node>/run-<k>/summary.json RunSummary, once the run is finished
//! ```

use crate::post_evaluation::EvalReport;
use hevo_evolve::StrategyState;
use hevo_evolve::ga::GaState;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// A controller file: a node's chosen controller, or a run's best.
pub const BEST: &str = "best.json";
/// A node's [`NodeSummary`] or a run's [`RunSummary`].
pub const SUMMARY: &str = "summary.json";
/// A run's [`Checkpoint`]; removed once the run is finished.
pub const CHECKPOINT: &str = "checkpoint.json";
/// A run's fitness log, one [`FitnessRow`] per generation.
pub const FITNESS_CSV: &str = "fitness.csv";

/// The files a finished run keeps, and a fetch or a copy of a run directory carries.
pub const FINISHED_RUN_FILES: [&str; 3] = [FITNESS_CSV, BEST, SUMMARY];
/// The files a finished node keeps beside its runs.
pub const FINISHED_NODE_FILES: [&str; 2] = [BEST, SUMMARY];

/// The format tag of [`Checkpoint`]: the search strategy's state, tagged with its algorithm.
pub const CHECKPOINT_FORMAT: &str = "hevo.checkpoint/2";
/// The format tag of the checkpoints written before strategies had their own state: the GA's
/// population alone (read by [`parse_checkpoint`] as the GA's state).
pub const CHECKPOINT_FORMAT_POPULATION: &str = "hevo.checkpoint/1";

/// The directory of a node under a run output directory.
pub fn node_dir(out_dir: &Path, node: &str) -> PathBuf {
    out_dir.join(node)
}

/// The name of run `run`'s directory: the one place the `run-<k>` name is written.
pub fn run_dir_name(run: u32) -> String {
    format!("run-{run}")
}

/// The directory of run `run` of a node.
pub fn run_dir(node_dir: &Path, run: u32) -> PathBuf {
    node_dir.join(run_dir_name(run))
}

/// A node directory's run directories (`run-<k>`, see [`run_dir`]), in run order (run 10
/// after run 9), each with its run index. Other entries are left out.
pub fn run_dirs(node_dir: &Path) -> std::io::Result<Vec<(u32, PathBuf)>> {
    let mut runs: Vec<(u32, PathBuf)> = std::fs::read_dir(node_dir)?
        .filter_map(Result::ok)
        .filter_map(|entry| {
            let run = entry
                .file_name()
                .to_str()?
                .strip_prefix("run-")?
                .parse::<u32>()
                .ok()?;
            Some((run, entry.path()))
        })
        .collect();
    runs.sort();
    Ok(runs)
}

/// A run's checkpoint: everything needed to continue it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Checkpoint {
    /// Format tag ([`CHECKPOINT_FORMAT`]).
    pub format: String,
    /// The node's fingerprint when it was written.
    pub fingerprint: String,
    /// The next generation to evaluate (= generations when evolution is done).
    pub generation: u32,
    /// The search strategy's whole state: `{"algorithm": "ga", "state": {...}}`.
    pub strategy: StrategyState,
    /// The fitness log so far.
    pub log: Vec<FitnessRow>,
}

/// A checkpoint of format [`CHECKPOINT_FORMAT_POPULATION`], as the GA wrote it before
/// strategies had a state of their own.
#[derive(Debug, Clone, PartialEq, Deserialize)]
struct PopulationCheckpoint {
    format: String,
    fingerprint: String,
    generation: u32,
    /// The population to evaluate next (the final one when done).
    population: Vec<Vec<f32>>,
    /// The run's best genome, set once the last generation has been evaluated.
    best: Option<Vec<f32>>,
    log: Vec<FitnessRow>,
}

/// Reads a checkpoint's text, of either format: one of [`CHECKPOINT_FORMAT_POPULATION`] is
/// the GA's state, the population it holds and the best genome it names, with the run's seed
/// `run_seed` (the seed it was evolved from), so a run paused before strategies had their own
/// state continues exactly as it would have. The caller checks the format of what it gets
/// ([`CHECKPOINT_FORMAT`] for anything it can continue).
pub fn parse_checkpoint(text: &str, run_seed: u64) -> Result<Checkpoint, serde_json::Error> {
    #[derive(Deserialize)]
    struct Format {
        format: String,
    }
    if serde_json::from_str::<Format>(text)?.format != CHECKPOINT_FORMAT_POPULATION {
        return serde_json::from_str(text);
    }
    let old: PopulationCheckpoint = serde_json::from_str(text)?;
    Ok(Checkpoint {
        format: CHECKPOINT_FORMAT.into(),
        fingerprint: old.fingerprint,
        generation: old.generation,
        strategy: StrategyState::Ga(GaState {
            run_seed,
            generation: old.generation,
            population: old.population,
            best: old.best,
        }),
        log: old.log,
    })
}

/// The head of a [`Checkpoint`], for readers that need to know whose a checkpoint is and how
/// far it got without loading its population.
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct CheckpointHeader {
    /// The node's fingerprint when it was written.
    pub fingerprint: String,
    /// The next generation to evaluate.
    pub generation: u32,
}

/// A finished run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunSummary {
    /// Node.
    pub node: String,
    /// Run index.
    pub run: u32,
    /// Fingerprint of the node setup.
    pub fingerprint: String,
    /// The run's seed.
    pub run_seed: u64,
    /// Generations evolved.
    pub generations: u32,
    /// Training fitness of the best genome in the final generation.
    pub final_best_fitness: f64,
    /// Post-evaluation of that genome.
    pub post_evaluation: EvalReport,
}

/// A finished node.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NodeSummary {
    /// Node.
    pub node: String,
    /// Task.
    pub task: String,
    /// Fingerprint.
    pub fingerprint: String,
    /// Every run.
    pub runs: Vec<RunSummary>,
    /// The run whose controller the node keeps.
    pub best_run: u32,
    /// Mean post-evaluation solve rate over runs (the paper's "avg").
    pub mean_solve_rate: f64,
    /// The best run's solve rate (the paper's "best").
    pub best_solve_rate: f64,
}

/// A run directory that cannot be read.
#[derive(Debug, thiserror::Error)]
pub enum RunDirError {
    /// A directory or file could not be read.
    #[error("cannot read {path}: {source}")]
    Io {
        /// What was being read.
        path: PathBuf,
        /// Why not.
        source: std::io::Error,
    },
    /// A fitness log does not parse.
    #[error("{path}: {source}")]
    FitnessLog {
        /// The log.
        path: PathBuf,
        /// Where and what.
        source: FitnessLogError,
    },
}

/// Every run's fitness log under a node directory: the `run-<k>/fitness.csv` files, in run
/// order (run 10 after run 9), each with its run index. A run without a log yet is left out;
/// a log that does not parse is an error naming its file.
pub fn fitness_logs(node_dir: &Path) -> Result<Vec<(u32, Vec<FitnessRow>)>, RunDirError> {
    let runs = run_dirs(node_dir).map_err(|source| RunDirError::Io {
        path: node_dir.to_path_buf(),
        source,
    })?;
    let mut logs = Vec::new();
    for (run, dir) in runs {
        let path = dir.join(FITNESS_CSV);
        let Ok(text) = std::fs::read_to_string(&path) else {
            continue;
        };
        let rows =
            parse_fitness_csv(&text).map_err(|source| RunDirError::FitnessLog { path, source })?;
        logs.push((run, rows));
    }
    Ok(logs)
}

/// One generation's line of a `fitness.csv` log (also kept in run checkpoints).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FitnessRow {
    /// Generation number, from 0.
    pub generation: u32,
    /// Fitness of the generation's best genome.
    pub best: f64,
    /// Population mean fitness.
    pub mean: f64,
    /// Population minimum fitness.
    pub min: f64,
    /// Population maximum fitness.
    pub max: f64,
    /// Population standard deviation of fitness.
    pub std: f64,
}

/// A fitness log's text: the header, then one line per row.
pub fn fitness_csv(rows: &[FitnessRow]) -> String {
    let mut text = String::from(FITNESS_CSV_HEADER);
    text.push('\n');
    for row in rows {
        text.push_str(&format!(
            "{},{},{},{},{},{}\n",
            row.generation, row.best, row.mean, row.min, row.max, row.std
        ));
    }
    text
}

/// The header a fitness log starts with.
pub const FITNESS_CSV_HEADER: &str = "generation,best,mean,min,max,std";
const COLUMNS: [&str; 6] = ["generation", "best", "mean", "min", "max", "std"];

/// A problem in a fitness log. Lines and columns count from 1.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FitnessLogError {
    /// No header line.
    #[error("the fitness log is empty; expected the header `{FITNESS_CSV_HEADER}`")]
    Empty,
    /// The header lacks a required column.
    #[error("line {line}: the header has no column `{column}`; expected `{FITNESS_CSV_HEADER}`")]
    MissingColumn {
        /// Line of the header.
        line: usize,
        /// The missing column's name.
        column: &'static str,
    },
    /// The header names a column twice.
    #[error("line {line}, column {column}: the header names `{name}` a second time")]
    DuplicateColumn {
        /// Line of the header.
        line: usize,
        /// Position of the second occurrence.
        column: usize,
        /// The repeated name.
        name: String,
    },
    /// A row has more or fewer fields than the header.
    #[error(
        "line {line}: expected {expected} comma-separated fields like the header, found {found}"
    )]
    FieldCount {
        /// The row's line.
        line: usize,
        /// Fields in the header.
        expected: usize,
        /// Fields in the row.
        found: usize,
    },
    /// A field is not a valid value.
    #[error("line {line}, column {column} ({name}): `{value}` is not {expected}")]
    BadValue {
        /// The row's line.
        line: usize,
        /// The field's position.
        column: usize,
        /// The column's name.
        name: &'static str,
        /// The field as written.
        value: String,
        /// What the column holds.
        expected: &'static str,
    },
    /// Generations must increase from row to row.
    #[error(
        "line {line}, column {column} (generation): generation {generation} does not follow generation {previous}"
    )]
    GenerationOrder {
        /// The row's line.
        line: usize,
        /// The generation column's position.
        column: usize,
        /// This row's generation.
        generation: u32,
        /// The previous row's generation.
        previous: u32,
    },
}

/// Parses a `fitness.csv` log. The header must name the six columns of
/// [`FITNESS_CSV_HEADER`], in any order (extra columns are ignored, so a later writer may add
/// some); blank lines and `#` comments are skipped; generations must increase. An incomplete
/// last line, as a run being written may leave, is reported like any other bad line.
pub fn parse_fitness_csv(text: &str) -> Result<Vec<FitnessRow>, FitnessLogError> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(index, line)| (index + 1, line.trim()))
        .filter(|(_, line)| !line.is_empty() && !line.starts_with('#'));
    let (header_line, header) = lines.next().ok_or(FitnessLogError::Empty)?;
    let header_fields: Vec<&str> = header.split(',').map(str::trim).collect();
    for (position, name) in header_fields.iter().enumerate() {
        if header_fields[..position].contains(name) {
            return Err(FitnessLogError::DuplicateColumn {
                line: header_line,
                column: position + 1,
                name: name.to_string(),
            });
        }
    }
    let mut positions = [0usize; 6];
    for (slot, column) in positions.iter_mut().zip(COLUMNS) {
        *slot = header_fields
            .iter()
            .position(|name| *name == column)
            .ok_or(FitnessLogError::MissingColumn {
                line: header_line,
                column,
            })?;
    }

    let mut rows: Vec<FitnessRow> = Vec::new();
    for (line, content) in lines {
        let fields: Vec<&str> = content.split(',').map(str::trim).collect();
        if fields.len() != header_fields.len() {
            return Err(FitnessLogError::FieldCount {
                line,
                expected: header_fields.len(),
                found: fields.len(),
            });
        }
        let generation_column = positions[0];
        let generation: u32 =
            fields[generation_column]
                .parse()
                .map_err(|_| FitnessLogError::BadValue {
                    line,
                    column: generation_column + 1,
                    name: "generation",
                    value: fields[generation_column].to_string(),
                    expected: "a whole number of generations",
                })?;
        let mut values = [0.0f64; 5];
        for (value, (&position, name)) in values
            .iter_mut()
            .zip(positions[1..].iter().zip(&COLUMNS[1..]))
        {
            *value = fields[position]
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| FitnessLogError::BadValue {
                    line,
                    column: position + 1,
                    name,
                    value: fields[position].to_string(),
                    expected: "a finite number",
                })?;
        }
        if let Some(previous) = rows.last()
            && generation <= previous.generation
        {
            return Err(FitnessLogError::GenerationOrder {
                line,
                column: generation_column + 1,
                generation,
                previous: previous.generation,
            });
        }
        let [best, mean, min, max, std] = values;
        rows.push(FitnessRow {
            generation,
            best,
            mean,
            min,
            max,
            std,
        });
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn synthetic_rows(generations: u32) -> Vec<FitnessRow> {
        (0..generations)
            .map(|g| {
                let best = 0.1 + 0.8 * (1.0 - (-(f64::from(g)) / 30.0).exp());
                FitnessRow {
                    generation: g,
                    best,
                    mean: best / 2.0,
                    min: 0.0,
                    max: best,
                    std: 0.1,
                }
            })
            .collect()
    }

    #[test]
    fn csv_round_trips() {
        let rows = synthetic_rows(12);
        let parsed = parse_fitness_csv(&fitness_csv(&rows)).expect("valid log");
        assert_eq!(parsed.len(), 12);
        for (a, b) in parsed.iter().zip(&rows) {
            assert_eq!(a.generation, b.generation);
            assert!((a.best - b.best).abs() < 1e-12 && (a.std - b.std).abs() < 1e-12);
        }
        // Reordered and extra columns, CRLF line ends, blank lines and a byte-order mark.
        let text = "\u{feff}best,generation,std,mean,min,max,wall_seconds\r\n1.5,0,0.1,1,0.5,1.5,3\r\n\r\n2,1,0.1,1,0.5,2,4\r\n";
        let parsed = parse_fitness_csv(text).expect("valid log");
        assert_eq!(
            parsed[1],
            FitnessRow {
                generation: 1,
                best: 2.0,
                mean: 1.0,
                min: 0.5,
                max: 2.0,
                std: 0.1
            }
        );
    }

    #[test]
    fn csv_errors_name_the_line_and_column() {
        let header = FITNESS_CSV_HEADER;
        assert_eq!(parse_fitness_csv("\n \n"), Err(FitnessLogError::Empty));
        let err = parse_fitness_csv("generation,best,mean,min,max\n0,1,1,1,1\n").unwrap_err();
        assert_eq!(
            err,
            FitnessLogError::MissingColumn {
                line: 1,
                column: "std"
            }
        );
        assert!(err.to_string().starts_with("line 1:"), "{err}");

        let err =
            parse_fitness_csv(&format!("{header}\n0,1,1,1,1,0\n1,0.5,abc,0,1,0\n")).unwrap_err();
        assert!(
            matches!(
                err,
                FitnessLogError::BadValue {
                    line: 3,
                    column: 3,
                    name: "mean",
                    ..
                }
            ),
            "{err:?}"
        );
        assert!(err.to_string().contains("line 3, column 3 (mean)"), "{err}");

        let err = parse_fitness_csv(&format!("{header}\n0,1,1,1,1,0\n1,0.5,0.4\n")).unwrap_err();
        assert_eq!(
            err,
            FitnessLogError::FieldCount {
                line: 3,
                expected: 6,
                found: 3
            }
        );
        assert!(err.to_string().starts_with("line 3:"));

        let err = parse_fitness_csv(&format!("{header}\n-1,1,1,1,1,0\n")).unwrap_err();
        assert!(matches!(
            err,
            FitnessLogError::BadValue {
                line: 2,
                column: 1,
                name: "generation",
                ..
            }
        ));

        let err =
            parse_fitness_csv(&format!("{header}\n0,1,1,1,1,0\n0,NaN,1,1,1,0\n")).unwrap_err();
        assert!(matches!(
            err,
            FitnessLogError::BadValue {
                line: 3,
                column: 2,
                name: "best",
                ..
            }
        ));

        let err =
            parse_fitness_csv(&format!("{header}\n0,1,1,1,1,0\n\n0,1,1,1,1,0\n")).unwrap_err();
        assert!(matches!(
            err,
            FitnessLogError::GenerationOrder {
                line: 4,
                generation: 0,
                previous: 0,
                ..
            }
        ));

        let err = parse_fitness_csv("generation,best,best,mean,min,max,std\n").unwrap_err();
        assert!(matches!(
            err,
            FitnessLogError::DuplicateColumn {
                line: 1,
                column: 3,
                ..
            }
        ));
    }

    #[test]
    fn fitness_logs_are_read_in_run_order_and_a_broken_log_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let log = format!("{FITNESS_CSV_HEADER}\n0,1,0.5,0,1,0.1\n");
        for run in [10, 2, 9] {
            let run_dir = run_dir(dir.path(), run);
            std::fs::create_dir_all(&run_dir).unwrap();
            std::fs::write(run_dir.join(FITNESS_CSV), &log).unwrap();
        }
        // A run that has not logged a generation yet, and a directory that is not a run.
        std::fs::create_dir_all(dir.path().join("run-11")).unwrap();
        std::fs::create_dir_all(dir.path().join("plots")).unwrap();
        let runs: Vec<u32> = fitness_logs(dir.path())
            .unwrap()
            .into_iter()
            .map(|(run, _)| run)
            .collect();
        assert_eq!(runs, [2, 9, 10]);

        std::fs::write(dir.path().join("run-9/fitness.csv"), "generation,best\n").unwrap();
        let err = fitness_logs(dir.path()).unwrap_err().to_string();
        assert!(
            err.contains("run-9") && err.contains("fitness.csv"),
            "{err}"
        );
        assert!(fitness_logs(&dir.path().join("missing")).is_err());
    }

    #[test]
    fn a_population_only_checkpoint_is_read_as_the_ga_s_state() {
        let log = synthetic_rows(3);
        let text = serde_json::json!({
            "format": CHECKPOINT_FORMAT_POPULATION,
            "fingerprint": "abc",
            "generation": 3,
            "population": [[0.5, -1.25], [3.0, 0.1]],
            "best": [3.0, 0.1],
            "log": log,
        })
        .to_string();
        let checkpoint = parse_checkpoint(&text, 42).unwrap();
        let expected = Checkpoint {
            format: CHECKPOINT_FORMAT.into(),
            fingerprint: "abc".into(),
            generation: 3,
            strategy: StrategyState::Ga(GaState {
                run_seed: 42,
                generation: 3,
                population: vec![vec![0.5, -1.25], vec![3.0, 0.1]],
                best: Some(vec![3.0, 0.1]),
            }),
            log,
        };
        assert_eq!(checkpoint, expected);

        // Written back, it is the current format, which reads back as itself, whatever seed
        // the reader has (the state carries its own).
        let written = serde_json::to_string_pretty(&checkpoint).unwrap();
        assert!(
            written.contains("\"format\": \"hevo.checkpoint/2\""),
            "{written}"
        );
        assert!(
            written.contains("\"strategy\": {\n    \"algorithm\": \"ga\",\n    \"state\": {"),
            "{written}"
        );
        assert_eq!(parse_checkpoint(&written, 7).unwrap(), expected);

        // A checkpoint that is neither is malformed, naming what it lacks.
        let error = parse_checkpoint(
            r#"{"format": "hevo.checkpoint/2", "fingerprint": "abc"}"#,
            1,
        )
        .unwrap_err()
        .to_string();
        assert!(error.contains("missing field `generation`"), "{error}");
        assert!(parse_checkpoint("{}", 1).is_err());
    }
}
