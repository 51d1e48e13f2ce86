//! Golden (snapshot) tests: fixed-seed samples of every task, driven by the scripted reference
//! policies, must reproduce exactly the recorded outcome (fitness to the bit, cycles, ending,
//! stage), final pose and a few trajectory points. Any change to the robot, sensor, world or
//! fitness model, to the random streams, or to the scripted policies changes them; this test
//! makes such a change visible instead of silent.
//!
//! When a change is intended, re-record the table and paste it over `EXPECTED` below:
//!
//! ```text
//! HEVO_BLESS=1 cargo test -p hevo-sim-core --release --test golden
//! ```
//!
//! In bless mode the test prints the new table to stderr instead of comparing, and then fails,
//! so that a blessing run can never pass for a checking one (the failure report shows the
//! table). Paste it over `EXPECTED` and rerun without `HEVO_BLESS`. The values are exact
//! f32 bit patterns: they are the same on every machine that computes `sin`, `cos` and
//! `hypot` identically (the same Rust standard library and platform maths); a different
//! platform may need its own blessing.

use hevo_scripted::{
    CorridorFollower, MazeSolver, Rescuer, Returner, RoomExiter, TurnSide, Turner,
};
use hevo_sim_core::Pose;
use hevo_sim_core::SHIPPED_NAMES;
use hevo_sim_core::{Ending, Evaluator, Policy, Sample, TaskConfig, Trace};

/// A pose as the bit patterns of x, y and heading.
type PoseBits = [u32; 3];

/// The recorded facts of one sample.
#[derive(Debug, Clone, PartialEq)]
struct Golden {
    task: &'static str,
    seed: u64,
    variant: Option<u32>,
    fitness_bits: u32,
    cycles: u32,
    ending: Ending,
    stage: u8,
    final_pose: PoseBits,
    /// The robot's pose at the start of cycles 0, n/4, n/2 and 3n/4 of the n cycles run.
    points: [(u32, PoseBits); 4],
}

/// The samples recorded, in the tasks' default configurations: each task with its scripted
/// policy, two seeds each, and the maze in all four light configurations.
const CASES: &[(&str, u64, Option<u32>)] = &[
    ("follow_wall", 1, None),
    ("follow_wall", 2, None),
    ("turn_left", 3, None),
    ("turn_left", 4, None),
    ("turn_right", 5, None),
    ("turn_right", 6, None),
    ("solve_maze", 7, Some(0)),
    ("solve_maze", 7, Some(1)),
    ("solve_maze", 7, Some(2)),
    ("solve_maze", 7, Some(3)),
    ("return_room", 8, None),
    ("return_room", 9, None),
    ("exit_room", 10, None),
    ("exit_room", 11, None),
    ("rescue", 12, None),
    ("rescue", 13, None),
];

fn pose_bits(pose: &Pose) -> PoseBits {
    [pose.x.to_bits(), pose.y.to_bits(), pose.heading.to_bits()]
}

fn traced(kind: &'static str, sample: Sample) -> Trace {
    let evaluator = Evaluator::new(TaskConfig::shipped(kind).unwrap())
        .expect("the paper's task configurations are valid");
    match kind {
        "exit_room" => run(&evaluator, RoomExiter::new(), sample),
        "follow_wall" => run(&evaluator, CorridorFollower::new(), sample),
        "turn_left" => run(&evaluator, Turner::new(TurnSide::Left), sample),
        "turn_right" => run(&evaluator, Turner::new(TurnSide::Right), sample),
        "solve_maze" => run(&evaluator, MazeSolver::new(), sample),
        "return_room" => run(&evaluator, Returner::new(), sample),
        "rescue" => run(&evaluator, Rescuer::new(), sample),
        other => panic!("no scripted policy for {other}"),
    }
}

fn run(evaluator: &Evaluator, mut policy: impl Policy, sample: Sample) -> Trace {
    evaluator.evaluate_traced(&mut policy, sample)
}

fn observe(kind: &'static str, seed: u64, variant: Option<u32>) -> Golden {
    let trace = traced(kind, Sample { seed, variant });
    let n = trace.cycles.len();
    let point = |index: usize| {
        let cycle = trace
            .cycles
            .get(index)
            .map_or(trace.final_robot, |c| c.robot);
        (index as u32, pose_bits(&cycle))
    };
    Golden {
        task: kind,
        seed,
        variant,
        fitness_bits: trace.outcome.fitness.to_bits(),
        cycles: trace.outcome.cycles,
        ending: trace.outcome.ending,
        stage: trace.outcome.stage,
        final_pose: pose_bits(&trace.final_robot),
        points: [point(0), point(n / 4), point(n / 2), point(3 * n / 4)],
    }
}

fn pose_source(bits: &PoseBits) -> String {
    format!("[{:#010x}, {:#010x}, {:#010x}]", bits[0], bits[1], bits[2])
}

