//! Compiling a scenario file into a [`Scenario`], one section of the file at a time, in the
//! order a file's mistakes are reported: the header, the world, the regions, the robot's
//! sensors, the lights, the variants, the start, the teammate, then (with what the blocks may
//! rely on) the endings, the fitness, the phases and stages, and last whether every goal can
//! be reached.

use super::blocks::atoms::RegionTest;
use super::blocks::{self, Facts, World};
use super::file::{
    ControllerFileRef, GroupControllerDecl, MapFile, MapRef, ScenarioFile, TriggerDecl,
};
use super::formula::{Condition, Formula, Quantities, quantity_index};
use super::{
    BOX_RADIUS, BoxGroup, CompiledMap, ControllerSource, DEFAULT_DESCRIPTOR, Facing, GroupDriver,
    LightDef, MAX_BOXES, MAX_CONTROLLER_FILE_BYTES, MAX_DESCRIPTOR, MAX_ITEMS, MAX_LIGHTS,
    MAX_MOVER_POINTS, MAX_MOVER_SPEED, MAX_MOVERS, MAX_PHASES, MAX_REGIONS, MAX_ROBOTS,
    MAX_SCHEDULE_CYCLES, MAX_SOLID_COORDINATE, MAX_SOLIDS, MAX_VARIANTS, MOVER_RADIUS, Nest,
    ObjectGroup, Phase, Place, PlaceAt, RobotGroup, SCHEMA, SHIPPED, SHIPPED_MAPS, Scenario,
    ScenarioError, Stage, TeammatePlan, Variant, bounded, check_sensors, compile_map, formula,
    is_proper_rect, line_of_path, shipped_map,
};
use crate::geometry::bodies::{MoverPath, PathMode};
use crate::geometry::scene::{Rect, RectKind};
use crate::network::controller::{Controller, ControllerFile};
use crate::sensors::frame::{InputGroup, SensorSet};
use crate::world::lights::Trigger;
use std::collections::BTreeMap;
use std::sync::Arc;

/// What a section calls to refuse the file: the key path and what is wrong.
type Refuse<'a> = &'a dyn Fn(&str, String) -> ScenarioError;

/// Refuses a position that is not a finite point within [`MAX_SOLID_COORDINATE`] of the
/// origin, where every world lies.
fn check_point([x, y]: [f32; 2]) -> Result<(), String> {
    if [x, y]
        .iter()
        .all(|v| v.is_finite() && v.abs() <= MAX_SOLID_COORDINATE)
    {
        Ok(())
    } else {
        Err(format!(
            "({x}, {y}) m is not a point within {MAX_SOLID_COORDINATE} m of the origin"
        ))
    }
}

/// Refuses a distance, metres, that is not a finite number within a world's size
/// ([`MAX_SOLID_COORDINATE`]), or, when `non_negative`, that is below 0.
fn check_distance(metres: f32, non_negative: bool) -> Result<(), String> {
    let low = if non_negative {
        0.0
    } else {
        -MAX_SOLID_COORDINATE
    };
    if metres.is_finite() && (low..=MAX_SOLID_COORDINATE).contains(&metres) {
        Ok(())
    } else {
        Err(format!(
            "{metres} is not a distance in [{low}, {MAX_SOLID_COORDINATE}] metres"
        ))
    }
}

/// Refuses a formula that can be other than a finite number: its value over every quantity's
/// range (the evaluator's own arithmetic, so a huge product or a tiny divisor shows here).
fn check_formula_range(
    formula: &Formula,
    quantities: &Quantities,
    n_phases: usize,
) -> Result<(), String> {
    let (low, high) = formula.range(&|idx| quantities[idx].1.range(n_phases));
    if low.is_finite() && high.is_finite() {
        Ok(())
    } else {
        Err(format!(
            "can be [{low}, {high}], not a finite number; keep its numbers and their products \
             and quotients within ±{:e}",
            formula::MAX_FORMULA_NUMBER
        ))
    }
}

/// Turns a parsed file into a scenario, checking that its parts fit together.
pub(super) fn compile(
    file: ScenarioFile,
    text: &str,
    origin: &str,
    controllers: ControllerSource<'_>,
) -> Result<Scenario, ScenarioError> {
    let error = |path: &str, message: String| ScenarioError {
        origin: origin.to_string(),
        path: path.to_string(),
        line: line_of_path(text, path),
        message,
    };
    header(&file, text, &error)?;
    let (map, world, solids) = world(&file, &error)?;
    let regions = Regions::new(&file, map.as_deref(), world.as_ref(), &error)?;
    let sensors = sensors(&file, &error)?;
    let lights = lights(&file, map.as_deref(), &regions.rects, &error)?;
    let variants = variants(&file, &lights, &regions, &error)?;
    let place = place(&file, world.as_ref(), &variants, &regions, &error)?;
    let teammate = teammate(&file, &variants, &regions, &error)?;
    let (robot_groups, controller_files) =
        robot_groups(&file, &regions, sensors, controllers, &error)?;
    let (object_groups, nest) = objects(&file, &regions, &error)?;
    let movers = movers(&file, &error)?;
    let box_groups = box_groups(&file, &regions, &error)?;
    if teammate.is_some() && (!movers.is_empty() || !box_groups.is_empty()) {
        let key = if movers.is_empty() { "boxes" } else { "movers" };
        return Err(error(
            key,
            "movers and boxes do not go with a [teammate], whose moves check walls alone; use \
             [[robots]] for other robots"
                .into(),
        ));
    }

    // What the blocks may rely on.
    let judged_region = |name: &str| regions.judged(name);
    let end = &file.end;
    check_distance(end.near_m, true).map_err(|message| error("end.near_m", message))?;
    let goals_in_cells =
        world.has_corridor() || (map.is_some() && variants.iter().all(|v| v.goal.is_some()));
    let facts = Facts {
        lights: &lights,
        region: &judged_region,
        has_room: world.has_room(),
        goals_in_cells,
        has_teammate: teammate.is_some(),
        has_team: !robot_groups.is_empty(),
        has_items: !object_groups.is_empty(),
        has_boxes: !box_groups.is_empty(),
        has_phases: !file.phases.is_empty(),
        near_m: end.near_m,
    };

    let (solved, wrong_branch, forbidden) = endings(&file, &facts, goals_in_cells, &error)?;
    let (fitness, mut quantities) = fitness(&file, &facts, &error)?;
    let descriptor = descriptor(&file, &facts, &mut quantities, &error)?;
    let (phases, stages) = phases_and_stages(&file, &facts, &error)?;
    goals_reachable(map.as_deref(), &variants, &place, &error)?;
    if world.has_corridor()
        && let Some(map) = map.as_deref()
    {
        exit_reachable(map, &variants, &place, &error)?;
    }

    let rect_regions = regions.rects;
    Ok(Scenario {
        source: text.to_string(),
        origin: origin.to_string(),
        sensors,
        world,
        map,
        rect_regions,
        lights,
        variants,
        solids,
        place,
        teammate,
        robot_groups,
        controller_files,
        object_groups,
        nest,
        movers,
        box_groups,
        solved,
        wrong_branch,
        wrong_branch_ends: end.wrong_branch_ends,
        forbidden,
        near_m: end.near_m,
        fitness,
        quantities,
        descriptor,
        phases,
        stages,
        file,
    })
}

