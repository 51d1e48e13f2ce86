//! What a sensor is: a kind ([`SensorKind`]: its name, its inputs, how it compiles with the
//! task's numbers), a compiled sensor all samples of an evaluator share ([`Sensor`]) and one
//! sample's reading of it ([`SensorRun`]), which turns what a cycle shows ([`SenseView`]) into
//! its inputs. The registered kinds are [`SENSORS`](super::SENSORS); a new sensor is one file
//! beside [`kinds`](super::kinds) and one line there.

use crate::body::Pose;
use crate::config::Params;
use crate::geometry::bodies::Disc;
use crate::geometry::crowd::Crowd;
use crate::geometry::items::Items;
use crate::geometry::scene::Scene;
use crate::math::rng::SimRng;
use std::fmt::Debug;

/// What a task's world holds that a sensor may need before it is built: whether anything in
/// it can excite the sensor at all.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SensedWorld {
    /// Whether the scenario holds any light.
    pub has_lights: bool,
    /// Whether the scenario holds a teammate.
    pub has_teammate: bool,
    /// Whether the scenario holds other robots of a team (`[[robots]]`).
    pub has_team: bool,
    /// Whether the scenario holds movable items (`[[objects]]`).
    pub has_items: bool,
}

/// One kind of sensor: its name, its inputs and how it compiles for a task.
#[derive(Debug)]
pub struct SensorKind {
    /// The name `sensors` and a network's `inputs` give.
    pub name: &'static str,
    /// Each input's name, in the order the sensor fills them: trace columns and the Python
    /// binding's `input_names`. Their number is the group's width.
    pub inputs: &'static [&'static str],
    /// Whether a robot whose scenario names no `sensors` carries it: the e-puck's sensors do.
    /// A new sensor that does not leaves every existing scenario's results as they are.
    pub by_default: bool,
    /// The sensor with a task's settings (its geometry, noise, calibration), built once per
    /// evaluator; `None` when nothing in the task's world can excite it (no light for
    /// `light`, no teammate for `near_robot`, no team for `rab`), so that it would read 0 and
    /// draw nothing in every cycle of every sample: it is then not run at all.
    pub compile: fn(params: &Params, world: &SensedWorld) -> Option<Box<dyn Sensor>>,
}

/// A compiled sensor: what all samples of an evaluator share.
pub trait Sensor: Debug + Send + Sync {
    /// A sample's reading of it, with whatever it keeps between cycles; drawn at the sample's
    /// start from the sample's own sensor-setup stream (shared by the sensors in registry
    /// order).
    fn start<'s>(&'s self, setup: &mut SimRng) -> Box<dyn SensorRun + 's>;
}

/// One sample's reading of a sensor.
pub trait SensorRun: Debug + Send {
    /// Fills `out` (as many values as the kind's `inputs`, each in [0, 1], all 0 on entry)
    /// with this cycle's reading, drawing any noise from the sample's noise stream.
    fn read(&mut self, view: &SenseView<'_>, noise: &mut SimRng, out: &mut [f32]);
}

/// What a sensor sees of a sample at the start of a cycle.
#[derive(Debug, Clone, Copy)]
pub struct SenseView<'a> {
    /// The robot.
    pub robot: &'a Pose,
    /// The sine of the robot's heading, computed once per cycle for every sensor.
    pub sin_heading: f32,
    /// The cosine of the robot's heading.
    pub cos_heading: f32,
    /// The solids.
    pub scene: &'a Scene,
    /// The positions of the sample's lights, by index.
    pub lights: &'a [[f32; 2]],
    /// Bit `i` set when light `i` is lit in this cycle.
    pub lit_mask: u32,
    /// The teammate, in scenarios with one.
    pub teammate: Option<&'a Pose>,
    /// Every robot of a team, at the cycle's start (`None` for one robot alone): the sensing
    /// robot is robot `me` of it, the others are bodies its sensors see.
    pub crowd: Option<&'a Crowd>,
    /// The sensing robot's index in `crowd` (0 the focal robot), and in the items' carriers.
    pub me: usize,
    /// The items, in a scenario with `[[objects]]`.
    pub items: Option<&'a Items>,
    /// The movers and boxes where they stand (`[[movers]]`, `[[boxes]]`; empty without):
    /// discs the IR sensors see as they see another robot.
    pub bodies: &'a [Disc],
}

/// The crowd of a robot alone.
static NO_CROWD: Crowd = Crowd::EMPTY;

impl SenseView<'_> {
    /// The other robots of the team whose centre lies within `reach` of the sensing robot's,
    /// as (position, squared distance): none for a robot alone.
    #[inline]
    pub fn others_near(&self, reach: f32) -> impl Iterator<Item = ([f32; 2], f32)> + '_ {
        let me = self.me;
        // An empty crowd rather than an optional one: no flattening in a loop this hot.
        self.crowd
            .unwrap_or(&NO_CROWD)
            .near(self.robot.position(), reach)
            .filter(move |&(idx, _, _)| idx != me)
            .map(|(_, position, distance_sq)| (position, distance_sq))
    }
}

impl<'a> SenseView<'a> {
    /// What a robot at `robot` sees of `scene` with no light and no teammate: for the tests of
    /// one sensor on its own.
    #[cfg(test)]
    pub(crate) fn unlit(robot: &'a Pose, scene: &'a Scene) -> SenseView<'a> {
        let (sin_heading, cos_heading) = robot.heading.sin_cos();
        SenseView {
            robot,
            sin_heading,
            cos_heading,
            scene,
            lights: &[],
            lit_mask: 0,
            teammate: None,
            crowd: None,
            me: 0,
            items: None,
            bodies: &[],
        }
    }
}
