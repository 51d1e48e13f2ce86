//! The sensor frame: what the robot perceives in one control cycle, in the normalised form the
//! networks read. It is the single interface between the world (whose sensors fill it) and the
//! controllers (which read the groups of inputs each network declares). The groups are the
//! registered sensors ([`SENSORS`]): a frame holds every registered sensor's inputs, one after
//! the other in registry order, so its layout is fixed when the crate compiles.

use super::SENSORS;
use super::SensorKind;
use super::{SenseView, SensorRun};
use crate::math::rng::SimRng;
use serde::{Deserialize, Deserializer, Serialize, Serializer};
use std::fmt;

/// Number of input groups: one per registered sensor.
pub const N_GROUPS: usize = SENSORS.len();

/// Number of inputs in a frame: every registered sensor's, in registry order.
pub const N_FLAT: usize = GROUP_STARTS[N_GROUPS];

/// Where each group's inputs start in a frame, and (last) where the frame ends.
const GROUP_STARTS: [usize; N_GROUPS + 1] = {
    let mut starts = [0; N_GROUPS + 1];
    let mut group = 0;
    while group < N_GROUPS {
        starts[group + 1] = starts[group] + SENSORS[group].inputs.len();
        group += 1;
    }
    starts
};

/// Every group's name, in registry order (what a file may name).
const GROUP_NAMES: [&str; N_GROUPS] = {
    let mut names = [""; N_GROUPS];
    let mut group = 0;
    while group < N_GROUPS {
        names[group] = SENSORS[group].name;
        group += 1;
    }
    names
};

/// All inputs of one control cycle, each in [0, 1]: every group's where
/// [`InputGroup::flat_range`] says. A group the robot lacks reads 0.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct SensorFrame {
    /// The inputs, group after group.
    pub inputs: [f32; N_FLAT],
}

impl SensorFrame {
    /// Every input's name, in frame order: each group's [`InputGroup::input_names`].
    pub const INPUT_NAMES: [&'static str; N_FLAT] = {
        let mut names = [""; N_FLAT];
        let mut group = 0;
        while group < N_GROUPS {
            let inputs = SENSORS[group].inputs;
            let mut input = 0;
            while input < inputs.len() {
                names[GROUP_STARTS[group] + input] = inputs[input];
                input += 1;
            }
            group += 1;
        }
        names
    };

    /// One robot's frame: each sensor it carries (`runs`, by input group) reads `view`, in
    /// registry order, drawing its noise from `noise`; the groups it lacks read 0.
    #[inline]
    pub(crate) fn read(
        runs: &mut [Option<Box<dyn SensorRun + '_>>; N_GROUPS],
        view: &SenseView<'_>,
        noise: &mut SimRng,
    ) -> SensorFrame {
        let mut frame = SensorFrame::default();
        // A loop over a constant number of groups, which the compiler unrolls: one call site
        // per sensor, and each group's place in the frame a constant.
        for (group, run) in InputGroup::ALL.into_iter().zip(runs) {
            if let Some(run) = run {
                run.read(view, noise, frame.values_mut(group));
            }
        }
        frame
    }

    /// The current values of `group`.
    #[inline]
    pub fn values(&self, group: InputGroup) -> &[f32] {
        &self.inputs[group.flat_range()]
    }

    /// The values of `group`, to fill.
    #[inline]
    pub fn values_mut(&mut self, group: InputGroup) -> &mut [f32] {
        &mut self.inputs[group.flat_range()]
    }

    /// This frame with `group` reading `values` (as many as its width); for tests and
    /// scripted inputs.
    pub fn with(mut self, group: InputGroup, values: &[f32]) -> SensorFrame {
        self.values_mut(group).copy_from_slice(values);
        self
    }
}

/// A named group of inputs a network can declare: one registered sensor's. A network's inputs
/// are the concatenation of its groups in the order it lists them. Files name a group by its
/// sensor's name (`"ir"`).
#[derive(Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct InputGroup(u8);

impl InputGroup {
    /// Every group, in registry (frame) order.
    pub const ALL: [InputGroup; N_GROUPS] = {
        let mut all = [InputGroup(0); N_GROUPS];
        let mut group = 0;
        while group < N_GROUPS {
            all[group] = InputGroup(group as u8);
            group += 1;
        }
        all
    };

