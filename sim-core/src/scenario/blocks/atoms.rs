//! The condition atoms: what a phase's `when`, a stage's `reached` and `end.solved` are made
//! of. Each tests the robot (or the teammate, or a light) against the sample's ground truth,
//! with every name resolved when the scenario compiles.

use super::{Atom, AtomKind, CycleView, fixed_word};
use crate::geometry::rect_holds;

/// `in maze`: the robot's centre in a map cell.
pub const IN_MAZE: AtomKind = AtomKind {
    syntax: &["in maze"],
    compile: |text, _| fixed_word::<dyn Atom>(text, &["in maze"], None, || Box::new(InMaze)),
};

#[derive(Debug)]
struct InMaze;

impl Atom for InMaze {
    #[inline]
    fn holds(&self, view: &CycleView<'_>) -> bool {
        view.ground
            .cells
            .as_ref()
            .is_some_and(|cells| view.robot_cell(cells).is_some())
    }
}

/// `in goal`: the robot's centre in the goal cell.
pub const IN_GOAL: AtomKind = AtomKind {
    syntax: &["in goal"],
    compile: |text, facts| {
        let missing = (!facts.goals_in_cells)
            .then_some("needs a corridor, or a map and a goal in every variant");
        fixed_word::<dyn Atom>(text, &["in goal"], missing, || Box::new(InGoal))
    },
};

#[derive(Debug)]
struct InGoal;

impl Atom for InGoal {
    #[inline]
    fn holds(&self, view: &CycleView<'_>) -> bool {
        view.ground
            .goal
            .as_ref()
            .is_some_and(|goal| view.robot_cell(&goal.map) == Some(goal.goal))
    }
}

/// `in REGION`: the robot's centre in a named region, resolved to its test.
pub const IN_REGION: AtomKind = AtomKind {
    syntax: &["in REGION"],
    compile: |text, facts| {
        let name = text.strip_prefix("in ")?.trim();
        Some((facts.region)(name).map(|test| Box::new(InRegion(test)) as Box<dyn Atom>))
    },
};

/// What `in REGION` tests.
#[derive(Debug, Clone, PartialEq)]
pub enum RegionTest {
    /// Inside a rectangle `[x0, y0, x1, y1]`, metres, edges included.
    Rect([f32; 4]),
    /// Inside the generated room, short of its exit.
    Room,
    /// In one of a map's cells: `true` at the cell indices of the region.
    Cells(Vec<bool>),
}

impl RegionTest {
    /// Whether `position` lies in the region of the sample `view` shows; `cell` finds the
    /// position's cell in the world's cells (the robot's is found once per view).
    #[inline]
    fn holds_at(
        &self,
        view: &CycleView<'_>,
        position: [f32; 2],
        cell: impl FnOnce(&crate::geometry::cells::CellMap) -> Option<usize>,
    ) -> bool {
        match self {
            RegionTest::Rect(rect) => rect_holds(*rect, position),
            RegionTest::Room => view
                .ground
                .room
                .as_ref()
                .is_some_and(|room| room.depth_beyond_exit(position) < 0.0),
            RegionTest::Cells(mask) => view.ground.cells.as_ref().is_some_and(|cells| {
                cell(cells).is_some_and(|cell| mask.get(cell).copied().unwrap_or(false))
            }),
        }
    }

    /// Whether `position` (any robot's) lies in the region of the sample `view` shows.
    pub fn contains(&self, view: &CycleView<'_>, position: [f32; 2]) -> bool {
        self.holds_at(view, position, |cells| cells.cell_at(position))
    }
}

#[derive(Debug)]
struct InRegion(RegionTest);

impl Atom for InRegion {
    #[inline]
    fn holds(&self, view: &CycleView<'_>) -> bool {
        self.0
            .holds_at(view, view.robot.position(), |cells| view.robot_cell(cells))
    }
}

/// `teammate following` (or `teammate met`): the robot has come within
/// `robot.near_robot_range` of the teammate at some cycle.
pub const TEAMMATE_FOLLOWING: AtomKind = AtomKind {
    syntax: &["teammate following", "teammate met"],
    compile: |text, facts| {
        let missing = (!facts.has_teammate).then_some("needs a [teammate]");
        fixed_word::<dyn Atom>(
            text,
            &["teammate following", "teammate met"],
            missing,
            || Box::new(TeammateFollowing),
        )
    },
};

