//! Golden (snapshot) tests: fixed-seed samples of every task, driven by the scripted reference
//! policies, must reproduce exactly the recorded outcome (fitness to the bit, cycles, ending,
//! stage), final pose and a few trajectory points. Any change to the robot, sensor, world or
//! fitness model, to the random streams, or to the scripted policies changes them; this test
//! makes such a change visible instead of silent.
//!
//! When a change is intended, re-record the table and paste it over `EXPECTED` below:
//!
//! ```text
//! HEVO_BLESS=1 cargo test -p hevo-sim-core --release --test golden -- --nocapture
//! ```
//!
//! In bless mode the test prints the new table and does not compare. The values are exact
//! f32 bit patterns: they are the same on every machine that computes `sin`, `cos` and
//! `hypot` identically (the same Rust standard library and platform maths); a different
//! platform may need its own blessing.

use sim_core::robot::Pose;
use sim_core::scripted::{
    CorridorFollower, MazeSolver, Rescuer, Returner, RoomExiter, TurnSide, Turner,
};
use sim_core::{Ending, Evaluator, Policy, Sample, TaskConfig, TaskKind, Trace};

/// A pose as the bit patterns of x, y and heading.
type PoseBits = [u32; 3];

/// The recorded facts of one sample.
#[derive(Debug, Clone, PartialEq)]
struct Golden {
    task: TaskKind,
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
const CASES: &[(TaskKind, u64, Option<u32>)] = &[
    (TaskKind::FollowWall, 1, None),
    (TaskKind::FollowWall, 2, None),
    (TaskKind::TurnLeft, 3, None),
    (TaskKind::TurnLeft, 4, None),
    (TaskKind::TurnRight, 5, None),
    (TaskKind::TurnRight, 6, None),
    (TaskKind::SolveMaze, 7, Some(0)),
    (TaskKind::SolveMaze, 7, Some(1)),
    (TaskKind::SolveMaze, 7, Some(2)),
    (TaskKind::SolveMaze, 7, Some(3)),
    (TaskKind::ReturnRoom, 8, None),
    (TaskKind::ReturnRoom, 9, None),
    (TaskKind::ExitRoom, 10, None),
    (TaskKind::ExitRoom, 11, None),
    (TaskKind::Rescue, 12, None),
    (TaskKind::Rescue, 13, None),
];

fn pose_bits(pose: &Pose) -> PoseBits {
    [pose.x.to_bits(), pose.y.to_bits(), pose.heading.to_bits()]
}

fn traced(kind: TaskKind, sample: Sample) -> Trace {
    let evaluator =
        Evaluator::new(TaskConfig::new(kind)).expect("the paper's task configurations are valid");
    match kind {
        TaskKind::ExitRoom => run(&evaluator, RoomExiter::new(), sample),
        TaskKind::FollowWall => run(&evaluator, CorridorFollower::new(), sample),
        TaskKind::TurnLeft => run(&evaluator, Turner::new(TurnSide::Left), sample),
        TaskKind::TurnRight => run(&evaluator, Turner::new(TurnSide::Right), sample),
        TaskKind::SolveMaze => run(&evaluator, MazeSolver::new(), sample),
        TaskKind::ReturnRoom => run(&evaluator, Returner::new(), sample),
        TaskKind::Rescue => run(&evaluator, Rescuer::new(), sample),
    }
}

fn run(evaluator: &Evaluator, mut policy: impl Policy, sample: Sample) -> Trace {
    evaluator.evaluate_traced(&mut policy, sample)
}

fn observe(kind: TaskKind, seed: u64, variant: Option<u32>) -> Golden {
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
            "    Golden {{\n        task: TaskKind::{:?},\n        seed: {},\n        variant: {:?},\n        \
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
        println!("{}", table_source(&observed));
        return;
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
    for kind in TaskKind::ALL {
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
        task: TaskKind::FollowWall,
        seed: 1,
        variant: None,
        fitness_bits: 0x3fc851ec, // 1.565
        cycles: 174,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0x3bf5efe0, 0x3f86b048, 0x3fc70b8f],
        points: [(0, [0xbc33bdfa, 0xb003d099, 0x3fc31ef2]), (43, [0x3bc5d17e, 0x3e8a058a, 0x3fca2db4]), (87, [0x3bfb454f, 0x3f0852a6, 0x3fc7e494]), (130, [0x3bf5aaab, 0x3f49fee2, 0x3fc79e96])],
    },
    Golden {
        task: TaskKind::FollowWall,
        seed: 2,
        variant: None,
        fitness_bits: 0x3ff00000, // 1.875
        cycles: 50,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0xbb463d4e, 0x3ee9fb27, 0x3fcd6c4a],
        points: [(0, [0x3c8bfeb8, 0x304d5509, 0x3fc6fa3a]), (12, [0x3c2e4893, 0x3dcd400d, 0x3fd4a0fe]), (25, [0xbb46d78d, 0x3e60afec, 0x3fd0cdc4]), (37, [0xbb51616d, 0x3eac08b3, 0x3fc7f2b3])],
    },
    Golden {
        task: TaskKind::TurnLeft,
        seed: 3,
        variant: None,
        fitness_bits: 0x3fb8f5c2, // 1.4449999
        cycles: 222,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0xbf86c6b8, 0x3f1949b2, 0x4044ea14],
        points: [(0, [0x3c9522cf, 0x305abd45, 0x3fbe7896]), (55, [0x3b2c62fa, 0x3eb7f2cd, 0x3fda77bd]), (111, [0xbdabca75, 0x3f1a5785, 0xc044c3d3]), (166, [0xbf159448, 0x3f18f216, 0xc048e858])],
    },
    Golden {
        task: TaskKind::TurnLeft,
        seed: 4,
        variant: None,
        fitness_bits: 0x3d5f26d9, // 0.054480407
        cycles: 65,
        ending: Ending::WrongBranch,
        stage: 0,
        final_pose: [0x3e1c8ab8, 0x3e9b2685, 0xbd7c7fb2],
        points: [(0, [0x3c98fd5e, 0x30606444, 0x3fcf6d72]), (16, [0x3c53ebcf, 0x3de9df1d, 0x3fcd3133]), (32, [0x3c0440e2, 0x3e87c57e, 0x3fc81652]), (48, [0x3bf979c5, 0x3e9ffdb9, 0x3d7fdd4c])],
    },
    Golden {
        task: TaskKind::TurnRight,
        seed: 5,
        variant: None,
        fitness_bits: 0x3fcf0a3e, // 1.6175001
        cycles: 153,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0x3f426669, 0x3f1ae2c6, 0x3c57746a],
        points: [(0, [0x3b4c7818, 0x2f15f2d3, 0x3fcd50b2]), (38, [0xbba305cf, 0x3ebb150a, 0x3fc7c246]), (76, [0x3c951b84, 0x3f1af403, 0xbe181c84]), (114, [0x3ec2920b, 0x3f1a973d, 0xbd06b986])],
    },
    Golden {
        task: TaskKind::TurnRight,
        seed: 6,
        variant: None,
        fitness_bits: 0x3fd947ae, // 1.6975
        cycles: 121,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0x3f4240a5, 0x3e9a3387, 0xbbf467e6],
        points: [(0, [0xbb4858e0, 0xaf12ecf9, 0x3fc2e922]), (30, [0xba907285, 0x3e940bd2, 0x3fc7fe6e]), (60, [0x3e31dd26, 0x3e9dd6cc, 0xbb8091f6]), (90, [0x3eedfa8b, 0x3e9d884b, 0xbd7e55f0])],
    },
    Golden {
        task: TaskKind::SolveMaze,
        seed: 7,
        variant: Some(0),
        fitness_bits: 0x3fdb22d1, // 1.712
        cycles: 288,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0x3f66de04, 0x3e1a0c0e, 0x3fc17466],
        points: [(0, [0x3ae148a0, 0xbfc00000, 0x3fd920b2]), (72, [0xbb0426e7, 0xbf4fd7cf, 0x3fcdfdca]), (144, [0x3d989e45, 0xbe9b0d51, 0xbdea4d71]), (216, [0x3f441fff, 0xbe9a5868, 0x3d50acd8])],
    },
    Golden {
        task: TaskKind::SolveMaze,
        seed: 7,
        variant: Some(1),
        fitness_bits: 0x3fdb020c, // 1.711
        cycles: 289,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0x3f660dd4, 0xbf411cc4, 0xbfcf97f0],
        points: [(0, [0x3ae148a0, 0xbfc00000, 0x3fd920b2]), (72, [0xbb0426e7, 0xbf4fd7cf, 0x3fcdfdca]), (144, [0x3d989e45, 0xbe9b0d51, 0xbdea4d71]), (216, [0x3f441fff, 0xbe9a5868, 0x3d50acd8])],
    },
    Golden {
        task: TaskKind::SolveMaze,
        seed: 7,
        variant: Some(2),
        fitness_bits: 0x3fdac083, // 1.709
        cycles: 291,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0xbf65c004, 0x3e1ec6a8, 0x3fc24a88],
        points: [(0, [0x3ae148a0, 0xbfc00000, 0x3fd920b2]), (72, [0xbb0426e7, 0xbf4fd7cf, 0x3fcdfdca]), (145, [0xbd854ec0, 0xbe954b8a, 0xc0473104]), (218, [0xbf450da0, 0xbe995716, 0xc045a9ec])],
    },
    Golden {
        task: TaskKind::SolveMaze,
        seed: 7,
        variant: Some(3),
        fitness_bits: 0x3fdac083, // 1.709
        cycles: 291,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0xbf673476, 0xbf42404a, 0xbfcebdaa],
        points: [(0, [0x3ae148a0, 0xbfc00000, 0x3fd920b2]), (72, [0xbb0426e7, 0xbf4fd7cf, 0x3fcdfdca]), (145, [0xbd854ec0, 0xbe954b8a, 0xc0473104]), (218, [0xbf450da0, 0xbe995716, 0xc045a9ec])],
    },
    Golden {
        task: TaskKind::ReturnRoom,
        seed: 8,
        variant: None,
        fitness_bits: 0x3fce978e, // 1.6140001
        cycles: 386,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0xbb606840, 0xbfacda3c, 0xbfc71798],
        points: [(0, [0xbf685053, 0x3e800000, 0xbfd6a4d4]), (96, [0xbf5da0df, 0xbe8b5f54, 0x3c361c27]), (193, [0xbe817dfb, 0xbe9cde42, 0xbb942bef]), (289, [0xbb5722ce, 0xbf2a80d4, 0xbfc8af2b])],
    },
    Golden {
        task: TaskKind::ReturnRoom,
        seed: 9,
        variant: None,
        fitness_bits: 0x3da4dd54, // 0.080500275
        cycles: 132,
        ending: Ending::Collision,
        stage: 0,
        final_pose: [0x3f559fd9, 0xbec2e25c, 0x4045b96b],
        points: [(0, [0x3f659551, 0xbf59999a, 0x3fdf2b92]), (33, [0x3f6850a3, 0xbf094e74, 0x3fc7ebe2]), (66, [0x3f64d757, 0xbe60e59e, 0x3fd25bc0]), (99, [0x3f67602a, 0xbe882595, 0xbfd6e4eb])],
    },
    Golden {
        task: TaskKind::ExitRoom,
        seed: 10,
        variant: None,
        fitness_bits: 0x40b6e148, // 5.715
        cycles: 285,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0xbf26e1a1, 0xbe6c27fa, 0x404742ad],
        points: [(0, [0x3d8c597c, 0xbcfe1950, 0x3dfc3340]), (71, [0x3eca9653, 0xbdccc6dd, 0xbf84da17]), (142, [0x3e746482, 0xbef4caf7, 0x4048a6b8]), (213, [0xbecb8b58, 0xbef1ff51, 0xc048c795])],
    },
    Golden {
        task: TaskKind::ExitRoom,
        seed: 11,
        variant: None,
        fitness_bits: 0x40a8ac08, // 5.271
        cycles: 729,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0x3e9f0147, 0xbf2525b8, 0xbfc0aeb7],
        points: [(0, [0x3d427a30, 0x3d6de1e8, 0x40579e63]), (182, [0xbed4a45f, 0x3e9b6252, 0xbfbfa9f9]), (364, [0xbecbaa40, 0x3ecf330b, 0xbfeac6b8]), (546, [0x3eb9df14, 0x3ee7fa66, 0xbb537708])],
    },
    Golden {
        task: TaskKind::Rescue,
        seed: 12,
        variant: None,
        fitness_bits: 0x403f9268, // 2.993311
        cycles: 1213,
        ending: Ending::Solved,
        stage: 3,
        final_pose: [0x3bd41482, 0xbfebb6c0, 0xbfc3c9d6],
        points: [(0, [0xbebd5b28, 0xc011b338, 0xbfaa12bf]), (303, [0xbab33a46, 0xbfcdff3a, 0x3fc3bbae]), (606, [0x3f190b20, 0xbe96e050, 0x3d11a346]), (909, [0x3eda81b8, 0xbe9b1184, 0x40484c29])],
    },
    Golden {
        task: TaskKind::Rescue,
        seed: 13,
        variant: None,
        fitness_bits: 0x403ef970, // 2.9839745
        cycles: 1224,
        ending: Ending::Solved,
        stage: 3,
        final_pose: [0xbaa8ab01, 0xbfeb245b, 0xbfc93cb9],
        points: [(0, [0x3e11ae50, 0xc01272dc, 0x3fb402ba]), (306, [0x3e0d654c, 0xc0332467, 0xc048b2d1]), (612, [0xbb83b736, 0xbfa08c6f, 0x3fc128d7]), (918, [0xbf6561cc, 0x3d17c14c, 0xbfcb0e92])],
    },
];