    /// The e-puck's four IR proximity inputs (`ir`).
    pub const IR: InputGroup = InputGroup::registered("ir");
    /// The e-puck's two light-flash inputs (`light`).
    pub const LIGHT: InputGroup = InputGroup::registered("light");
    /// The near-robot boolean (`near_robot`).
    pub const NEAR_ROBOT: InputGroup = InputGroup::registered("near_robot");
    /// The range-and-bearing board's four sectors and count (`rab`).
    pub const RAB: InputGroup = InputGroup::registered("rab");
    /// The item sensor's four sectors and whether the robot carries an item (`items`).
    pub const ITEMS: InputGroup = InputGroup::registered("items");

    /// The group of the sensor registered as `name`; fails to compile when there is none.
    const fn registered(name: &str) -> InputGroup {
        let mut group = 0;
        while group < N_GROUPS {
            if const_str_eq(GROUP_NAMES[group], name) {
                return InputGroup(group as u8);
            }
            group += 1;
        }
        panic!("no sensor of that name is registered")
    }

    /// The group named `name` in files, if a sensor of that name is registered.
    pub fn named(name: &str) -> Option<InputGroup> {
        GROUP_NAMES
            .iter()
            .position(|&registered| registered == name)
            .map(|group| InputGroup(group as u8))
    }

    /// The group's place in [`InputGroup::ALL`].
    #[inline]
    pub fn index(self) -> usize {
        usize::from(self.0)
    }

    /// The sensor that fills it.
    pub fn kind(self) -> &'static SensorKind {
        &SENSORS[self.index()]
    }

    /// The group's name in controller and scenario files.
    pub fn name(self) -> &'static str {
        GROUP_NAMES[self.index()]
    }

    /// Each of its inputs' names, as trace columns show them.
    pub fn input_names(self) -> &'static [&'static str] {
        self.kind().inputs
    }

    /// How many network inputs this group contributes.
    #[inline]
    pub fn width(self) -> usize {
        self.flat_range().len()
    }

    /// Where the group's values sit in [`SensorFrame::inputs`].
    #[inline]
    pub fn flat_range(self) -> std::ops::Range<usize> {
        GROUP_STARTS[self.index()]..GROUP_STARTS[self.index() + 1]
    }
}

/// Byte-wise string equality, in a constant.
const fn const_str_eq(a: &str, b: &str) -> bool {
    let (a, b) = (a.as_bytes(), b.as_bytes());
    if a.len() != b.len() {
        return false;
    }
    let mut idx = 0;
    while idx < a.len() {
        if a[idx] != b[idx] {
            return false;
        }
        idx += 1;
    }
    true
}

impl fmt::Debug for InputGroup {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl fmt::Display for InputGroup {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl Serialize for InputGroup {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.serialize_str(self.name())
    }
}

impl<'de> Deserialize<'de> for InputGroup {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<InputGroup, D::Error> {
        let name = <std::borrow::Cow<'de, str>>::deserialize(deserializer)?;
        InputGroup::named(&name)
            .ok_or_else(|| serde::de::Error::unknown_variant(&name, &GROUP_NAMES))
    }
}

/// The input groups a robot's sensors give; a group the robot lacks reads 0 and its sensor
/// draws no noise.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SensorSet([bool; N_GROUPS]);

impl SensorSet {
    /// A robot's whose scenario names no `sensors`: the sensors registered as carried by
    /// default (the e-puck's).
    pub const DEFAULT: SensorSet = {
        let mut set = [false; N_GROUPS];
        let mut group = 0;
        while group < N_GROUPS {
            set[group] = SENSORS[group].by_default;
            group += 1;
        }
        SensorSet(set)
    };

