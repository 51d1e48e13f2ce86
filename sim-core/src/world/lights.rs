//! The lights of a sample and what makes them light: each light as the sample's variant sets
//! it ([`LightSpec`]), its trigger ([`Trigger`]), and its state cycle by cycle as the robot
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
/// when the robot first enters the region. Only the lights of the
/// sample's variant light at all.
#[derive(Debug)]
pub(crate) struct LiveLight {
    position: [f32; 2],
    flashes: bool,
    trigger: Trigger,
    /// Whether it flashes with the trigger `Always`: lit in every cycle.
    always_lit: bool,
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
            // A light of `Always` never fires, so it is never looked at for firing.
            triggered: spec.trigger == Trigger::Always,
            lit_cycles_left: 0,
        }
    }

    /// Counts the current cycle off the time it stays lit.
    #[inline]
    pub(crate) fn count_down(&mut self) {
        self.lit_cycles_left = self.lit_cycles_left.saturating_sub(1);
    }

    /// Whether it is lit in the current cycle.
    #[inline]
    pub(crate) fn lit(&self) -> bool {
        self.lit_cycles_left > 0 || self.always_lit
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
            Trigger::Always => false,
        };
        if fired {
            light.triggered = true;
            if light.flashes {
                light.lit_cycles_left = flash_cycles;
            }
        }
    }
}