/// `[descriptor]`: its quantities, compiled after (and shared with) the formulas', so the
/// formulas' indices and what the judge tracks for them stay as they were; the final position
/// when the file has none.
fn descriptor(
    file: &ScenarioFile,
    facts: &Facts<'_>,
    quantities: &mut Quantities,
    error: Refuse<'_>,
) -> Result<Vec<usize>, ScenarioError> {
    let texts: Vec<&str> = match &file.descriptor {
        Some(decl) => decl.quantities.iter().map(String::as_str).collect(),
        None => DEFAULT_DESCRIPTOR.to_vec(),
    };
    if texts.is_empty() || texts.len() > MAX_DESCRIPTOR {
        return Err(error(
            "descriptor.quantities",
            format!(
                "lists {} quantities, 1 to {MAX_DESCRIPTOR} are accepted",
                texts.len()
            ),
        ));
    }
    let mut indices = Vec::with_capacity(texts.len());
    for (position, text) in texts.iter().enumerate() {
        let key = format!("descriptor.quantities[{position}]");
        let idx = quantity_index(text.trim(), facts, quantities)
            .unwrap_or_else(|| {
                Err(format!(
                    "'{text}' is not a quantity: expected {}",
                    blocks::listed(
                        blocks::QUANTITIES
                            .iter()
                            .flat_map(|k| k.syntax.iter().copied())
                    )
                ))
            })
            .map_err(|message| error(&key, message))?;
        if indices.contains(&idx) {
            return Err(error(&key, format!("'{text}' is listed twice")));
        }
        indices.push(idx);
    }
    Ok(indices)
}

/// The schema, the name, the cycle limit.
fn header(file: &ScenarioFile, text: &str, error: Refuse<'_>) -> Result<(), ScenarioError> {
    if file.schema != SCHEMA {
        return Err(error(
            "schema",
            format!(
                "'{}' is not {SCHEMA}",
                crate::scenario::bounded(&file.schema)
            ),
        ));
    }
    // A legacy name makes the task travel as that paper task's name, so workers would run
    // the shipped file instead of this one: only the shipped texts themselves may carry it.
    if file.legacy.is_some() && !SHIPPED.iter().any(|(_, shipped)| *shipped == text) {
        return Err(error(
            "legacy",
            "is reserved for the scenarios shipped with hevo; leave it out".into(),
        ));
    }
    if file.name.trim().is_empty() || file.name.len() > 64 {
        return Err(error("name", "must be 1 to 64 characters".into()));
    }
    // Captions and reports speak of the paper's tasks by these names, so a file of one's own
    // (a modified copy of a shipped one, say) takes a name of its own.
    if file.legacy.is_none() && Scenario::shipped_names().contains(&file.name.as_str()) {
        return Err(error(
            "name",
            format!(
                "'{}' is the name of a scenario shipped with hevo; give yours a name of its own",
                file.name
            ),
        ));
    }
    if file.max_cycles == 0 || file.max_cycles > 1_000_000 {
        return Err(error("max_cycles", "must be between 1 and 1000000".into()));
    }
    Ok(())
}

/// What `[world]` compiles to: the map, if any, the world and the solid rectangles.
type CompiledWorld = (Option<Arc<CompiledMap>>, Box<dyn World>, Vec<Rect>);

/// `[world]`: the map (shipped or inline), the compiled world, and the solid rectangles.
fn world(file: &ScenarioFile, error: Refuse<'_>) -> Result<CompiledWorld, ScenarioError> {
    let w = &file.world;
    let map = match &w.map {
        None => None,
        Some(MapRef::Shipped(name)) => {
            let text = shipped_map(name).ok_or_else(|| {
                error(
                    "world.map",
                    format!(
                        "no shipped map is named '{name}'; shipped: {}",
                        SHIPPED_MAPS.map(|(n, _)| n).join(", ")
                    ),
                )
            })?;
            let map_file: MapFile = toml::from_str(text)
                .map_err(|e| error("world.map", format!("shipped map '{name}': {e}")))?;
            Some(
                compile_map(&map_file)
                    .map_err(|(path, message)| error(&format!("world.map.{path}"), message))?,
            )
        }
        Some(MapRef::Inline(map_file)) => Some(
            compile_map(map_file)
                .map_err(|(path, message)| error(&format!("world.map.{path}"), message))?,
        ),
    }
    .map(Arc::new);
    let world = blocks::worlds::compile(w, map.as_deref())
        .map_err(|(path, message)| error(path, message))?;
    if w.solids.len() > MAX_SOLIDS {
        return Err(error(
            "world.solids",
            format!("{} rectangles, at most {MAX_SOLIDS}", w.solids.len()),
        ));
    }
    let mut solids = Vec::with_capacity(w.solids.len());
    for (idx, &rect) in w.solids.iter().enumerate() {
        let [x0, y0, x1, y1] = rect;
        if !(is_proper_rect(rect) && rect.iter().all(|v| v.abs() <= MAX_SOLID_COORDINATE)) {
            return Err(error(
                &format!("world.solids[{idx}]"),
                format!(
                    "must be [x0, y0, x1, y1] with x0 < x1 and y0 < y1, within \
                     {MAX_SOLID_COORDINATE} m of the origin"
                ),
            ));
        }
        solids.push(Rect::from_corners(RectKind::Obstacle, x0, y0, x1, y1));
    }
    Ok((map, world, solids))
}