/// The table as Rust source, for pasting over `EXPECTED`.
fn table_source(rows: &[Golden]) -> String {
    let mut out = String::from("const EXPECTED: &[Golden] = &[\n");
    for row in rows {
        let points: Vec<String> = row
            .points
            .iter()
            .map(|(cycle, pose)| format!("({cycle}, {})", pose_source(pose)))
            .collect();
        out += &format!(
            "    Golden {{\n        task: {:?},\n        seed: {},\n        variant: {:?},\n        \
             fitness_bits: {:#010x}, // {}\n        cycles: {},\n        ending: Ending::{:?},\n        \
             stage: {},\n        final_pose: {},\n        points: [{}],\n    }},\n",
            row.task,
            row.seed,
            row.variant,
            row.fitness_bits,
            f32::from_bits(row.fitness_bits),
            row.cycles,
            row.ending,
            row.stage,
            pose_source(&row.final_pose),
            points.join(", "),
        );
    }
    out + "];\n"
}

/// A pose in readable units, for failure messages.
fn pose_text(bits: &PoseBits) -> String {
    let [x, y, heading] = bits.map(f32::from_bits);
    format!("({x}, {y}, {heading})")
}

#[test]
fn fixed_seed_samples_reproduce_their_recorded_trajectories() {
    let observed: Vec<Golden> = CASES
        .iter()
        .map(|&(kind, seed, variant)| observe(kind, seed, variant))
        .collect();
    if std::env::var_os("HEVO_BLESS").is_some_and(|v| v == "1") {
        eprintln!("{}", table_source(&observed));
        panic!(
            "HEVO_BLESS is set, so the golden table was printed (above, on stderr) and not \
             compared: paste it over EXPECTED in sim-core/tests/golden.rs and rerun without \
             HEVO_BLESS"
        );
    }
    assert_eq!(
        EXPECTED.len(),
        observed.len(),
        "the table has {} rows for {} cases; re-bless (see the top of this file)",
        EXPECTED.len(),
        observed.len()
    );
    let mut differences = Vec::new();
    for (expected, got) in EXPECTED.iter().zip(&observed) {
        if expected == got {
            continue;
        }
        let mut what = vec![format!(
            "{} seed {} variant {:?}:",
            got.task, got.seed, got.variant
        )];
        if (expected.task, expected.seed, expected.variant) != (got.task, got.seed, got.variant) {
            what.push(format!("case was {} seed {}", expected.task, expected.seed));
        }
        if expected.fitness_bits != got.fitness_bits {
            what.push(format!(
                "fitness {} -> {}",
                f32::from_bits(expected.fitness_bits),
                f32::from_bits(got.fitness_bits)
            ));
        }
        if (expected.cycles, expected.ending, expected.stage) != (got.cycles, got.ending, got.stage)
        {
            what.push(format!(
                "cycles/ending/stage {}/{:?}/{} -> {}/{:?}/{}",
                expected.cycles, expected.ending, expected.stage, got.cycles, got.ending, got.stage
            ));
        }
        if expected.final_pose != got.final_pose {
            what.push(format!(
                "final pose {} -> {}",
                pose_text(&expected.final_pose),
                pose_text(&got.final_pose)
            ));
        }
        for (e, g) in expected.points.iter().zip(&got.points) {
            if e != g {
                what.push(format!(
                    "cycle {} pose {} -> cycle {} pose {}",
                    e.0,
                    pose_text(&e.1),
                    g.0,
                    pose_text(&g.1)
                ));
            }
        }
        differences.push(what.join(" "));
    }
    assert!(
        differences.is_empty(),
        "{} of {} golden samples changed; if the change is intended, re-bless with \
         HEVO_BLESS=1 (see the top of this file):\n{}",
        differences.len(),
        observed.len(),
        differences.join("\n")
    );
}

#[test]
fn the_golden_cases_cover_every_task_and_mostly_succeed() {
    // The snapshot is only a useful tripwire if it pins real behaviour: every task appears,
    // and most recorded samples are solved ones (long, eventful trajectories).
    for kind in SHIPPED_NAMES {
        assert!(
            CASES.iter().any(|&(k, ..)| k == kind),
            "{kind} has no golden case"
        );
    }
    let solved = EXPECTED
        .iter()
        .filter(|g| g.ending == Ending::Solved)
        .count();
    assert!(
        solved * 4 >= EXPECTED.len() * 3,
        "only {solved} of {} golden samples are solved",
        EXPECTED.len()
    );
}

