//! The controllers shipped in `controllers/` still do what REPRODUCTION.md says they do under
//! the current simulator. A change to physics, sensors or tasks that silently breaks the
//! evolved hierarchy fails here, instead of surprising the first user who runs
//! `hevo eval controllers/rescue.json`.
//!
//! Each controller runs the post-evaluation samples of seed 1, 100 per light configuration (or
//! start branch), so the counts are the same on every run and machine. The floors are the
//! counts measured on those samples less a margin of two or three samples, so any change that
//! loses more than a couple of them, overall, in one light configuration or at one rescue
//! stage, fails here. And unless the model changed on purpose, each must solve exactly the
//! samples it solved when measured (a hash of which ones), as every refactoring keeps outcomes
//! bit-identical. (The rates these counts give agree with REPRODUCTION.md's, which were
//! measured on other samples: rescue 88.0 % here, 87.8-88.8 % there.)

use hevo_engine::post_evaluation::{post_evaluation_samples, report};
use hevo_sim_core::Controller;
use hevo_sim_core::SampleSummary;
use hevo_sim_core::{Evaluator, TaskConfig};
use std::path::PathBuf;

use crate::support::{repo_root, shipped_controller};

/// Samples per light configuration (or start branch), as in REPRODUCTION.md's post-evaluation.
const N_SAMPLES: u32 = 100;
/// The post-evaluation seed the samples derive from.
const SEED: u64 = 1;

/// What a shipped controller must reach on its samples, in samples.
struct Floor {
    file: &'static str,
    task: &'static str,
    /// Samples solved, of all.
    solved: usize,
    /// Tasks with light configurations (start branches): solved, per configuration, of 100.
    per_variant: &'static [usize],
    /// Rescue: samples that left the room, reached the teammate, and brought it back.
    stages: Option<[usize; 3]>,
    /// Which samples it solved when measured: the FNV-1a hash of one `1` (solved) or `0` per
    /// sample, in post-evaluation order. The floors allow for a change made on purpose; this
    /// does not: the same simulator solves exactly the same samples.
    solved_samples: &'static str,
}