/// The regions a scenario may name: the map's, the generators', and `[regions]` rectangles.
struct Regions<'m> {
    /// Every region's name.
    names: Vec<String>,
    /// The `[regions]` rectangles, by name.
    rects: BTreeMap<String, [f32; 4]>,
    map: Option<&'m CompiledMap>,
}

impl<'m> Regions<'m> {
    fn new(
        file: &ScenarioFile,
        map: Option<&'m CompiledMap>,
        world: &dyn World,
        error: Refuse<'_>,
    ) -> Result<Regions<'m>, ScenarioError> {
        let mut region_names: Vec<String> = map
            .as_ref()
            .map(|m| m.regions.keys().cloned().collect())
            .unwrap_or_default();
        if world.has_room() {
            region_names.extend(["room".to_string(), "room.exit".to_string()]);
        }
        if world.has_corridor() {
            region_names.extend(["corridor.start".to_string(), "corridor.end".to_string()]);
        }
        if file.regions.len() > MAX_REGIONS {
            return Err(error(
                "regions",
                format!("{} rectangles, at most {MAX_REGIONS}", file.regions.len()),
            ));
        }
        if file.variants.len() > MAX_VARIANTS {
            return Err(error(
                "variant",
                format!("{} variants, at most {MAX_VARIANTS}", file.variants.len()),
            ));
        }
        let mut rect_regions = BTreeMap::new();
        for (name, region) in &file.regions {
            if !is_proper_rect(region.rect) {
                return Err(error(
                    &format!("regions.{name}.rect"),
                    "must be [x0, y0, x1, y1] with x0 < x1 and y0 < y1: an empty region".into(),
                ));
            }
            if region.rect.iter().any(|v| v.abs() > MAX_SOLID_COORDINATE) {
                return Err(error(
                    &format!("regions.{name}.rect"),
                    format!("must lie within {MAX_SOLID_COORDINATE} m of the origin"),
                ));
            }
            rect_regions.insert(name.clone(), region.rect);
            region_names.push(name.clone());
        }
        Ok(Regions {
            names: region_names,
            rects: rect_regions,
            map,
        })
    }

    fn has(&self, name: &str) -> bool {
        self.names.iter().any(|r| r == name)
    }

    /// Whether `name` is a region of the map.
    fn in_map(&self, name: &str) -> bool {
        self.map.is_some_and(|m| m.regions.contains_key(name))
    }

    /// What the judge tests for a condition naming `name`. The generators' exit and corridor
    /// ends are drawn, and places may name them, but the judge does not test a position
    /// against them: a condition naming one is refused rather than silently never holding.
    /// The order of the tests is the judge's: a rectangle, then the room, then the map's cells.
    fn judged(&self, name: &str) -> Result<RegionTest, String> {
        if let Some(rect) = self.rects.get(name) {
            return Ok(RegionTest::Rect(*rect));
        }
        match name {
            _ if !self.has(name) => Err(format!("no region is named '{name}'")),
            "room.exit" | "corridor.start" | "corridor.end" => Err(format!(
                "conditions cannot test '{name}' (only the map's regions, 'room' and [regions] \
                 rectangles); draw the area as a [regions] rectangle"
            )),
            "room" => Ok(RegionTest::Room),
            _ => {
                let map = self
                    .map
                    .ok_or_else(|| format!("'{name}' is not a map region"))?;
                let cells = &map.regions[name];
                let mut mask = vec![false; map.map.cells.len()];
                for &cell in cells {
                    mask[cell] = true;
                }
                Ok(RegionTest::Cells(mask))
            }
        }
    }
}

/// `sensors`: the input groups the robot carries.
fn sensors(file: &ScenarioFile, error: Refuse<'_>) -> Result<SensorSet, ScenarioError> {
    let sensors = match &file.sensors {
        None => SensorSet::DEFAULT,
        Some(groups) => {
            if groups.is_empty() {
                let names: Vec<&str> = InputGroup::ALL.into_iter().map(InputGroup::name).collect();
                return Err(error(
                    "sensors",
                    format!("name at least one of {}", names.join(", ")),
                ));
            }
            for (idx, group) in groups.iter().enumerate() {
                if groups[..idx].contains(group) {
                    return Err(error(
                        &format!("sensors[{idx}]"),
                        format!("'{}' is listed twice", group.name()),
                    ));
                }
            }
            SensorSet::of(groups)
        }
    };
    Ok(sensors)
}

