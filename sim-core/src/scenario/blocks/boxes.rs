//! The box-pushing terms (scenarios with `[[boxes]]`): where the boxes are. `boxes.in REGION`
//! is the share of the boxes whose centre lies in a region at the end, in [0, 1], so a formula
//! reads the same whatever the box count; the atom `boxes in REGION` holds when every box's
//! centre is in it. Each refuses a scenario without boxes, where it would say nothing.

use super::atoms::RegionTest;
use super::{Atom, AtomKind, CycleView, EndView, Facts, Quantity, QuantityKind, Tracked};

/// Why a box term is refused in a scenario without `[[boxes]]`.
const NEEDS_BOXES: &str = "needs boxes ([[boxes]])";

/// The region `text` names after `prefix`, when the scenario has boxes.
fn boxes_region(text: &str, prefix: &str, facts: &Facts<'_>) -> Option<Result<RegionTest, String>> {
    let name = text.strip_prefix(prefix)?.trim();
    if !facts.has_boxes {
        return Some(Err(NEEDS_BOXES.into()));
    }
    Some((facts.region)(name))
}

/// The share of the boxes of `view` whose centre `test` holds (0 without boxes).
fn share_in(test: &RegionTest, view: &CycleView<'_>) -> f32 {
    if view.boxes.is_empty() {
        return 0.0;
    }
    let inside = view
        .boxes
        .iter()
        .filter(|disc| test.contains(view, disc.center))
        .count();
    inside as f32 / view.boxes.len() as f32
}

/// `boxes.in REGION`: the share of the boxes whose centre is in the region at the end.
pub const BOXES_IN: QuantityKind = QuantityKind {
    syntax: &["boxes.in REGION"],
    compile: |text, facts| {
        boxes_region(text, "boxes.in ", facts)
            .map(|test| test.map(|test| Box::new(BoxesIn(test)) as Box<dyn Quantity>))
    },
};

#[derive(Debug)]
struct BoxesIn(RegionTest);

impl Quantity for BoxesIn {
    fn value(&self, _tracked: &Tracked, end: &EndView<'_>) -> f32 {
        share_in(&self.0, &end.cycle)
    }
}

/// `boxes in REGION`: every box's centre is in the region.
pub const BOXES_IN_REGION: AtomKind = AtomKind {
    syntax: &["boxes in REGION"],
    compile: |text, facts| {
        boxes_region(text, "boxes in ", facts)
            .map(|test| test.map(|test| Box::new(BoxesInRegion(test)) as Box<dyn Atom>))
    },
};

#[derive(Debug)]
struct BoxesInRegion(RegionTest);

impl Atom for BoxesInRegion {
    fn holds(&self, view: &CycleView<'_>) -> bool {
        !view.boxes.is_empty() && share_in(&self.0, view) == 1.0
    }
}
