//! Golden (snapshot) tests: fixed-seed samples of every task, driven by the scripted reference
//! policies, by the shipped evolved controllers (CTRNN primitives and arbitrators), and by two
//! networks that fail (one drives straight into a wall, one stands still), must reproduce
//! exactly the recorded outcome (fitness to the bit, cycles, ending, stage), final pose and a
//! few trajectory points. Any change to the robot, sensor, world or
//! fitness model, to the random streams, or to the scripted policies changes them; this test
//! makes such a change visible instead of silent.
//!
//! When a change is intended, re-record the table and paste it over `EXPECTED` below:
//!
//! ```text
//! HEVO_BLESS=1 cargo test -p hevo-sim-core --release --test sim golden::
//! ```
//!
//! In bless mode the test prints the new table to stderr instead of comparing, and then fails,
//! so that a blessing run can never pass for a checking one (the failure report shows the
//! table). Paste it over `EXPECTED` and rerun without `HEVO_BLESS`. The values are exact
//! f32 bit patterns: they are the same on every machine that computes `sin`, `cos` and
//! `hypot` identically (the same Rust standard library and platform maths); a different
//! platform may need its own blessing.

use hevo_sim_core::Pose;
use hevo_sim_core::SHIPPED_NAMES;
use hevo_sim_core::{Controller, ControllerFile, InputGroup, NodeSpec};
use hevo_sim_core::{Ending, Evaluator, Policy, Sample, TaskConfig, Trace};

use crate::support::{Scripted, example_task};

/// A pose as the bit patterns of x, y and heading.
type PoseBits = [u32; 3];

