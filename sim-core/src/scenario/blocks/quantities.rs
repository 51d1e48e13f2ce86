//! The fitness quantities a formula's terms name: the time left, the progress along the
//! corridor distance, a closest approach, the derived fitness, the robot's final position, the
//! distance it travelled and the energy its wheels spent.
//! Each is a number in a known range when the sample ends; an approach keeps its closest
//! distance cycle by cycle. A scenario's behaviour descriptor is a list of them too.

use super::{CycleView, EndView, Quantity, QuantityKind, Tracked, fixed_word};
use crate::math::float::hypot;

/// `time_bonus`: (max_cycles - cycles) / max_cycles.
pub const TIME_BONUS: QuantityKind = QuantityKind {
    syntax: &["time_bonus"],
    compile: |text, _| {
        fixed_word::<dyn Quantity>(text, &["time_bonus"], None, || Box::new(TimeBonus))
    },
};

/// The share of the cycle limit left, as the time bonus and the rescue's solved bonus count it.
pub fn time_bonus(cycles: u32, max_cycles: u32) -> f32 {
    let max_cycles = max_cycles as f32;
    (max_cycles - cycles as f32) / max_cycles
}

#[derive(Debug)]
struct TimeBonus;

impl Quantity for TimeBonus {
    fn value(&self, _tracked: &Tracked, end: &EndView<'_>) -> f32 {
        time_bonus(end.cycles, end.cycle.max_cycles)
    }
}

/// `progress`: the share of the corridor distance to the goal covered, in [0, 1].
pub const PROGRESS: QuantityKind = QuantityKind {
    syntax: &["progress"],
    compile: |text, facts| {
        let missing = (!facts.goals_in_cells)
            .then_some("needs a goal in cells (a corridor, or a map and a goal in every variant)");
        fixed_word::<dyn Quantity>(text, &["progress"], missing, || Box::new(Progress))
    },
};

#[derive(Debug)]
struct Progress;

impl Quantity for Progress {
    fn value(&self, _tracked: &Tracked, end: &EndView<'_>) -> f32 {
        end.cycle.ground.goal.as_ref().map_or(0.0, |goal| {
            // Outside the cells (in a room below them): none made. On a path of no length (a
            // one-cell corridor) the robot in its cell has made it all, not 0 / 0.
            goal.distance_from(end.cycle.robot.position())
                .map_or(0.0, |current| share_covered(goal.total_distance, current))
        })
    }
}

/// The largest |coordinate| `final.x` and `final.y` may report, metres: a bound far outside
/// any world (a map spans at most 16,384 cells of at most 10 m) that still refuses garbage.
pub const MAX_FINAL_COORDINATE: f32 = 1.0e6;

/// `final.x`, `final.y`: where the robot's centre is when the sample ends, metres.
pub const FINAL_POSITION: QuantityKind = QuantityKind {
    syntax: &["final.x", "final.y"],
    compile: |text, _| match text {
        "final.x" => Some(Ok(Box::new(FinalPosition { axis: 0 }) as Box<dyn Quantity>)),
        "final.y" => Some(Ok(Box::new(FinalPosition { axis: 1 }) as Box<dyn Quantity>)),
        _ => None,
    },
};

#[derive(Debug)]
struct FinalPosition {
    /// 0 for x, 1 for y.
    axis: usize,
}

impl Quantity for FinalPosition {
    fn value(&self, _tracked: &Tracked, end: &EndView<'_>) -> f32 {
        end.cycle.robot.position()[self.axis]
    }

    fn range(&self, _n_phases: usize) -> (f32, f32) {
        (-MAX_FINAL_COORDINATE, MAX_FINAL_COORDINATE)
    }
}

/// `derived`: the sum over the phases reached of the share of cycles the arbitrator chose the
/// phase's child.
pub const DERIVED: QuantityKind = QuantityKind {
    syntax: &["derived"],
    compile: |text, facts| {
        let missing = (!facts.has_phases).then_some("needs [[phase]]s");
        fixed_word::<dyn Quantity>(text, &["derived"], missing, || Box::new(Derived))
    },
};

#[derive(Debug)]
struct Derived;

impl Quantity for Derived {
    fn value(&self, _tracked: &Tracked, end: &EndView<'_>) -> f32 {
        end.sub_task_choices.derived_fitness()
    }

    fn range(&self, n_phases: usize) -> (f32, f32) {
        (0.0, n_phases as f32)
    }
}

/// `approach room.exit` (from the room's centre to its exit), `approach teammate` and
/// `approach LIGHT` (from the start): the share of the way the closest approach covered, in
/// [0, 1].
pub const APPROACH: QuantityKind = QuantityKind {
    syntax: &["approach room.exit", "approach teammate", "approach LIGHT"],
    compile: |text, facts| {
        let target = text.strip_prefix("approach ")?.trim();
        Some(match target {
            "room.exit" if facts.has_room => Ok(Box::new(ApproachExit) as Box<dyn Quantity>),
            "room.exit" => Err("needs a room".into()),
            "teammate" if facts.has_teammate => Ok(Box::new(ApproachTeammate) as Box<dyn Quantity>),
            "teammate" => Err("needs a [teammate]".into()),
            name => match facts.light(name) {
                Some(light) => Ok(Box::new(ApproachLight {
                    position: facts.lights[light].position,
                }) as Box<dyn Quantity>),
                None => Err(format!("no light is named '{name}'")),
            },
        })
    },
};

/// The share of `start` covered by the closest approach `closest` (1 when starting there).
fn share_covered(start: f32, closest: f32) -> f32 {
    if start > 0.0 {
        ((start - closest) / start).clamp(0.0, 1.0)
    } else {
        1.0
    }
}

