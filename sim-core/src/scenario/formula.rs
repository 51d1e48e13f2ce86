//! The two small languages of a scenario file, parsed once when the scenario is compiled.
//!
//! A *formula* is a fitness: a sum of terms, each a number or a quantity of the sample,
//! optionally divided or multiplied by a number, added left to right in `f32` exactly as
//! written (`"5 + time_bonus"`, `"progress / 3"`). The quantities: `time_bonus`
//! ((max_cycles - cycles) / max_cycles), `progress` (the share of the corridor distance to the
//! goal covered, in [0, 1]), `approach room.exit` (the share of the way from the room's centre to
//! its exit that the robot's closest approach covered, in [0, 1]), `approach NAME` (the same
//! for a light, from the start), `approach teammate` (the same for the other robot, which may
//! move), and `derived` (the derived fitness: the sum over the phases
//! reached of the share of cycles the arbitrator chose the phase's child).
//!
//! A *condition* says when a phase is in force or a stage reached: atoms joined by `and`, each
//! optionally preceded by `not`: `in maze` (the robot's centre in a map cell), `in goal`,
//! `in REGION`, `teammate following`, `near LIGHT` (within the scenario's `near_m`), `always`.

/// What a term of a formula is.
#[derive(Debug, Clone, PartialEq)]
pub enum Quantity {
    /// A number.
    Constant(f32),
    /// (max_cycles - cycles) / max_cycles.
    TimeBonus,
    /// Share of the corridor distance to the goal covered.
    Progress,
    /// Share of the way from the room's centre to its exit covered by the closest approach.
    ApproachExit,
    /// Share of the way from the start to a light covered by the closest approach.
    ApproachLight(usize),
    /// Share of the start's distance to the teammate covered by the closest approach (the
    /// teammate may move: each cycle's distance counts).
    ApproachTeammate,
    /// The derived fitness.
    Derived,
}

/// One term: a quantity, divided or multiplied by a number.
#[derive(Debug, Clone, PartialEq)]
pub struct Term {
    /// The quantity.
    pub quantity: Quantity,
    /// `/ d` (true) or `* f` (false), and the number.
    pub scale: Option<(bool, f32)>,
}

/// A fitness formula.
#[derive(Debug, Clone, PartialEq)]
pub struct Formula {
    /// The terms, added left to right.
    pub terms: Vec<Term>,
}

impl Formula {
    /// Parses a formula; `light` resolves a light's name to its index.
    pub fn parse(text: &str, light: &dyn Fn(&str) -> Option<usize>) -> Result<Formula, String> {
        let mut terms = Vec::new();
        for raw in text.split('+') {
            let raw = raw.trim();
            if raw.is_empty() {
                return Err(format!("'{text}': a term is missing around '+'"));
            }
            let (base, scale) = match raw.split_once(['/', '*']) {
                Some((base, number)) => {
                    let divide = raw[base.len()..].starts_with('/');
                    let value: f32 = number
                        .trim()
                        .parse()
                        .map_err(|_| format!("'{raw}': '{}' is not a number", number.trim()))?;
                    if divide && value == 0.0 {
                        return Err(format!("'{raw}': division by zero"));
                    }
                    (base.trim(), Some((divide, value)))
                }
                None => (raw, None),
            };
            let quantity = match base {
                "time_bonus" => Quantity::TimeBonus,
                "progress" => Quantity::Progress,
                "derived" => Quantity::Derived,
                "approach room.exit" => Quantity::ApproachExit,
                "approach teammate" => Quantity::ApproachTeammate,
                other => {
                    if let Some(name) = other.strip_prefix("approach ") {
                        Quantity::ApproachLight(light(name.trim()).ok_or_else(|| {
                            format!("'{raw}': no light is named '{}'", name.trim())
                        })?)
                    } else if let Ok(value) = other.parse::<f32>() {
                        Quantity::Constant(value)
                    } else {
                        return Err(format!(
                            "'{raw}': expected a number, time_bonus, progress, derived, \
                             approach room.exit, approach teammate or approach LIGHT"
                        ));
                    }
                }
            };
            terms.push(Term { quantity, scale });
        }
        Ok(Formula { terms })
    }

    /// Whether any term is `q`.
    pub fn uses(&self, q: &dyn Fn(&Quantity) -> bool) -> bool {
        self.terms.iter().any(|term| q(&term.quantity))
    }

