//! Items (`[[objects]]` and `[nest]`): a robot that drives over an item carries it and delivers
//! it in the nest; no item is created or lost (every item ends on the floor, carried by one
//! robot, or delivered); a trace shows every item every cycle; a sample is the same every
//! time and on both evaluators (the lockstep property test draws from the foraging scenario
//! too); and a file whose items or nest cannot work is refused before any evaluation, naming
//! the key.

use hevo_sim_core::{BatchEvaluator, ControllerFile, EvaluatorKind, Sample};
use hevo_sim_core::{Evaluator, InputGroup, Scenario, SimRng, TaskConfig};
use proptest::prelude::*;
use rand::SeedableRng;
use std::sync::Arc;

/// The shipped foraging scenario: five robots, ten items, a nest under a beacon.
const FORAGING: &str = include_str!("../../../scenarios/swarm/foraging.toml");

pub(crate) fn foraging_task() -> TaskConfig {
    task(FORAGING)
}

fn task(text: &str) -> TaskConfig {
    TaskConfig::from_scenario(Arc::new(
        Scenario::parse(text, "foraging.toml").expect("the scenario compiles"),
    ))
}

/// A primitive on the IR ring and the item sensor with random genes.
fn random_controller(rng: &mut SimRng) -> (ControllerFile, Vec<f32>) {
    crate::support::random_primitive(rng, vec![InputGroup::IR, InputGroup::ITEMS])
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 12, ..ProptestConfig::default() })]

    /// However the robots drive, every item ends on the floor, carried by exactly one robot,
    /// or delivered; a carried one where its carrier stands, and a robot carries at most one.
    #[test]
    fn items_are_neither_created_nor_lost(case_seed in any::<u64>(), seed in 0u64..1000) {
        let task = foraging_task();
        let rng = &mut SimRng::seed_from_u64(case_seed);
        let (template, genes) = random_controller(rng);
        let batch = BatchEvaluator::new(template, task.clone()).expect("valid");
        let mut controller = batch.controller(Some(&genes)).expect("genes fit");
        let trace = batch.evaluator().evaluate_traced(&mut controller, Sample::seeded(seed));
        prop_assert_eq!(trace.items.len(), task.scenario.n_items());
        let carried: Vec<_> = trace.items.iter().filter(|item| item.carried).collect();
        prop_assert!(trace.items.iter().all(|item| !(item.carried && item.delivered)));
        prop_assert!(carried.len() <= task.scenario.n_robots());
        // Two carried items never stand at one place: each has its own carrier.
        for (idx, item) in carried.iter().enumerate() {
            for other in &carried[idx + 1..] {
                prop_assert!(item.end != other.end, "{:?} and {:?}", item, other);
            }
        }
        // The share the fitness reads is the count the trace shows.
        let delivered = trace.items.iter().filter(|item| item.delivered).count();
        prop_assert_eq!(
            trace.outcome.descriptor[0],
            delivered as f32 / trace.items.len() as f32
        );
        // An item never moved lies where it was drawn.
        for item in trace.items.iter().filter(|item| !item.carried && !item.delivered) {
            prop_assert_eq!(item.start, item.end);
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 12, ..ProptestConfig::default() })]

    /// Every cycle of a trace shows every item: the first where it was drawn, one on the
    /// floor where it lay the cycle before, a carried one on a robot, a delivered one where it
    /// was delivered for the rest of the sample. Tracing changes nothing: the traced outcome
    /// is the plain one, and the lockstep evaluator's.
    #[test]
    fn every_cycle_of_a_trace_shows_every_item(case_seed in any::<u64>(), seed in 0u64..1000) {
        let task = foraging_task();
        let rng = &mut SimRng::seed_from_u64(case_seed);
        let (template, genes) = random_controller(rng);
        let batch = BatchEvaluator::new(template.clone(), task.clone()).expect("valid");
        let mut controller = batch.controller(Some(&genes)).expect("genes fit");
        let sample = Sample::seeded(seed);
        let trace = batch.evaluator().evaluate_traced(&mut controller, sample);
        let n_items = task.scenario.n_items();
        prop_assert!(trace.cycles.iter().all(|cycle| cycle.items.len() == n_items));
        for (place, item) in trace.cycles[0].items.iter().zip(&trace.items) {
            prop_assert_eq!(place.at, item.start);
            prop_assert!(!place.carried && !place.delivered);
        }
        for pair in trace.cycles.windows(2) {
            let robots: Vec<[f32; 2]> = std::iter::once(&pair[1].robot)
                .chain(&pair[1].team)
                .map(|pose| pose.position())
                .collect();
            for (before, now) in pair[0].items.iter().zip(&pair[1].items) {
                prop_assert!(!(now.carried && now.delivered), "{:?}", now);
                if before.delivered || !(now.carried || now.delivered) {
                    prop_assert_eq!(before.at, now.at);
                }
                prop_assert!(!before.delivered || now.delivered);
                if now.carried {
                    prop_assert!(robots.contains(&now.at), "{:?} on no robot", now);
                }
            }
        }
        let mut plain = batch.controller(Some(&genes)).expect("genes fit");
        prop_assert_eq!(&trace.outcome, &batch.evaluator().evaluate(&mut plain, sample));
        let lockstep = BatchEvaluator::new(template, task)
            .expect("valid")
            .with_kind(EvaluatorKind::Lockstep)
            .evaluate_genome(Some(&genes), &[sample])
            .expect("genes fit");
        prop_assert_eq!(&trace.outcome, &lockstep[0]);
    }
}