/// `[[light]]`: each light's place and trigger.
fn lights(
    file: &ScenarioFile,
    map: Option<&CompiledMap>,
    rect_regions: &BTreeMap<String, [f32; 4]>,
    error: Refuse<'_>,
) -> Result<Vec<LightDef>, ScenarioError> {
    let mut lights = Vec::new();
    for (idx, light) in file.lights.iter().enumerate() {
        let at = |key: &str| format!("light[{idx}].{key}");
        if idx >= MAX_LIGHTS {
            return Err(error(
                &at("name"),
                format!("a scenario holds at most {MAX_LIGHTS} lights"),
            ));
        }
        if lights.iter().any(|l: &LightDef| l.name == light.name) {
            return Err(error(
                &at("name"),
                format!("'{}' is declared twice", light.name),
            ));
        }
        let (key, position) = match (light.cell, light.at) {
            (Some([x, y]), None) => {
                let Some(map) = &map else {
                    return Err(error(&at("cell"), "cell units need a map world".into()));
                };
                ("cell", [x * map.map.cell_size, y * map.map.cell_size])
            }
            (None, Some(p)) => ("at", p),
            _ => return Err(error(&at("at"), "give either `cell` or `at`".into())),
        };
        check_point(position).map_err(|message| error(&at(key), message))?;
        let trigger = match &light.trigger {
            TriggerDecl::Named(name) if name == "passed" => Trigger::Passed,
            TriggerDecl::Named(name) if name == "always" => Trigger::Always,
            TriggerDecl::AfterCycles { after_cycles } => Trigger::AfterCycles(*after_cycles),
            TriggerDecl::Entered { entered } => match rect_regions.get(entered) {
                Some(rect) => Trigger::Entered(*rect),
                None => {
                    return Err(error(
                        &at("trigger.entered"),
                        format!("'{entered}' is not a [regions] rectangle"),
                    ));
                }
            },
            TriggerDecl::Blink { blink } => {
                for (key, cycles, least) in [
                    ("from", blink.from, 0),
                    ("lit", blink.lit, 1),
                    ("dark", blink.dark, 1),
                ] {
                    check_schedule_cycles(cycles, least)
                        .map_err(|message| error(&at(&format!("trigger.blink.{key}")), message))?;
                }
                Trigger::Blink {
                    from: blink.from,
                    lit: blink.lit,
                    dark: blink.dark,
                }
            }
            TriggerDecl::LitUntil { lit_until } => {
                check_schedule_cycles(*lit_until, 1)
                    .map_err(|message| error(&at("trigger.lit_until"), message))?;
                Trigger::LitUntil(*lit_until)
            }
            TriggerDecl::Named(other) => {
                return Err(error(
                    &at("trigger"),
                    format!(
                        "'{other}' is not passed, always, {{ after_cycles = N }}, \
                         {{ entered = \"REGION\" }}, {{ blink = {{ from = K, lit = N, dark = M }} }} \
                         or {{ lit_until = N }}"
                    ),
                ));
            }
        };
        lights.push(LightDef {
            name: light.name.clone(),
            position,
            trigger,
        });
    }
    Ok(lights)
}

/// A schedule's count of cycles: at least `least` (a light lit for 0 cycles, or dark for 0, is
/// a mistake: `"always"` is a light never dark) and at most [`MAX_SCHEDULE_CYCLES`].
fn check_schedule_cycles(cycles: u32, least: u32) -> Result<(), String> {
    if cycles < least {
        return Err(format!("{cycles} cycles: must be at least {least}"));
    }
    if cycles > MAX_SCHEDULE_CYCLES {
        return Err(format!(
            "{cycles} cycles: a schedule counts at most {MAX_SCHEDULE_CYCLES}"
        ));
    }
    Ok(())
}

/// `[[variant]]`: which lights flash, the goal and the start regions.
fn variants(
    file: &ScenarioFile,
    lights: &[LightDef],
    regions: &Regions<'_>,
    error: Refuse<'_>,
) -> Result<Vec<Variant>, ScenarioError> {
    let light_index = |name: &str| lights.iter().position(|l| l.name == name);
    let mut variants = Vec::new();
    for (idx, variant) in file.variants.iter().enumerate() {
        let at = |key: &str| format!("variant[{idx}].{key}");
        let mut flashes = vec![false; lights.len()];
        for name in &variant.flash {
            let light = light_index(name)
                .ok_or_else(|| error(&at("flash"), format!("no light is named '{name}'")))?;
            flashes[light] = true;
        }
        for (key, region) in [("goal", &variant.goal), ("start", &variant.start)] {
            if let Some(region) = region
                && !regions.in_map(region)
            {
                return Err(error(
                    &at(key),
                    format!("'{region}' is not a region of the map"),
                ));
            }
        }
        variants.push(Variant {
            name: variant.name.clone(),
            flashes,
            goal: variant.goal.clone(),
            start: variant.start.clone(),
        });
    }
    if variants.is_empty() {
        // Without variants every light behaves as its trigger says.
        variants.push(Variant {
            name: String::new(),
            flashes: vec![true; lights.len()],
            goal: None,
            start: None,
        });
    }
    // A light that flashes in no variant, with a trigger that only matters for flashes,
    // is probably a mistake in the variants.
    for (light_idx, light) in lights.iter().enumerate() {
        if matches!(light.trigger, Trigger::Passed | Trigger::Entered(_))
            && file.variants.len() > 1
            && !variants.iter().any(|v| v.flashes[light_idx])
        {
            return Err(error(
                &format!("light[{light_idx}]"),
                format!("'{}' flashes in no variant", light.name),
            ));
        }
    }
    Ok(variants)
}

