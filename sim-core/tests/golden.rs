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
        fitness_bits: 0x3fdccccd, // 1.725
        cycles: 110,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0x3b86cc12, 0x3f878625, 0x3fbe2f4b],
        points: [(0, [0xbc33bdfa, 0xb003d099, 0x3fc31ef2]), (27, [0xbb4b84b6, 0x3e84ee6f, 0x3fc39dd2]), (55, [0x399ecca0, 0x3f07cb68, 0x3fcafaf8]), (82, [0xbb30fe54, 0x3f4a78c6, 0x3fc9af79])],
    },
    Golden {
        task: TaskKind::FollowWall,
        seed: 2,
        variant: None,
        fitness_bits: 0x3ff0a3d7, // 1.88
        cycles: 48,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0xba8ab06b, 0x3eea61ea, 0x3fc9d1a8],
        points: [(0, [0x3c8bfeb8, 0x304d5509, 0x3fc6fa3a]), (12, [0x3c101e1b, 0x3debadcb, 0x3fd552ff]), (24, [0xbb17d137, 0x3e6a3b89, 0x3fd0a723]), (36, [0xba1aa831, 0x3eb00f6d, 0x3fc7bd12])],
    },
    Golden {
        task: TaskKind::TurnLeft,
        seed: 3,
        variant: None,
        fitness_bits: 0x3fc570a4, // 1.5425
        cycles: 183,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0xbf873570, 0x3f16f5b1, 0xc048cac4],
        points: [(0, [0x3c9522cf, 0x305abd45, 0x3fbe7896]), (45, [0x3c4c9dd9, 0x3edddc1a, 0x3fcda3e3]), (91, [0xbe30ddb3, 0x3f19820a, 0xc044942a]), (137, [0xbf1db679, 0x3f161e0a, 0xc048828a])],
    },
    Golden {
        task: TaskKind::TurnLeft,
        seed: 4,
        variant: None,
        fitness_bits: 0x3fe23d70, // 1.7674999
        cycles: 93,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0xbeea7eda, 0x3e99fb3b, 0xc045e457],
        points: [(0, [0x3c98fd5e, 0x30606444, 0x3fcf6d72]), (23, [0x3c482c85, 0x3e638df2, 0x3fcb528a]), (46, [0xbbed4ca0, 0x3ea1c93a, 0xc0463f35]), (69, [0xbe67417d, 0x3e9fb42a, 0xc0482c09])],
    },
    Golden {
        task: TaskKind::TurnRight,
        seed: 5,
        variant: None,
        fitness_bits: 0x3fcfae14, // 1.6225
        cycles: 151,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0x3f402ffb, 0x3f19a972, 0x3b5d3d6c],
        points: [(0, [0x3b4c7818, 0x2f15f2d3, 0x3fcd50b2]), (37, [0xba72445a, 0x3eb69b96, 0x3fc8ffa6]), (75, [0x3c958a5e, 0x3f1b6f80, 0x3c27317b]), (113, [0x3ec35065, 0x3f19818e, 0xbd047a4d])],
    },
    Golden {
        task: TaskKind::TurnRight,
        seed: 6,
        variant: None,
        fitness_bits: 0x3fd8f5c2, // 1.6949999
        cycles: 122,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0x3f40a7d6, 0x3e9a2ecd, 0xb9c12530],
        points: [(0, [0xbb4858e0, 0xaf12ecf9, 0x3fc2e922]), (30, [0xba8a9eeb, 0x3e941582, 0x3fc7ee2b]), (61, [0x3e2e0b5c, 0x3e9dd46b, 0x3c7bcfda]), (91, [0x3eec1194, 0x3e9d2f67, 0xbd85d4e0])],
    },
    Golden {
        task: TaskKind::SolveMaze,
        seed: 7,
        variant: Some(0),
        fitness_bits: 0x3fdac083, // 1.709
        cycles: 291,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0x3f661897, 0x3e22febf, 0x3fc30bed],
        points: [(0, [0x3ae148a0, 0xbfc00000, 0x3fd920b2]), (72, [0xbb9491bc, 0xbf50f9b2, 0x3fd0dcc7]), (145, [0x3d8d7a24, 0xbe97fe1f, 0xbdf8a8f3]), (218, [0x3f449ba0, 0xbe97be88, 0x3d6b6bc3])],
    },
    Golden {
        task: TaskKind::SolveMaze,
        seed: 7,
        variant: Some(1),
        fitness_bits: 0x3fda9fbe, // 1.708
        cycles: 292,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0x3f66893d, 0xbf40655a, 0xbfd0878f],
        points: [(0, [0x3ae148a0, 0xbfc00000, 0x3fd920b2]), (73, [0xbba5163e, 0xbf4e87bf, 0x3fcec274]), (146, [0x3da0ba3d, 0xbe9890b2, 0xbdec5c2e]), (219, [0x3f471f12, 0xbe97788f, 0x3d51900e])],
    },
    Golden {
        task: TaskKind::SolveMaze,
        seed: 7,
        variant: Some(2),
        fitness_bits: 0x3fda9fbe, // 1.708
        cycles: 292,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0xbf667a31, 0x3e239a80, 0x3fc396c0],
        points: [(0, [0x3ae148a0, 0xbfc00000, 0x3fd920b2]), (73, [0xbba5163e, 0xbf4e87bf, 0x3fcec274]), (146, [0xbd91a5d2, 0xbe9384a3, 0xc042d3fa]), (219, [0xbf459800, 0xbe9bbb81, 0xc045cc3d])],
    },
    Golden {
        task: TaskKind::SolveMaze,
        seed: 7,
        variant: Some(3),
        fitness_bits: 0x3fdac083, // 1.709
        cycles: 291,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0xbf661a89, 0xbf422b3e, 0xbfcf0bdf],
        points: [(0, [0x3ae148a0, 0xbfc00000, 0x3fd920b2]), (72, [0xbb9491bc, 0xbf50f9b2, 0x3fd0dcc7]), (145, [0xbd7c85dc, 0xbe931724, 0xc0440752]), (218, [0xbf431479, 0xbe9b75c2, 0xc045658a])],
    },
    Golden {
        task: TaskKind::ReturnRoom,
        seed: 8,
        variant: None,
        fitness_bits: 0x00000000, // 0
        cycles: 1000,
        ending: Ending::Timeout,
        stage: 0,
        final_pose: [0xbef8db2f, 0xbea8fd2d, 0xbe3c30ce],
        points: [(0, [0xbf685053, 0x3e800000, 0xbfd6a4d4]), (250, [0xbef8db2f, 0xbea8fd2d, 0xbe3c30ce]), (500, [0xbef8db2f, 0xbea8fd2d, 0xbe3c30ce]), (750, [0xbef8db2f, 0xbea8fd2d, 0xbe3c30ce])],
    },
    Golden {
        task: TaskKind::ReturnRoom,
        seed: 9,
        variant: None,
        fitness_bits: 0x3d604f37, // 0.054763045
        cycles: 228,
        ending: Ending::WrongBranch,
        stage: 0,
        final_pose: [0x3f5e5cdd, 0xbe164942, 0x3fd9b02b],
        points: [(0, [0x3f659551, 0xbf59999a, 0x3fdf2b92]), (57, [0x3f616bdc, 0xbf6b6117, 0x40353e0a]), (114, [0x3f686dee, 0xbf4d6b5e, 0xbfd57473]), (171, [0x3f655d83, 0xbf323b09, 0x3fcbd4f2])],
    },
    Golden {
        task: TaskKind::ExitRoom,
        seed: 10,
        variant: None,
        fitness_bits: 0x40b5374c, // 5.663
        cycles: 337,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0xbf2766c0, 0xbe6d5077, 0x40453bf3],
        points: [(0, [0x3d8c597c, 0xbcfe1950, 0x3dfc3340]), (84, [0x3ee04a2b, 0xbe0ae8c6, 0xbf3c8720]), (168, [0x3e3058ca, 0xbe603b66, 0xc02f700c]), (252, [0xbe96921b, 0xbee9239d, 0xc0305657])],
    },
    Golden {
        task: TaskKind::ExitRoom,
        seed: 11,
        variant: None,
        fitness_bits: 0x40a4dd2f, // 5.152
        cycles: 848,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0x3eb65616, 0xbf2478c6, 0xbfca54f6],
        points: [(0, [0x3d427a30, 0x3d6de1e8, 0x40579e63]), (212, [0xbe0a590d, 0x3e3f2f26, 0x3dd3a870]), (424, [0xbe90f80f, 0xbedfb44d, 0xc0367743]), (636, [0x3df16c68, 0x3ee81da4, 0xbcc2a77a])],
    },
    Golden {
        task: TaskKind::Rescue,
        seed: 12,
        variant: None,
        fitness_bits: 0x403fd539, // 2.997389
        cycles: 1035,
        ending: Ending::Solved,
        stage: 3,
        final_pose: [0x3bb7464c, 0xbfea278d, 0xbfc6a4ee],
        points: [(0, [0xbebd5b28, 0xc011b338, 0xbfaa12bf]), (258, [0xbf544d39, 0xbfe41355, 0x3fcd5286]), (517, [0xbb97e2d3, 0xbeb270b1, 0x3fc955cd]), (776, [0x3f549915, 0xbe95d426, 0x4046226f])],
    },
    Golden {
        task: TaskKind::Rescue,
        seed: 13,
        variant: None,
        fitness_bits: 0x3f800000, // 1
        cycles: 2000,
        ending: Ending::Timeout,
        stage: 1,
        final_pose: [0x3f682a2d, 0x3eb097aa, 0x3d92ad7a],
        points: [(0, [0x3e11ae50, 0xc01272dc, 0x3fb402ba]), (500, [0xbece1deb, 0xbfe0974c, 0x3d4b9c8a]), (1000, [0x3f735dbe, 0xbe719363, 0xbfc8fabf]), (1500, [0x3f5a05da, 0xbf395707, 0x3fca1d3c])],
    },
];
