//! The movable items of one sample (`[[objects]]`): small discs on the floor that robots drive
//! over, pick up on contact, carry one at a time and deliver in the nest. This is the state
//! and its one rule of change ([`Items::step`]); where the items start and what the nest is
//! are the scenario's, and the judge counts what this keeps. Nothing here draws a number, so
//! a sample with items is as deterministic as one without.

/// The radius of an item, metres: a small token an e-puck drives over (about a bottle cap).
pub const ITEM_RADIUS: f32 = 0.02;

/// Where an item is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ItemState {
    /// Lying on the floor, free to be picked up.
    Floor,
    /// Carried by robot `k` of the sample (0 the focal robot, then the team's other robots in
    /// group order).
    Carried(u16),
    /// Delivered in the nest: counted, off the floor for good.
    Delivered,
}

/// Every item of a sample: where each is and who carries what.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Items {
    /// By item: where it lies on the floor, where its carrier stood after the last step, or
    /// where it was delivered.
    positions: Vec<[f32; 2]>,
    /// By item.
    states: Vec<ItemState>,
    /// By robot, the item it carries.
    carrying: Vec<Option<u16>>,
}

impl Items {
    /// Items on the floor at `positions`, in a sample of `n_robots` robots carrying nothing.
    pub fn new(positions: Vec<[f32; 2]>, n_robots: usize) -> Items {
        Items {
            states: vec![ItemState::Floor; positions.len()],
            positions,
            carrying: vec![None; n_robots],
        }
    }

    /// One cycle's pick-ups and deliveries, robot by robot in index order (`robots`: every
    /// robot's centre after the cycle's moves, the focal robot first). A robot carrying an item
    /// takes it along and delivers it when its centre is in the nest (`in_nest`); a robot
    /// carrying nothing picks up the first item on the floor (by item index) whose centre lies
    /// within `touch` of its own. An item delivered is gone; a robot that delivers picks up
    /// nothing in the same cycle.
    pub fn step(&mut self, robots: &[[f32; 2]], touch: f32, in_nest: impl Fn([f32; 2]) -> bool) {
        let touch_sq = touch * touch;
        for (robot, &at) in robots.iter().enumerate().take(self.carrying.len()) {
            match self.carrying[robot] {
                Some(item) => {
                    let item = item as usize;
                    self.positions[item] = at;
                    if in_nest(at) {
                        self.states[item] = ItemState::Delivered;
                        self.carrying[robot] = None;
                    }
                }
                None => {
                    let touched =
                        self.states
                            .iter()
                            .zip(&self.positions)
                            .position(|(state, position)| {
                                let (dx, dy) = (position[0] - at[0], position[1] - at[1]);
                                *state == ItemState::Floor && dx * dx + dy * dy <= touch_sq
                            });
                    if let Some(item) = touched {
                        self.states[item] = ItemState::Carried(robot as u16);
                        self.positions[item] = at;
                        self.carrying[robot] = Some(item as u16);
                    }
                }
            }
        }
    }

    /// The number of items.
    pub fn len(&self) -> usize {
        self.states.len()
    }

    /// Whether there is none.
    pub fn is_empty(&self) -> bool {
        self.states.is_empty()
    }

    /// Each item's position (see [`Items`]), by item.
    pub fn positions(&self) -> &[[f32; 2]] {
        &self.positions
    }

    /// Each item's state, by item.
    pub fn states(&self) -> &[ItemState] {
        &self.states
    }