/// Recorded with `HEVO_BLESS=1` (see the top of this file).
#[rustfmt::skip]
const EXPECTED: &[Golden] = &[
    Golden {
        task: "follow_wall",
        seed: 1,
        variant: None,
        fitness_bits: 0x3fd66666, // 1.675
        cycles: 130,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0x3bee4eae, 0x3f8704e7, 0x3fcb3663],
        points: [(0, [0xbc33bdfa, 0xb003d099, 0x3fc31ef2]), (32, [0x3c073d2c, 0x3e8a3ccd, 0x3fc4168c]), (65, [0x3c17d277, 0x3f0a4385, 0x3fced93d]), (97, [0x3c458dec, 0x3f4d035e, 0x3fc718bb])],
    },
    Golden {
        task: "follow_wall",
        seed: 2,
        variant: None,
        fitness_bits: 0x3ff00000, // 1.875
        cycles: 50,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0xbb0e5ed8, 0x3ee872ba, 0x3fcc95f3],
        points: [(0, [0x3c8bfeb8, 0x304d5509, 0x3fc6fa3a]), (12, [0x3c199790, 0x3dc7319e, 0x3fd7c40d]), (25, [0xba975c81, 0x3e5f638d, 0x3fcc9bc5]), (37, [0xbba1867b, 0x3ea8e18e, 0x3fc80287])],
    },
    Golden {
        task: "turn_left",
        seed: 3,
        variant: None,
        fitness_bits: 0x3fa33333, // 1.275
        cycles: 290,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0xbf86dc31, 0x3f188de3, 0xc0465405],
        points: [(0, [0x3c9522cf, 0x3e8d4a3e, 0x3fbe7896]), (72, [0xbbc585a8, 0xbc4dd30b, 0xbf4464d2]), (145, [0x3c2ed3f0, 0x3efd2a0f, 0x3fc1b233]), (217, [0xbed0d75b, 0x3f18d414, 0xc048bac4])],
    },
    Golden {
        task: "turn_left",
        seed: 4,
        variant: None,
        fitness_bits: 0x3fe70a3e, // 1.8050001
        cycles: 78,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0xbee8d6b6, 0x3e9c6ac4, 0xc04836f9],
        points: [(0, [0x3c98fd5e, 0x3e80b460, 0x3fcf6d72]), (19, [0x3c2f1120, 0x3e9e1c88, 0xc0469686]), (39, [0xbe1ed99d, 0x3e9c036c, 0x404406fc]), (58, [0xbe9dbe8f, 0x3e9b1ef8, 0x40461ba2])],
    },
    Golden {
        task: "turn_right",
        seed: 5,
        variant: None,
        fitness_bits: 0x3fd75c29, // 1.6825
        cycles: 127,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0x3f426c5c, 0x3f1ad598, 0xbccaf0b2],
        points: [(0, [0x3b4c7818, 0x3e67c6c5, 0x3fcd50b2]), (31, [0xbb3d8dcb, 0x3f066d63, 0x3fcc1299]), (63, [0x3e0e1c51, 0x3f18a697, 0x3e11bd8f]), (95, [0x3ee56992, 0x3f1ac02e, 0xbc1b38c6])],
    },
    Golden {
        task: "turn_right",
        seed: 6,
        variant: None,
        fitness_bits: 0x3fe1999a, // 1.7625
        cycles: 95,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0x3f41ff9a, 0x3e99c3b1, 0x3c7b9118],
        points: [(0, [0xbb4858e0, 0x3e6c05d5, 0x3fc2e922]), (23, [0x3d8e9704, 0x3e93d4d0, 0xbcade3d1]), (47, [0x3e96cd10, 0x3e967baf, 0xbc85a92b]), (71, [0x3f0643c2, 0x3e9a4700, 0xb8aaea80])],
    },
    Golden {
        task: "solve_maze",
        seed: 7,
        variant: Some(0),
        fitness_bits: 0x3fdb020c, // 1.711
        cycles: 289,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0x3f65fcd8, 0x3e200926, 0x3fc7cf19],
        points: [(0, [0x3ae148a0, 0xbfc00000, 0x3fd920b2]), (72, [0x3bb4212f, 0xbf4f46a9, 0x3fcac4d0]), (144, [0x3d8e2f32, 0xbe96c2ef, 0xbd6cbb08]), (216, [0x3f4323dc, 0xbe9b3b07, 0xbb9e4886])],
    },
    Golden {
        task: "solve_maze",
        seed: 7,
        variant: Some(1),
        fitness_bits: 0x3fdae148, // 1.71
        cycles: 290,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0x3f65f234, 0xbf40cad8, 0xbfca11e5],
        points: [(0, [0x3ae148a0, 0xbfc00000, 0x3fd920b2]), (72, [0x3bb4212f, 0xbf4f46a9, 0x3fcac4d0]), (145, [0x3da1996b, 0xbe970780, 0xbd56de4a]), (217, [0x3f45a4a3, 0xbe9b4697, 0xbc587271])],
    },
    Golden {
        task: "solve_maze",
        seed: 7,
        variant: Some(2),
        fitness_bits: 0x3fdb020c, // 1.711
        cycles: 289,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0xbf65e915, 0x3e1dfc24, 0x3fc0d06d],
        points: [(0, [0x3ae148a0, 0xbfc00000, 0x3fd920b2]), (72, [0x3bb4212f, 0xbf4f46a9, 0x3fcac4d0]), (144, [0xbd825848, 0xbe95f918, 0xc0465a3f]), (216, [0xbf42ea89, 0xbe998326, 0x4047d6ca])],
    },
    Golden {
        task: "solve_maze",
        seed: 7,
        variant: Some(3),
        fitness_bits: 0x3fdb020c, // 1.711
        cycles: 289,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0xbf678f53, 0xbf41de63, 0xbfbf4047],
        points: [(0, [0x3ae148a0, 0xbfc00000, 0x3fd920b2]), (72, [0x3bb4212f, 0xbf4f46a9, 0x3fcac4d0]), (144, [0xbd825848, 0xbe95f918, 0xc0465a3f]), (216, [0xbf42ea89, 0xbe998326, 0x4047d6ca])],
    },
    Golden {
        task: "return_room",
        seed: 8,
        variant: None,
        fitness_bits: 0x3fd58106, // 1.668
        cycles: 332,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0xbbd9435d, 0xbfad0db3, 0xbfc62ebd],
        points: [(0, [0xbf685053, 0x3e800000, 0x40335b09]), (83, [0xbf67062d, 0xbe93b2e3, 0xbf9c00e3]), (166, [0xbe87eb45, 0xbe9ce7a1, 0x3b7d2984]), (249, [0xbb629b48, 0xbf29e11b, 0xbfcf047e])],
    },
    Golden {
        task: "return_room",
        seed: 9,
        variant: None,
        fitness_bits: 0x3fd7ef9e, // 1.687
        cycles: 313,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0xbbcac01e, 0xbfad9217, 0xbfc44363],
        points: [(0, [0x3f659551, 0xbf59999a, 0xbfcd3cc2]), (78, [0x3f67cd48, 0xbed3de76, 0x3fc72e3d]), (156, [0x3eba7513, 0xbe95f942, 0x40477c3c]), (234, [0xbbbe7d69, 0xbf16405a, 0xbfca15bf])],
    },
    Golden {
        task: "exit_room",
        seed: 10,
        variant: None,
        fitness_bits: 0x40a93f7d, // 5.289
        cycles: 711,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0xbf27a2de, 0xbe6e3d83, 0x4046df9d],
        points: [(0, [0x3d8c597c, 0xbcfe1950, 0x3dfc3340]), (177, [0x3deeda21, 0xbeef4752, 0x40414918]), (355, [0xbe0fb177, 0x3ef1745b, 0x3c645292]), (533, [0x3ee94458, 0xbee9fcc3, 0xbfc62da7])],
    },
    Golden {
        task: "exit_room",
        seed: 11,
        variant: None,
        fitness_bits: 0x40ad1eb8, // 5.41
        cycles: 590,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0x3ea0fdd9, 0xbf247bf3, 0xbfceef5e],
        points: [(0, [0x3d427a30, 0x3d6de1e8, 0x40579e63]), (147, [0xbeeb68f6, 0x3eda8f4d, 0x4001fbf5]), (295, [0xbe869207, 0x3df678d7, 0xbd37efd9]), (442, [0x3e88cd98, 0x3e8b6369, 0xbf6b7845])],
    },
    Golden {
        task: "rescue",
        seed: 12,
        variant: None,
        fitness_bits: 0x403fd018, // 2.997076
        cycles: 1510,
        ending: Ending::Solved,
        stage: 3,
        final_pose: [0x38ea5d45, 0xbfea8e1a, 0xbfc81aac],
        points: [(0, [0xbebd5b28, 0xc011b338, 0xbfaa12bf]), (377, [0xbe0fc56d, 0xc02a9547, 0xc0490d06]), (755, [0xbba189dd, 0xbf93da4b, 0x3fcb2d7f]), (1132, [0x3f66b87c, 0xbca6bf66, 0xbfc6d893])],
    },
    Golden {
        task: "rescue",
        seed: 13,
        variant: None,
        fitness_bits: 0x403fe2cc, // 2.9982176
        cycles: 1212,
        ending: Ending::Solved,
        stage: 3,
        final_pose: [0x39f087ff, 0xbfebd750, 0xbfce5e71],
        points: [(0, [0x3e11ae50, 0xc01272dc, 0x3fb402ba]), (303, [0x3d938170, 0xc033230e, 0x4047b586]), (606, [0xbb47092e, 0xbf9c2a22, 0x3fce9e24]), (909, [0xbf67c29b, 0xb98dace0, 0xbfca244f])],
    },
];