    /// The formula's value, given each quantity's (`value_of` is not asked for numbers).
    pub fn eval(&self, value_of: &dyn Fn(&Quantity) -> f32) -> f32 {
        let mut terms = self.terms.iter().map(|term| {
            let value = match term.quantity {
                Quantity::Constant(value) => value,
                ref quantity => value_of(quantity),
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

    /// The formula's smallest and largest value when every quantity lies in its range
    /// (`range_of` is not asked for numbers).
    pub fn range(&self, range_of: &dyn Fn(&Quantity) -> (f32, f32)) -> (f32, f32) {
        self.terms.iter().fold((0.0, 0.0), |(low, high), term| {
            let (a, b) = match term.quantity {
                Quantity::Constant(value) => (value, value),
                ref quantity => range_of(quantity),
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

/// An atom of a condition.
#[derive(Debug, Clone, PartialEq)]
pub enum Atom {
    /// Always true.
    Always,
    /// The robot's centre in a map cell.
    InMaze,
    /// The robot's centre in the goal region.
    InGoal,
    /// The robot's centre in a named region, resolved to its test when the scenario compiles
    /// so that no name is looked up in the control loop.
    InRegion(RegionTest),
    /// The teammate follows.
    TeammateFollowing,
    /// Within `near_m` of a light.
    Near(usize),
}

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

/// A condition: every atom (or its negation) holds.
#[derive(Debug, Clone, PartialEq)]
pub struct Condition {
    /// (negated, atom).
    pub atoms: Vec<(bool, Atom)>,
}

impl Condition {
    /// Parses a condition; `region` resolves a region's name to its test (or says why a
    /// condition may not name it), `light` resolves a light.
    pub fn parse(
        text: &str,
        region: &dyn Fn(&str) -> Result<RegionTest, String>,
        light: &dyn Fn(&str) -> Option<usize>,
    ) -> Result<Condition, String> {
        let mut atoms = Vec::new();
        for raw in text.split(" and ") {
            let raw = raw.trim();
            let (negated, body) = match raw.strip_prefix("not ") {
                Some(rest) => (true, rest.trim()),
                None => (false, raw),
            };
            let atom = match body {
                "always" | "otherwise" => Atom::Always,
                "in maze" => Atom::InMaze,
                "in goal" => Atom::InGoal,
                "teammate following" => Atom::TeammateFollowing,
                other => {
                    if let Some(name) = other.strip_prefix("in ") {
                        let name = name.trim();
                        Atom::InRegion(region(name).map_err(|why| format!("'{raw}': {why}"))?)
                    } else if let Some(name) = other.strip_prefix("near ") {
                        Atom::Near(light(name.trim()).ok_or_else(|| {
                            format!("'{raw}': no light is named '{}'", name.trim())
                        })?)
                    } else {
                        return Err(format!(
                            "'{raw}': expected in maze, in goal, in REGION, teammate following, \
                             near LIGHT or always, each perhaps after 'not', joined by 'and'"
                        ));
                    }
                }
            };
            atoms.push((negated, atom));
        }
        Ok(Condition { atoms })
    }

    /// Whether the condition holds, given each atom's truth.
    #[inline]
    pub fn holds(&self, truth: &dyn Fn(&Atom) -> bool) -> bool {
        self.atoms
            .iter()
            .all(|(negated, atom)| truth(atom) != *negated)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn no_region(name: &str) -> Result<RegionTest, String> {
        Err(format!("no region is named '{name}'"))
    }

    fn no_light(_: &str) -> Option<usize> {
        None
    }

    #[test]
    fn formulas_add_left_to_right_as_written() {
        let f = Formula::parse("5 + time_bonus", &no_light).unwrap();
        assert_eq!(
            f.eval(&|q| if *q == Quantity::TimeBonus { 0.25 } else { 0.0 }),
            5.25
        );
        let f = Formula::parse("progress / 3", &no_light).unwrap();
        let third = f.eval(&|_| 0.5);
        assert_eq!(third, 0.5f32 / 3.0);
        let f = Formula::parse(" 0 ", &no_light).unwrap();
        assert_eq!(f.eval(&|_| 9.0), 0.0);
        assert_eq!(
            Formula::parse("1 + time_bonus", &no_light)
                .unwrap()
                .range(&|q| if *q == Quantity::TimeBonus {
                    (0.0, 1.0)
                } else {
                    (0.0, 0.0)
                }),
            (1.0, 2.0)
        );
    }

    #[test]
    fn bad_formulas_say_what_is_wrong() {
        for (text, wanted) in [
            ("1 +", "a term is missing"),
            ("progress / zero", "'zero' is not a number"),
            ("progress / 0", "division by zero"),
            ("speed", "expected a number"),
            ("approach beacon", "no light is named 'beacon'"),
        ] {
            let error = Formula::parse(text, &no_light).unwrap_err();
            assert!(error.contains(wanted), "{text}: {error}");
        }
    }

    #[test]
    fn conditions_join_negated_atoms() {
        let c =
            Condition::parse("in maze and not teammate following", &no_region, &no_light).unwrap();
        let truth = |maze: bool, following: bool| {
            move |atom: &Atom| match atom {
                Atom::InMaze => maze,
                Atom::TeammateFollowing => following,
                _ => false,
            }
        };
        assert!(c.holds(&truth(true, false)));
        assert!(!c.holds(&truth(true, true)));
        assert!(!c.holds(&truth(false, false)));
        let error = Condition::parse("in kitchen", &no_region, &no_light).unwrap_err();
        assert!(error.contains("no region is named 'kitchen'"), "{error}");
        let error = Condition::parse("flying", &no_region, &no_light).unwrap_err();
        assert!(error.contains("expected in maze"), "{error}");
    }
}
