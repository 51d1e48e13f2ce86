//! The sensor frame: what the robot perceives in one control cycle, in the normalised form the
//! networks read. It is the single interface between the world (which fills it) and the
//! controllers (which read the groups of inputs each network declares).

use serde::{Deserialize, Serialize};

/// Number of infrared proximity inputs: front-left (+17 deg), left (+90 deg), right (-90 deg),
/// front-right (-17 deg), in that order.
pub const N_IR: usize = 4;
/// Number of light-flash inputs: left, right.
pub const N_LIGHT: usize = 2;

/// Angles of the four IR sensors from the heading, radians, in input order.
pub const IR_ANGLES: [f32; N_IR] = [
    17.0 * std::f32::consts::PI / 180.0,
    std::f32::consts::FRAC_PI_2,
    -std::f32::consts::FRAC_PI_2,
    -17.0 * std::f32::consts::PI / 180.0,
];

/// Number of inputs in a frame laid out flat ([`SensorFrame::flat`]): IR, light, near-robot.
pub const N_FLAT: usize = N_IR + N_LIGHT + 1;

/// All inputs of one control cycle, each in [0, 1].
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct SensorFrame {
    /// IR proximity: 1 at contact, 0 at 12 cm or beyond.
    pub ir: [f32; N_IR],
    /// Light flash held inputs: left, right.
    pub light: [f32; N_LIGHT],
    /// 1 when another robot is within the near-robot range.
    pub near_robot: f32,
}

impl SensorFrame {
    /// Every input in one array: IR, then light, then near-robot ([`InputGroup::flat_range`]
    /// says where a group sits).
    #[inline]
    pub fn flat(&self) -> [f32; N_FLAT] {
        let mut flat = [0.0; N_FLAT];
        flat[..N_IR].copy_from_slice(&self.ir);
        flat[N_IR..N_IR + N_LIGHT].copy_from_slice(&self.light);
        flat[N_IR + N_LIGHT] = self.near_robot;
        flat
    }
}

/// A named group of inputs a network can declare. A network's inputs are the concatenation of
/// its groups in the order it lists them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum InputGroup {
    /// The four IR proximity inputs.
    Ir,
    /// The two light-flash inputs.
    Light,
    /// The near-robot boolean.
    NearRobot,
}

impl InputGroup {
    /// Every group, in frame order.
    pub const ALL: [InputGroup; 3] = [InputGroup::Ir, InputGroup::Light, InputGroup::NearRobot];

    /// The group's place in [`InputGroup::ALL`].
    pub fn index(self) -> usize {
        match self {
            InputGroup::Ir => 0,
            InputGroup::Light => 1,
            InputGroup::NearRobot => 2,
        }
    }

    /// The group's name in controller and scenario files.
    pub fn name(self) -> &'static str {
        match self {
            InputGroup::Ir => "ir",
            InputGroup::Light => "light",
            InputGroup::NearRobot => "near_robot",
        }
    }

    /// How many network inputs this group contributes.
    pub fn width(self) -> usize {
        match self {
            InputGroup::Ir => N_IR,
            InputGroup::Light => N_LIGHT,
            InputGroup::NearRobot => 1,
        }
    }

    /// Where the group's values sit in [`SensorFrame::flat`].
    pub fn flat_range(self) -> std::ops::Range<usize> {
        match self {
            InputGroup::Ir => 0..N_IR,
            InputGroup::Light => N_IR..N_IR + N_LIGHT,
            InputGroup::NearRobot => N_IR + N_LIGHT..N_FLAT,
        }
    }

    /// The group's current values in the frame.
    pub fn values(self, frame: &SensorFrame) -> &[f32] {
        match self {
            InputGroup::Ir => &frame.ir,
            InputGroup::Light => &frame.light,
            InputGroup::NearRobot => std::slice::from_ref(&frame.near_robot),
        }
    }
}

/// The input groups a robot's sensors give; a group the robot lacks reads 0 and its sensor
/// draws no noise.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SensorSet([bool; InputGroup::ALL.len()]);

impl SensorSet {
    /// The e-puck's: every group.
    pub const ALL: SensorSet = SensorSet([true; InputGroup::ALL.len()]);

    /// The set of `groups`.
    pub fn of(groups: &[InputGroup]) -> SensorSet {
        let mut set = [false; InputGroup::ALL.len()];
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
        }
        let set = SensorSet::of(&[InputGroup::NearRobot, InputGroup::Ir]);
        assert!(set.carries(InputGroup::Ir) && !set.carries(InputGroup::Light));
        let carried: Vec<_> = set.groups().collect();
        assert_eq!(carried, [InputGroup::Ir, InputGroup::NearRobot]);
        assert_eq!(SensorSet::ALL.groups().count(), 3);
    }

    #[test]
    fn a_flat_frame_holds_each_group_where_its_range_says() {
        let frame = SensorFrame {
            ir: [0.1, 0.2, 0.3, 0.4],
            light: [0.5, 0.6],
            near_robot: 1.0,
        };
        let flat = frame.flat();
        for group in [InputGroup::Ir, InputGroup::Light, InputGroup::NearRobot] {
            assert_eq!(&flat[group.flat_range()], group.values(&frame), "{group:?}");
            assert_eq!(group.flat_range().len(), group.width());
        }
    }
}
