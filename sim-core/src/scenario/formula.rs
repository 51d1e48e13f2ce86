//! The two small languages of a scenario file, parsed once when the scenario is compiled.
//!
//! A *formula* is a fitness: a sum of terms, each a number or a quantity of the sample,
//! optionally divided or multiplied by a number, added left to right in `f32` exactly as
//! written (`"5 + time_bonus"`, `"progress / 3"`). The quantities: `time_bonus`
//! ((max_cycles - cycles) / max_cycles), `progress` (the share of the corridor distance to the
//! goal covered, in [0, 1]), `approach room.exit` (the share of the way from the room's centre to
//! its exit that the robot's closest approach covered, in [0, 1]), `approach NAME` (the same
//! for a light, from the start), `approach teammate` (the same for the other robot, which may
//! move), `derived` (the derived fitness: the sum over the phases
//! reached of the share of cycles the arbitrator chose the phase's child), `final.x` and
//! `final.y`, `distance` (metres travelled) and `energy` (the wheels' mean absolute speed over
//! the cycles, a share of full speed for the whole cycle limit); with other robots
//! (`[[robots]]`), `team.spread`, `team.nearest` (metres, averaged over the cycles) and
//! `team.in REGION` (the share of the team in a region at the end); with items
//! (`[[objects]]`), `items.delivered` and `items.picked` (shares of the items at the end);
//! with boxes (`[[boxes]]`), `boxes.in REGION` (the share of the boxes in a region at the end).
//!
//! A *condition* says when a phase is in force, a stage reached or a sample solved: atoms
//! joined by `and` and `or` (`and` binding tighter), each optionally preceded by `not`: `in maze` (the robot's centre in a map
//! cell), `in goal`, `in REGION`, `teammate following` (or `teammate met`), `teammate in room`,
//! `beyond room.exit`, `near LIGHT` (within the scenario's `near_m`), `team gathered` (every
//! robot within `near_m` of the team's centre), `team dispersed` (every robot's nearest
//! neighbour at least `near_m` away), `team in REGION`, `items delivered` (every item
//! delivered), `carrying` (the focal robot carries an item), `boxes in REGION` (every box's
//! centre in the region), `always`.
//!
//! The quantities and atoms themselves are building blocks ([`super::blocks`]): this module
//! only splits the text and asks the registered blocks what each piece names.

use super::blocks::{self, Atom, CycleView, Facts, Quantity};

/// What a term adds: a number, or a quantity (an index into the scenario's compiled
/// quantities).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TermBase {
    /// A number.
    Number(f32),
    /// The quantity at this index.
    Quantity(usize),
}

/// One term: a number or a quantity, divided or multiplied by a number.
#[derive(Debug, Clone, PartialEq)]
pub struct Term {
    /// What it adds.
    pub base: TermBase,
    /// `/ d` (true) or `* f` (false), and the number.
    pub scale: Option<(bool, f32)>,
}

/// A fitness formula.
#[derive(Debug, Clone, PartialEq)]
pub struct Formula {
    /// The terms, added left to right.
    pub terms: Vec<Term>,
}

/// The quantities a scenario's formulas and behaviour descriptor use, each compiled once and
/// kept under the text that names it (two formulas naming `approach room.exit` share one).
pub type Quantities = Vec<(String, Box<dyn Quantity>)>;

/// The index in `quantities` of the quantity `text` names, compiled into them first if it is
/// not there yet; `None` when the text names no quantity, an error when it names one this
/// scenario cannot have.
pub fn quantity_index(
    text: &str,
    facts: &Facts<'_>,
    quantities: &mut Quantities,
) -> Option<Result<usize, String>> {
    if let Some(idx) = quantities.iter().position(|(name, _)| name == text) {
        return Some(Ok(idx));
    }
    let compiled = blocks::QUANTITIES
        .iter()
        .find_map(|kind| (kind.compile)(text, facts))?;
    Some(compiled.map(|quantity| {
        quantities.push((text.to_string(), quantity));
        quantities.len() - 1
    }))
}

