//! Light schedules and the conditions that see lights and the team: a light that blinks or
//! switches off is lit in the cycles its schedule says, in the trace's lit bits and to the
//! light sensor; `LIGHT lit` and the team atoms hold in a phase's `when` and a stage's
//! `reached` as they do in `end.solved`; the lockstep evaluator agrees with the scalar one on
//! such a scenario (`lockstep::tasks()` holds it); and a schedule out of bounds is refused,
//! naming its key.

use hevo_sim_core::{Evaluator, InputGroup, Sample, Scenario, TaskConfig};
use std::sync::Arc;

use crate::support::Fixed;

/// A walled arena with a lamp lit for the first 40 cycles, a lamp that blinks (5 lit, 7 dark,
/// from cycle 10), the focal robot beside the first lamp and three robots standing still near
/// it. Phases: "lamp lit and the team gathered", then the rest; a stage for each atom kind.
pub(crate) const SCHEDULED: &str = r#"
schema = "hevo.scenario/1"
name = "scheduled"
max_cycles = 100
end_on_collision = false

[world]
solids = [
    [-0.65, -0.65, 0.65, -0.6],
    [-0.65, 0.6, 0.65, 0.65],
    [-0.65, -0.6, -0.6, 0.6],
    [0.6, -0.6, 0.65, 0.6],
]

[regions]
arena = { rect = [-0.6, -0.6, 0.6, 0.6] }
pad = { rect = [-0.05, -0.05, 0.05, 0.05] }
side = { rect = [0.2, -0.5, 0.5, 0.5] }
nowhere = { rect = [0.5, 0.5, 0.55, 0.55] }

[[light]]
name = "lamp"
at = [-0.05, 0.0]
trigger = { lit_until = 40 }

[[light]]
name = "blinker"
at = [-0.5, -0.5]
trigger = { blink = { from = 10, lit = 5, dark = 7 } }

[place]
at = "pad"
facing = "up"

[[robots]]
name = "posts"
count = 3
region = "side"
controller = "fixed"

[end]
solved = "in nowhere"
near_m = 5.0

[[phase]]
name = "lit and gathered"
child = 0
when = "lamp lit and team gathered"

[[phase]]
name = "the rest"
child = 1
when = "otherwise"

[[stage]]
name = "blinked"
reached = "blinker lit and team in arena and not lamp lit"

[fitness]
solved = "derived"
otherwise = "derived"
"#;

pub(crate) fn scheduled_task() -> TaskConfig {
    TaskConfig::from_scenario(Arc::new(
        Scenario::parse(SCHEDULED, "scheduled.toml").expect("the scheduled arena compiles"),
    ))
}

/// Whether the blinker is lit in `cycle`, as the file says, written out.
fn blinker_lit(cycle: u32) -> bool {
    cycle >= 10 && (cycle - 10) % 12 < 5
}

#[test]
fn scheduled_lights_are_lit_in_the_trace_and_to_the_sensor_as_their_schedule_says() {
    let evaluator = Evaluator::new(scheduled_task()).expect("valid");
    // The robot stands still beside the lamp for the whole sample.
    let trace = evaluator.evaluate_traced(&mut Fixed::new([0.5, 0.5], 0), Sample::seeded(4));
    assert_eq!(trace.cycles.len(), 100);
    for (cycle, record) in (0u32..).zip(&trace.cycles) {
        let lamp = record.lit_lights & 1 != 0;
        let blinker = record.lit_lights & 2 != 0;
        assert_eq!(lamp, cycle < 40, "lamp at cycle {cycle}");
        assert_eq!(blinker, blinker_lit(cycle), "blinker at cycle {cycle}");
    }
    // The light sensor, 5 cm from the lamp, sees it while lit, and nothing once the flash
    // detector's hold (15 cycles) has run out after the lamp went dark; the blinker, 0.7 m
    // away, is out of its range.
    let light = |cycle: usize| trace.cycles[cycle].frame.values(InputGroup::LIGHT).to_vec();
    assert!(
        (0..40).all(|cycle| light(cycle).contains(&1.0)),
        "the lamp unseen while lit"
    );
    assert!(
        (40 + 15..100).all(|cycle| light(cycle) == [0.0, 0.0]),
        "a dark lamp seen"
    );
}

#[test]
fn phases_and_stages_see_the_lights_and_the_team() {
    let evaluator = Evaluator::new(scheduled_task()).expect("valid");
    let outcome = evaluator.evaluate(&mut Fixed::new([0.5, 0.5], 0), Sample::seeded(7));
    // The team (within 5 m of its centre) is always gathered, so the first phase is in force
    // exactly while the lamp is lit: 40 cycles, then 60 of the rest.
    assert_eq!(outcome.sub_task_choices.cycles[..2], [40, 60]);
    // The stage needs the blinker lit, the team in the arena and the lamp dark: cycle 46 on.
    assert_eq!(outcome.stage, 1);
    // A lamp lit for the whole sample never lets the stage be reached.
    let always_lit = SCHEDULED.replace("lit_until = 40", "lit_until = 1000");
    let task = TaskConfig::from_scenario(Arc::new(
        Scenario::parse(&always_lit, "scheduled.toml").expect("compiles"),
    ));
    let outcome = Evaluator::new(task)
        .expect("valid")
        .evaluate(&mut Fixed::new([0.5, 0.5], 0), Sample::seeded(7));
    assert_eq!(outcome.sub_task_choices.cycles[..2], [100, 0]);
    assert_eq!(outcome.stage, 0);
}

/// The error the scheduled arena gets with `from` replaced by `to`.
fn refusal(from: &str, to: &str) -> String {
    crate::support::refusal_of(SCHEDULED, from, to)
}

#[test]
fn a_schedule_out_of_bounds_is_refused_naming_its_key() {
    for (from, to, key) in [
        (
            "lit_until = 40",
            "lit_until = 0",
            "light[0].trigger.lit_until",
        ),
        (
            "lit_until = 40",
            "lit_until = 1000001",
            "light[0].trigger.lit_until",
        ),
        ("lit = 5,", "lit = 0,", "light[1].trigger.blink.lit"),
        ("dark = 7", "dark = 0", "light[1].trigger.blink.dark"),
        ("from = 10", "from = 2000000", "light[1].trigger.blink.from"),
    ] {
        let error = refusal(from, to);
        assert!(error.contains(key), "{to}: {error}");
    }
    // A negative count, a fraction, an unknown key or two triggers in one table are refused
    // at the trigger, saying what is wrong.
    for (from, to, says) in [
        ("dark = 7", "dark = -7", "-7"),
        ("dark = 7", "dark = 7.5", "7.5"),
        (
            "dark = 7",
            "dark = 7, often = true",
            "unknown field `often`",
        ),
        (
            "{ lit_until = 40 }",
            "{ lit_until = 40, after_cycles = 3 }",
            "exactly one of",
        ),
        (
            "{ lit_until = 40 }",
            "{ lit_untl = 40 }",
            "unknown field `lit_untl`",
        ),
    ] {
        let error = refusal(from, to);
        assert!(
            error.contains("trigger") && error.contains(says),
            "{to}: {error}"
        );
    }
    // `LIGHT lit` names a light the scenario has.
    let error = refusal("when = \"lamp lit", "when = \"lantern lit");
    assert!(
        error.contains("phase[0].when") && error.contains("no light is named 'lantern'"),
        "{error}"
    );
}