/// Every shipped controller, with its floors: the counts measured on these samples (in the
/// comments) less three samples overall and at each rescue stage, two in each light
/// configuration. A change that moves a count on purpose updates its floor here.
const SHIPPED: &[Floor] = &[
    Floor {
        file: "exit_room.json",
        task: "exit_room",
        solved: 97, // measured 100 of 100
        per_variant: &[],
        stages: None,
        solved_samples: "6bf4b31f38d38dd9",
    },
    Floor {
        file: "follow_wall.json",
        task: "follow_wall",
        solved: 97, // measured 100 of 100
        per_variant: &[],
        stages: None,
        solved_samples: "6bf4b31f38d38dd9",
    },
    Floor {
        file: "turn_left.json",
        task: "turn_left",
        solved: 91, // measured 94 of 100
        per_variant: &[],
        stages: None,
        solved_samples: "a8f3a744c2d7da61",
    },
    Floor {
        file: "turn_right.json",
        task: "turn_right",
        solved: 93, // measured 96 of 100
        per_variant: &[],
        stages: None,
        solved_samples: "49d2f81341f0a98f",
    },
    Floor {
        file: "solve_maze.json",
        task: "solve_maze",
        solved: 395, // measured 398 of 400
        // measured 100, 100, 100, 98 of 100
        per_variant: &[98, 98, 98, 96],
        stages: None,
        solved_samples: "c5adfeb7ada2edd5",
    },
    Floor {
        file: "return_room.json",
        task: "return_room",
        solved: 377, // measured 380 of 400
        // measured 93, 95, 95, 97 of 100
        per_variant: &[91, 93, 93, 95],
        stages: None,
        solved_samples: "d1d185c87c6c9c4d",
    },
    Floor {
        file: "rescue.json",
        task: "rescue",
        solved: 349, // measured 352 of 400
        // measured 85, 90, 89, 88 of 100
        per_variant: &[83, 88, 87, 86],
        // measured 380 left the room, 372 reached the teammate, 352 brought it back
        stages: Some([377, 369, 349]),
        solved_samples: "1822a8253e9bb021",
    },
    // Tasks that are not the paper's, from the example scenario files.
    Floor {
        file: "triple_t_maze.json",
        task: "scenarios/examples/triple_t_maze.toml",
        solved: 670, // measured 673 of 800
        // measured 98, 83, 100, 99, 100, 0, 95, 98 of 100
        per_variant: &[96, 81, 98, 97, 98, 0, 93, 96],
        stages: None,
        solved_samples: "d2bfeddd8a07007c",
    },
    Floor {
        file: "triple_t_maze_single.json",
        task: "scenarios/examples/triple_t_maze.toml",
        solved: 384, // measured 387 of 800
        // measured 94, 97, 0, 98, 0, 0, 0, 98 of 100
        per_variant: &[92, 95, 0, 96, 0, 0, 0, 96],
        stages: None,
        solved_samples: "d26ed034e8d741a6",
    },
    Floor {
        file: "cross_yard.json",
        task: "scenarios/examples/cross_yard.toml",
        solved: 187, // measured 190 of 200
        // measured 98, 92 of 100
        per_variant: &[96, 90],
        stages: None,
        solved_samples: "ad6311b2624fb815",
    },
    Floor {
        file: "room_to_yard.json",
        task: "scenarios/examples/room_to_yard.toml",
        solved: 188, // measured 191 of 200
        // measured 94, 97 of 100
        per_variant: &[92, 95],
        stages: None,
        solved_samples: "97793c63a7e1ab06",
    },
    // Collective primitives: ten robots, each running a copy (scenarios/swarm/). Homing
    // solves none (the whole team home): its samples are pinned, its floor says nothing.
    Floor {
        file: "aggregation.json",
        task: "scenarios/swarm/aggregation.toml",
        solved: 79, // measured 82 of 100
        per_variant: &[],
        stages: None,
        solved_samples: "17e9b2b2af0511a9",
    },
    Floor {
        file: "dispersion.json",
        task: "scenarios/swarm/dispersion.toml",
        solved: 97, // measured 100 of 100
        per_variant: &[],
        stages: None,
        solved_samples: "6bf4b31f38d38dd9",
    },
    // A heterogeneous team: five robots run aggregation.json read from the scenario's group
    // (`controller = { file = ... }`), five (the focal one too) the controller judged, here
    // aggregation.json again. That is the aggregation team robot for robot (the same arena,
    // starts and streams), so it solves exactly aggregation.toml's samples: a file's copies
    // run as evolved copies do.
    Floor {
        file: "aggregation.json",
        task: "scenarios/swarm/mixed_aggregation.toml",
        solved: 79, // measured 82 of 100
        per_variant: &[],
        stages: None,
        solved_samples: "17e9b2b2af0511a9",
    },
    Floor {
        file: "homing.json",
        task: "scenarios/swarm/homing.toml",
        solved: 0, // measured 0 of 100
        per_variant: &[],
        stages: None,
        solved_samples: "a2103c010d71aeb5",
    },
    // The mission: an arbitrator over aggregation and dispersion, every robot running the
    // whole tree; the lamps lit for 300 cycles, then dark.
    Floor {
        file: "mission.json",
        task: "scenarios/swarm/mission.toml",
        solved: 92, // measured 95 of 100
        per_variant: &[],
        stages: None,
        solved_samples: "98d0dac4bcbc657c",
    },
    // Foraging: five robots, ten items, a nest (scenarios/swarm/foraging.toml). Solved means
    // every item delivered within the limit, which it rarely does (it delivers most of them):
    // its samples are pinned, its floor says little.
    Floor {
        file: "foraging.json",
        task: "scenarios/swarm/foraging.toml",
        solved: 0, // measured 2 of 100
        per_variant: &[],
        stages: None,
        solved_samples: "ed60478ee8de3eff",
    },
    // Crossing: three robots cross a room past three movers (scenarios/swarm/crossing.toml);
    // solved when the focal robot reaches the east end without a collision.
    Floor {
        file: "crossing.json",
        task: "scenarios/swarm/crossing.toml",
        solved: 81, // measured 84 of 100
        per_variant: &[],
        stages: None,
        solved_samples: "1a7960ec65dd0ce5",
    },
    // A shipped controller on a task it was not evolved for: exit room in the authors' room
    // (docs/decisions/model/0044-the-authors-room.md).
    Floor {
        file: "exit_room.json",
        task: "scenarios/examples/exit_room_authors.toml",
        solved: 85, // measured 88 of 100
        per_variant: &[],
        stages: None,
        solved_samples: "b873af4df46cd00f",
    },
];

