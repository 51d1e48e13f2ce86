//! The runner's part of the run-directory format: a run's checkpoint (everything needed to
//! continue it, the search strategy's state included), in its current and its earlier format.
//! The rest of the format (names, paths, summaries, fitness logs) is `hevo_rundir`'s, which
//! the pictures and the dashboard read without the engine; it is re-exported here.

pub use hevo_rundir::archive;
pub use hevo_rundir::fitness_log::*;
pub use hevo_rundir::layout::*;

use hevo_evolve::StrategyState;
use hevo_evolve::ga::GaState;
use serde::{Deserialize, Serialize};

/// The format tag of [`Checkpoint`]: the search strategy's state, tagged with its algorithm.
pub const CHECKPOINT_FORMAT: &str = "hevo.checkpoint/2";
/// The format tag of the checkpoints written before strategies had their own state: the GA's
/// population alone (read by [`parse_checkpoint`] as the GA's state).
pub const CHECKPOINT_FORMAT_POPULATION: &str = "hevo.checkpoint/1";

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

#[cfg(test)]
mod tests {
    use super::*;

    fn synthetic_rows(generations: u32) -> Vec<FitnessRow> {
        (0..generations)
            .map(|g| FitnessRow {
                generation: g,
                best: f64::from(g),
                mean: 0.5,
                min: 0.0,
                max: f64::from(g),
                std: 0.1,
            })
            .collect()
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