impl Formula {
    /// Parses a formula, compiling each quantity it names into `quantities` (unless one of
    /// that name is there already).
    pub fn parse(
        text: &str,
        facts: &Facts<'_>,
        quantities: &mut Quantities,
    ) -> Result<Formula, String> {
        let mut terms = Vec::new();
        for raw in text.split('+') {
            let raw = raw.trim();
            if raw.is_empty() {
                return Err(format!("'{text}': a term is missing around '+'"));
            }
            let (base, scale) = match raw.split_once(['/', '*']) {
                Some((base, number)) => {
                    let divide = raw[base.len()..].starts_with('/');
                    let value = formula_number(number.trim())
                        .map_err(|why| format!("'{raw}': '{}' {why}", number.trim()))?;
                    if divide && value == 0.0 {
                        return Err(format!("'{raw}': division by zero"));
                    }
                    (base.trim(), Some((divide, value)))
                }
                None => (raw, None),
            };
            let base = if let Some(idx) = quantity_index(base, facts, quantities) {
                TermBase::Quantity(idx.map_err(|why| format!("'{raw}': {why}"))?)
            } else if base.parse::<f32>().is_ok() {
                TermBase::Number(
                    formula_number(base).map_err(|why| format!("'{raw}': '{base}' {why}"))?,
                )
            } else {
                return Err(format!(
                    "'{raw}': expected a number, {}",
                    blocks::listed(
                        blocks::QUANTITIES
                            .iter()
                            .flat_map(|k| k.syntax.iter().copied())
                    )
                ));
            };
            terms.push(Term { base, scale });
        }
        Ok(Formula { terms })
    }

    /// The formula's value, given each quantity's by index.
    pub fn eval(&self, value_of: &dyn Fn(usize) -> f32) -> f32 {
        let mut terms = self.terms.iter().map(|term| {
            let value = match term.base {
                TermBase::Number(value) => value,
                TermBase::Quantity(idx) => value_of(idx),
            };
            match term.scale {
                Some((true, d)) => value / d,
                Some((false, f)) => value * f,
                None => value,
            }
        });
        let first = terms.next().unwrap_or(0.0);
        terms.fold(first, |sum, value| sum + value)
    }

    /// The formula's smallest and largest value when every quantity lies in its range.
    pub fn range(&self, range_of: &dyn Fn(usize) -> (f32, f32)) -> (f32, f32) {
        self.terms.iter().fold((0.0, 0.0), |(low, high), term| {
            let (a, b) = match term.base {
                TermBase::Number(value) => (value, value),
                TermBase::Quantity(idx) => range_of(idx),
            };
            let (a, b) = match term.scale {
                Some((true, d)) => (a / d, b / d),
                Some((false, f)) => (a * f, b * f),
                None => (a, b),
            };
            (low + a.min(b), high + a.max(b))
        })
    }
}

/// The largest number a formula may write, in magnitude: fitness must stay a finite `f32`
/// whatever the formula adds up, and no task needs more.
pub const MAX_FORMULA_NUMBER: f32 = 1e6;

/// A number of a formula: finite and at most [`MAX_FORMULA_NUMBER`] in magnitude (`nan`,
/// `inf` and `1e40` parse as `f32`s, and would make every sample's fitness one).
fn formula_number(text: &str) -> Result<f32, String> {
    match text.parse::<f32>() {
        Ok(value) if value.is_finite() && value.abs() <= MAX_FORMULA_NUMBER => Ok(value),
        Ok(_) => Err(format!(
            "is not a finite number of at most {MAX_FORMULA_NUMBER:e} in magnitude"
        )),
        Err(_) => Err("is not a number".into()),
    }
}