#[test]
fn a_foraging_sample_is_the_same_every_time_and_on_every_evaluator() {
    let task = foraging_task();
    let rng = &mut SimRng::seed_from_u64(11);
    let (template, genes) = random_controller(rng);
    let scalar = crate::support::outcomes_on_every_evaluator(&template, &genes, &task);
    // The robots did pick items up: the comparison covers carrying, not only items lying.
    let picked: Vec<f32> = scalar.iter().map(|outcome| outcome.descriptor[1]).collect();
    assert!(picked.iter().any(|&share| share > 0.0), "{picked:?}");
}

/// One robot facing east, an item 0.2 m ahead and a nest beyond it.
const ONE_ITEM: &str = r#"
schema = "hevo.scenario/1"
name = "one_item"
max_cycles = 100
sensors = ["ir", "items"]

[world]
solids = [[-1.05, -1.05, 1.05, -1.0], [-1.05, 1.0, 1.05, 1.05], [-1.05, -1.0, -1.0, 1.0], [1.0, -1.0, 1.05, 1.0]]

[regions]
here = { rect = [-0.001, -0.001, 0.001, 0.001] }
item = { rect = [0.199, -0.001, 0.201, 0.001] }
nest = { rect = [0.4, -0.3, 0.6, 0.3] }

[place]
at = "here"
facing = "right"

[[objects]]
name = "token"
count = 1
region = "item"

[nest]
region = "nest"

[end]
solved = "items delivered"

[fitness]
solved = "1 + items.delivered"
otherwise = "items.picked"
"#;

