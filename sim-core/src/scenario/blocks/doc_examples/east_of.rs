//! `east of X`: the robot's centre east of x = X metres.
use super::{Atom, AtomKind, CycleView};

pub const EAST_OF: AtomKind = AtomKind {
    syntax: &["east of X"],
    compile: |text, _facts| {
        let x = text.strip_prefix("east of ")?.trim();
        Some(match x.parse::<f32>() {
            Ok(x) if x.is_finite() => Ok(Box::new(EastOf(x)) as Box<dyn Atom>),
            _ => Err(format!("'{x}' is not a number of metres")),
        })
    },
};

#[derive(Debug)]
struct EastOf(f32);

impl Atom for EastOf {
    fn holds(&self, view: &CycleView<'_>) -> bool {
        view.robot.x > self.0
    }
}