/// `[place]`: where and how the robot starts.
fn place(
    file: &ScenarioFile,
    world: &dyn World,
    variants: &[Variant],
    regions: &Regions<'_>,
    error: Refuse<'_>,
) -> Result<Place, ScenarioError> {
    let place_decl = &file.place;
    let at = match place_decl.at.as_str() {
        "room.start" if world.has_room() => PlaceAt::RoomStart,
        "corridor.start" if world.has_corridor() => PlaceAt::CorridorStart,
        "start" => {
            if variants.iter().any(|v| v.start.is_none()) {
                return Err(error(
                    "place.at",
                    "'start' is the variant's start region, but a variant has none".into(),
                ));
            }
            PlaceAt::VariantStart
        }
        region if regions.in_map(region) => PlaceAt::Region(region.to_string()),
        region if regions.rects.contains_key(region) => PlaceAt::Rect(regions.rects[region]),
        other => {
            return Err(error(
                "place.at",
                format!(
                    "'{other}' is no start here: use room.start, corridor.start, start, or a \
                     region of the map or of [regions]"
                ),
            ));
        }
    };
    let facing = match place_decl.facing.as_deref() {
        None => None,
        Some("up") => Some(Facing::Heading(std::f32::consts::FRAC_PI_2)),
        Some("down") => Some(Facing::Heading(-std::f32::consts::FRAC_PI_2)),
        Some("right") => Some(Facing::Heading(0.0)),
        Some("left") => Some(Facing::Heading(std::f32::consts::PI)),
        Some("path") => Some(Facing::Path),
        Some(other) => {
            return Err(error(
                "place.facing",
                format!("'{other}' is not up, down, left, right or path"),
            ));
        }
    };
    if (at == PlaceAt::RoomStart) == facing.is_some() {
        return Err(error(
            "place.facing",
            if at == PlaceAt::RoomStart {
                "the room's start draws its own heading: leave facing out".into()
            } else {
                "say which way the robot faces: up, down, left, right or path".into()
            },
        ));
    }
    if place_decl.advance && !world.advances() {
        return Err(error(
            "place.advance",
            "advancing the start is for corridors".into(),
        ));
    }
    if matches!(at, PlaceAt::Rect(_)) && facing == Some(Facing::Path) {
        return Err(error(
            "place.facing",
            "a rectangle's start faces a fixed way: up, down, left or right".into(),
        ));
    }
    if place_decl.anywhere {
        let why = match at {
            PlaceAt::RoomStart | PlaceAt::CorridorStart => {
                Some("is for a region: give its name, or `start`, as `at`")
            }
            _ if place_decl.ahead_m != 0.0 => Some("leaves no centre for `ahead_m` to move"),
            _ if place_decl.advance => Some("does not advance along a corridor"),
            _ => None,
        };
        if let Some(why) = why {
            return Err(error("place.anywhere", format!("starting anywhere {why}")));
        }
    }
    let turn = match place_decl.turn_deg {
        None => None,
        Some(_) if at == PlaceAt::RoomStart => {
            return Err(error(
                "place.turn_deg",
                "the room's start draws its own heading: leave turn_deg out".into(),
            ));
        }
        Some([from, to]) if from.is_finite() && to.is_finite() && from <= to => {
            Some([from.to_radians(), to.to_radians()])
        }
        Some([from, to]) => {
            return Err(error(
                "place.turn_deg",
                format!("[{from}, {to}] is not a range of degrees [from, to] with from <= to"),
            ));
        }
    };
    check_distance(place_decl.ahead_m, false).map_err(|message| error("place.ahead_m", message))?;
    let place = Place {
        at,
        facing,
        ahead_m: place_decl.ahead_m,
        advance: place_decl.advance,
        anywhere: place_decl.anywhere,
        turn,
    };
    Ok(place)
}

/// `[teammate]`: where the other robot stands and how it moves.
fn teammate(
    file: &ScenarioFile,
    variants: &[Variant],
    regions: &Regions<'_>,
    error: Refuse<'_>,
) -> Result<Option<TeammatePlan>, ScenarioError> {
    let teammate = match &file.teammate {
        None => None,
        Some(t) => {
            let (at_goal, region) = match t.at.as_str() {
                "goal" => (true, None),
                "start" => (false, None),
                region if regions.in_map(region) => (false, Some(region.to_string())),
                other => {
                    return Err(error(
                        "teammate.at",
                        format!("'{other}' is not goal, start or a region of the map"),
                    ));
                }
            };
            let (branch_end, centre) = match t.placement.as_deref() {
                None => (false, false),
                Some("branch_end") => (true, false),
                Some("centre") => (false, true),
                Some(other) => {
                    return Err(error(
                        "teammate.placement",
                        format!("'{other}' is not branch_end or centre"),
                    ));
                }
            };
            if region.is_some() && !centre {
                return Err(error(
                    "teammate.placement",
                    format!(
                        "a teammate at the region '{}' stands at its centre: say \
                         `placement = \"centre\"`",
                        t.at
                    ),
                ));
            }
            if branch_end && !at_goal {
                return Err(error(
                    "teammate.placement",
                    "'branch_end' is the goal's dead end: it needs `at = \"goal\"`".into(),
                ));
            }
            let behaviour = match t.behaviour.as_deref() {
                None => blocks::BEHAVIOURS[0],
                Some(name) => *blocks::BEHAVIOURS
                    .iter()
                    .find(|b| b.name() == name)
                    .ok_or_else(|| {
                        error(
                            "teammate.behaviour",
                            format!(
                                "'{name}' is not {}",
                                blocks::listed(blocks::BEHAVIOURS.iter().map(|b| b.name()))
                            ),
                        )
                    })?,
            };
            behaviour
                .check(t.following)
                .map_err(|why| error("teammate.following", why))?;
            check_distance(t.behind_m, true)
                .map_err(|message| error("teammate.behind_m", message))?;
            let regions_named = region.is_some()
                || variants.iter().all(|v| {
                    if at_goal {
                        v.goal.is_some()
                    } else {
                        v.start.is_some()
                    }
                });
            if !regions_named {
                return Err(error(
                    "teammate.at",
                    format!("'{}': a variant has no {} region", t.at, t.at),
                ));
            }
            Some(TeammatePlan {
                at_goal,
                branch_end,
                centre,
                region,
                behind_m: t.behind_m,
                following: t.following,
                behaviour,
            })
        }
    };
    Ok(teammate)
}