/// The recorded facts of one sample.
#[derive(Debug, Clone, PartialEq)]
struct Golden {
    /// What drives the robot: `scripted` (the task's reference policy), a controller file in
    /// `controllers/`, or one of the failing networks of [`failing_network`].
    policy: &'static str,
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

/// The samples recorded, in the tasks' default configurations (a task ending in `.toml` is the
/// example scenario of that name): each task with its scripted
/// policy, two seeds each, and the maze in all four light configurations; then the shipped
/// evolved controllers (a CTRNN primitive, an arbitrator over primitives, an arbitrator over
/// arbitrators), and the failing networks on exit room and the maze, so f1's and f2's failure
/// branches (a collision, a timeout) are pinned too.
const CASES: &[(&str, &str, u64, Option<u32>)] = &[
    ("scripted", "follow_wall", 1, None),
    ("scripted", "follow_wall", 2, None),
    ("scripted", "turn_left", 3, None),
    ("scripted", "turn_left", 4, None),
    ("scripted", "turn_right", 5, None),
    ("scripted", "turn_right", 6, None),
    ("scripted", "solve_maze", 7, Some(0)),
    ("scripted", "solve_maze", 7, Some(1)),
    ("scripted", "solve_maze", 7, Some(2)),
    ("scripted", "solve_maze", 7, Some(3)),
    ("scripted", "return_room", 8, None),
    ("scripted", "return_room", 9, None),
    ("scripted", "exit_room", 10, None),
    ("scripted", "exit_room", 11, None),
    ("scripted", "rescue", 12, None),
    ("scripted", "rescue", 13, None),
    ("exit_room.json", "exit_room", 14, None),
    ("follow_wall.json", "follow_wall", 15, None),
    ("solve_maze.json", "solve_maze", 16, Some(1)),
    ("return_room.json", "return_room", 17, None),
    ("rescue.json", "rescue", 18, Some(2)),
    ("straight", "exit_room", 19, None),
    ("straight", "solve_maze", 20, Some(0)),
    ("standing", "exit_room", 21, None),
    ("standing", "solve_maze", 22, Some(3)),
    // The authors' room (an example scenario file): the shipped exit room controller in it,
    // and a robot that drives straight into its clutter.
    ("exit_room.json", "exit_room_authors.toml", 23, None),
    ("exit_room.json", "exit_room_authors.toml", 24, None),
    ("straight", "exit_room_authors.toml", 25, None),
];

fn pose_bits(pose: &Pose) -> PoseBits {
    [pose.x.to_bits(), pose.y.to_bits(), pose.heading.to_bits()]
}

/// A primitive reading the IR sensors whose genes are all 0 but its two output biases:
/// `straight` drives both wheels at nearly full speed (bias 10: the robot runs into the first
/// wall ahead), `standing` leaves them at 0.5 (no speed, so no wheel noise either: the robot
/// never moves and times out).
fn failing_network(policy: &str) -> ControllerFile {
    let bias = match policy {
        "straight" => 10.0,
        "standing" => 0.0,
        other => panic!("no failing network {other}"),
    };
    let mut node = NodeSpec::primitive(policy, vec![InputGroup::IR], 2);
    let n_genes = 4 * 2 + 2 * 2 + 2 + 2 + 2 * 2 + 2;
    let mut genome = vec![0.0; n_genes];
    genome[n_genes - 2..].fill(bias);
    node.genome = Some(genome);
    ControllerFile::new(node)
}

/// A shipped controller file from `controllers/`.
fn shipped_controller(file: &str) -> ControllerFile {
    let path = format!("{}/../controllers/{file}", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
    ControllerFile::from_json_str(&text).unwrap_or_else(|e| panic!("{path}: {e}"))
}

fn traced(policy: &'static str, kind: &'static str, sample: Sample) -> Trace {
    let task = match kind.strip_suffix(".toml") {
        Some(example) => example_task(example),
        None => TaskConfig::shipped(kind).unwrap(),
    };
    let evaluator = Evaluator::new(task).expect("the task configurations are valid");
    if policy != "scripted" {
        let file = if policy.ends_with(".json") {
            shipped_controller(policy)
        } else {
            failing_network(policy)
        };
        let controller = Controller::new(&file, None).expect("a complete controller");
        return run(&evaluator, controller, sample);
    }
    run(&evaluator, Scripted::standard(kind), sample)
}

fn run(evaluator: &Evaluator, mut policy: impl Policy, sample: Sample) -> Trace {
    evaluator.evaluate_traced(&mut policy, sample)
}

fn observe(policy: &'static str, kind: &'static str, seed: u64, variant: Option<u32>) -> Golden {
    let trace = traced(policy, kind, Sample { seed, variant });
    let n = trace.cycles.len();
    let point = |index: usize| {
        let cycle = trace
            .cycles
            .get(index)
            .map_or(trace.final_robot, |c| c.robot);
        (index as u32, pose_bits(&cycle))
    };
    Golden {
        policy,
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
            "    Golden {{\n        policy: {:?},\n        task: {:?},\n        seed: {},\n        variant: {:?},\n        \
             fitness_bits: {:#010x}, // {}\n        cycles: {},\n        ending: Ending::{:?},\n        \
             stage: {},\n        final_pose: {},\n        points: [{}],\n    }},\n",
            row.policy,
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
        .map(|&(policy, kind, seed, variant)| observe(policy, kind, seed, variant))
        .collect();
    if std::env::var_os("HEVO_BLESS").is_some_and(|v| v == "1") {
        eprintln!("{}", table_source(&observed));
        panic!(
            "HEVO_BLESS is set, so the golden table was printed (above, on stderr) and not \
             compared: paste it over EXPECTED in sim-core/tests/sim/golden.rs and rerun without \
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
            "{} by {} seed {} variant {:?}:",
            got.task, got.policy, got.seed, got.variant
        )];
        let case = |g: &Golden| (g.policy, g.task, g.seed, g.variant);
        if case(expected) != case(got) {
            what.push(format!(
                "case was {} by {} seed {}",
                expected.task, expected.policy, expected.seed
            ));
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
    // and most scripted samples are solved ones (long, eventful trajectories); the evolved
    // networks of every kind are there; and the failure branches of f1 and f2 are pinned by
    // samples that end on a collision and on a timeout.
    for kind in SHIPPED_NAMES {
        assert!(
            CASES
                .iter()
                .any(|&(policy, k, ..)| policy == "scripted" && k == kind),
            "{kind} has no scripted golden case"
        );
    }
    let scripted: Vec<&Golden> = EXPECTED.iter().filter(|g| g.policy == "scripted").collect();
    let solved = scripted
        .iter()
        .filter(|g| g.ending == Ending::Solved)
        .count();
    assert!(
        solved * 4 >= scripted.len() * 3,
        "only {solved} of {} scripted golden samples are solved",
        scripted.len()
    );
    for file in ["exit_room.json", "solve_maze.json", "rescue.json"] {
        assert!(
            CASES.iter().any(|&(policy, ..)| policy == file),
            "no golden case of the shipped {file} (a primitive, an arbitrator over primitives, \
             an arbitrator over arbitrators)"
        );
    }
    for task in ["exit_room", "solve_maze"] {
        for ending in [Ending::Collision, Ending::Timeout] {
            assert!(
                EXPECTED
                    .iter()
                    .any(|g| g.task == task && g.ending == ending && g.stage == 0),
                "no failed {task} sample ending in {ending:?}"
            );
        }
    }
}

/// sim-core's bit-for-bit comparisons of its CPU-specific paths (glibc's FMA sines, the AVX2
/// IR cones) skip, saying so, on a CPU without the feature. Under CI (`CI` set), whose machines
/// have both, a skip must not pass silently: this fails instead, as a test whose tool is
/// missing does.
#[test]
fn under_ci_the_cpu_has_what_the_bit_comparisons_need() {
    if std::env::var_os("CI").is_none() {
        return;
    }
    for (feature, present) in [
        ("fma", std::arch::is_x86_feature_detected!("fma")),
        ("avx2", std::arch::is_x86_feature_detected!("avx2")),
    ] {
        assert!(
            present,
            "CI's CPU lacks {feature}: sim-core's comparisons of its {feature} code with the \
             reference were skipped"
        );
    }
}

/// Recorded with `HEVO_BLESS=1` (see the top of this file).
#[rustfmt::skip]
const EXPECTED: &[Golden] = &[
    Golden {
        policy: "scripted",
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
        policy: "scripted",
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
        policy: "scripted",
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
        policy: "scripted",
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
        policy: "scripted",
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
        policy: "scripted",
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
        policy: "scripted",
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
        policy: "scripted",
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
        policy: "scripted",
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
        policy: "scripted",
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
        policy: "scripted",
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
        policy: "scripted",
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
        policy: "scripted",
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
        policy: "scripted",
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
        policy: "scripted",
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
        policy: "scripted",
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
    Golden {
        policy: "exit_room.json",
        task: "exit_room",
        seed: 14,
        variant: None,
        fitness_bits: 0x40b07ae1, // 5.515
        cycles: 485,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0xbf2c88ff, 0x3e7f0dd8, 0x403edbd9],
        points: [(0, [0xbda84180, 0x3dcc2708, 0x409259cd]), (121, [0x3e324bc6, 0xbe800650, 0xbe8d7fba]), (242, [0x3eee2834, 0xbb8c1934, 0x3fc78b3d]), (363, [0x3d8c7cc2, 0x3ee39a78, 0xc0469451])],
    },
    Golden {
        policy: "follow_wall.json",
        task: "follow_wall",
        seed: 15,
        variant: None,
        fitness_bits: 0x3ff147ae, // 1.885
        cycles: 46,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0xbcc91544, 0x3ee70d05, 0x3fd3e76b],
        points: [(0, [0x3c85d22b, 0x304446d3, 0x3fde1a9a]), (11, [0x3af1975b, 0x3ddbd855, 0x3fd78576]), (23, [0xbc08629c, 0x3e667b64, 0x3fd1eebc]), (34, [0xbc7e4e0e, 0x3eaabc0d, 0x3fd289de])],
    },
    Golden {
        policy: "solve_maze.json",
        task: "solve_maze",
        seed: 16,
        variant: Some(1),
        fitness_bits: 0x3fdef9db, // 1.742
        cycles: 258,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0x3f647925, 0xbf406501, 0xbfdbe8a5],
        points: [(0, [0x3bc3c928, 0xbfc00000, 0x3fc842d2]), (64, [0x3c6303d3, 0xbf6857cb, 0x3fc4e0a6]), (129, [0x3dac18ba, 0xbeab0cf4, 0x3f215570]), (193, [0x3f2a9a48, 0xbea61b2d, 0x3d350a22])],
    },
    Golden {
        policy: "return_room.json",
        task: "return_room",
        seed: 17,
        variant: None,
        fitness_bits: 0x00000000, // 0
        cycles: 1000,
        ending: Ending::Timeout,
        stage: 0,
        final_pose: [0xbf6a6122, 0x3eac9692, 0x4037db83],
        points: [(0, [0xbf6a6943, 0x3e800000, 0xc025a810]), (250, [0xbf6a80fd, 0x3eaccf50, 0x4037e1da]), (500, [0xbf6a185f, 0x3eac852d, 0x40367413]), (750, [0xbf6a5e6a, 0x3eac9e3c, 0x4037ac47])],
    },
    Golden {
        policy: "rescue.json",
        task: "rescue",
        seed: 18,
        variant: Some(2),
        fitness_bits: 0x40383841, // 2.8784335
        cycles: 1021,
        ending: Ending::Solved,
        stage: 3,
        final_pose: [0x3e0ac06f, 0xbfe6e418, 0xbe601bba],
        points: [(0, [0xbe136460, 0xc00cbc63, 0xbf604c90]), (255, [0x3e9857a9, 0xbfe99bdd, 0x3fd2654c]), (510, [0xbefe001a, 0xbe8f99dc, 0xc041bdd1]), (765, [0xbec6b421, 0xbe948208, 0xbdf38412])],
    },
    Golden {
        policy: "straight",
        task: "exit_room",
        seed: 19,
        variant: None,
        fitness_bits: 0x3da4fdde, // 0.08056234
        cycles: 47,
        ending: Ending::Collision,
        stage: 0,
        final_pose: [0x3d4fba40, 0x3f06d59c, 0x3fd671e2],
        points: [(0, [0x3dc4c860, 0x3da4e0f4, 0x3fd6574c]), (11, [0x3dacdb91, 0x3e4030c1, 0x3fd7571b]), (23, [0x3d9200a0, 0x3e9be2d4, 0x3fd78870]), (35, [0x3d70b899, 0x3ed72174, 0x3fd2be96])],
    },
    Golden {
        policy: "straight",
        task: "solve_maze",
        seed: 20,
        variant: Some(0),
        fitness_bits: 0x3d727985, // 0.05919792
        cycles: 51,
        ending: Ending::Collision,
        stage: 0,
        final_pose: [0x3d7b9868, 0xbf820bd6, 0x3fb7c4f6],
        points: [(0, [0xbc04ae7a, 0xbfc00000, 0x3fbeca9a]), (12, [0x3bba15bd, 0xbfb11a6d, 0x3fb863cc]), (25, [0x3cc38970, 0xbfa12c31, 0x3fb20503]), (38, [0x3d3aed47, 0xbf910a9b, 0x3fb62772])],
    },
    Golden {
        policy: "standing",
        task: "exit_room",
        seed: 21,
        variant: None,
        fitness_bits: 0x00000000, // 0
        cycles: 1000,
        ending: Ending::Timeout,
        stage: 0,
        final_pose: [0xbd0d5960, 0x3d9aad48, 0xbd5f47c0],
        points: [(0, [0xbd0d5960, 0x3d9aad48, 0xbd5f47c0]), (250, [0xbd0d5960, 0x3d9aad48, 0xbd5f47c0]), (500, [0xbd0d5960, 0x3d9aad48, 0xbd5f47c0]), (750, [0xbd0d5960, 0x3d9aad48, 0xbd5f47c0])],
    },
    Golden {
        policy: "standing",
        task: "solve_maze",
        seed: 22,
        variant: Some(3),
        fitness_bits: 0x00000000, // 0
        cycles: 1000,
        ending: Ending::Timeout,
        stage: 0,
        final_pose: [0xbc9f3e36, 0xbfc00000, 0x3fc34362],
        points: [(0, [0xbc9f3e36, 0xbfc00000, 0x3fc34362]), (250, [0xbc9f3e36, 0xbfc00000, 0x3fc34362]), (500, [0xbc9f3e36, 0xbfc00000, 0x3fc34362]), (750, [0xbc9f3e36, 0xbfc00000, 0x3fc34362])],
    },
    Golden {
        policy: "exit_room.json",
        task: "exit_room_authors.toml",
        seed: 23,
        variant: None,
        fitness_bits: 0x00000000, // 0
        cycles: 1000,
        ending: Ending::Timeout,
        stage: 0,
        final_pose: [0x3f03e85f, 0xbea0e3cf, 0x3fc4eb90],
        points: [(0, [0xbd09f600, 0xbd9b2968, 0xbff0d8a7]), (250, [0x3eb7479f, 0xbe553ca9, 0x40440ede]), (500, [0xbc94ca88, 0xbf034e72, 0xbcf2a50b]), (750, [0xbe5cd874, 0xbe807d4f, 0xc01130bb])],
    },
    Golden {
        policy: "exit_room.json",
        task: "exit_room_authors.toml",
        seed: 24,
        variant: None,
        fitness_bits: 0x40b94fdf, // 5.791
        cycles: 209,
        ending: Ending::Solved,
        stage: 1,
        final_pose: [0x3f2e805b, 0x3cb6022b, 0xbeb03af1],
        points: [(0, [0x3da02860, 0xbc954d80, 0x408c8526]), (52, [0x3d1ee651, 0xbee08770, 0xc001b9c8]), (104, [0x3eb3d8c6, 0xbef1ed19, 0xbd774b21]), (156, [0x3eeed109, 0xbe7273b3, 0x3fc52895])],
    },
    Golden {
        policy: "straight",
        task: "exit_room_authors.toml",
        seed: 25,
        variant: None,
        fitness_bits: 0x00000000, // 0
        cycles: 59,
        ending: Ending::Collision,
        stage: 0,
        final_pose: [0x3f07a04d, 0x3e551ad2, 0x3ec10d8c],
        points: [(0, [0x00000000, 0x00000000, 0x3ecf18f0]), (14, [0x3e0322e7, 0x3d5c57e7, 0x3eca0589]), (29, [0x3e87f030, 0x3dd749f4, 0x3eb512da]), (44, [0x3ece51fb, 0x3e21053d, 0x3ebd060d])],
    },
];