#[derive(Debug)]
struct TeammateFollowing;

impl Atom for TeammateFollowing {
    #[inline]
    fn holds(&self, view: &CycleView<'_>) -> bool {
        view.teammate.is_some_and(|mate| mate.following)
    }
}

/// `teammate in room`: the teammate, met, a body radius inside the room.
pub const TEAMMATE_IN_ROOM: AtomKind = AtomKind {
    syntax: &["teammate in room"],
    compile: |text, facts| {
        let missing =
            (!(facts.has_teammate && facts.has_room)).then_some("needs a room and a [teammate]");
        fixed_word::<dyn Atom>(text, &["teammate in room"], missing, || {
            Box::new(TeammateInRoom)
        })
    },
};

#[derive(Debug)]
struct TeammateInRoom;

impl Atom for TeammateInRoom {
    #[inline]
    fn holds(&self, view: &CycleView<'_>) -> bool {
        view.teammate.is_some_and(|mate| {
            mate.following
                && view.ground.room.as_ref().is_some_and(|room| {
                    room.depth_beyond_exit(mate.pose.position()) < -view.params.robot.radius
                })
        })
    }
}

/// `beyond room.exit`: the robot a body radius beyond the exit wall's outer face.
pub const BEYOND_EXIT: AtomKind = AtomKind {
    syntax: &["beyond room.exit"],
    compile: |text, facts| {
        let missing = (!facts.has_room).then_some("needs a room");
        fixed_word::<dyn Atom>(text, &["beyond room.exit"], missing, || {
            Box::new(BeyondExit)
        })
    },
};

#[derive(Debug)]
struct BeyondExit;

impl Atom for BeyondExit {
    #[inline]
    fn holds(&self, view: &CycleView<'_>) -> bool {
        view.ground.room.as_ref().is_some_and(|room| {
            room.depth_beyond_exit(view.robot.position())
                > view.params.room.wall_thickness + view.params.robot.radius
        })
    }
}

/// `near LIGHT`: the robot's centre within `end.near_m` of a light.
pub const NEAR: AtomKind = AtomKind {
    syntax: &["near LIGHT"],
    compile: |text, facts| {
        let name = text.strip_prefix("near ")?.trim();
        Some(match facts.light(name) {
            None => Err(format!("no light is named '{name}'")),
            // Also refuses NaN.
            Some(_) if facts.near_m.is_nan() || facts.near_m <= 0.0 => {
                Err("needs a positive `end.near_m`".into())
            }
            Some(light) => Ok(Box::new(Near {
                position: facts.lights[light].position,
            }) as Box<dyn Atom>),
        })
    },
};

#[derive(Debug)]
struct Near {
    position: [f32; 2],
}

impl Atom for Near {
    #[inline]
    fn holds(&self, view: &CycleView<'_>) -> bool {
        view.robot.distance_to(self.position) < view.scenario.near_m
    }
}

/// `LIGHT lit`: the light is lit in the cycle judged (as the light sensor sees it).
pub const LIGHT_LIT: AtomKind = AtomKind {
    syntax: &["LIGHT lit"],
    compile: |text, facts| {
        let name = text.strip_suffix(" lit")?.trim();
        Some(match facts.light(name) {
            None => Err(format!("no light is named '{name}'")),
            Some(light) => Ok(Box::new(LightLit { bit: 1 << light }) as Box<dyn Atom>),
        })
    },
};

#[derive(Debug)]
struct LightLit {
    /// The light's bit in a lit mask.
    bit: u32,
}

impl Atom for LightLit {
    #[inline]
    fn holds(&self, view: &CycleView<'_>) -> bool {
        view.lit_mask & self.bit != 0
    }
}

/// `always` (or `otherwise`).
pub const ALWAYS: AtomKind = AtomKind {
    syntax: &["always"],
    compile: |text, _| {
        fixed_word::<dyn Atom>(text, &["always", "otherwise"], None, || Box::new(Always))
    },
};

#[derive(Debug)]
struct Always;

impl Atom for Always {
    #[inline]
    fn holds(&self, _view: &CycleView<'_>) -> bool {
        true
    }
}