#[derive(Debug)]
struct ApproachExit;

impl Quantity for ApproachExit {
    fn tracks(&self) -> bool {
        true
    }

    fn start(&self, view: &CycleView<'_>) -> Tracked {
        let closest = view.ground.room.as_ref().map_or(f32::INFINITY, |room| {
            view.robot.distance_to(room.exit_center)
        });
        Tracked {
            start: closest,
            best: closest,
            ..Tracked::default()
        }
    }

    #[inline]
    fn observe(&self, tracked: &mut Tracked, view: &CycleView<'_>) {
        if let Some(room) = &view.ground.room {
            tracked.best = tracked.best.min(view.robot.distance_to(room.exit_center));
        }
    }

    fn value(&self, tracked: &Tracked, end: &EndView<'_>) -> f32 {
        // From the room's centre, not the start: the start is drawn anywhere in the room.
        end.cycle.ground.room.as_ref().map_or(0.0, |room| {
            let to_exit = hypot(
                room.center[0] - room.exit_center[0],
                room.center[1] - room.exit_center[1],
            );
            ((to_exit - tracked.best) / to_exit).clamp(0.0, 1.0)
        })
    }
}

#[derive(Debug)]
struct ApproachLight {
    position: [f32; 2],
}

impl Quantity for ApproachLight {
    fn tracks(&self) -> bool {
        true
    }

    fn start(&self, view: &CycleView<'_>) -> Tracked {
        let d = view.robot.distance_to(self.position);
        Tracked {
            start: d,
            best: d,
            ..Tracked::default()
        }
    }

    #[inline]
    fn observe(&self, tracked: &mut Tracked, view: &CycleView<'_>) {
        tracked.best = tracked.best.min(view.robot.distance_to(self.position));
    }

    fn value(&self, tracked: &Tracked, _end: &EndView<'_>) -> f32 {
        share_covered(tracked.start, tracked.best)
    }
}

/// The teammate may move: each cycle's distance counts.
#[derive(Debug)]
struct ApproachTeammate;

impl Quantity for ApproachTeammate {
    fn tracks(&self) -> bool {
        true
    }

    fn start(&self, view: &CycleView<'_>) -> Tracked {
        let d = view.teammate.map_or(f32::INFINITY, |mate| {
            view.robot.distance_to(mate.pose.position())
        });
        Tracked {
            start: d,
            best: d,
            ..Tracked::default()
        }
    }

    #[inline]
    fn observe(&self, tracked: &mut Tracked, view: &CycleView<'_>) {
        if let Some(mate) = view.teammate {
            tracked.best = tracked
                .best
                .min(view.robot.distance_to(mate.pose.position()));
        }
    }

    fn value(&self, tracked: &Tracked, _end: &EndView<'_>) -> f32 {
        if tracked.start.is_finite() {
            share_covered(tracked.start, tracked.best)
        } else {
            0.0
        }
    }
}

/// The most `distance` may report, metres: far beyond what any robot can drive in a sample (at
/// 0.1 m/s for 1,000,000 cycles of 0.1 s, 10 km), and still a bound remote results are checked
/// against.
pub const MAX_DISTANCE: f32 = 1.0e6;

/// `distance`: how far the robot's centre travelled, metres: the sum of each cycle's straight
/// move (a move a collision undid counts nothing).
pub const DISTANCE: QuantityKind = QuantityKind {
    syntax: &["distance"],
    compile: |text, _| fixed_word::<dyn Quantity>(text, &["distance"], None, || Box::new(Distance)),
};

#[derive(Debug)]
struct Distance;

impl Quantity for Distance {
    fn tracks(&self) -> bool {
        true
    }

    fn start(&self, view: &CycleView<'_>) -> Tracked {
        Tracked {
            last: view.robot.position(),
            ..Tracked::default()
        }
    }

    #[inline]
    fn observe(&self, tracked: &mut Tracked, view: &CycleView<'_>) {
        let now = view.robot.position();
        tracked.sum += hypot(now[0] - tracked.last[0], now[1] - tracked.last[1]);
        tracked.last = now;
    }

    fn value(&self, tracked: &Tracked, _end: &EndView<'_>) -> f32 {
        tracked.sum.min(MAX_DISTANCE)
    }

    fn range(&self, _n_phases: usize) -> (f32, f32) {
        (0.0, MAX_DISTANCE)
    }
}

/// `energy`: the sum over the cycles judged of the mean absolute speed of the two wheels (as
/// driven, noise included), in units of `robot.v_max`, divided by the cycle limit: 0 for a
/// robot that never moves its wheels, 1 for one that drives them at full speed, either way, for
/// the whole cycle limit. A sample that ends early has spent less. (The cycle of a collision
/// that ends the sample is not judged, and not counted.)
pub const ENERGY: QuantityKind = QuantityKind {
    syntax: &["energy"],
    compile: |text, _| fixed_word::<dyn Quantity>(text, &["energy"], None, || Box::new(Energy)),
};

#[derive(Debug)]
struct Energy;

impl Quantity for Energy {
    fn tracks(&self) -> bool {
        true
    }

    #[inline]
    fn observe(&self, tracked: &mut Tracked, view: &CycleView<'_>) {
        let [left, right] = view.wheel_speeds;
        tracked.sum += 0.5 * (left.abs() + right.abs()) / view.params.robot.v_max;
    }

    fn value(&self, tracked: &Tracked, end: &EndView<'_>) -> f32 {
        (tracked.sum / end.cycle.max_cycles as f32).clamp(0.0, 1.0)
    }
}
