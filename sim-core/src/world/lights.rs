//! The lights of a sample and what makes them light: each light as the sample's variant sets
//! it ([`LightSpec`]), its trigger ([`Trigger`]: an event that flashes it once, or a schedule
//! that says for every cycle whether it is lit), and its state cycle by cycle as the robot
//! drives ([`LiveLight`], [`trigger_lights`]).

use crate::body::Pose;
use crate::geometry::rect_holds;

/// When a light lights.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Trigger {
    /// Once, when the robot's centre first crosses its row going up within its distance from
    /// the centre line.
    Passed,
    /// Always (a beacon).
    Always,
    /// Once, at this cycle.
    AfterCycles(u32),
    /// Once, when the robot's centre is first inside this rectangle `[x0, y0, x1, y1]` after
    /// a move.
    Entered([f32; 4]),
    /// A schedule: dark before cycle `from`, then lit for `lit` cycles and dark for `dark`,
    /// over and over (cycles count from 0).
    Blink {
        /// The first lit cycle.
        from: u32,
        /// Cycles lit in each period (at least 1).
        lit: u32,
        /// Cycles dark in each period (at least 1).
        dark: u32,
    },
    /// A schedule: lit from the start, dark from this cycle on.
    LitUntil(u32),
}

impl Trigger {
    /// Whether a light of this trigger is lit in `cycle` (counted from 0) by its schedule;
    /// `false` for the triggers that are events rather than schedules.
    #[inline]
    pub fn scheduled_lit(&self, cycle: u32) -> bool {
        match *self {
            Trigger::Blink { from, lit, dark } => {
                // Compiled lights hold `lit` and `dark` of at least 1 and at most a million
                // each, so the period neither is 0 nor overflows.
                cycle >= from && (cycle - from) % (lit + dark) < lit
            }
            Trigger::LitUntil(until) => cycle < until,
            Trigger::Passed | Trigger::Always | Trigger::AfterCycles(_) | Trigger::Entered(_) => {
                false
            }
        }
    }

    /// Whether the trigger is a schedule (its light never fires, it follows the cycle).
    #[inline]
    pub fn is_schedule(&self) -> bool {
        matches!(self, Trigger::Blink { .. } | Trigger::LitUntil(_))
    }
}

/// A light as one sample sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LightSpec {
    /// Position, metres.
    pub position: [f32; 2],
    /// Whether this light lights in the sample's variant.
    pub flashes: bool,
    /// When it lights.
    pub trigger: Trigger,
}

/// A light's state during a sample: a row light flashes once, when the robot first drives past
/// it; a beacon is always lit; a timed light flashes once at its cycle; a region's light once,
/// when the robot first enters the region; a scheduled light is lit in the cycles its schedule
/// says. Only the lights of the sample's variant light at all.
#[derive(Debug)]
pub(crate) struct LiveLight {
    position: [f32; 2],
    flashes: bool,
    trigger: Trigger,
    /// Whether it flashes with the trigger `Always`: lit in every cycle.
    always_lit: bool,
    /// Whether it flashes with a schedule: lit as the schedule says.
    scheduled: bool,
    /// Whether its trigger has fired, or never will.
    triggered: bool,
    lit_cycles_left: u32,
}

impl LiveLight {
    /// A sample's light, not yet triggered.
    pub(crate) fn new(spec: &LightSpec) -> LiveLight {
        LiveLight {
            position: spec.position,
            flashes: spec.flashes,
            trigger: spec.trigger,
            always_lit: spec.flashes && spec.trigger == Trigger::Always,
            scheduled: spec.flashes && spec.trigger.is_schedule(),
            // A light of `Always` or a schedule never fires, so it is never looked at for
            // firing.
            triggered: spec.trigger == Trigger::Always || spec.trigger.is_schedule(),
            lit_cycles_left: 0,
        }
    }

    /// Counts the current cycle off the time it stays lit.
    #[inline]
    pub(crate) fn count_down(&mut self) {
        self.lit_cycles_left = self.lit_cycles_left.saturating_sub(1);
    }

