//! The foraging terms (scenarios with `[[objects]]`): how many items the robots delivered in
//! the nest or picked up, and whether the focal robot carries one. The quantities are shares
//! of the scenario's items at the end, in [0, 1], so a formula reads the same whatever the
//! item count; `items.picked` counts the delivered ones too, so it rewards the first half of
//! the task before any item reaches the nest. Each refuses a scenario without items, where it
//! would say nothing.

use super::{Atom, AtomKind, CycleView, EndView, Facts, Quantity, QuantityKind, Recognised};

/// Why an item term is refused in a scenario without `[[objects]]`.
const NEEDS_ITEMS: &str = "needs items ([[objects]] and a [nest])";

/// `block` when `text` is `word` and the scenario has items.
fn items_word<Block: ?Sized>(
    text: &str,
    word: &str,
    facts: &Facts<'_>,
    make: impl FnOnce() -> Box<Block>,
) -> Recognised<Block> {
    super::fixed_word(
        text,
        &[word],
        (!facts.has_items).then_some(NEEDS_ITEMS),
        make,
    )
}

/// `items.delivered`: the share of the items delivered in the nest when the sample ends.
pub const ITEMS_DELIVERED: QuantityKind = QuantityKind {
    syntax: &["items.delivered"],
    compile: |text, facts| {
        items_word::<dyn Quantity>(text, "items.delivered", facts, || {
            Box::new(ItemShare {
                delivered_only: true,
            })
        })
    },
};

/// `items.picked`: the share of the items picked up by any robot when the sample ends, the
/// delivered ones included.
pub const ITEMS_PICKED: QuantityKind = QuantityKind {
    syntax: &["items.picked"],
    compile: |text, facts| {
        items_word::<dyn Quantity>(text, "items.picked", facts, || {
            Box::new(ItemShare {
                delivered_only: false,
            })
        })
    },
};

/// A share of the items at the end: the delivered ones, or every one off the floor.
#[derive(Debug)]
struct ItemShare {
    delivered_only: bool,
}

impl Quantity for ItemShare {
    fn value(&self, _tracked: &super::Tracked, end: &EndView<'_>) -> f32 {
        let Some(items) = end.cycle.items.filter(|items| !items.is_empty()) else {
            return 0.0;
        };
        let counted = match self.delivered_only {
            true => items.delivered(),
            false => items.len() - items.floor(),
        };
        counted as f32 / items.len() as f32
    }
}

/// `items delivered`: every item has been delivered.
pub const ALL_DELIVERED: AtomKind = AtomKind {
    syntax: &["items delivered"],
    compile: |text, facts| {
        items_word::<dyn Atom>(text, "items delivered", facts, || Box::new(AllDelivered))
    },
};

#[derive(Debug)]
struct AllDelivered;

impl Atom for AllDelivered {
    fn holds(&self, view: &CycleView<'_>) -> bool {
        view.items
            .is_some_and(|items| !items.is_empty() && items.delivered() == items.len())
    }
}

/// `carrying`: the focal robot carries an item.
pub const CARRYING: AtomKind = AtomKind {
    syntax: &["carrying"],
    compile: |text, facts| items_word::<dyn Atom>(text, "carrying", facts, || Box::new(Carrying)),
};

#[derive(Debug)]
struct Carrying;

impl Atom for Carrying {
    fn holds(&self, view: &CycleView<'_>) -> bool {
        view.items.is_some_and(|items| items.carries(0))
    }
}