/// A condition: clauses joined by `or`, each atoms (each perhaps negated) joined by `and`;
/// `and` binds tighter, so `in a and not teammate met or in b` is `(in a and not teammate met)
/// or in b`. It holds when every atom of some clause does.
#[derive(Debug)]
pub struct Condition {
    /// The clauses, each (negated, atom) pairs.
    pub clauses: Vec<Vec<(bool, Box<dyn Atom>)>>,
}

impl Condition {
    /// Parses a condition, compiling each atom by the first registered kind that knows it.
    pub fn parse(text: &str, facts: &Facts<'_>) -> Result<Condition, String> {
        // Words joined by single spaces, so that a joining word at either end or two in a row
        // is seen, and said, as an atom missing.
        let words: Vec<&str> = text.split_whitespace().collect();
        let joins = |word: &str| word == "and" || word == "or";
        if let Some(at) = (0..words.len()).find(|&idx| {
            joins(words[idx]) && (idx == 0 || idx + 1 == words.len() || joins(words[idx + 1]))
        }) {
            return Err(format!(
                "'{text}': an atom is missing beside '{}'",
                words[at]
            ));
        }
        let clauses = words
            .join(" ")
            .split(" or ")
            .map(|clause| {
                clause
                    .split(" and ")
                    .map(|raw| Self::atom(raw.trim(), facts))
                    .collect::<Result<Vec<_>, String>>()
            })
            .collect::<Result<Vec<_>, String>>()?;
        Ok(Condition { clauses })
    }

    /// One atom, perhaps after `not`.
    fn atom(raw: &str, facts: &Facts<'_>) -> Result<(bool, Box<dyn Atom>), String> {
        let (negated, body) = match raw.strip_prefix("not ") {
            Some(rest) => (true, rest.trim()),
            None => (false, raw),
        };
        let atom = blocks::ATOMS
            .iter()
            .find_map(|kind| (kind.compile)(body, facts))
            .ok_or_else(|| {
                format!(
                    "'{raw}': expected {}, each perhaps after 'not', joined by 'and' or 'or'",
                    blocks::listed(blocks::ATOMS.iter().flat_map(|k| k.syntax.iter().copied()))
                )
            })?
            .map_err(|why| format!("'{raw}': {why}"))?;
        Ok((negated, atom))
    }

    /// Whether the condition holds in this cycle.
    #[inline]
    pub fn holds(&self, view: &CycleView<'_>) -> bool {
        self.clauses.iter().any(|atoms| {
            atoms
                .iter()
                .all(|(negated, atom)| atom.holds(view) != *negated)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenario::blocks::atoms::RegionTest;

    fn no_region(name: &str) -> Result<RegionTest, String> {
        Err(format!("no region is named '{name}'"))
    }

    /// A scenario with everything but lights and regions.
    fn facts() -> Facts<'static> {
        Facts {
            lights: &[],
            region: &no_region,
            has_room: true,
            goals_in_cells: true,
            has_teammate: true,
            has_team: true,
            has_items: true,
            has_boxes: true,
            has_phases: true,
            near_m: 0.1,
        }
    }

    fn named<'q>(quantities: &'q Quantities) -> impl Fn(usize) -> &'q str {
        |idx| quantities[idx].0.as_str()
    }

    #[test]
    fn formulas_add_left_to_right_as_written() {
        let mut quantities = Quantities::new();
        let f = Formula::parse("5 + time_bonus", &facts(), &mut quantities).unwrap();
        let name = named(&quantities);
        assert_eq!(
            f.eval(&|q| if name(q) == "time_bonus" { 0.25 } else { 0.0 }),
            5.25
        );
        let mut quantities = Quantities::new();
        let f = Formula::parse("progress / 3", &facts(), &mut quantities).unwrap();
        let third = f.eval(&|_| 0.5);
        assert_eq!(third, 0.5f32 / 3.0);
        let f = Formula::parse(" 0 ", &facts(), &mut quantities).unwrap();
        assert_eq!(f.eval(&|_| 9.0), 0.0);
        let mut quantities = Quantities::new();
        let f = Formula::parse("1 + time_bonus", &facts(), &mut quantities).unwrap();
        assert_eq!(f.range(&|_| (0.0, 1.0)), (1.0, 2.0));
    }