fn controllers_dir() -> PathBuf {
    repo_root().join("controllers")
}

/// A floor's task: a shipped scenario's name, or a scenario file's path in the repository.
fn task_of(floor: &Floor) -> TaskConfig {
    if !floor.task.ends_with(".toml") {
        return TaskConfig::shipped(floor.task).expect("a shipped task");
    }
    // Read as the command line reads it: with the controller files its groups run.
    let path = repo_root().join(floor.task);
    let scenario = hevo_engine::inputs::read_scenario(&path.to_string_lossy())
        .unwrap_or_else(|e| panic!("{e}"));
    TaskConfig::from_scenario(std::sync::Arc::new(scenario))
}

#[test]
fn every_shipped_controller_is_listed_here() {
    let mut found: Vec<String> = std::fs::read_dir(controllers_dir())
        .expect("controllers/ exists")
        .map(|entry| entry.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|name| name.ends_with(".json"))
        .collect();
    found.sort();
    let mut listed: Vec<String> = SHIPPED.iter().map(|f| f.file.to_string()).collect();
    listed.sort();
    // A controller judged on more than one task is listed once per task.
    listed.dedup();
    for (file, _) in MEAN_FITNESS_FLOORS {
        assert!(
            listed.contains(&file.to_string()),
            "{file} has a fitness floor, not a floor"
        );
    }
    assert_eq!(
        found, listed,
        "add new controllers to SHIPPED with their floor"
    );
}

/// Controllers whose task is rarely solved outright (every robot of the team home, every item
/// delivered), so that a solve count says little of them: the mean fitness on the same samples
/// must stay above these floors, a little under what was measured (in the comments). Homing's
/// fitness is the share of the team home at the end; foraging's the share delivered plus a
/// quarter of the share picked up.
const MEAN_FITNESS_FLOORS: &[(&str, f64)] = &[
    ("homing.json", 0.46),   // measured 0.494
    ("foraging.json", 0.90), // measured 0.93
];

/// What a controller achieved on its samples, in samples.
#[derive(Debug, PartialEq)]
struct Counts {
    samples: usize,
    solved: usize,
    /// The mean fitness over the samples.
    mean_fitness: f64,
    per_variant: Vec<usize>,
    stages: Option<[usize; 3]>,
    solved_samples: String,
}