#[test]
fn a_robot_driving_over_an_item_carries_it_into_the_nest() {
    let evaluator = Evaluator::new(task(ONE_ITEM)).expect("valid");
    let trace =
        evaluator.evaluate_traced(&mut crate::support::Fixed::straight(), Sample::seeded(0));
    assert!(trace.outcome.solved, "{:?}", trace.outcome);
    assert_eq!(trace.outcome.fitness, 2.0);
    let item = trace.items[0];
    assert!(item.delivered && !item.carried, "{item:?}");
    // Delivered where the robot's centre first entered the nest.
    assert!(item.end[0] >= 0.4 && item.end[0] < 0.45, "{item:?}");
    // The item sensor saw it ahead at the start, and the robot carried it on the way.
    let first = trace.cycles[0].frame.values(InputGroup::ITEMS);
    assert!((first[0] - (1.0 - 0.2 / 0.3)).abs() < 0.01, "{first:?}");
    let carrying = trace
        .cycles
        .iter()
        .filter(|cycle| cycle.frame.values(InputGroup::ITEMS)[4] == 1.0)
        .count();
    assert!(carrying > 0 && carrying < trace.cycles.len(), "{carrying}");
    // Cycle by cycle: on the floor, then on the robot to the end (delivering it ended the
    // sample, so no cycle began with it delivered).
    let places: Vec<_> = trace.cycles.iter().map(|cycle| cycle.items[0]).collect();
    let carried_from = places.iter().position(|place| place.carried).unwrap();
    assert!(carried_from > 0);
    assert!(
        places[..carried_from]
            .iter()
            .all(|place| place.at == item.start)
    );
    for (cycle, place) in trace.cycles.iter().zip(&places).skip(carried_from) {
        assert!(place.carried && !place.delivered);
        assert_eq!(place.at, cycle.robot.position());
    }
    // Not ended by the delivery, the sample shows the item delivered where it was delivered
    // for the rest of its cycles.
    let open_ended = ONE_ITEM.replace(r#"solved = "items delivered""#, r#"solved = "not always""#);
    let open_evaluator = Evaluator::new(task(&open_ended)).expect("valid");
    let long =
        open_evaluator.evaluate_traced(&mut crate::support::Fixed::straight(), Sample::seeded(0));
    let places: Vec<_> = long.cycles.iter().map(|cycle| cycle.items[0]).collect();
    let delivered_from = places.iter().position(|place| place.delivered).unwrap();
    assert!(delivered_from > carried_from && delivered_from + 1 < places.len());
    assert!(
        places[delivered_from..]
            .iter()
            .all(|place| place.at == item.end && !place.carried)
    );
    assert_eq!(long.items[0].end, item.end);
    // Standing still, the robot picks nothing up.
    let still = evaluator.evaluate_traced(&mut crate::support::Fixed::still(), Sample::seeded(0));
    assert!(!still.outcome.solved);
    assert_eq!(still.outcome.fitness, 0.0);
    assert_eq!(still.items[0].start, still.items[0].end);
}

/// A derived fitness's phases see the items: a phase `when = "carrying"` is in force in
/// exactly the cycles the robot senses that it carries the item.
#[test]
fn a_phase_sees_what_the_robot_carries() {
    let phased = ONE_ITEM.replace(
        "[end]",
        "[[phase]]\nname = \"carry\"\nchild = 0\nwhen = \"carrying\"\n\n\
         [[phase]]\nname = \"search\"\nchild = 1\nwhen = \"always\"\n\n[end]",
    );
    let evaluator = Evaluator::new(task(&phased)).expect("valid");
    let trace =
        evaluator.evaluate_traced(&mut crate::support::Fixed::straight(), Sample::seeded(0));
    let mut carried_cycles = 0;
    for cycle in &trace.cycles {
        let carrying = cycle.frame.values(InputGroup::ITEMS)[4] == 1.0;
        carried_cycles += usize::from(carrying);
        assert_eq!(cycle.sub_task, if carrying { 0 } else { 1 });
    }
    assert!(carried_cycles > 0);
}

/// The refusal of the one-item scenario with `from` replaced by `to`.
fn refusal(from: &str, to: &str) -> String {
    crate::support::refusal_of(ONE_ITEM, from, to)
}

#[test]
fn items_or_a_nest_that_cannot_work_are_refused_naming_the_key() {
    for (from, to, wanted) in [
        ("count = 1", "count = 0", "objects[0].count"),
        ("count = 1", "count = 65", "at most 64"),
        (
            "region = \"item\"",
            "region = \"nowhere\"",
            "objects[0].region",
        ),
        ("region = \"nest\"", "region = \"nowhere\"", "nest.region"),
        // The nest inside the east wall: no robot's centre fits in it.
        (
            "nest = { rect = [0.4, -0.3, 0.6, 0.3] }",
            "nest = { rect = [1.0, -0.3, 1.05, 0.3] }",
            "nest.region",
        ),
        // A wall across the arena between the robot and the nest.
        (
            "[1.0, -1.0, 1.05, 1.0]]",
            "[1.0, -1.0, 1.05, 1.0], [0.3, -1.0, 0.32, 1.0]]",
            "no robot can reach the nest 'nest' from where the robots start: walls close it off",
        ),
        // A walled pen round the item, room for it but no way in.
        (
            "[1.0, -1.0, 1.05, 1.0]]",
            "[1.0, -1.0, 1.05, 1.0], [0.12, -0.08, 0.28, -0.06], [0.12, 0.06, 0.28, 0.08], \
             [0.12, -0.06, 0.14, 0.06], [0.26, -0.06, 0.28, 0.06]]",
            "m from where the robots start: walls close it off",
        ),
        // The item on the robot's own start.
        (
            "item = { rect = [0.199, -0.001, 0.201, 0.001] }",
            "item = { rect = [0.01, -0.001, 0.011, 0.001] }",
            "objects[0].region",
        ),
        // Items without a nest, and a nest without items.
        ("[nest]\nregion = \"nest\"\n", "", "[nest]"),
        (
            "[[objects]]\nname = \"token\"\ncount = 1\nregion = \"item\"\n",
            "",
            "nest",
        ),
        ("name = \"token\"", "name = \"token\"\nradius = 1", "radius"),
    ] {
        let error = refusal(from, to);
        assert!(error.contains(wanted), "{to}: {error}");
    }
    // Each item term in a scenario without items is refused, naming its key.
    let alone = ONE_ITEM
        .replace(
            "[[objects]]\nname = \"token\"\ncount = 1\nregion = \"item\"\n",
            "",
        )
        .replace("[nest]\nregion = \"nest\"\n", "")
        .replace("solved = \"items delivered\"", "solved = \"always\"")
        .replace("solved = \"1 + items.delivered\"", "solved = \"1\"")
        .replace("otherwise = \"items.picked\"", "otherwise = \"0\"");
    Scenario::parse(&alone, "alone.toml").expect("valid without the item terms");
    for (from, to, key) in [
        (
            "solved = \"always\"",
            "solved = \"items delivered\"",
            "end.solved",
        ),
        ("solved = \"always\"", "solved = \"carrying\"", "end.solved"),
        (
            "solved = \"1\"",
            "solved = \"1 + items.delivered\"",
            "fitness.solved",
        ),
        (
            "otherwise = \"0\"",
            "otherwise = \"items.picked\"",
            "fitness.otherwise",
        ),
    ] {
        let text = alone.replacen(from, to, 1);
        let error = Scenario::parse(&text, "alone.toml")
            .unwrap_err()
            .to_string();
        assert!(
            error.contains(key) && error.contains("needs items"),
            "{to}: {error}"
        );
    }
}