    #[test]
    fn distance_is_metres_up_to_its_bound_and_energy_a_share() {
        let mut quantities = Quantities::new();
        let f = Formula::parse("distance / 1000 + energy", &facts(), &mut quantities).unwrap();
        let range_of = |idx: usize| quantities[idx].1.range(0);
        assert_eq!(f.range(&range_of), (0.0, 1001.0));
        // The docs' saving on energy: 1 for none spent, 0 for all.
        let saving = Formula::parse("1 + energy * -1", &facts(), &mut quantities).unwrap();
        let range_of = |idx: usize| quantities[idx].1.range(0);
        assert_eq!(saving.range(&range_of), (0.0, 1.0));
        assert_eq!(saving.eval(&|_| 0.25), 0.75);
    }

    #[test]
    fn a_quantity_named_twice_is_compiled_once() {
        let mut quantities = Quantities::new();
        Formula::parse("progress + 2 * 1", &facts(), &mut quantities).unwrap();
        Formula::parse("progress / 3 + time_bonus", &facts(), &mut quantities).unwrap();
        let names: Vec<&str> = quantities.iter().map(|(name, _)| name.as_str()).collect();
        assert_eq!(names, ["progress", "time_bonus"]);
    }

    #[test]
    fn bad_formulas_say_what_is_wrong() {
        let bare = Facts {
            has_room: false,
            goals_in_cells: false,
            has_teammate: false,
            has_team: false,
            has_items: false,
            has_boxes: false,
            has_phases: false,
            ..facts()
        };
        for (text, wanted) in [
            ("1 +", "a term is missing"),
            ("progress / zero", "'zero' is not a number"),
            ("progress / 0", "division by zero"),
            ("nan", "'nan' is not a finite number"),
            ("1 + inf", "'inf' is not a finite number"),
            ("1e40", "'1e40' is not a finite number"),
            ("progress * -1e7", "'-1e7' is not a finite number"),
            ("progress / NaN", "'NaN' is not a finite number"),
            (
                "speed",
                "expected a number, time_bonus, progress, derived, approach room.exit, \
                 approach teammate, approach LIGHT, final.x, final.y, distance, energy, \
                 team.spread, team.nearest, team.in REGION, items.delivered, items.picked or \
                 boxes.in REGION",
            ),
            (
                "team.spread",
                "'team.spread': needs other robots ([[robots]])",
            ),
            (
                "team.in nest",
                "'team.in nest': needs other robots ([[robots]])",
            ),
            ("approach beacon", "no light is named 'beacon'"),
            ("progress", "'progress': needs a goal in cells"),
            ("approach room.exit", "'approach room.exit': needs a room"),
            (
                "approach teammate",
                "'approach teammate': needs a [teammate]",
            ),
            ("1 + derived", "'derived': needs [[phase]]s"),
            (
                "items.delivered",
                "'items.delivered': needs items ([[objects]] and a [nest])",
            ),
            ("boxes.in nest", "'boxes.in nest': needs boxes ([[boxes]])"),
        ] {
            let error = Formula::parse(text, &bare, &mut Quantities::new()).unwrap_err();
            assert!(error.contains(wanted), "{text}: {error}");
        }
    }