/// `[[robots]]`: the team's other robots, group by group, and the texts of the controller
/// files they run, by the path as written.
fn robot_groups(
    file: &ScenarioFile,
    regions: &Regions<'_>,
    sensors: SensorSet,
    controllers: ControllerSource<'_>,
    error: Refuse<'_>,
) -> Result<(Vec<RobotGroup>, BTreeMap<String, String>), ScenarioError> {
    let mut n_robots = 1u64;
    let mut names = std::collections::BTreeSet::new();
    let mut controller_files = BTreeMap::new();
    let groups = file
        .robot_groups
        .iter()
        .enumerate()
        .map(|(group_idx, decl)| {
            let key = |name: &str| format!("robots[{group_idx}].{name}");
            // The name labels the group's columns in trace tables (`swarm_0_x`) and a replay's key.
            let plain = |c: char| c.is_ascii_alphanumeric() || c == '_' || c == '-';
            if decl.name.is_empty() || decl.name.len() > 32 || !decl.name.chars().all(plain) {
                return Err(error(
                    &key("name"),
                    format!(
                        "'{}' is not a group name: 1 to 32 ASCII letters, digits, '_' or '-'",
                        decl.name
                    ),
                ));
            }
            if !names.insert(decl.name.as_str()) {
                return Err(error(
                    &key("name"),
                    format!("a second group is named '{}'", decl.name),
                ));
            }
            n_robots += u64::from(decl.count);
            if decl.count == 0 || n_robots > u64::from(MAX_ROBOTS) {
                return Err(error(
                    &key("count"),
                    format!(
                        "{} robots: a group holds at least 1, and a team at most {MAX_ROBOTS} \
                         robots, the one [place] starts included",
                        decl.count
                    ),
                ));
            }
            let region = drawn_region(regions, &decl.region)
                .map_err(|message| error(&key("region"), message))?;
            let driver = match &decl.controller {
                GroupControllerDecl::Named(name) if name == "evolved" => GroupDriver::Evolved,
                GroupControllerDecl::Named(name) => GroupDriver::Scripted(
                    *blocks::BEHAVIOURS
                        .iter()
                        .filter(|b| b.name() != "follow")
                        .find(|b| b.name() == name)
                        .ok_or_else(|| {
                            error(
                                &key("controller"),
                                format!(
                                    "'{}' is not evolved, wander, fixed or {{ file = \"PATH\" }}",
                                    bounded(name)
                                ),
                            )
                        })?,
                ),
                GroupControllerDecl::File(ControllerFileRef { file: path }) => {
                    let (controller, text) =
                        group_controller(path, sensors, &file.name, controllers)
                            .map_err(|message| error(&key("controller.file"), message))?;
                    controller_files.insert(path.clone(), text);
                    GroupDriver::File {
                        path: path.clone(),
                        controller: Arc::new(controller),
                    }
                }
            };
            Ok(RobotGroup {
                name: decl.name.clone(),
                count: decl.count,
                region,
                driver,
            })
        })
        .collect::<Result<Vec<_>, _>>()?;
    Ok((groups, controller_files))
}

/// The controller file at `path` (as written) that a group runs, from `controllers`, and its
/// text: a complete tree (every node with its genome) that reads only the sensors the robot
/// carries (`sensors`, of scenario `scenario_name`).
fn group_controller(
    path: &str,
    sensors: SensorSet,
    scenario_name: &str,
    controllers: ControllerSource<'_>,
) -> Result<(Controller, String), String> {
    if path.is_empty() {
        return Err("is empty; give the controller file's path, relative to the scenario".into());
    }
    let text = controllers(path)?;
    let shown = bounded(path);
    if text.len() > MAX_CONTROLLER_FILE_BYTES {
        return Err(format!(
            "'{shown}' is {} bytes, at most {MAX_CONTROLLER_FILE_BYTES} are accepted",
            text.len()
        ));
    }
    let tree = ControllerFile::from_json_str(&text).map_err(|e| {
        format!(
            "'{shown}' is not a controller file: {}",
            bounded(&e.to_string())
        )
    })?;
    if let Some((node, _)) = tree.free_node_topology() {
        return Err(format!(
            "'{shown}': node '{node}' has no genome; a group's controller must be complete"
        ));
    }
    check_sensors(sensors, scenario_name, &tree.root.groups_read())
        .map_err(|problem| format!("'{shown}': controller '{}' {problem}", tree.root.name))?;
    let controller = Controller::new(&tree, None)
        .map_err(|e| format!("'{shown}' is not a controller file: {e}"))?;
    Ok((controller, text))
}

/// Where a group of robots or items is drawn: a `[regions]` rectangle or a map region.
fn drawn_region(regions: &Regions<'_>, name: &str) -> Result<PlaceAt, String> {
    match name {
        region if regions.rects.contains_key(region) => Ok(PlaceAt::Rect(regions.rects[region])),
        region if regions.in_map(region) => Ok(PlaceAt::Region(region.to_string())),
        other => Err(format!(
            "'{other}' is neither a [regions] rectangle nor a map region"
        )),
    }
}

/// `[[objects]]` and `[nest]`: the items, group by group, and where they are delivered (each
/// needs the other).
fn objects(
    file: &ScenarioFile,
    regions: &Regions<'_>,
    error: Refuse<'_>,
) -> Result<(Vec<ObjectGroup>, Option<Nest>), ScenarioError> {
    let mut n_items = 0u64;
    let mut names = std::collections::BTreeSet::new();
    let groups = file
        .object_groups
        .iter()
        .enumerate()
        .map(|(group_idx, decl)| {
            let key = |name: &str| format!("objects[{group_idx}].{name}");
            if !names.insert(decl.name.as_str()) {
                return Err(error(
                    &key("name"),
                    format!("a second group is named '{}'", decl.name),
                ));
            }
            n_items += u64::from(decl.count);
            if decl.count == 0 || n_items > u64::from(MAX_ITEMS) {
                return Err(error(
                    &key("count"),
                    format!(
                        "{} items: a group holds at least 1, and a scenario at most {MAX_ITEMS} \
                         items",
                        decl.count
                    ),
                ));
            }
            let region = drawn_region(regions, &decl.region)
                .map_err(|message| error(&key("region"), message))?;
            Ok(ObjectGroup {
                name: decl.name.clone(),
                count: decl.count,
                region,
            })
        })
        .collect::<Result<Vec<_>, _>>()?;
    let nest = match (&file.nest, groups.is_empty()) {
        (None, true) => None,
        (None, false) => {
            return Err(error(
                "objects",
                "items need a [nest] to be delivered in (`[nest]` with `region = \"NAME\"`)".into(),
            ));
        }
        (Some(_), true) => {
            return Err(error(
                "nest",
                "a nest without [[objects]] has nothing to take in".into(),
            ));
        }
        (Some(decl), false) => Some(Nest {
            name: decl.region.clone(),
            test: regions
                .judged(&decl.region)
                .map_err(|message| error("nest.region", message))?,
        }),
    };
    Ok((groups, nest))
}

