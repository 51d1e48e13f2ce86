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
        fitness_bits: 0x3fdd1eb8, // 1.7275
        cycles: 109,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0x3c101dc8, 0x3f86816d, 0x3fc63655],
        points: [(0, [0xbc33bdfa, 0xb003d099, 0x3fc31ef2]), (27, [0x3b843dde, 0x3e83acfd, 0x3fc2784f]), (54, [0x3bf16037, 0x3f040abf, 0x3fc5178c]), (81, [0x3bffb3a3, 0x3f47874b, 0x3fcc411a])],
    },
    Golden {
        task: TaskKind::FollowWall,
        seed: 2,
        variant: None,
        fitness_bits: 0x3ff0a3d7, // 1.88
        cycles: 48,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0xba04f6db, 0x3eea3b40, 0x3fcb0ed0],
        points: [(0, [0x3c8bfeb8, 0x304d5509, 0x3fc6fa3a]), (12, [0x3c1a0da0, 0x3de9ca62, 0x3fd59ed1]), (24, [0xbab3d994, 0x3e67df98, 0x3fd0a77e]), (36, [0xba39de62, 0x3eaf8e9a, 0x3fc687a0])],
    },
    Golden {
        task: TaskKind::TurnLeft,
        seed: 3,
        variant: None,
        fitness_bits: 0x3fc570a4, // 1.5425
        cycles: 183,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0xbf867f05, 0x3f1986e9, 0xc048a19e],
        points: [(0, [0x3c9522cf, 0x305abd45, 0x3fbe7896]), (45, [0x3c2356a2, 0x3eddd31c, 0x3fcf0689]), (91, [0xbe2ca2d1, 0x3f18bb76, 0xc0444077]), (137, [0xbf1bc42d, 0x3f18ddde, 0xc04854bb])],
    },
    Golden {
        task: TaskKind::TurnLeft,
        seed: 4,
        variant: None,
        fitness_bits: 0x3fe1999a, // 1.7625
        cycles: 95,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0xbee7403c, 0x3e9ab98f, 0xc0477532],
        points: [(0, [0x3c98fd5e, 0x30606444, 0x3fcf6d72]), (23, [0x3ac179c2, 0x3e512078, 0x3fca8f33]), (47, [0xbc02ef3e, 0x3e9e5b7d, 0xc045465a]), (71, [0xbe70f071, 0x3e99c89c, 0xc048c0c8])],
    },
    Golden {
        task: TaskKind::TurnRight,
        seed: 5,
        variant: None,
        fitness_bits: 0x3fce147b, // 1.61
        cycles: 156,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0x3f41dbc1, 0x3f19e0d8, 0x3c226f1a],
        points: [(0, [0x3b4c7818, 0x2f15f2d3, 0x3fcd50b2]), (39, [0xbab7061b, 0x3eb93b05, 0x3fc67832]), (78, [0x3d420b03, 0x3f13f722, 0x3c251fd2]), (117, [0x3ec32320, 0x3f192041, 0xbce1fbd2])],
    },
    Golden {
        task: TaskKind::TurnRight,
        seed: 6,
        variant: None,
        fitness_bits: 0x3fd9eb85, // 1.7025
        cycles: 119,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0x3f41adeb, 0x3e9ae22a, 0xbcdcb279],
        points: [(0, [0xbb4858e0, 0xaf12ecf9, 0x3fc2e922]), (29, [0x3a87a347, 0x3e8d35c5, 0x3fc2798b]), (59, [0x3e3705ab, 0x3e9a4b84, 0x3db075ba]), (89, [0x3eef7f13, 0x3e9a8dae, 0xbc80e78f])],
    },
    Golden {
        task: TaskKind::SolveMaze,
        seed: 7,
        variant: Some(0),
        fitness_bits: 0x3fdae148, // 1.71
        cycles: 290,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0x3f6616b5, 0x3e1bf2f6, 0x3fc2b9e2],
        points: [(0, [0x3ae148a0, 0xbfc00000, 0x3fd920b2]), (72, [0xbb9cd8b7, 0xbf501dc1, 0x3fcefbdd]), (145, [0x3d8ecedc, 0xbe99cc74, 0xbde6f970]), (217, [0x3f428614, 0xbe983ce4, 0x3d3040a9])],
    },
    Golden {
        task: TaskKind::SolveMaze,
        seed: 7,
        variant: Some(1),
        fitness_bits: 0x3fda5e35, // 1.706
        cycles: 294,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0x3f66043a, 0xbf4209c0, 0xbfd1e51a],
        points: [(0, [0x3ae148a0, 0xbfc00000, 0x3fd920b2]), (73, [0xbba95b26, 0xbf4da616, 0x3fcd463e]), (147, [0x3db64cbd, 0xbe9ad10d, 0xbdd5b4cf]), (220, [0x3f49e854, 0xbe978b6c, 0x3d0c1f78])],
    },
    Golden {
        task: TaskKind::SolveMaze,
        seed: 7,
        variant: Some(2),
        fitness_bits: 0x3fda7efa, // 1.707
        cycles: 293,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0xbf662616, 0x3e1ef999, 0x3fc201c0],
        points: [(0, [0x3ae148a0, 0xbfc00000, 0x3fd920b2]), (73, [0xbba95b26, 0xbf4da616, 0x3fcd463e]), (146, [0xbd92812a, 0xbe95a0aa, 0xc043381c]), (219, [0xbf456ba7, 0xbe9b7519, 0xc045d7ef])],
    },
    Golden {
        task: TaskKind::SolveMaze,
        seed: 7,
        variant: Some(3),
        fitness_bits: 0x3fdae148, // 1.71
        cycles: 290,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0xbf6617d1, 0xbf411eb9, 0xbfcf58ad],
        points: [(0, [0x3ae148a0, 0xbfc00000, 0x3fd920b2]), (72, [0xbb9cd8b7, 0xbf501dc1, 0x3fcefbdd]), (145, [0xbd7eee3f, 0xbe9540bb, 0xc044d91f]), (217, [0xbf405f2c, 0xbe9af61b, 0xc0464e83])],
    },
    Golden {
        task: TaskKind::ReturnRoom,
        seed: 8,
        variant: None,
        fitness_bits: 0x00000000, // 0
        cycles: 1000,
        ending: Ending::Timeout,
        stage: 0,
        final_pose: [0xbf6bf146, 0xbe92bb27, 0x404685cd],
        points: [(0, [0xbf685053, 0x3e800000, 0xbfd6a4d4]), (250, [0xbc3ccd6e, 0xbedce4a8, 0x3fbf47a6]), (500, [0xbf6bf146, 0xbe92bb27, 0x404685cd]), (750, [0xbf6bf146, 0xbe92bb27, 0x404685cd])],
    },
    Golden {
        task: TaskKind::ReturnRoom,
        seed: 9,
        variant: None,
        fitness_bits: 0x3fd83127, // 1.689
        cycles: 311,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0xbb8bc8a4, 0xbfad1387, 0xbfc952e1],
        points: [(0, [0x3f659551, 0xbf59999a, 0x3fdf2b92]), (77, [0x3f55e2d5, 0xbea3a4b7, 0xc0481ef9]), (155, [0x3ea2adb3, 0xbe97cc86, 0xc0471668]), (233, [0xbb9ec4e6, 0xbf19c23a, 0xbfc7f06b])],
    },
    Golden {
        task: TaskKind::ExitRoom,
        seed: 10,
        variant: None,
        fitness_bits: 0x40b73333, // 5.725
        cycles: 275,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0xbf27fd60, 0xbe6a8430, 0xc047f21d],
        points: [(0, [0x3d8c597c, 0xbcfe1950, 0x3dfc3340]), (68, [0x3eea0c0e, 0xbe4d240d, 0xbfcaa9c7]), (137, [0x3e3c4443, 0xbef30fa2, 0x4048b4a2]), (206, [0xbedec2aa, 0xbef2050e, 0x40478da2])],
    },
    Golden {
        task: TaskKind::ExitRoom,
        seed: 11,
        variant: None,
        fitness_bits: 0x40b25604, // 5.573
        cycles: 427,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0x3e9d55b9, 0xbf249092, 0xbfd46af7],
        points: [(0, [0x3d427a30, 0x3d6de1e8, 0x40579e63]), (106, [0xbef0a6a9, 0x3dd51a2c, 0x3fec431a]), (213, [0x3da6b193, 0x3ee8d1a5, 0xbc286f28]), (320, [0x3efdfef6, 0xbca93f2d, 0xbfc6f547])],
    },
    Golden {
        task: TaskKind::Rescue,
        seed: 12,
        variant: None,
        fitness_bits: 0x403fbfc0, // 2.9960785
        cycles: 1441,
        ending: Ending::Solved,
        stage: 3,
        final_pose: [0x3b932f2b, 0xbfeb2d06, 0xbfc9988f],
        points: [(0, [0xbebd5b28, 0xc011b338, 0xbfaa12bf]), (360, [0x3e28850c, 0xc00be8c2, 0xbfcb4c92]), (720, [0xbe5797d9, 0xbfe16a66, 0x3b02d3a6]), (1080, [0x3f66b9d9, 0x3e350432, 0x3fc54766])],
    },
    Golden {
        task: TaskKind::Rescue,
        seed: 13,
        variant: None,
        fitness_bits: 0x3e7ac688, // 0.24489796
        cycles: 441,
        ending: Ending::Collision,
        stage: 0,
        final_pose: [0x3f159ebf, 0xc00af0d0, 0xbfa0ee25],
        points: [(0, [0x3e11ae50, 0xc01272dc, 0x3fb402ba]), (110, [0x3ed7caeb, 0xbfe1f88d, 0x3d6aee05]), (220, [0xbd8ffa7d, 0xbfe8b9eb, 0xc047580c]), (330, [0x3d538352, 0xbfe7b574, 0xbccc81e4])],
    },
];