    #[test]
    fn conditions_compile_their_atoms_and_refuse_what_the_scenario_lacks() {
        let c = Condition::parse("in maze and not teammate following", &facts()).unwrap();
        assert_eq!(c.clauses.len(), 1);
        assert_eq!(c.clauses[0].len(), 2);
        assert!(!c.clauses[0][0].0 && c.clauses[0][1].0);
        let c = Condition::parse("in maze and not teammate met or in goal", &facts()).unwrap();
        let shape: Vec<Vec<bool>> = c
            .clauses
            .iter()
            .map(|clause| clause.iter().map(|(negated, _)| *negated).collect())
            .collect();
        assert_eq!(shape, [vec![false, true], vec![false]]);
        for (text, wanted) in [
            ("in maze or", "an atom is missing beside 'or'"),
            ("or in maze", "an atom is missing beside 'or'"),
            ("in maze and or in goal", "an atom is missing beside 'and'"),
            ("in maze or in kitchen", "no region is named 'kitchen'"),
            ("in maze or flying", "joined by 'and' or 'or'"),
        ] {
            let error = Condition::parse(text, &facts()).unwrap_err();
            assert!(error.contains(wanted), "{text}: {error}");
        }
        let error = Condition::parse("in kitchen", &facts()).unwrap_err();
        assert!(error.contains("no region is named 'kitchen'"), "{error}");
        let error = Condition::parse("flying", &facts()).unwrap_err();
        assert!(
            error.contains("expected in maze, in goal, in REGION, teammate following"),
            "{error}"
        );
        let alone = Facts {
            has_teammate: false,
            has_room: false,
            goals_in_cells: false,
            ..facts()
        };
        for (text, wanted) in [
            ("teammate met", "needs a [teammate]"),
            ("not teammate following", "needs a [teammate]"),
            ("beyond room.exit", "needs a room"),
            ("teammate in room", "needs a room and a [teammate]"),
            (
                "in goal",
                "needs a corridor, or a map and a goal in every variant",
            ),
            ("near lamp", "no light is named 'lamp'"),
        ] {
            let error = Condition::parse(text, &alone).unwrap_err();
            assert!(error.contains(wanted), "{text}: {error}");
        }
    }

    mod ranges {
        use super::super::{Formula, Quantities};
        use crate::scenario::blocks::Facts;
        use proptest::prelude::*;

        /// A term as a file writes it: a number or a quantity, perhaps scaled.
        fn term() -> impl Strategy<Value = String> {
            let base = prop_oneof![
                (0u32..20).prop_map(|n| n.to_string()),
                Just("time_bonus".to_string()),
                Just("progress".to_string()),
                Just("derived".to_string()),
                Just("approach room.exit".to_string()),
            ];
            let scale = prop_oneof![
                Just(String::new()),
                (1u32..9).prop_map(|n| format!(" / {n}")),
                (1u32..9).prop_map(|n| format!(" * {n}")),
            ];
            (base, scale).prop_map(|(base, scale)| format!("{base}{scale}"))
        }

        proptest! {
            /// Whatever the formula and wherever each quantity lies in its range, the value lies
            /// in the range the checks of remote results use.
            #[test]
            fn a_formula_stays_inside_its_range(
                terms in prop::collection::vec(term(), 1..5),
                values in prop::array::uniform4(0.0f32..=1.0),
                derived in 0.0f32..=3.0,
            ) {
                let text = terms.join(" + ");
                let facts = Facts {
                    lights: &[],
                    region: &|name| Err(format!("no region '{name}'")),
                    has_room: true,
                    goals_in_cells: true,
                    has_teammate: true,
                    has_team: true,
                    has_items: true,
                    has_boxes: true,
                    has_phases: true,
                    near_m: 0.1,
                };
                let mut quantities = Quantities::new();
                let formula = Formula::parse(&text, &facts, &mut quantities).unwrap();
                // Each quantity's own range, for a scenario of three phases.
                let range_of = |idx: usize| quantities[idx].1.range(3);
                let value_of = |idx: usize| match quantities[idx].0.as_str() {
                    "time_bonus" => values[0],
                    "progress" => values[1],
                    "approach room.exit" => values[2],
                    "derived" => derived,
                    _ => values[3],
                };
                let (low, high) = formula.range(&range_of);
                let value = formula.eval(&value_of);
                // f32 sums in another order than the range's: allow a rounding step.
                let slack = 1e-4 * (1.0 + high.abs());
                prop_assert!(value >= low - slack && value <= high + slack, "{text}: {value} outside [{low}, {high}]");
            }
        }
    }
}