/// Refuses a group or body name that could not label a replay's key or a trace's column.
fn check_name(name: &str) -> Result<(), String> {
    let plain = |c: char| c.is_ascii_alphanumeric() || c == '_' || c == '-';
    if name.is_empty() || name.len() > 32 || !name.chars().all(plain) {
        Err(format!(
            "'{name}' is not a name: 1 to 32 ASCII letters, digits, '_' or '-'"
        ))
    } else {
        Ok(())
    }
}

/// Refuses a number outside the closed range `[low, high]` (or not a number).
fn check_range(value: f32, (low, high): (f32, f32), unit: &str) -> Result<(), String> {
    if value.is_finite() && (low..=high).contains(&value) {
        Ok(())
    } else {
        Err(format!("{value} is not in [{low}, {high}] {unit}"))
    }
}

/// `[[movers]]`: the moving obstacles, each checked alone (whether its legs clear the walls
/// depends on the world a sample builds: `Evaluator::check_starts` tells).
fn movers(file: &ScenarioFile, error: Refuse<'_>) -> Result<Vec<MoverPath>, ScenarioError> {
    if file.movers.len() > MAX_MOVERS {
        return Err(error(
            "movers",
            format!(
                "{} movers: a scenario holds at most {MAX_MOVERS}",
                file.movers.len()
            ),
        ));
    }
    let mut names = std::collections::BTreeSet::new();
    file.movers
        .iter()
        .enumerate()
        .map(|(mover_idx, decl)| {
            let key = |name: &str| format!("movers[{mover_idx}].{name}");
            check_name(&decl.name).map_err(|message| error(&key("name"), message))?;
            if !names.insert(decl.name.as_str()) {
                return Err(error(
                    &key("name"),
                    format!("a second mover is named '{}'", decl.name),
                ));
            }
            check_range(decl.radius, MOVER_RADIUS, "metres")
                .map_err(|message| error(&key("radius"), message))?;
            check_range(decl.speed, (0.0, MAX_MOVER_SPEED), "metres a second")
                .and_then(|()| {
                    (decl.speed > 0.0)
                        .then_some(())
                        .ok_or_else(|| "a mover's speed must be above 0".to_string())
                })
                .map_err(|message| error(&key("speed"), message))?;
            if !(2..=MAX_MOVER_POINTS).contains(&decl.path.len()) {
                return Err(error(
                    &key("path"),
                    format!(
                        "{} waypoints: a path lists 2 to {MAX_MOVER_POINTS}",
                        decl.path.len()
                    ),
                ));
            }
            for (point_idx, &point) in decl.path.iter().enumerate() {
                let point_key = format!("movers[{mover_idx}].path[{point_idx}]");
                check_point(point).map_err(|message| error(&point_key, message))?;
                if point_idx > 0 && decl.path[point_idx - 1] == point {
                    return Err(error(
                        &point_key,
                        "repeats the waypoint before it: a leg must have a length".into(),
                    ));
                }
            }
            let mode = match decl.mode.as_str() {
                "loop" => PathMode::Loop,
                "back_and_forth" => PathMode::BackAndForth,
                other => {
                    return Err(error(
                        &key("mode"),
                        format!("'{other}' is not a mode: `loop` or `back_and_forth`"),
                    ));
                }
            };
            if !(decl.start.is_finite() && (0.0..1.0).contains(&decl.start)) {
                return Err(error(
                    &key("start"),
                    format!("{} is not a share of a lap in [0, 1)", decl.start),
                ));
            }
            Ok(MoverPath {
                name: decl.name.clone(),
                radius: decl.radius,
                points: decl.path.clone(),
                speed: decl.speed,
                mode,
                start: decl.start,
            })
        })
        .collect()
}

/// `[[boxes]]`: the boxes robots push, group by group.
fn box_groups(
    file: &ScenarioFile,
    regions: &Regions<'_>,
    error: Refuse<'_>,
) -> Result<Vec<BoxGroup>, ScenarioError> {
    let mut n_boxes = 0u64;
    let mut names = std::collections::BTreeSet::new();
    file.box_groups
        .iter()
        .enumerate()
        .map(|(group_idx, decl)| {
            let key = |name: &str| format!("boxes[{group_idx}].{name}");
            check_name(&decl.name).map_err(|message| error(&key("name"), message))?;
            if !names.insert(decl.name.as_str()) {
                return Err(error(
                    &key("name"),
                    format!("a second group is named '{}'", decl.name),
                ));
            }
            n_boxes += u64::from(decl.count);
            if decl.count == 0 || n_boxes > u64::from(MAX_BOXES) {
                return Err(error(
                    &key("count"),
                    format!(
                        "{} boxes: a group holds at least 1, and a scenario at most {MAX_BOXES} \
                         boxes",
                        decl.count
                    ),
                ));
            }
            check_range(decl.radius, BOX_RADIUS, "metres")
                .map_err(|message| error(&key("radius"), message))?;
            let region = drawn_region(regions, &decl.region)
                .map_err(|message| error(&key("region"), message))?;
            Ok(BoxGroup {
                name: decl.name.clone(),
                count: decl.count,
                region,
                radius: decl.radius,
            })
        })
        .collect()
}