/// Runs the shipped controller `file` on its task's samples.
fn measure(file: &str, task: &TaskConfig) -> Counts {
    let controller_file = shipped_controller(file);
    let evaluator = Evaluator::new(task.clone()).expect("valid task");
    let summaries: Vec<SampleSummary> = post_evaluation_samples(task, N_SAMPLES, SEED)
        .into_iter()
        .map(|sample| {
            let mut controller = Controller::new(&controller_file, None)
                .unwrap_or_else(|e| panic!("controllers/{file}: {e}"));
            SampleSummary::from(&evaluator.evaluate(&mut controller, sample))
        })
        .collect();
    let n_variants = task.scenario.n_variants();
    let count =
        |keep: &dyn Fn(&SampleSummary) -> bool| summaries.iter().filter(|s| keep(s)).count();
    let counts = Counts {
        samples: summaries.len(),
        solved: count(&|s| s.solved),
        mean_fitness: summaries.iter().map(|s| f64::from(s.fitness)).sum::<f64>()
            / summaries.len() as f64,
        per_variant: if n_variants > 1 {
            (0..n_variants)
                .map(|v| count(&|s| s.variant == v && s.solved))
                .collect()
        } else {
            Vec::new()
        },
        stages: (task.name() == "rescue")
            .then(|| [1, 2, 3].map(|stage| count(&|s| s.stage >= stage))),
        solved_samples: hevo_sim_core::fnv1a_hex(
            &summaries
                .iter()
                .map(|s| if s.solved { b'1' } else { b'0' })
                .collect::<Vec<u8>>(),
        ),
    };
    // The post-evaluation report says the same as the counts.
    let report = report(task, &summaries, &controller_file.node_paths());
    assert_eq!(
        report.solve_rate,
        counts.solved as f64 / counts.samples as f64
    );
    for (variant, &solved) in report.per_variant.iter().zip(&counts.per_variant) {
        assert_eq!(variant.samples, N_SAMPLES);
        assert_eq!(variant.solve_rate, solved as f64 / f64::from(N_SAMPLES));
    }
    counts
}

#[test]
fn shipped_controllers_solve_their_tasks_and_exactly_the_samples_measured() {
    let (mut failures, mut changed) = (Vec::new(), Vec::new());
    for floor in SHIPPED {
        let task = task_of(floor);
        let counts = measure(floor.file, &task);
        eprintln!("{}: {counts:?}", floor.file);
        if counts.solved_samples != floor.solved_samples {
            changed.push(format!(
                "{}: solved samples {} (solving {} of {}), measured {}",
                floor.file,
                counts.solved_samples,
                counts.solved,
                counts.samples,
                floor.solved_samples
            ));
        }
        let n_variants = task.scenario.n_variants() as usize;
        assert_eq!(counts.samples, N_SAMPLES as usize * n_variants);
        let fitness_floor = MEAN_FITNESS_FLOORS
            .iter()
            .find(|(file, _)| *file == floor.file);
        if let Some(&(_, least)) = fitness_floor
            && counts.mean_fitness < least
        {
            failures.push(format!(
                "{} has a mean fitness of {:.3} on {}, below its floor {least}",
                floor.file, counts.mean_fitness, floor.task
            ));
        }
        if counts.solved < floor.solved {
            failures.push(format!(
                "{} solves {} of {} {} samples, below its floor {}",
                floor.file, counts.solved, counts.samples, floor.task, floor.solved
            ));
        }
        assert_eq!(
            floor.per_variant.len(),
            counts.per_variant.len(),
            "{}",
            floor.file
        );
        for (variant, (&found, &least)) in
            counts.per_variant.iter().zip(floor.per_variant).enumerate()
        {
            if found < least {
                failures.push(format!(
                    "{} solves {found} of {N_SAMPLES} samples in light configuration (start branch) {variant}, below its floor {least}",
                    floor.file
                ));
            }
        }
        assert_eq!(
            floor.stages.is_some(),
            counts.stages.is_some(),
            "{}",
            floor.file
        );
        if let (Some(found), Some(least)) = (counts.stages, floor.stages) {
            for (stage, (found, least)) in
                ["left the room", "reached the teammate", "brought it back"]
                    .iter()
                    .zip(found.iter().zip(least))
            {
                if found < &least {
                    failures.push(format!(
                        "{}: {found} of {} samples {stage}, below its floor {least}",
                        floor.file, counts.samples
                    ));
                }
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    assert!(
        changed.is_empty(),
        "a shipped controller solves other samples than when measured; a change to the model \
         made on purpose bumps MODEL_VERSION, re-measures and updates `solved_samples`:\n{}",
        changed.join("\n")
    );
}