    /// The items still on the floor: their positions.
    pub fn on_floor(&self) -> impl Iterator<Item = [f32; 2]> + '_ {
        self.states
            .iter()
            .zip(&self.positions)
            .filter(|(state, _)| **state == ItemState::Floor)
            .map(|(_, &position)| position)
    }

    /// How many items are in a state `of` accepts.
    fn count(&self, of: impl Fn(&ItemState) -> bool) -> usize {
        self.states.iter().filter(|state| of(state)).count()
    }

    /// How many items have been delivered.
    pub fn delivered(&self) -> usize {
        self.count(|state| *state == ItemState::Delivered)
    }

    /// How many items are being carried.
    pub fn carried(&self) -> usize {
        self.count(|state| matches!(state, ItemState::Carried(_)))
    }

    /// How many items lie on the floor.
    pub fn floor(&self) -> usize {
        self.count(|state| *state == ItemState::Floor)
    }

    /// Whether robot `robot` carries an item.
    pub fn carries(&self, robot: usize) -> bool {
        self.carrying.get(robot).is_some_and(Option::is_some)
    }

    /// By robot, the item it carries.
    pub fn carrying(&self) -> &[Option<u16>] {
        &self.carrying
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A nest: the half-plane x >= 1.
    fn in_nest(at: [f32; 2]) -> bool {
        at[0] >= 1.0
    }

    #[test]
    fn a_robot_touching_an_item_picks_it_up_and_carries_it() {
        let mut items = Items::new(vec![[0.0, 0.0], [0.5, 0.0]], 1);
        // 0.06 m away with a 0.05 m touch: nothing.
        items.step(&[[0.06, 0.0]], 0.05, in_nest);
        assert_eq!(items.states(), &[ItemState::Floor, ItemState::Floor]);
        assert!(!items.carries(0));
        // 0.05 m away: the edge counts.
        items.step(&[[0.05, 0.0]], 0.05, in_nest);
        assert_eq!(items.states()[0], ItemState::Carried(0));
        assert!(items.carries(0));
        // Carried along, and the second item is not taken while carrying one.
        items.step(&[[0.5, 0.0]], 0.05, in_nest);
        assert_eq!(items.positions()[0], [0.5, 0.0]);
        assert_eq!(items.states()[1], ItemState::Floor);
        assert_eq!(
            (items.carried(), items.floor(), items.delivered()),
            (1, 1, 0)
        );
    }

    #[test]
    fn a_carried_item_is_delivered_in_the_nest_and_stays_delivered() {
        let mut items = Items::new(vec![[0.9, 0.0], [1.2, 0.0]], 1);
        items.step(&[[0.9, 0.0]], 0.05, in_nest);
        assert_eq!(items.states()[0], ItemState::Carried(0));
        items.step(&[[1.0, 0.0]], 0.05, in_nest);
        assert_eq!(items.states()[0], ItemState::Delivered);
        assert_eq!(items.positions()[0], [1.0, 0.0]);
        assert!(!items.carries(0));
        // Delivering takes the cycle: the item in the nest waits for the next one.
        items.step(&[[1.2, 0.0]], 0.05, in_nest);
        assert_eq!(
            items.states(),
            &[ItemState::Delivered, ItemState::Carried(0)]
        );
        assert_eq!(items.delivered(), 1);
        assert_eq!(items.on_floor().count(), 0);
    }

    proptest::proptest! {
        /// Whatever the robots do, every cycle each item is on the floor, carried or delivered
        /// (their counts add up to the items), a carried item is carried by exactly the robot
        /// that says it carries it, and a delivered item never comes back.
        #[test]
        fn items_are_conserved_every_cycle(
            starts in proptest::collection::vec((-1.0f32..1.0, -1.0f32..1.0), 1..20),
            walks in proptest::collection::vec(
                proptest::collection::vec((-1.0f32..1.5, -1.0f32..1.0), 1..6),
                1..60,
            ),
        ) {
            let n_robots = walks.iter().map(Vec::len).max().unwrap_or(1);
            let positions = starts.iter().map(|&(x, y)| [x, y]).collect();
            let mut items = Items::new(positions, n_robots);
            let mut delivered_before = 0;
            for robots in &walks {
                let robots: Vec<[f32; 2]> = robots.iter().map(|&(x, y)| [x, y]).collect();
                items.step(&robots, 0.3, in_nest);
                proptest::prop_assert_eq!(
                    items.floor() + items.carried() + items.delivered(),
                    items.len()
                );
                for (item, state) in items.states().iter().enumerate() {
                    if let ItemState::Carried(robot) = state {
                        proptest::prop_assert_eq!(
                            items.carrying()[*robot as usize],
                            Some(item as u16)
                        );
                    }
                }
                for (robot, carried) in items.carrying().iter().enumerate() {
                    if let Some(item) = carried {
                        proptest::prop_assert_eq!(
                            items.states()[*item as usize],
                            ItemState::Carried(robot as u16)
                        );
                    }
                }
                proptest::prop_assert!(items.delivered() >= delivered_before);
                delivered_before = items.delivered();
            }
        }
    }

    #[test]
    fn robots_take_items_in_robot_order_and_the_first_item_by_index() {
        // Two robots on the same two items: the first robot takes item 0, the second item 1.
        let mut items = Items::new(vec![[0.0, 0.0], [0.01, 0.0]], 2);
        items.step(&[[0.0, 0.0], [0.0, 0.0]], 0.05, in_nest);
        assert_eq!(
            items.states(),
            &[ItemState::Carried(0), ItemState::Carried(1)]
        );
        assert_eq!(items.carrying(), &[Some(0), Some(1)]);
    }
}