    /// The set of `groups`.
    pub fn of(groups: &[InputGroup]) -> SensorSet {
        let mut set = [false; N_GROUPS];
        for group in groups {
            set[group.index()] = true;
        }
        SensorSet(set)
    }

    /// Whether the robot has the sensor of `group`.
    #[inline]
    pub fn carries(self, group: InputGroup) -> bool {
        self.0[group.index()]
    }

    /// The groups carried, in frame order.
    pub fn groups(self) -> impl Iterator<Item = InputGroup> {
        InputGroup::ALL
            .into_iter()
            .filter(move |&group| self.carries(group))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn groups_know_their_index_and_name_and_a_set_what_it_carries() {
        for (idx, group) in InputGroup::ALL.into_iter().enumerate() {
            assert_eq!(group.index(), idx);
            let json = serde_json::to_string(&group).unwrap();
            assert_eq!(json, format!("\"{}\"", group.name()));
            assert_eq!(serde_json::from_str::<InputGroup>(&json).unwrap(), group);
            assert_eq!(InputGroup::named(group.name()), Some(group));
            assert_eq!(group.input_names().len(), group.width());
        }
        assert_eq!(
            InputGroup::ALL.map(InputGroup::name),
            ["ir", "light", "near_robot", "rab", "items"]
        );
        let set = SensorSet::of(&[InputGroup::NEAR_ROBOT, InputGroup::IR]);
        assert!(set.carries(InputGroup::IR) && !set.carries(InputGroup::LIGHT));
        let carried: Vec<_> = set.groups().collect();
        assert_eq!(carried, [InputGroup::IR, InputGroup::NEAR_ROBOT]);
        assert_eq!(
            SensorSet::DEFAULT.groups().collect::<Vec<_>>(),
            [InputGroup::IR, InputGroup::LIGHT, InputGroup::NEAR_ROBOT]
        );
    }

    #[test]
    fn an_unknown_group_is_refused_naming_the_registered_ones() {
        let err = serde_json::from_str::<InputGroup>("\"sonar\"").unwrap_err();
        assert!(
            err.to_string().starts_with(
                "unknown variant `sonar`, expected one of `ir`, `light`, `near_robot`, `rab`, \
                 `items`"
            ),
            "{err}"
        );
    }

    #[test]
    fn the_groups_tile_the_frame_in_registry_order() {
        let mut next = 0;
        for group in InputGroup::ALL {
            assert_eq!(group.flat_range().start, next, "{group}");
            next = group.flat_range().end;
        }
        assert_eq!(next, N_FLAT);
        let frame = SensorFrame::default()
            .with(InputGroup::IR, &[0.1, 0.2, 0.3, 0.4])
            .with(InputGroup::NEAR_ROBOT, &[1.0]);
        assert_eq!(frame.values(InputGroup::IR), [0.1, 0.2, 0.3, 0.4]);
        assert_eq!(frame.values(InputGroup::LIGHT), [0.0, 0.0]);
        assert_eq!(frame.values(InputGroup::NEAR_ROBOT), [1.0]);
        assert_eq!(
            SensorFrame::INPUT_NAMES[InputGroup::IR.flat_range()],
            ["ir_front_left", "ir_left", "ir_right", "ir_front_right"]
        );
        // The board comes last, so the groups before it keep their places.
        assert_eq!(SensorFrame::INPUT_NAMES[6], "near_robot");
        assert_eq!(
            SensorFrame::INPUT_NAMES[InputGroup::RAB.flat_range()],
            [
                "rab_front",
                "rab_left",
                "rab_back",
                "rab_right",
                "rab_count"
            ]
        );
        // The item sensor comes after the board.
        assert_eq!(
            SensorFrame::INPUT_NAMES[InputGroup::ITEMS.flat_range()],
            [
                "items_front",
                "items_left",
                "items_back",
                "items_right",
                "items_carrying"
            ]
        );
        assert_eq!(N_FLAT, 17);
    }
}