/// `[end]`: when a sample is solved, whether a wrong branch ends it, what is forbidden.
fn endings(
    file: &ScenarioFile,
    facts: &Facts<'_>,
    goals_in_cells: bool,
    error: Refuse<'_>,
) -> Result<(Condition, bool, Option<Condition>), ScenarioError> {
    let end = &file.end;
    let condition = |path: &str, text: &str| {
        Condition::parse(text, facts).map_err(|message| error(path, message))
    };
    let solved = condition("end.solved", &end.solved)?;
    let wrong_branch = match end.wrong_branch.as_deref() {
        None => false,
        Some("off path") => {
            if !goals_in_cells {
                return Err(error(
                    "end.wrong_branch",
                    "'off path' needs a corridor, or a map and a goal in every variant".into(),
                ));
            }
            true
        }
        Some(other) => {
            return Err(error(
                "end.wrong_branch",
                format!("'{other}' is not 'off path'"),
            ));
        }
    };

    let forbidden = end
        .forbidden
        .as_deref()
        .map(|text| condition("end.forbidden", text))
        .transpose()?;
    Ok((solved, wrong_branch, forbidden))
}

/// `[fitness]`: one formula per ending, and the quantities they name.
fn fitness(
    file: &ScenarioFile,
    facts: &Facts<'_>,
    error: Refuse<'_>,
) -> Result<([Formula; 4], Quantities), ScenarioError> {
    let f = &file.fitness;
    let mut quantities = Quantities::new();
    let mut fitness = Vec::with_capacity(4);
    for (key, own) in [
        ("solved", Some(&f.solved)),
        ("wrong_branch", f.wrong_branch.as_ref()),
        ("collision", f.collision.as_ref()),
        ("timeout", f.timeout.as_ref()),
    ] {
        let (key, text) = match (own, &f.otherwise) {
            (Some(text), _) => (key, text),
            (None, Some(text)) => ("otherwise", text),
            (None, None) => {
                return Err(error(
                    &format!("fitness.{key}"),
                    "give it, or `otherwise` for every ending but solved".into(),
                ));
            }
        };
        let formula = Formula::parse(text, facts, &mut quantities)
            .and_then(|formula| {
                check_formula_range(&formula, &quantities, file.phases.len()).map(|()| formula)
            })
            .map_err(|message| error(&format!("fitness.{key}"), message))?;
        fitness.push(formula);
    }
    let fitness: [Formula; 4] = fitness.try_into().expect("one formula per ending");
    Ok((fitness, quantities))
}

/// `[[phase]]` and `[[stage]]`: the derived fitness's phases and the stages reports count.
fn phases_and_stages(
    file: &ScenarioFile,
    facts: &Facts<'_>,
    error: Refuse<'_>,
) -> Result<(Vec<Phase>, Vec<Stage>), ScenarioError> {
    let condition = |path: &str, text: &str| {
        Condition::parse(text, facts).map_err(|message| error(path, message))
    };
    if file.phases.len() > MAX_PHASES {
        return Err(error(
            "phase",
            format!("{} phases, at most {MAX_PHASES}", file.phases.len()),
        ));
    }
    let mut phases = Vec::new();
    for (idx, phase) in file.phases.iter().enumerate() {
        phases.push(Phase {
            name: phase.name.clone(),
            child: phase.child.clone(),
            when: condition(&format!("phase[{idx}].when"), &phase.when)?,
        });
    }
    let mut stages = Vec::new();
    for (idx, stage) in file.stages.iter().enumerate() {
        stages.push(Stage {
            name: stage.name.clone(),
            reached: condition(&format!("stage[{idx}].reached"), &stage.reached)?,
        });
    }
    if stages.len() > 8 {
        return Err(error("stage", "at most 8 stages".into()));
    }
    Ok((phases, stages))
}

/// In map worlds: every variant's goal can be reached from its start.
/// A corridor beyond a map: its end is the goal, and every start reaches the map's exit.
fn exit_reachable(
    map: &CompiledMap,
    variants: &[Variant],
    place: &Place,
    error: Refuse<'_>,
) -> Result<(), ScenarioError> {
    let exit = map.regions["exit"][0];
    for (idx, variant) in variants.iter().enumerate() {
        if variant.goal.is_some() {
            return Err(error(
                &format!("variant[{idx}].goal"),
                "the goal of a corridor beyond a map is the corridor's end: leave the \
                 variant's goal out"
                    .into(),
            ));
        }
        let start = match &place.at {
            PlaceAt::VariantStart => variant.start.clone(),
            PlaceAt::Region(region) => Some(region.clone()),
            _ => None,
        };
        // A rectangle start is tested where the robot is drawn, not here.
        let Some(cells) = start.as_ref().and_then(|start| map.regions.get(start)) else {
            continue;
        };
        let reaches = cells
            .iter()
            .all(|&from| crate::geometry::cells::path_between(&map.map, from, exit).is_some());
        if !reaches {
            let start = start.expect("a map region's name");
            return Err(error(
                "world.corridor",
                format!("no way leads from the start '{start}' to the map's exit"),
            ));
        }
    }
    Ok(())
}

fn goals_reachable(
    map: Option<&CompiledMap>,
    variants: &[Variant],
    place: &Place,
    error: Refuse<'_>,
) -> Result<(), ScenarioError> {
    if let Some(map) = &map {
        for (idx, variant) in variants.iter().enumerate() {
            let start = match &place.at {
                PlaceAt::VariantStart => variant.start.clone(),
                PlaceAt::Region(region) => Some(region.clone()),
                PlaceAt::Rect(_) => None,
                _ => map.regions.get("entrance").map(|_| "entrance".to_string()),
            };
            if let (Some(start), Some(goal)) = (start, &variant.goal) {
                let (Some(from), Some(to)) = (map.regions.get(&start), map.regions.get(goal))
                else {
                    continue;
                };
                if crate::geometry::cells::path_between(&map.map, from[0], to[0]).is_none() {
                    return Err(error(
                        &format!("variant[{idx}].goal"),
                        format!("no start can reach the goal '{goal}' from '{start}'"),
                    ));
                }
            }
        }
    }
    Ok(())
}
