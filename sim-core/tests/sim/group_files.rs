//! Groups that run a controller file (`controller = { file = "PATH" }`): each robot runs its
//! own reset copy of the file's tree, exactly as an `evolved` group's copies run the evaluated
//! controller; a sample is the same on every evaluator; the file's text travels in the task's
//! wire form and its content hash; and a file that cannot be run is refused before any
//! evaluation, naming `robots[i].controller.file`.

use hevo_sim_core::{BatchEvaluator, ControllerFile, EvaluatorKind, InputGroup, NodeSpec};
use hevo_sim_core::{Sample, Scenario, SimRng, TaskConfig, task_content_hash};
use proptest::prelude::*;
use rand::{RngExt, SeedableRng};
use std::sync::Arc;

use crate::team::TEAM_ARENA;

/// Where the team arena's group of copies is read from when it runs a file.
const PILOT: &str = "pilots/pilot.json";

/// The team arena with its five copies running the controller file `PILOT` instead.
fn file_arena() -> String {
    let evolved = "name = \"copies\"\ncount = 5\nregion = \"arena\"\ncontroller = \"evolved\"";
    assert!(TEAM_ARENA.contains(evolved));
    TEAM_ARENA.replace(
        evolved,
        &format!("name = \"copies\"\ncount = 5\nregion = \"arena\"\ncontroller = {{ file = \"{PILOT}\" }}"),
    )
}

/// The file arena's task with `pilot` (a controller file's text) as `PILOT`.
fn file_task(pilot: &str) -> Result<TaskConfig, String> {
    let give = |path: &str| match path {
        PILOT => Ok(pilot.to_string()),
        other => Err(format!("no file {other}")),
    };
    Scenario::parse_with(&file_arena(), "file_arena.toml", &give)
        .map(|scenario| TaskConfig::from_scenario(Arc::new(scenario)))
        .map_err(|error| error.to_string())
}

/// A complete random tree over the arena robot's sensors: an arbitrator over two primitives
/// half the time, else a primitive, so the copies switch and reset sub-trees too.
fn random_pilot(rng: &mut SimRng) -> ControllerFile {
    let inputs = vec![InputGroup::IR, InputGroup::NEAR_ROBOT];
    let with_genes = |spec: NodeSpec, rng: &mut SimRng| {
        let n_genes = spec.topology().n_genes();
        spec.with_genome(
            (0..n_genes)
                .map(|_| rng.random_range(-10.0f32..10.0))
                .collect(),
        )
    };
    let root = if rng.random_range(0..2) == 0 {
        let children = ["left", "right"]
            .map(|name| with_genes(NodeSpec::primitive(name, inputs.clone(), 3), rng));
        NodeSpec::arbitrator("pilot", inputs, 2, children.to_vec())
    } else {
        NodeSpec::primitive("pilot", inputs, 4)
    };
    ControllerFile::new(with_genes(root, rng))
}

/// The file arena's task with a random pilot from `seed`: one of the lockstep property's
/// tasks.
pub(crate) fn file_group_task(seed: u64) -> TaskConfig {
    let pilot = random_pilot(&mut SimRng::seed_from_u64(seed));
    file_task(&pilot.to_json_pretty().expect("plain data")).expect("the file arena compiles")
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 8, ..ProptestConfig::default() })]

    /// Whatever tree the file holds and whatever the focal robot runs, both evaluators give
    /// the same outcomes, twice.
    #[test]
    fn a_file_group_runs_alike_on_every_evaluator(pilot_seed in any::<u64>(), focal_seed in any::<u64>()) {
        let task = file_group_task(pilot_seed);
        let (template, genes) = crate::support::random_primitive(
            &mut SimRng::seed_from_u64(focal_seed),
            vec![InputGroup::IR],
        );
        crate::support::outcomes_on_every_evaluator(&template, &genes, &task);
    }
}

/// A group running a file moves exactly as an `evolved` group does when the evaluated
/// controller is that file: the same copies, reset alike, stepped alike.
#[test]
fn a_file_group_moves_as_evolved_copies_of_the_same_tree() {
    let pilot = random_pilot(&mut SimRng::seed_from_u64(3));
    let json = pilot.to_json_pretty().unwrap();
    let traces = |task: TaskConfig| {
        let batch = BatchEvaluator::new(pilot.clone(), task).expect("valid");
        let mut controller = batch.controller(None).expect("complete");
        (0..4)
            .map(|seed| {
                batch
                    .evaluator()
                    .evaluate_traced(&mut controller, Sample::seeded(seed))
            })
            .collect::<Vec<_>>()
    };
    let evolved = traces(crate::team::team_task());
    let from_file = traces(file_task(&json).unwrap());
    for (a, b) in evolved.iter().zip(&from_file) {
        assert_eq!(a.cycles.len(), b.cycles.len());
        for (ca, cb) in a.cycles.iter().zip(&b.cycles) {
            assert_eq!(ca.team, cb.team);
            assert_eq!(ca.robot, cb.robot);
        }
    }
    // The copies moved: the comparison says something.
    let first = &from_file[0].cycles[0].team[..5];
    let last = &from_file[0].final_team[..5];
    assert!(first.iter().zip(last).any(|(a, b)| a != b), "no copy moved");
}

/// The file group runs whatever the focal robot does, even when it stands still (an
/// `evolved` group would stand still with it only if it ran the same still controller).
#[test]
fn a_file_group_runs_beside_any_focal_controller() {
    let pilot = random_pilot(&mut SimRng::seed_from_u64(3));
    let task = file_task(&pilot.to_json_pretty().unwrap()).unwrap();
    let evaluator = hevo_sim_core::Evaluator::new(task).expect("valid");
    let trace = evaluator.evaluate_traced(&mut crate::support::Fixed::still(), Sample::seeded(2));
    assert_eq!(
        trace.cycles[0].robot, trace.final_robot,
        "the focal robot moved"
    );
    let first = &trace.cycles[0].team[..5];
    assert!(
        first
            .iter()
            .zip(&trace.final_team[..5])
            .any(|(a, b)| a != b),
        "no copy moved"
    );
}