    /// Whether it is lit in the current cycle, `cycle` (counted from 0).
    #[inline]
    pub(crate) fn lit(&self, cycle: u32) -> bool {
        self.lit_cycles_left > 0
            || self.always_lit
            || (self.scheduled && self.trigger.scheduled_lit(cycle))
    }
}

/// A light row is passed when the robot's centre crosses the light's y going up the stem,
/// within the stem (|x| below the light's x). A timed light lights at its cycle; a region's
/// light when the robot's centre is in the region after a move.
pub(crate) fn trigger_lights(
    lights: &mut [LiveLight],
    before: &Pose,
    after: &Pose,
    cycle: u32,
    flash_cycles: u32,
) {
    for light in lights.iter_mut().filter(|l| !l.triggered) {
        let fired = match light.trigger {
            Trigger::Passed => {
                let row = light.position[1];
                before.y < row && after.y >= row && after.x.abs() < light.position[0].abs()
            }
            Trigger::AfterCycles(at) => cycle + 1 >= at,
            Trigger::Entered(rect) => rect_holds(rect, after.position()),
            Trigger::Always | Trigger::Blink { .. } | Trigger::LitUntil(_) => false,
        };
        if fired {
            light.triggered = true;
            if light.flashes {
                light.lit_cycles_left = flash_cycles;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The cycles of `0..cycles` in which a light of `spec` is lit, stepped as a sample steps
    /// it (lit, counted down, triggered), its robot standing still at the origin.
    fn lit_cycles(spec: LightSpec, cycles: u32) -> Vec<u32> {
        let mut lights = [LiveLight::new(&spec)];
        let still = Pose {
            x: 0.0,
            y: 0.0,
            heading: 0.0,
        };
        let mut lit = Vec::new();
        for cycle in 0..cycles {
            if lights[0].lit(cycle) {
                lit.push(cycle);
            }
            lights[0].count_down();
            trigger_lights(&mut lights, &still, &still, cycle, 5);
        }
        lit
    }

    fn spec(trigger: Trigger, flashes: bool) -> LightSpec {
        LightSpec {
            position: [1.0, 1.0],
            flashes,
            trigger,
        }
    }

    #[test]
    fn a_blinking_light_is_dark_before_its_start_then_lit_and_dark_in_turn() {
        let blink = Trigger::Blink {
            from: 3,
            lit: 2,
            dark: 3,
        };
        assert_eq!(
            lit_cycles(spec(blink, true), 16),
            vec![3, 4, 8, 9, 13, 14],
            "lit 3-4, dark 5-7, lit 8-9, dark 10-12, lit 13-14"
        );
        let from_start = Trigger::Blink {
            from: 0,
            lit: 1,
            dark: 1,
        };
        assert_eq!(lit_cycles(spec(from_start, true), 6), vec![0, 2, 4]);
    }

    #[test]
    fn a_light_lit_until_a_cycle_is_lit_from_the_start_and_dark_from_that_cycle() {
        assert_eq!(
            lit_cycles(spec(Trigger::LitUntil(4), true), 10),
            vec![0, 1, 2, 3]
        );
        assert_eq!(lit_cycles(spec(Trigger::LitUntil(1), true), 3), vec![0]);
    }

    #[test]
    fn a_scheduled_light_that_does_not_flash_in_the_variant_stays_dark() {
        for trigger in [
            Trigger::LitUntil(50),
            Trigger::Blink {
                from: 0,
                lit: 3,
                dark: 1,
            },
        ] {
            assert_eq!(lit_cycles(spec(trigger, false), 20), Vec::<u32>::new());
        }
    }

    #[test]
    fn the_event_triggers_keep_their_flashes() {
        // A timed light at cycle 4 fires at the end of its fourth cycle (3) and is lit for the
        // five cycles after; a beacon always.
        assert_eq!(
            lit_cycles(spec(Trigger::AfterCycles(4), true), 12),
            vec![4, 5, 6, 7, 8]
        );
        assert_eq!(lit_cycles(spec(Trigger::Always, true), 3), vec![0, 1, 2]);
        for event in [Trigger::Passed, Trigger::Always, Trigger::AfterCycles(2)] {
            assert!(!event.is_schedule());
            assert!((0..10).all(|cycle| !event.scheduled_lit(cycle)));
        }
    }
}