#[test]
fn a_file_group_travels_with_its_task_and_its_text_is_hashed() {
    let pilot = random_pilot(&mut SimRng::seed_from_u64(5));
    let json = pilot.to_json_pretty().unwrap();
    let task = file_task(&json).unwrap();
    let wire = serde_json::to_string(&task).unwrap();
    assert!(
        wire.contains("\"controllers\":{\"pilots/pilot.json\":"),
        "{wire}"
    );
    let back: TaskConfig = serde_json::from_str(&wire).unwrap();
    assert_eq!(back, task);
    assert_eq!(task_content_hash(&back), task_content_hash(&task));
    assert_eq!(back.scenario.content_hash(), task.scenario.content_hash());
    // The same tree in the same file, evaluated from the wire: the same outcomes.
    let (template, genes) =
        crate::support::random_primitive(&mut SimRng::seed_from_u64(1), vec![InputGroup::IR]);
    let samples: Vec<Sample> = (0..3).map(Sample::seeded).collect();
    let outcomes = |task: TaskConfig| {
        BatchEvaluator::new(template.clone(), task)
            .unwrap()
            .with_kind(EvaluatorKind::Lockstep)
            .evaluate_genome(Some(&genes), &samples)
            .unwrap()
    };
    assert_eq!(outcomes(back), outcomes(task.clone()));

    // Another controller in the same file: another task, another hash.
    let other = random_pilot(&mut SimRng::seed_from_u64(6));
    let other_task = file_task(&other.to_json_pretty().unwrap()).unwrap();
    assert_ne!(task_content_hash(&other_task), task_content_hash(&task));
    assert_ne!(
        other_task.scenario.content_hash(),
        task.scenario.content_hash()
    );
    assert_ne!(other_task, task);

    // A wire form that lacks the file, or carries one no group runs, is refused.
    let value: serde_json::Value = serde_json::from_str(&wire).unwrap();
    let mut lacking = value.clone();
    lacking["controllers"] = serde_json::json!({});
    let error = serde_json::from_value::<TaskConfig>(lacking)
        .unwrap_err()
        .to_string();
    assert!(error.contains("robots[0].controller.file"), "{error}");
    assert!(
        error.contains("not among the task's controllers"),
        "{error}"
    );
    let mut extra = value;
    extra["controllers"]["spare.json"] = serde_json::json!(json);
    let error = serde_json::from_value::<TaskConfig>(extra)
        .unwrap_err()
        .to_string();
    assert!(error.contains("'spare.json' is run by no group"), "{error}");
}

#[test]
fn a_resized_team_keeps_its_controller_files() {
    let task = file_group_task(4);
    let bigger = task.scenario.with_team_size(20).unwrap();
    assert_eq!(bigger.n_robots(), 20);
    assert_eq!(bigger.controller_files, task.scenario.controller_files);
}

#[test]
fn a_file_group_that_cannot_run_is_refused_naming_the_key() {
    let key = "robots[0].controller.file";
    let pilot = random_pilot(&mut SimRng::seed_from_u64(3));
    let mut free = pilot.clone();
    free.root.genome = None;
    let reads_rab = ControllerFile::new(
        NodeSpec::primitive("pilot", vec![InputGroup::RAB], 2).with_genome(vec![
                0.0;
                NodeSpec::primitive("p", vec![InputGroup::RAB], 2)
                    .topology()
                    .n_genes()
            ]),
    );
    for (text, wanted) in [
        ("{".to_string(), "is not a controller file"),
        (
            "{\"schema\": \"hevo.controller/9\"}".to_string(),
            "is not a controller file",
        ),
        (free.to_json_pretty().unwrap(), "node 'pilot' has no genome"),
        (
            reads_rab.to_json_pretty().unwrap(),
            "reads 'rab', a sensor the robot",
        ),
        (
            "x".repeat(hevo_sim_core::MAX_CONTROLLER_FILE_BYTES + 1),
            "bytes, at most",
        ),
    ] {
        let error = file_task(&text).unwrap_err();
        assert!(error.contains(key), "{wanted}: {error}");
        assert!(error.contains(wanted), "{wanted}: {error}");
    }
    // Not given (a file not found, or a scenario that came as text alone).
    let error = Scenario::parse(&file_arena(), "file_arena.toml")
        .unwrap_err()
        .to_string();
    assert!(
        error.contains(key) && error.contains("was not given"),
        "{error}"
    );
    // The key's line is found inside the inline table.
    assert!(error.contains("file_arena.toml:"), "{error}");
    let arena = file_arena();
    for (from, to, wanted) in [
        (
            "{ file = \"pilots/pilot.json\" }",
            "{ file = \"\" }",
            "robots[0].controller.file",
        ),
        (
            "{ file = \"pilots/pilot.json\" }",
            "{ path = \"pilot.json\" }",
            "robots[0].controller",
        ),
        (
            "{ file = \"pilots/pilot.json\" }",
            "3",
            "a controller file, { file = \"PATH\" }",
        ),
        (
            "{ file = \"pilots/pilot.json\" }",
            "\"pilot\"",
            "not evolved, wander, fixed or",
        ),
    ] {
        let error = crate::support::refusal_of(&arena, from, to);
        assert!(error.contains(wanted), "{to}: {error}");
    }
}
