//! Replays of one evaluated sample as an SVG picture: the world drawn to scale (walls,
//! obstacles, the room's exit, the maze's lights and goal), the teammate's path, a team's other
//! robots (each one's path, start and last pose, in a muted colour per group), the items of a
//! foraging sample (where each lay, where it ended, delivered or not), the movers (each one's
//! path and where it ended) and boxes (where each stood, where it was pushed to), and the
//! robot's trajectory coloured by which leaf controller of the tree was driving at each moment,
//! with a legend naming those controllers, markers for the start, collisions and the final
//! pose, optional IR sensor cones at chosen cycles, and an optional looping animation. It reads
//! only a recorded [`Trace`]; the sensor cones come from the caller, so drawing needs no
//! simulator.

use crate::svg::{INK, PathData, SvgDocument, Tag, num_with, palette_colour, text_width};
use hevo_sim_core::InputGroup;
use hevo_sim_core::NamedRegion;
use hevo_sim_core::Pose;
use hevo_sim_core::RectKind;
use hevo_sim_core::{CycleItem, Ending, ITEM_RADIUS, Trace};
use std::collections::BTreeMap;

/// One IR sensor's cone as `Evaluator::ir_cones` gives it: the sensor's position, the
/// directions of its first and last ray (unit vectors, world frame) and the range, metres.
pub use hevo_sim_core::IrCone;

/// What to draw besides the trace itself.
#[derive(Debug, Clone, PartialEq)]
pub struct ReplayOptions {
    /// Name of each controller node, indexed like the trace's active paths, with `/` between
    /// levels (e.g. `rescue/solve_maze/follow_wall`). Missing names are shown as `node N`.
    pub node_names: Vec<String>,
    /// Cycles at which to draw the robot with its four IR cones; cycles past the end of the
    /// trace are ignored.
    pub rays_at_cycles: Vec<u32>,
    /// Whether to add a looping animation of the robot along its trajectory.
    pub animate: bool,
    /// Title above the picture; a default naming the task when absent.
    pub title: Option<String>,
    /// Robot body radius, metres.
    pub robot_radius: f32,
    /// The two caption lines below the picture, instead of the default (what was run, and
    /// how it ended): a picture of a world before any controller drove in it says so.
    pub caption: Option<[String; 2]>,
}

impl Default for ReplayOptions {
    fn default() -> Self {
        ReplayOptions {
            node_names: Vec::new(),
            rays_at_cycles: Vec::new(),
            animate: false,
            title: None,
            robot_radius: 0.0375,
            caption: None,
        }
    }
}

/// Seconds per control cycle. The trace does not carry it, and every task of the paper uses
/// the e-puck's 0.1 s cycle, so captions and the animation assume it.
pub const CYCLE_SECONDS: f64 = 0.1;
/// How much faster than real time the animation runs.
pub const ANIMATION_SPEEDUP: f64 = 10.0;
/// Pause at the end of each loop of the animation, seconds, so the final pose can be seen.
const ANIMATION_PAUSE_SECONDS: f64 = 1.0;

/// Picture width, pixels: READMEs show it at about 700 px, so fonts are sized for that.
const WIDTH: f64 = 800.0;
/// Outer padding, pixels.
const PAD: f64 = 16.0;
/// Height reserved above the scene for the title.
const TITLE_HEIGHT: f64 = 44.0;
/// The tallest the scene may be, pixels; tall scenes are fitted to this and centred.
const MAX_SCENE_HEIGHT: f64 = 820.0;
/// Empty world margin around everything drawn, metres.
const WORLD_MARGIN: f64 = 0.06;
/// Font sizes, pixels.
const TITLE_FONT: f64 = 20.0;
const CAPTION_FONT: f64 = 15.0;
const LEGEND_FONT: f64 = 14.0;
const LABEL_FONT: f64 = 13.0;
/// Trajectory stroke width, pixels.
const TRAJECTORY_WIDTH: f64 = 3.0;
/// A team's other robots' path width, pixels: thinner than the focal robot's, which is the one
/// the picture is about.
const TEAM_PATH_WIDTH: f64 = 1.5;

/// An item on the floor or carried (`[[objects]]`): a small dark-orange disc.
const ITEM_COLOUR: &str = "#d55e00";
/// An item delivered in the nest.
const DELIVERED_COLOUR: &str = "#009e73";
/// A mover (`[[movers]]`): its path and its disc, a dark blue-grey.
const MOVER_COLOUR: &str = "#44546a";
/// A box robots push (`[[boxes]]`): a brown disc.
const BOX_COLOUR: &str = "#8c564b";

const WALL_COLOUR: &str = "#4d4d4d";
const OBSTACLE_COLOUR: &str = "#a68a64";
const TEAMMATE_COLOUR: &str = "#6e6e6e";
const LIGHT_ON_COLOUR: &str = "#F0E442";
const CONE_COLOUR: &str = "#56B4E9";
/// Colour for cycles whose active path was empty (a policy that reports no nodes).
const NO_NODE_COLOUR: &str = "#999999";
/// One colour per group of a team's other robots, in group order: muted, so that none is
/// mistaken for a controller's colour on the focal robot's path.
const TEAM_COLOURS: [&str; 6] = [
    "#8e7cc3", // dusty violet
    "#5f9e8f", // sage teal
    "#b5866a", // clay
    "#7790b5", // slate blue
    "#a8789b", // mauve
    "#8d9a5b", // olive
];

/// Maps world metres (y up) to picture pixels (y down): `px = origin_x + scale * x`,
/// `py = origin_y - scale * y`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SceneTransform {
    /// Pixels per metre.
    pub scale: f64,
    /// Pixel position of the world origin.
    pub origin: [f64; 2],
}

impl SceneTransform {
    /// The pixel position of a world point.
    pub fn apply(&self, point: [f32; 2]) -> [f64; 2] {
        [
            self.origin[0] + self.scale * point[0] as f64,
            self.origin[1] - self.scale * point[1] as f64,
        ]
    }

    /// A world length in pixels.
    pub fn length(&self, metres: f64) -> f64 {
        self.scale * metres
    }
}

/// The world rectangle that holds everything the picture draws: `[min_x, min_y, max_x, max_y]`.
fn world_bounds(trace: &Trace, regions: &[NamedRegion], robot_radius: f64) -> [f64; 4] {
    let mut bounds = [
        f64::INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NEG_INFINITY,
    ];
    let mut include = |p: [f32; 2], pad: f64| {
        let [x, y] = [p[0] as f64, p[1] as f64];
        if x.is_finite() && y.is_finite() {
            bounds[0] = bounds[0].min(x - pad);
            bounds[1] = bounds[1].min(y - pad);
            bounds[2] = bounds[2].max(x + pad);
            bounds[3] = bounds[3].max(y + pad);
        }
    };
    for rect in &trace.rects {
        for corner in rect.corners() {
            include(corner, 0.0);
        }
    }
    for [x0, y0, x1, y1] in regions.iter().flat_map(|r| r.rects.iter().copied()) {
        include([x0, y0], 0.0);
        include([x1, y1], 0.0);
    }
    for (position, _) in &trace.lights {
        include(*position, 0.03);
    }
    if let Some(goal) = trace.goal {
        include(goal, 0.07);
    }
    if let Some((centre, outward)) = trace.exit {
        include(
            [centre[0] + 0.16 * outward[0], centre[1] + 0.16 * outward[1]],
            0.02,
        );
    }
    for cycle in &trace.cycles {
        include(cycle.robot.position(), robot_radius);
        if let Some(mate) = cycle.teammate {
            include(mate.position(), robot_radius);
        }
        for other in &cycle.team {
            include(other.position(), robot_radius);
        }
    }
    include(trace.final_robot.position(), robot_radius);
    if !bounds.iter().all(|v| v.is_finite()) {
        // Nothing finite to draw: show a metre around the origin rather than fail.
        return [-1.0, -1.0, 1.0, 1.0];
    }
    [
        bounds[0] - WORLD_MARGIN,
        bounds[1] - WORLD_MARGIN,
        bounds[2] + WORLD_MARGIN,
        bounds[3] + WORLD_MARGIN,
    ]
}

/// Fits the world bounds into the scene area below the title.
fn fit(bounds: [f64; 4]) -> (SceneTransform, f64) {
    let world_width = (bounds[2] - bounds[0]).max(1e-3);
    let world_height = (bounds[3] - bounds[1]).max(1e-3);
    let area_width = WIDTH - 2.0 * PAD;
    let scale = (area_width / world_width).min(MAX_SCENE_HEIGHT / world_height);
    let left = PAD + 0.5 * (area_width - scale * world_width);
    let origin = [left - scale * bounds[0], TITLE_HEIGHT + scale * bounds[3]];
    (
        SceneTransform { scale, origin },
        TITLE_HEIGHT + scale * world_height,
    )
}

/// The node that drove the robot in a cycle: the last (leaf-most) entry of the active path.
fn leaf_of(path: &[u16]) -> Option<u16> {
    path.last().copied()
}

/// Display name of a node: its path with spaced separators, or `node N` without a name.
fn display_name(names: &[String], node: Option<u16>) -> String {
    match node {
        None => "no controller reported".to_string(),
        Some(index) => match names.get(index as usize).filter(|n| !n.trim().is_empty()) {
            Some(name) => name
                .split('/')
                .map(str::trim)
                .collect::<Vec<_>>()
                .join(" / "),
            None => format!("node {index}"),
        },
    }
}

/// A colour for each leaf that drove the robot. Colours follow the tree, not the trace: the
/// k-th leaf of the tree (a named node no other name extends) always gets the k-th palette
/// colour, so pictures of different samples of one controller agree. Nodes outside that list
/// (unnamed, or arbitrators reported as leaves) get the following colours in order of use.
fn leaf_colours(names: &[String], used: &[Option<u16>]) -> BTreeMap<Option<u16>, &'static str> {
    let tree_leaves: Vec<u16> = (0..names.len())
        .filter(|&i| {
            let prefix = format!("{}/", names[i]);
            !names.iter().any(|other| other.starts_with(&prefix))
        })
        .filter_map(|i| u16::try_from(i).ok())
        .collect();
    let mut colours = BTreeMap::new();
    let mut next_extra = tree_leaves.len();
    for &node in used {
        if colours.contains_key(&node) {
            continue;
        }
        let colour = match node {
            None => NO_NODE_COLOUR,
            Some(index) => match tree_leaves.iter().position(|&leaf| leaf == index) {
                Some(rank) => palette_colour(rank),
                None => {
                    next_extra += 1;
                    palette_colour(next_extra - 1)
                }
            },
        };
        colours.insert(node, colour);
    }
    colours
}

/// A text label drawn over the scene: a white halo keeps it legible over walls and paths.
fn halo_label(class: &str, x: f64, y: f64, anchor: &str) -> Tag {
    Tag::new("text")
        .class(class)
        .num("x", x)
        .num("y", y)
        .num("font-size", LABEL_FONT)
        .attr("text-anchor", anchor)
        .attr("fill", INK)
        .attr("stroke", "#ffffff")
        .attr("stroke-width", "3.5")
        .attr("stroke-linejoin", "round")
        .attr("paint-order", "stroke")
}

/// How a robot disc is painted.
#[derive(Debug, Clone, Copy)]
struct RobotStyle<'a> {
    fill: &'a str,
    outline: &'a str,
    outline_width: f64,
    heading: &'a str,
}

/// The final pose: solid dark, so it stands apart from every path colour.
const FINAL_ROBOT: RobotStyle<'static> = RobotStyle {
    fill: INK,
    outline: INK,
    outline_width: 1.5,
    heading: "#ffffff",
};
/// The teammate: light grey.
const TEAMMATE_ROBOT: RobotStyle<'static> = RobotStyle {
    fill: "#cccccc",
    outline: TEAMMATE_COLOUR,
    outline_width: 1.5,
    heading: INK,
};

/// A robot disc with a heading line from its centre to its rim, heading in world radians.
fn draw_robot(
    doc: &mut SvgDocument,
    group: Tag,
    centre: [f64; 2],
    heading: f32,
    radius_px: f64,
    style: RobotStyle<'_>,
) {
    doc.open(group);
    doc.leaf(
        Tag::new("circle")
            .num("cx", centre[0])
            .num("cy", centre[1])
            .num("r", radius_px)
            .attr("fill", style.fill)
            .attr("stroke", style.outline)
            .num("stroke-width", style.outline_width),
    );
    let heading = heading as f64;
    let tip = [
        centre[0] + radius_px * heading.cos(),
        centre[1] - radius_px * heading.sin(),
    ];
    doc.leaf(
        Tag::new("line")
            .class("heading")
            .num("x1", centre[0])
            .num("y1", centre[1])
            .num("x2", tip[0])
            .num("y2", tip[1])
            .attr("stroke", style.heading)
            .attr("stroke-width", "2")
            .attr("stroke-linecap", "round"),
    );
    doc.close();
}

/// Whether a world point is finite, so it can be drawn.
fn finite(point: [f32; 2]) -> bool {
    point[0].is_finite() && point[1].is_finite()
}

/// The robot's position at the start of cycle `index`, or its final position when `index` is
/// the number of cycles: the trajectory's points.
fn trajectory_point(trace: &Trace, index: usize) -> [f32; 2] {
    trace
        .cycles
        .get(index)
        .map_or(trace.final_robot.position(), |c| c.robot.position())
}

/// One group of a team's other robots as the picture draws it.
#[derive(Debug, Clone, PartialEq, Eq)]
struct TeamGroup<'t> {
    /// The group's name, when the trace records its groups.
    name: Option<&'t str>,
    /// Its robots: their indices in each cycle's `team`.
    members: std::ops::Range<usize>,
    colour: &'static str,
}

impl TeamGroup<'_> {
    /// The key's words for the group: its name, and how many robots it drew.
    fn words(&self) -> String {
        let count = self.members.len();
        let robots = format!(
            "{count} other {}",
            if count == 1 { "robot" } else { "robots" }
        );
        match self.name {
            Some(name) => format!("{name}: {robots}"),
            None => robots,
        }
    }
}

/// The groups of the trace's other robots (none without a team). A trace whose groups do not
/// account for exactly the robots its cycles hold (one recorded without its groups) is drawn
/// as one unnamed group rather than with wrong names.
fn team_groups(trace: &Trace) -> Vec<TeamGroup<'_>> {
    let n_members = trace.cycles.iter().map(|c| c.team.len()).max().unwrap_or(0);
    if n_members == 0 {
        return Vec::new();
    }
    let counted: usize = trace.team_groups.iter().map(|(_, n)| *n as usize).sum();
    if counted != n_members {
        return vec![TeamGroup {
            name: None,
            members: 0..n_members,
            colour: TEAM_COLOURS[0],
        }];
    }
    let mut next = 0;
    trace
        .team_groups
        .iter()
        .enumerate()
        .map(|(index, (name, count))| {
            let members = next..next + *count as usize;
            next = members.end;
            TeamGroup {
                name: Some(name),
                members,
                colour: TEAM_COLOURS[index % TEAM_COLOURS.len()],
            }
        })
        .collect()
}

/// Where one of a team's other robots stood at the start of each cycle, then where it ended,
/// as the focal robot's cycles and final pose, leaving out what cannot be drawn. A trace
/// written before final team poses were kept ends on its last recorded pose, held once more
/// so every robot keeps the focal robot's timing.
pub fn team_member_poses(trace: &Trace, member: usize) -> Vec<Pose> {
    let recorded = trace.cycles.iter().filter_map(|c| c.team.get(member));
    let last = trace
        .final_team
        .get(member)
        .or_else(|| trace.cycles.last().and_then(|c| c.team.get(member)));
    recorded
        .chain(last)
        .copied()
        .filter(|p| finite(p.position()) && p.heading.is_finite())
        .collect()
}

/// The caption's words for the sample's variant, when the task has variants: the paper's tasks
/// say it as the paper does, any other scenario by its variant's name.
fn variant_text(trace: &Trace, variant: u32) -> Option<String> {
    match trace.scenario.as_str() {
        "solve_maze" | "rescue" => Some(format!("light configuration {variant}")),
        "return_room" => Some(format!("start branch {variant}")),
        _ => trace.variant_label.clone(),
    }
}

/// The caption's words for how the sample ended.
fn ending_text(ending: Ending) -> &'static str {
    match ending {
        Ending::Solved => "solved",
        Ending::Collision => "ended by a collision",
        Ending::WrongBranch => "ended in a wrong branch",
        Ending::Timeout => "timed out",
    }
}

/// The rescue stages' names, by the outcome's stage number.
fn rescue_stage_text(stage: u8) -> &'static str {
    match stage {
        0 => "still in the room",
        1 => "left the room",
        2 => "found the teammate",
        _ => "brought the teammate back",
    }
}

/// Two caption lines: what was run, and how it went.
fn caption_lines(trace: &Trace) -> [String; 2] {
    let outcome = &trace.outcome;
    let mut first = format!("task {} · seed {}", trace.scenario, trace.sample.seed);
    if let Some(variant) = variant_text(trace, outcome.variant) {
        first.push_str(&format!(" · {variant}"));
    }
    let mut second = format!(
        "{} after {} cycles ({:.1} s) · fitness {:.3}",
        ending_text(outcome.ending),
        outcome.cycles,
        outcome.cycles as f64 * CYCLE_SECONDS,
        outcome.fitness
    );
    if trace.scenario == "rescue" {
        second.push_str(&format!(
            " · stage {}/3, {}",
            outcome.stage.min(3),
            rescue_stage_text(outcome.stage)
        ));
    }
    if outcome.collided && outcome.ending != Ending::Collision {
        // In a team, what the robot touched may be another robot.
        let touched = if trace.team_groups.is_empty() {
            "touched a wall"
        } else {
            "touched a wall or robot"
        };
        second.push_str(&format!(" · {touched}"));
    }
    if !trace.items.is_empty() {
        let delivered = trace.items.iter().filter(|item| item.delivered).count();
        second.push_str(&format!(
            " · {delivered}/{} items delivered",
            trace.items.len()
        ));
    }
    [first, second]
}

/// Unwraps headings so that consecutive values differ by less than half a turn, so an
/// interpolating animation turns the short way.
fn unwrapped_degrees(headings: &[f32]) -> Vec<f64> {
    let mut out: Vec<f64> = Vec::with_capacity(headings.len());
    for &heading in headings {
        let degrees = (heading as f64).to_degrees();
        let value = match out.last() {
            Some(&previous) => {
                let mut delta = (degrees - previous) % 360.0;
                if delta > 180.0 {
                    delta -= 360.0;
                } else if delta < -180.0 {
                    delta += 360.0;
                }
                previous + delta
            }
            None => degrees,
        };
        out.push(value);
    }
    out
}

/// Where [`replay_svg`] puts the world in its picture for this trace and robot radius (metres):
/// a page that moves its own robot marker over the picture places it with this.
pub fn replay_scene_transform(trace: &Trace, robot_radius: f32) -> SceneTransform {
    let robot_radius = if robot_radius.is_finite() && robot_radius > 0.0 {
        robot_radius as f64
    } else {
        0.0375
    };
    fit(world_bounds(trace, &[], robot_radius)).0
}

/// Draws a replay of one traced sample. `cones` gives the IR cones at a pose (for example
/// `|pose| evaluator.ir_cones(pose)`); it is only called for `options.rays_at_cycles`.
///
/// Bad data never panics: non-finite positions are left out of the drawing, unknown node
/// indices are named `node N`, and requested ray cycles past the end are ignored.
pub fn replay_svg(
    trace: &Trace,
    options: &ReplayOptions,
    cones: &dyn Fn(&Pose) -> Vec<IrCone>,
) -> String {
    render(trace, options, &[], cones, Legend::Controllers)
}

/// Draws a scenario's world as one traced sample starts in it (`hevo scenario draw`): the
/// replay's picture with every named region shaded under the walls and labelled by name,
/// to scale (`regions` from `hevo_sim_core::named_regions` for the same sample).
/// The world is fitted to hold the regions too, so a rectangle outside the walls is seen.
/// No controller drives it, so it has no legend of controllers.
pub fn scenario_svg(trace: &Trace, options: &ReplayOptions, regions: &[NamedRegion]) -> String {
    render(trace, options, regions, &|_| Vec::new(), Legend::None)
}

/// Whether a picture names the controllers that drove the robot.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Legend {
    Controllers,
    /// The trace's policy is a stand-in (a scenario's world before any controller).
    None,
}

fn render(
    trace: &Trace,
    options: &ReplayOptions,
    regions: &[NamedRegion],
    cones: &dyn Fn(&Pose) -> Vec<IrCone>,
    legend: Legend,
) -> String {
    let robot_radius = if options.robot_radius.is_finite() && options.robot_radius > 0.0 {
        options.robot_radius as f64
    } else {
        0.0375
    };
    let (transform, scene_bottom) = fit(world_bounds(trace, regions, robot_radius));
    let radius_px = transform.length(robot_radius);
    let team = team_groups(trace);

    // Consecutive cycles driven by the same leaf form one run, drawn as one polyline.
    let leaves: Vec<Option<u16>> = trace
        .cycles
        .iter()
        .map(|c| leaf_of(&c.active_path))
        .collect();
    let colours = leaf_colours(&options.node_names, &leaves);
    let mut runs: Vec<(usize, usize, Option<u16>)> = Vec::new();
    for (index, &leaf) in leaves.iter().enumerate() {
        match runs.last_mut() {
            Some((_, end, run_leaf)) if *run_leaf == leaf => *end = index + 1,
            _ => runs.push((index, index + 1, leaf)),
        }
    }
    let mut active_counts: BTreeMap<Option<u16>, usize> = BTreeMap::new();
    for &leaf in &leaves {
        *active_counts.entry(leaf).or_default() += 1;
    }

    // Everything below the scene is laid out first, so the document's height is known.
    let named_counts = match legend {
        Legend::Controllers => &active_counts,
        Legend::None => &BTreeMap::new(),
    };
    let legend_entries: Vec<(Option<u16>, String, String)> = named_counts
        .iter()
        .map(|(&node, &count)| {
            let share = 100.0 * count as f64 / trace.cycles.len().max(1) as f64;
            (
                node,
                display_name(&options.node_names, node),
                format!(
                    "{count} {}, {share:.0}%",
                    if count == 1 { "cycle" } else { "cycles" }
                ),
            )
        })
        .collect();
    let widest_name = legend_entries
        .iter()
        .map(|(_, name, _)| text_width(name, LEGEND_FONT))
        .fold(0.0, f64::max);
    let widest_count = legend_entries
        .iter()
        .map(|(_, _, count)| text_width(count, LABEL_FONT))
        .fold(0.0, f64::max);
    let widest_entry = 40.0 + widest_name + 16.0 + widest_count;
    let legend_columns = if legend_entries.len() > 3 && widest_entry < 0.5 * (WIDTH - 2.0 * PAD) {
        2
    } else {
        1
    };
    let legend_rows = legend_entries.len().div_ceil(legend_columns);
    let caption_top = scene_bottom + 26.0;
    let legend_title_y = caption_top + 2.0 * 22.0 + 10.0;
    let legend_top = legend_title_y + 24.0;
    let key_items = key_items(trace, options, &team);
    let key_top = match legend {
        Legend::Controllers => legend_top + legend_rows as f64 * 22.0 + 8.0,
        Legend::None => legend_title_y,
    };
    let key_rows = layout_key(&key_items).last().map_or(0, |item| item.row + 1);
    let height = key_top + key_rows as f64 * 24.0 + PAD;

    let mut doc = SvgDocument::new(WIDTH, height, "replay");
    let title = options
        .title
        .clone()
        .unwrap_or_else(|| format!("Replay: {}", trace.scenario));
    doc.title(&title);
    doc.text(
        Tag::new("text")
            .class("title")
            .num("x", PAD)
            .num("y", 30.0)
            .num("font-size", TITLE_FONT)
            .attr("font-weight", "bold")
            .attr("fill", INK),
        &title,
    );

    doc.open(
        Tag::new("g")
            .class("scene")
            .attr("data-px-per-m", num_with(transform.scale, 4))
            .attr("data-origin-x", num_with(transform.origin[0], 4))
            .attr("data-origin-y", num_with(transform.origin[1], 4)),
    );
    draw_region_shades(&mut doc, regions, &transform);
    draw_world(&mut doc, trace, &transform);
    draw_teammate(&mut doc, trace, &transform, radius_px);
    // Under the focal robot's path and marks, which the picture is about.
    draw_team(&mut doc, trace, &team, &transform, radius_px);
    draw_items(&mut doc, trace, &transform);
    draw_bodies(&mut doc, trace, &transform);
    let faint = options.animate;
    doc.open(
        Tag::new("g")
            .class("trajectories")
            .attr("fill", "none")
            .num("stroke-width", TRAJECTORY_WIDTH)
            .attr("stroke-linejoin", "round")
            .attr("stroke-linecap", "round")
            .attr("opacity", if faint { "0.4" } else { "1" }),
    );
    for &(first, end, leaf) in &runs {
        // A run's polyline ends where the next run starts, so the drawn path has no gaps.
        let points: Vec<[f64; 2]> = (first..=end)
            .map(|i| trajectory_point(trace, i))
            .filter(|&p| finite(p))
            .map(|p| transform.apply(p))
            .collect();
        let colour = colours.get(&leaf).copied().unwrap_or(NO_NODE_COLOUR);
        doc.leaf(
            Tag::new("polyline")
                .class("trajectory")
                .attr(
                    "data-node",
                    leaf.map_or("none".to_string(), |n| n.to_string()),
                )
                .attr("data-first-cycle", first.to_string())
                .attr("data-last-cycle", end.to_string())
                .attr("stroke", colour)
                .points(&points),
        );
    }
    doc.close();
    draw_rays(
        &mut doc, trace, options, &transform, radius_px, cones, &colours,
    );
    draw_start(&mut doc, trace, &transform, radius_px);
    if finite(trace.final_robot.position()) {
        draw_robot(
            &mut doc,
            Tag::new("g").class("final-robot"),
            transform.apply(trace.final_robot.position()),
            trace.final_robot.heading,
            radius_px,
            FINAL_ROBOT,
        );
    }
    // Collisions go over the final robot: a sample that ends on a collision ends there.
    draw_collisions(&mut doc, trace, &transform);
    if options.animate {
        draw_animation(&mut doc, trace, &team, &transform, radius_px);
    }
    // Region names go over everything in the scene, so no wall or robot hides one.
    draw_region_labels(
        &mut doc,
        regions,
        &transform,
        marks_to_avoid(trace, &transform, radius_px),
    );
    doc.close();

    // Caption, legend and key.
    let [first_line, second_line] = options
        .caption
        .clone()
        .unwrap_or_else(|| caption_lines(trace));
    for (i, line) in [first_line, second_line].iter().enumerate() {
        doc.text(
            Tag::new("text")
                .class("caption")
                .num("x", PAD)
                .num("y", caption_top + i as f64 * 22.0)
                .num("font-size", CAPTION_FONT)
                .attr("fill", INK),
            line,
        );
    }
    let legend_title = if trace.cycles.is_empty() {
        "No cycles recorded"
    } else {
        "Path colour: the controller driving the robot (leaf of the active path)"
    };
    if legend == Legend::Controllers {
        doc.text(
            Tag::new("text")
                .class("legend-title")
                .num("x", PAD)
                .num("y", legend_title_y)
                .num("font-size", LEGEND_FONT)
                .attr("font-weight", "bold")
                .attr("fill", INK),
            legend_title,
        );
    }
    let column_width = (WIDTH - 2.0 * PAD) / legend_columns as f64;
    // The cycle counts of a legend column line up after its longest name, so they read as a
    // column of numbers rather than trailing each name at a different place.
    let names_width = |column: usize| {
        legend_entries
            .iter()
            .skip(column * legend_rows)
            .take(legend_rows)
            .map(|(_, name, _)| text_width(name, LEGEND_FONT))
            .fold(0.0, f64::max)
    };
    for (i, (node, name, count)) in legend_entries.iter().enumerate() {
        let x = PAD + (i / legend_rows) as f64 * column_width;
        let y = legend_top + (i % legend_rows) as f64 * 22.0;
        let colour = colours.get(node).copied().unwrap_or(NO_NODE_COLOUR);
        let node_attr = node.map_or("none".to_string(), |n| n.to_string());
        doc.leaf(
            Tag::new("line")
                .class("legend-swatch")
                .attr("data-node", &node_attr)
                .num("x1", x)
                .num("y1", y - 5.0)
                .num("x2", x + 30.0)
                .num("y2", y - 5.0)
                .attr("stroke", colour)
                .num("stroke-width", 5.0)
                .attr("stroke-linecap", "round"),
        );
        doc.text(
            Tag::new("text")
                .class("legend")
                .attr("data-node", &node_attr)
                .num("x", x + 40.0)
                .num("y", y)
                .num("font-size", LEGEND_FONT)
                .attr("fill", INK),
            name,
        );
        doc.text(
            Tag::new("text")
                .class("legend-cycles")
                .attr("data-node", &node_attr)
                .num("x", x + 40.0 + names_width(i / legend_rows) + 16.0)
                .num("y", y)
                .num("font-size", LABEL_FONT)
                .attr("fill", "#666666"),
            count,
        );
    }
    draw_key(&mut doc, &key_items, key_top);
    doc.finish()
}

/// Walls, obstacles, the exit, the goal and the lights.
fn draw_world(doc: &mut SvgDocument, trace: &Trace, transform: &SceneTransform) {
    doc.open(Tag::new("g").class("world"));
    for rect in &trace.rects {
        let corners: Vec<[f64; 2]> = rect.corners().iter().map(|&c| transform.apply(c)).collect();
        if !corners.iter().flatten().all(|v| v.is_finite()) {
            continue;
        }
        let (class, colour) = match rect.kind {
            RectKind::Wall => ("wall", WALL_COLOUR),
            RectKind::Obstacle => ("obstacle", OBSTACLE_COLOUR),
        };
        // Polygons rather than rotated rects: one form for every angle, and a thin stroke of
        // the same colour closes hairline seams between touching walls.
        doc.leaf(
            Tag::new("polygon")
                .class(class)
                .points(&corners)
                .attr("fill", colour)
                .attr("stroke", colour)
                .attr("stroke-width", "0.75"),
        );
    }
    if let Some((centre, outward)) = trace.exit.filter(|(c, o)| finite(*c) && finite(*o)) {
        let from = transform.apply([centre[0] - 0.05 * outward[0], centre[1] - 0.05 * outward[1]]);
        let to = transform.apply([centre[0] + 0.14 * outward[0], centre[1] + 0.14 * outward[1]]);
        let (dx, dy) = (to[0] - from[0], to[1] - from[1]);
        let length = dx.hypot(dy).max(1e-6);
        let (ux, uy) = (dx / length, dy / length);
        let head = 10.0;
        doc.open(Tag::new("g").class("exit"));
        doc.leaf(
            Tag::new("line")
                .num("x1", from[0])
                .num("y1", from[1])
                .num("x2", to[0] - ux * head * 0.8)
                .num("y2", to[1] - uy * head * 0.8)
                .attr("stroke", "#009E73")
                .attr("stroke-width", "3"),
        );
        doc.leaf(
            Tag::new("polygon")
                .points(&[
                    to,
                    [
                        to[0] - ux * head - uy * head * 0.55,
                        to[1] - uy * head + ux * head * 0.55,
                    ],
                    [
                        to[0] - ux * head + uy * head * 0.55,
                        to[1] - uy * head - ux * head * 0.55,
                    ],
                ])
                .attr("fill", "#009E73"),
        );
        let (label_at, anchor) = exit_label_place(to, [ux, uy]);
        doc.text(
            halo_label("exit-label", label_at[0], label_at[1], anchor),
            "exit",
        );
        doc.close();
    }
    if let Some(goal) = trace.goal.filter(|g| finite(*g)) {
        let at = transform.apply(goal);
        let outer = transform.length(0.06).max(8.0);
        doc.open(Tag::new("g").class("goal"));
        doc.leaf(
            Tag::new("circle")
                .num("cx", at[0])
                .num("cy", at[1])
                .num("r", outer)
                .attr("fill", "none")
                .attr("stroke", "#009E73")
                .attr("stroke-width", "2.5"),
        );
        doc.leaf(
            Tag::new("circle")
                .num("cx", at[0])
                .num("cy", at[1])
                .num("r", outer * 0.4)
                .attr("fill", "#009E73"),
        );
        doc.close();
    }
    let scene_centre_x = transform.origin[0]
        + transform.scale
            * (trace.lights.iter().map(|(p, _)| p[0] as f64).sum::<f64>()
                / trace.lights.len().max(1) as f64);
    let labels: Vec<Option<String>> = (0..trace.lights.len())
        .map(|index| light_label(trace, index))
        .collect();
    for (index, &(position, flashes)) in trace.lights.iter().enumerate() {
        if !finite(position) {
            continue;
        }
        let at = transform.apply(position);
        let lit_cycle = trace
            .cycles
            .iter()
            .position(|c| index < 32 && c.lit_lights & (1 << index) != 0);
        // Lights that light alike (a field of lamps on one schedule) share one label, on the
        // first of them, saying how many.
        let label = labels[index].as_ref().and_then(|label| {
            let alike = labels.iter().filter(|l| l.as_ref() == Some(label)).count();
            let first = labels.iter().position(|l| l.as_ref() == Some(label)) == Some(index);
            match alike {
                1 => Some((label.clone(), false)),
                _ if first => Some((format!("{label} ({alike} lights)"), true)),
                _ => None,
            }
        });
        let radius = transform.length(0.02).max(5.0);
        let mut group = Tag::new("g")
            .class("light")
            .attr("data-flashes", flashes.to_string());
        if let Some(cycle) = lit_cycle {
            group = group.attr("data-lit-cycle", cycle.to_string());
        }
        doc.open(group);
        if lit_cycle.is_some() {
            doc.leaf(
                Tag::new("circle")
                    .class("light-glow")
                    .num("cx", at[0])
                    .num("cy", at[1])
                    .num("r", radius * 2.0)
                    .attr("fill", LIGHT_ON_COLOUR)
                    .attr("opacity", "0.55"),
            );
        }
        doc.leaf(
            Tag::new("circle")
                .num("cx", at[0])
                .num("cy", at[1])
                .num("r", radius)
                .attr("fill", if flashes { LIGHT_ON_COLOUR } else { "#ffffff" })
                .attr("stroke", if flashes { INK } else { "#888888" })
                .attr("stroke-width", "1.5"),
        );
        if let Some((label, shared)) = label {
            let text = if shared {
                // A label shared by a field of lamps goes under its first lamp, centred,
                // where a lamp's neighbours are not.
                halo_label("light-label", at[0], at[1] + radius * 2.0 + 14.0, "middle")
            } else {
                // Labels go on the outer side of the stem, away from the corridor and the path,
                // and clear of the wall the light is mounted on; on the inner side when the
                // outer one has no room left in the picture (a beacon on a side wall).
                let mut outward = if at[0] >= scene_centre_x { 1.0 } else { -1.0 };
                let reach = radius * 2.0 + 16.0 + text_width(&label, LABEL_FONT);
                if !(0.0..=WIDTH).contains(&(at[0] + outward * reach)) {
                    outward = -outward;
                }
                let anchor = if outward > 0.0 { "start" } else { "end" };
                halo_label(
                    "light-label",
                    at[0] + outward * (radius * 2.0 + 16.0),
                    at[1] + 4.5,
                    anchor,
                )
            };
            doc.text(text, &label);
        }
        doc.close();
    }
    doc.close();
}

/// What a light's label says of the cycles it was lit in: `lit at cycle C` when it lit once
/// (a flash, or a beacon from cycle 0 on), `lit until cycle C` when it was lit from the start
/// and went dark, `lit N times from cycle C` when it lit more than once (a blinking light);
/// `None` when it never lit.
fn light_label(trace: &Trace, index: usize) -> Option<String> {
    if index >= 32 {
        return None;
    }
    let lit: Vec<bool> = trace
        .cycles
        .iter()
        .map(|c| c.lit_lights & (1 << index) != 0)
        .collect();
    let first = lit.iter().position(|&on| on)?;
    let n_runs = (0..lit.len())
        .filter(|&cycle| lit[cycle] && (cycle == 0 || !lit[cycle - 1]))
        .count();
    let end = first + lit[first..].iter().take_while(|&&on| on).count();
    Some(if n_runs > 1 {
        format!("lit {n_runs} times from cycle {first}")
    } else if first == 0 && end < lit.len() {
        format!("lit until cycle {end}")
    } else {
        format!("lit at cycle {first}")
    })
}

/// Where the exit arrow's label goes, given the arrow's tip (pixels) and its unit direction
/// on the page: beside the arrow, on the side away from the robot's start, where there is
/// usually open floor or empty page. Returns the text position and anchor.
fn exit_label_place(to: [f64; 2], [ux, uy]: [f64; 2]) -> ([f64; 2], &'static str) {
    let side = [-uy, ux];
    let label_at = [
        to[0] + side[0] * 14.0 - ux * 6.0,
        to[1] + side[1] * 14.0 - uy * 6.0 + 4.0,
    ];
    let anchor = if side[0] < -0.3 {
        "end"
    } else if side[0] > 0.3 {
        "start"
    } else {
        "middle"
    };
    (label_at, anchor)
}

/// The page boxes `[x0, y0, x1, y1]` of the other labels and marks region names should keep
/// clear of: the start's disc and its label, the other robots' starts, and the exit arrow's
/// label.
fn marks_to_avoid(trace: &Trace, transform: &SceneTransform, radius_px: f64) -> Vec<[f64; 4]> {
    let mut boxes = Vec::new();
    let team_starts = trace.cycles.first().map_or(&[][..], |c| &c.team);
    for start in team_starts.iter().filter(|p| finite(p.position())) {
        let at = transform.apply(start.position());
        boxes.push([
            at[0] - radius_px,
            at[1] - radius_px,
            at[0] + radius_px,
            at[1] + radius_px,
        ]);
    }
    let start = trace.cycles.first().map_or(trace.final_robot, |c| c.robot);
    if finite(start.position()) {
        let at = transform.apply(start.position());
        let half = radius_px.max(0.5 * text_width("start", LABEL_FONT) + 2.0);
        boxes.push([
            at[0] - half,
            at[1] - radius_px,
            at[0] + half,
            at[1] + radius_px + 18.0,
        ]);
    }
    if let Some((centre, outward)) = trace.exit.filter(|(c, o)| finite(*c) && finite(*o)) {
        let from = transform.apply([centre[0] - 0.05 * outward[0], centre[1] - 0.05 * outward[1]]);
        let to = transform.apply([centre[0] + 0.14 * outward[0], centre[1] + 0.14 * outward[1]]);
        let (dx, dy) = (to[0] - from[0], to[1] - from[1]);
        let length = dx.hypot(dy).max(1e-6);
        let (at, anchor) = exit_label_place(to, [dx / length, dy / length]);
        let width = text_width("exit", LABEL_FONT) + 4.0;
        let x0 = match anchor {
            "end" => at[0] - width,
            "start" => at[0],
            _ => at[0] - 0.5 * width,
        };
        boxes.push([x0, at[1] - LABEL_FONT, x0 + width, at[1] + 3.0]);
    }
    boxes
}

/// Light fill, one palette colour per region, of every rectangle of every named region: under
/// the walls, so a region's cells read as tinted floor.
fn draw_region_shades(doc: &mut SvgDocument, regions: &[NamedRegion], transform: &SceneTransform) {
    if regions.is_empty() {
        return;
    }
    doc.open(Tag::new("g").class("regions"));
    for (index, region) in regions.iter().enumerate() {
        let colour = palette_colour(index);
        doc.open(
            Tag::new("g")
                .class("region")
                .attr("data-name", &region.name)
                .attr("fill", colour)
                .attr("fill-opacity", "0.22")
                .attr("stroke", colour)
                .attr("stroke-opacity", "0.6")
                .attr("stroke-width", "1"),
        );
        for rect in region
            .rects
            .iter()
            .filter(|r| r.iter().all(|v| v.is_finite()))
        {
            let [x0, y0] = transform.apply([rect[0], rect[3]]);
            let [x1, y1] = transform.apply([rect[2], rect[1]]);
            doc.leaf(
                Tag::new("rect")
                    .class("region-rect")
                    .attr("data-name", &region.name)
                    .num("x", x0.min(x1))
                    .num("y", y0.min(y1))
                    .num("width", (x1 - x0).abs())
                    .num("height", (y1 - y0).abs()),
            );
        }
        doc.close();
    }
    doc.close();
}

/// Each region's name, on its rectangle nearest the centre of all its rectangles (a region of
/// scattered cells is named on one of them, not between them): in the middle of a small one,
/// in the top-left corner of one large enough to hold a few lines (a room, whose middle is
/// where the robot starts). A label that would overlap another label or a mark in `avoid`
/// moves down or up by a line at a time, up to three lines, and otherwise stays where it first
/// went.
fn draw_region_labels(
    doc: &mut SvgDocument,
    regions: &[NamedRegion],
    transform: &SceneTransform,
    avoid: Vec<[f64; 4]>,
) {
    if regions.is_empty() {
        return;
    }
    let line = LABEL_FONT + 3.0;
    let mut placed: Vec<[f64; 4]> = avoid;
    doc.open(Tag::new("g").class("region-labels"));
    for region in regions {
        let rects: Vec<&[f32; 4]> = region
            .rects
            .iter()
            .filter(|r| r.iter().all(|v| v.is_finite()))
            .collect();
        if rects.is_empty() {
            continue;
        }
        let mid = |r: &[f32; 4]| [0.5 * (r[0] + r[2]), 0.5 * (r[1] + r[3])];
        let n = rects.len() as f32;
        let centre = rects.iter().fold([0.0f32; 2], |acc, r| {
            let m = mid(r);
            [acc[0] + m[0] / n, acc[1] + m[1] / n]
        });
        let nearest = rects
            .iter()
            .min_by(|a, b| {
                let (ma, mb) = (mid(a), mid(b));
                let da = (ma[0] - centre[0]).hypot(ma[1] - centre[1]);
                let db = (mb[0] - centre[0]).hypot(mb[1] - centre[1]);
                da.total_cmp(&db)
            })
            .expect("at least one rectangle");
        let half_width = 0.5 * text_width(&region.name, LABEL_FONT) + 2.0;
        let top_left = transform.apply([nearest[0], nearest[3]]);
        let bottom_right = transform.apply([nearest[2], nearest[1]]);
        let large = bottom_right[0] - top_left[0] > 2.0 * half_width + 16.0
            && bottom_right[1] - top_left[1] > 5.0 * line;
        let at = if large {
            [top_left[0] + 8.0 + half_width, top_left[1] + 4.0 + line]
        } else {
            transform.apply(mid(nearest))
        };
        let box_at = |dy: f64| {
            [
                at[0] - half_width,
                at[1] + dy - LABEL_FONT,
                at[0] + half_width,
                at[1] + dy + 3.0,
            ]
        };
        let overlaps = |b: &[f64; 4]| {
            placed
                .iter()
                .any(|p| b[0] < p[2] && p[0] < b[2] && b[1] < p[3] && p[1] < b[3])
        };
        // A corner label is already on its line; a middle one is centred on the rectangle.
        let base = if large { 0.0 } else { 0.5 * LABEL_FONT - 2.0 };
        let dy = [0.0, 1.0, -1.0, 2.0, -2.0, 3.0, -3.0]
            .iter()
            .map(|k| base + k * line)
            .find(|&dy| !overlaps(&box_at(dy)))
            .unwrap_or(base);
        placed.push(box_at(dy));
        doc.text(
            halo_label("region-label", at[0], at[1] + dy, "middle").attr("data-name", &region.name),
            &region.name,
        );
    }
    doc.close();
}

/// The teammate's path (dashed), where it started, and where it was last.
fn draw_teammate(doc: &mut SvgDocument, trace: &Trace, transform: &SceneTransform, radius_px: f64) {
    let poses: Vec<Pose> = trace
        .cycles
        .iter()
        .filter_map(|c| c.teammate)
        .filter(|p| finite(p.position()))
        .collect();
    let (Some(first), Some(last)) = (poses.first(), poses.last()) else {
        return;
    };
    doc.open(Tag::new("g").class("teammate-group"));
    let points: Vec<[f64; 2]> = poses
        .iter()
        .map(|p| transform.apply(p.position()))
        .collect();
    doc.leaf(
        Tag::new("polyline")
            .class("teammate-path")
            .points(&points)
            .attr("fill", "none")
            .attr("stroke", TEAMMATE_COLOUR)
            .attr("stroke-width", "2")
            .attr("stroke-dasharray", "6 4"),
    );
    let start = transform.apply(first.position());
    doc.leaf(
        Tag::new("circle")
            .class("teammate-start")
            .num("cx", start[0])
            .num("cy", start[1])
            .num("r", radius_px)
            .attr("fill", "none")
            .attr("stroke", TEAMMATE_COLOUR)
            .attr("stroke-width", "1.5")
            .attr("stroke-dasharray", "3 2"),
    );
    draw_robot(
        doc,
        Tag::new("g").class("teammate"),
        transform.apply(last.position()),
        last.heading,
        radius_px,
        TEAMMATE_ROBOT,
    );
    doc.close();
}

/// A team robot's last pose: a solid disc in its group's colour, as the focal robot's final
/// pose is a solid dark one.
fn team_final_style(colour: &str) -> RobotStyle<'_> {
    RobotStyle {
        fill: colour,
        outline: colour,
        outline_width: 1.5,
        heading: "#ffffff",
    }
}

/// A team's other robots, group by group: each one's path (thin, in its group's colour), a
/// ring where it started and a disc where it ended, as the focal robot's start and final
/// pose are drawn.
fn draw_team(
    doc: &mut SvgDocument,
    trace: &Trace,
    groups: &[TeamGroup<'_>],
    transform: &SceneTransform,
    radius_px: f64,
) {
    if groups.is_empty() {
        return;
    }
    doc.open(Tag::new("g").class("team"));
    for group in groups {
        let mut tag = Tag::new("g")
            .class("team-group")
            .attr("data-count", group.members.len().to_string());
        if let Some(name) = group.name {
            tag = tag.attr("data-name", name);
        }
        doc.open(tag);
        for member in group.members.clone() {
            let poses = team_member_poses(trace, member);
            let (Some(first), Some(last)) = (poses.first(), poses.last()) else {
                continue;
            };
            doc.open(
                Tag::new("g")
                    .class("team-robot")
                    .attr("data-member", member.to_string()),
            );
            if poses.len() > 1 {
                let points: Vec<[f64; 2]> = poses
                    .iter()
                    .map(|p| transform.apply(p.position()))
                    .collect();
                doc.leaf(
                    Tag::new("polyline")
                        .class("team-path")
                        .points(&points)
                        .attr("fill", "none")
                        .attr("stroke", group.colour)
                        .num("stroke-width", TEAM_PATH_WIDTH)
                        .attr("stroke-opacity", "0.8")
                        .attr("stroke-linejoin", "round")
                        .attr("stroke-linecap", "round"),
                );
            }
            doc.open(Tag::new("g").class("team-start"));
            let ring = RingStyle {
                colour: group.colour,
                width: TEAM_PATH_WIDTH,
            };
            draw_start_ring(
                doc,
                transform.apply(first.position()),
                first.heading,
                radius_px,
                ring,
            );
            doc.close();
            draw_robot(
                doc,
                Tag::new("g").class("team-final"),
                transform.apply(last.position()),
                last.heading,
                radius_px,
                team_final_style(group.colour),
            );
            doc.close();
        }
        doc.close();
    }
    doc.close();
}

/// The items of a foraging sample (none without `[[objects]]`): a ring where each lay at the
/// start, and, where it moved, a thin line to a disc where it ended (green when delivered in
/// the nest, orange on the floor or carried).
fn draw_items(doc: &mut SvgDocument, trace: &Trace, transform: &SceneTransform) {
    if trace.items.is_empty() {
        return;
    }
    let delivered = trace.items.iter().filter(|item| item.delivered).count();
    doc.open(
        Tag::new("g")
            .class("items")
            .attr("data-count", trace.items.len().to_string())
            .attr("data-delivered", delivered.to_string()),
    );
    let radius_px = transform.length(f64::from(ITEM_RADIUS)).max(2.0);
    for item in trace
        .items
        .iter()
        .filter(|item| finite(item.start) && finite(item.end))
    {
        let colour = if item.delivered {
            DELIVERED_COLOUR
        } else {
            ITEM_COLOUR
        };
        doc.open(
            Tag::new("g")
                .class("item")
                .attr("data-delivered", item.delivered.to_string())
                .attr("data-carried", item.carried.to_string()),
        );
        let moved = Moved {
            start: item.start,
            end: item.end,
            radius_px,
            ring: ITEM_COLOUR,
            disc: colour,
        };
        draw_moved(doc, "item", &moved, transform);
        doc.close();
    }
    doc.close();
}

/// A disc that moved: where it started and where it ended, metres, its radius in pixels, and
/// its colours (the start's ring, the way's line and the end's disc).
struct Moved {
    start: [f32; 2],
    end: [f32; 2],
    radius_px: f64,
    ring: &'static str,
    disc: &'static str,
}

/// A disc that moved, as items and boxes are drawn: where it moved, a ring at its start and a
/// thin dashed line to where it ended; a disc there (`class`-start, -way and -end).
fn draw_moved(doc: &mut SvgDocument, class: &str, moved: &Moved, transform: &SceneTransform) {
    let (start, end) = (transform.apply(moved.start), transform.apply(moved.end));
    if moved.start != moved.end {
        doc.leaf(
            Tag::new("circle")
                .class(&format!("{class}-start"))
                .num("cx", start[0])
                .num("cy", start[1])
                .num("r", moved.radius_px)
                .attr("fill", "none")
                .attr("stroke", moved.ring)
                .num("stroke-width", 1.0),
        );
        doc.leaf(
            Tag::new("line")
                .class(&format!("{class}-way"))
                .num("x1", start[0])
                .num("y1", start[1])
                .num("x2", end[0])
                .num("y2", end[1])
                .attr("stroke", moved.disc)
                .num("stroke-width", 1.0)
                .attr("stroke-dasharray", "3 3"),
        );
    }
    doc.leaf(
        Tag::new("circle")
            .class(&format!("{class}-end"))
            .num("cx", end[0])
            .num("cy", end[1])
            .num("r", moved.radius_px)
            .attr("fill", moved.disc)
            .attr("stroke", "#ffffff")
            .num("stroke-width", 0.5),
    );
}

/// The movers and boxes of a sample (none without `[[movers]]` or `[[boxes]]`): each mover's
/// path as a thin line (closed for a loop) and its disc where it ended; each box as an item
/// is drawn ([`draw_moved`]).
fn draw_bodies(doc: &mut SvgDocument, trace: &Trace, transform: &SceneTransform) {
    if trace.movers.is_empty() && trace.boxes.is_empty() {
        return;
    }
    doc.open(
        Tag::new("g")
            .class("bodies")
            .attr("data-movers", trace.movers.len().to_string())
            .attr("data-boxes", trace.boxes.len().to_string()),
    );
    for mover in trace.movers.iter().filter(|mover| {
        mover.path.iter().copied().all(finite) && finite(mover.end) && mover.radius.is_finite()
    }) {
        doc.open(Tag::new("g").class("mover").attr("data-name", &mover.name));
        let mut path = PathData::new();
        for (idx, &point) in mover.path.iter().enumerate() {
            let [x, y] = transform.apply(point);
            path = if idx == 0 {
                path.move_to(x, y)
            } else {
                path.line_to(x, y)
            };
        }
        if mover.looped {
            path = path.close();
        }
        doc.leaf(
            Tag::new("path")
                .class("mover-path")
                .attr("d", path.as_str())
                .attr("fill", "none")
                .attr("stroke", MOVER_COLOUR)
                .num("stroke-width", 1.0),
        );
        let end = transform.apply(mover.end);
        doc.leaf(
            Tag::new("circle")
                .class("mover-end")
                .num("cx", end[0])
                .num("cy", end[1])
                .num("r", transform.length(f64::from(mover.radius)).max(2.0))
                .attr("fill", MOVER_COLOUR)
                .attr("fill-opacity", "0.8")
                .attr("stroke", "#ffffff")
                .num("stroke-width", 0.5),
        );
        doc.close();
    }
    for one in trace
        .boxes
        .iter()
        .filter(|one| finite(one.start) && finite(one.end) && one.radius.is_finite())
    {
        let moved = Moved {
            start: one.start,
            end: one.end,
            radius_px: transform.length(f64::from(one.radius)).max(2.0),
            ring: BOX_COLOUR,
            disc: BOX_COLOUR,
        };
        draw_moved(doc, "box", &moved, transform);
    }
    doc.close();
}

/// A cross at the robot's position in every cycle whose move was undone by a collision,
/// leaving out crosses that would land on the previous one.
fn draw_collisions(doc: &mut SvgDocument, trace: &Trace, transform: &SceneTransform) {
    let mut previous: Option<[f64; 2]> = None;
    let size = 6.0;
    for (index, cycle) in trace.cycles.iter().enumerate() {
        if !cycle.collided || !finite(cycle.robot.position()) {
            continue;
        }
        let at = transform.apply(cycle.robot.position());
        if previous.is_some_and(|p| (p[0] - at[0]).hypot(p[1] - at[1]) < 3.0) {
            continue;
        }
        previous = Some(at);
        let cross = PathData::new()
            .move_to(at[0] - size, at[1] - size)
            .line_to(at[0] + size, at[1] + size)
            .move_to(at[0] - size, at[1] + size)
            .line_to(at[0] + size, at[1] - size);
        doc.open(
            Tag::new("g")
                .class("collision")
                .attr("data-cycle", index.to_string()),
        );
        doc.leaf(
            Tag::new("path")
                .attr("d", cross.as_str())
                .attr("stroke", "#ffffff")
                .attr("stroke-width", "6")
                .attr("stroke-linecap", "round"),
        );
        doc.leaf(
            Tag::new("path")
                .attr("d", cross.as_str())
                .attr("stroke", "#000000")
                .attr("stroke-width", "3")
                .attr("stroke-linecap", "round"),
        );
        doc.close();
    }
}

/// The robot and its four IR cones at each requested cycle; a cone's shade grows with the
/// reading the sensor gave in that cycle.
fn draw_rays(
    doc: &mut SvgDocument,
    trace: &Trace,
    options: &ReplayOptions,
    transform: &SceneTransform,
    radius_px: f64,
    cones: &dyn Fn(&Pose) -> Vec<IrCone>,
    colours: &BTreeMap<Option<u16>, &'static str>,
) {
    for &cycle_index in &options.rays_at_cycles {
        let Some(cycle) = trace.cycles.get(cycle_index as usize) else {
            continue;
        };
        if !finite(cycle.robot.position()) {
            continue;
        }
        doc.open(
            Tag::new("g")
                .class("ray-snapshot")
                .attr("data-cycle", cycle_index.to_string()),
        );
        for (sensor, &(origin, first, last, range)) in cones(&cycle.robot).iter().enumerate() {
            if !(finite(origin)
                && finite(first)
                && finite(last)
                && range.is_finite()
                && range > 0.0)
            {
                continue;
            }
            let at = |direction: [f32; 2]| {
                transform.apply([
                    origin[0] + range * direction[0],
                    origin[1] + range * direction[1],
                ])
            };
            let centre = transform.apply(origin);
            let (a, b) = (at(first), at(last));
            // On screen (y down) the arc turns the positive way, SVG's sweep flag 1, when the
            // cross product of the two screen directions is positive.
            let cross =
                (a[0] - centre[0]) * (b[1] - centre[1]) - (a[1] - centre[1]) * (b[0] - centre[0]);
            let dot =
                (a[0] - centre[0]) * (b[0] - centre[0]) + (a[1] - centre[1]) * (b[1] - centre[1]);
            let large = cross.abs() < 1e-9 && dot < 0.0;
            let wedge = PathData::new()
                .move_to(centre[0], centre[1])
                .line_to(a[0], a[1])
                .arc_to(
                    transform.length(range as f64),
                    large,
                    cross > 0.0,
                    b[0],
                    b[1],
                )
                .close();
            let reading = cycle
                .frame
                .values(InputGroup::IR)
                .get(sensor)
                .copied()
                .unwrap_or(0.0)
                .clamp(0.0, 1.0) as f64;
            let reading = if reading.is_finite() { reading } else { 0.0 };
            doc.leaf(
                Tag::new("path")
                    .class("ir-cone")
                    .attr("data-sensor", sensor.to_string())
                    .attr("data-reading", num_with(reading, 3))
                    .attr("d", wedge.as_str())
                    .attr("fill", CONE_COLOUR)
                    .attr("fill-opacity", num_with(0.18 + 0.6 * reading, 3))
                    .attr("stroke", "#0072B2")
                    .attr("stroke-width", "1"),
            );
        }
        // The snapshot's outline takes the colour of the controller driving at that cycle.
        let leaf = leaf_of(&cycle.active_path);
        let colour = colours.get(&leaf).copied().unwrap_or(INK);
        let centre = transform.apply(cycle.robot.position());
        let style = RobotStyle {
            fill: "#f4f4f4",
            outline: colour,
            outline_width: 3.0,
            heading: INK,
        };
        draw_robot(
            doc,
            Tag::new("g").class("ray-robot"),
            centre,
            cycle.robot.heading,
            radius_px,
            style,
        );
        // Above the disc, so it never meets the start label, which sits below the start.
        doc.text(
            halo_label(
                "ray-label",
                centre[0],
                centre[1] - radius_px - 7.0,
                "middle",
            ),
            &format!("cycle {cycle_index}"),
        );
        doc.close();
    }
}

/// How a start ring is painted: its colour and stroke width, pixels.
#[derive(Debug, Clone, Copy)]
struct RingStyle<'a> {
    colour: &'a str,
    width: f64,
}

/// The focal robot's start: dark, like its final pose.
const START_RING: RingStyle<'static> = RingStyle {
    colour: INK,
    width: 2.0,
};

/// A ring where a robot started, with a tick from its centre towards its heading (world
/// radians); the caller wraps it in a group.
fn draw_start_ring(
    doc: &mut SvgDocument,
    at: [f64; 2],
    heading: f32,
    radius_px: f64,
    style: RingStyle<'_>,
) {
    doc.leaf(
        Tag::new("circle")
            .num("cx", at[0])
            .num("cy", at[1])
            .num("r", radius_px)
            .attr("fill", "#ffffff")
            .attr("fill-opacity", "0.7")
            .attr("stroke", style.colour)
            .num("stroke-width", style.width),
    );
    let heading = heading as f64;
    let tip = [
        at[0] + radius_px * heading.cos(),
        at[1] - radius_px * heading.sin(),
    ];
    doc.leaf(
        Tag::new("line")
            .num("x1", at[0])
            .num("y1", at[1])
            .num("x2", tip[0])
            .num("y2", tip[1])
            .attr("stroke", style.colour)
            .num("stroke-width", style.width)
            .attr("stroke-linecap", "round"),
    );
}

/// A ring where the robot started, labelled.
fn draw_start(doc: &mut SvgDocument, trace: &Trace, transform: &SceneTransform, radius_px: f64) {
    let start = trace.cycles.first().map_or(trace.final_robot, |c| c.robot);
    if !finite(start.position()) {
        return;
    }
    let at = transform.apply(start.position());
    doc.open(Tag::new("g").class("start"));
    draw_start_ring(doc, at, start.heading, radius_px, START_RING);
    doc.text(
        halo_label("start-label", at[0], at[1] + radius_px + 15.0, "middle"),
        "start",
    );
    doc.close();
}

/// The animated focal robot: white with a black rim, so it stands out over every path.
const ANIMATED_ROBOT: RobotStyle<'static> = RobotStyle {
    fill: "#ffffff",
    outline: "#000000",
    outline_width: 2.5,
    heading: "#000000",
};

/// The id of the focal robot's animated move: every other animation starts with it.
const ANIMATION_ID: &str = "replay-move";

/// A robot disc that drives the trajectory in a loop at [`ANIMATION_SPEEDUP`] times real
/// time, pausing at the end, and a team's other robots moving in step with it. Translation
/// and rotation are separate keyframed transforms (one value per cycle, evenly spaced like the
/// cycles), so a disc turns in place when its robot does, which a path-following animation
/// could not show.
fn draw_animation(
    doc: &mut SvgDocument,
    trace: &Trace,
    team: &[TeamGroup<'_>],
    transform: &SceneTransform,
    radius_px: f64,
) {
    let poses: Vec<Pose> = trace
        .cycles
        .iter()
        .map(|c| c.robot)
        .chain(std::iter::once(trace.final_robot))
        .filter(|p| finite(p.position()) && p.heading.is_finite())
        .collect();
    if poses.len() < 2 {
        return;
    }
    let seconds = (poses.len() - 1) as f64 * CYCLE_SECONDS / ANIMATION_SPEEDUP;
    let loop_begin = format!(
        "0s;{ANIMATION_ID}.end+{}s",
        num_with(ANIMATION_PAUSE_SECONDS, 3)
    );
    let team_begin = format!("{ANIMATION_ID}.begin");
    // Under the robots, as the dashboard's slider draws them.
    draw_animated_bodies(doc, trace, transform, seconds, &team_begin);
    for group in team {
        for member in group.members.clone() {
            let member_poses = team_member_poses(trace, member);
            let marker = AnimatedMarker {
                class: "animated-team-robot",
                id: None,
                begin: &team_begin,
                size: 1.0,
                style: team_final_style(group.colour),
            };
            draw_animated_robot(doc, &member_poses, seconds, transform, radius_px, marker);
        }
    }
    let marker = AnimatedMarker {
        class: "animated-robot",
        id: Some(ANIMATION_ID),
        begin: &loop_begin,
        size: 1.15,
        style: ANIMATED_ROBOT,
    };
    draw_animated_robot(doc, &poses, seconds, transform, radius_px, marker);
}

/// What an animated robot looks like and when it moves.
#[derive(Debug, Clone, Copy)]
struct AnimatedMarker<'a> {
    class: &'a str,
    /// The id of its move, for the robot whose loop the others follow.
    id: Option<&'a str>,
    /// When its move starts (its rotation always starts with the focal robot's move).
    begin: &'a str,
    /// Its radius in robot radii.
    size: f64,
    style: RobotStyle<'a>,
}

/// One robot disc moving through `poses` in `seconds`, held at the last pose between loops;
/// nothing for fewer than two poses.
fn draw_animated_robot(
    doc: &mut SvgDocument,
    poses: &[Pose],
    seconds: f64,
    transform: &SceneTransform,
    radius_px: f64,
    marker: AnimatedMarker<'_>,
) {
    if poses.len() < 2 {
        return;
    }
    let positions: Vec<[f64; 2]> = poses
        .iter()
        .map(|p| transform.apply(p.position()))
        .collect();
    let rotations: Vec<f64> =
        unwrapped_degrees(&poses.iter().map(|p| p.heading).collect::<Vec<_>>())
            .into_iter()
            .map(|d| -d)
            .collect();
    let rotate_values: Vec<String> = rotations.iter().map(|r| crate::svg::num(*r)).collect();
    let duration = format!("{}s", num_with(seconds, 3));
    open_moving_group(
        doc,
        marker.class,
        &positions,
        &duration,
        marker.begin,
        marker.id,
    );
    doc.open(Tag::new("g").attr("transform", format!("rotate({})", rotate_values[0])));
    doc.leaf(
        Tag::new("animateTransform")
            .attr("attributeName", "transform")
            .attr("type", "rotate")
            .attr("calcMode", "linear")
            .attr("values", rotate_values.join(";"))
            .attr("dur", &duration)
            .attr("begin", format!("{ANIMATION_ID}.begin"))
            .attr("fill", "freeze"),
    );
    let radius = radius_px * marker.size;
    let style = marker.style;
    doc.leaf(
        Tag::new("circle")
            .num("cx", 0.0)
            .num("cy", 0.0)
            .num("r", radius)
            .attr("fill", style.fill)
            .attr("stroke", style.outline)
            .num("stroke-width", style.outline_width),
    );
    doc.leaf(
        Tag::new("line")
            .num("x1", 0.0)
            .num("y1", 0.0)
            .num("x2", radius)
            .num("y2", 0.0)
            .attr("stroke", style.heading)
            .num("stroke-width", style.outline_width)
            .attr("stroke-linecap", "round"),
    );
    doc.close();
    doc.close();
}

/// Opens a group of `class` that moves through `positions` (pixels, evenly spaced over
/// `duration`) from `begin`, held at the last between loops: the shared shape of every animated
/// marker. Its move has the id `id` when given. The caller draws the marker and closes it.
fn open_moving_group(
    doc: &mut SvgDocument,
    class: &str,
    positions: &[[f64; 2]],
    duration: &str,
    begin: &str,
    id: Option<&str>,
) {
    let values: Vec<String> = positions
        .iter()
        .map(|p| format!("{},{}", crate::svg::num(p[0]), crate::svg::num(p[1])))
        .collect();
    doc.open(
        Tag::new("g")
            .class(class)
            .attr("transform", format!("translate({})", values[0])),
    );
    let mut translate = Tag::new("animateTransform");
    if let Some(id) = id {
        translate = translate.attr("id", id);
    }
    doc.leaf(
        translate
            .attr("attributeName", "transform")
            .attr("type", "translate")
            .attr("calcMode", "linear")
            .attr("values", values.join(";"))
            .attr("dur", duration)
            .attr("begin", begin)
            .attr("fill", "freeze"),
    );
}

/// An animated item's look in one cycle: on the floor, carried or delivered, as the letters
/// `f`, `c` and `d` of the dashboard's tracks.
fn item_look(carried: bool, delivered: bool) -> (&'static str, &'static str) {
    match (carried, delivered) {
        (_, true) => (DELIVERED_COLOUR, "none"),
        (true, false) => (ITEM_COLOUR, "#000000"),
        (false, false) => (ITEM_COLOUR, "none"),
    }
}

/// What a [`BodyPath`] follows.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum BodyKind {
    /// A mover (`[[movers]]`).
    Mover,
    /// A box robots push (`[[boxes]]`).
    Box,
    /// An item (`[[objects]]`).
    Item,
}

/// One mover, box or item of a trace: its centre at the start of each cycle and where it
/// ended, in metres, and for an item its state at each of those.
#[derive(Debug, Clone, PartialEq)]
pub struct BodyPath {
    /// What it is.
    pub kind: BodyKind,
    /// Its radius, metres.
    pub radius: f32,
    /// Its centre at the start of each cycle, then at the end.
    pub places: Vec<[f32; 2]>,
    /// An item's `(carried, delivered)` at each place; empty for movers and boxes.
    pub item_states: Vec<(bool, bool)>,
}

/// Every mover, then box, then item of `trace`, cycle by cycle and then where it ended: what
/// an animated replay and the dashboard's slider move. A body that a cycle lacks, or whose
/// places or radius are not all finite, is left out.
pub fn body_paths(trace: &Trace) -> Vec<BodyPath> {
    let bodies = trace
        .movers
        .iter()
        .map(|m| (BodyKind::Mover, m.radius, m.end))
        .chain(trace.boxes.iter().map(|b| (BodyKind::Box, b.radius, b.end)));
    let movers_and_boxes = bodies
        .enumerate()
        .filter_map(|(index, (kind, radius, end))| {
            let places = trace
                .cycles
                .iter()
                .map(|c| c.bodies.get(index).copied())
                .chain([Some(end)])
                .collect::<Option<Vec<[f32; 2]>>>()?;
            Some(BodyPath {
                kind,
                radius,
                places,
                item_states: Vec::new(),
            })
        });
    let items = trace.items.iter().enumerate().filter_map(|(index, item)| {
        let end = CycleItem {
            at: item.end,
            carried: item.carried,
            delivered: item.delivered,
        };
        let cycles = trace
            .cycles
            .iter()
            .map(|c| c.items.get(index).copied())
            .chain([Some(end)])
            .collect::<Option<Vec<CycleItem>>>()?;
        Some(BodyPath {
            kind: BodyKind::Item,
            radius: ITEM_RADIUS,
            places: cycles.iter().map(|c| c.at).collect(),
            item_states: cycles.iter().map(|c| (c.carried, c.delivered)).collect(),
        })
    });
    movers_and_boxes
        .chain(items)
        .filter(|path| path.radius.is_finite() && path.places.iter().all(|&p| finite(p)))
        .collect()
}

/// The movers, boxes and items of a sample ([`body_paths`]), each moving in step with the
/// focal robot (one place per cycle and its end, over `seconds`, from `begin`) and looking as
/// the dashboard's slider draws them: a mover a blue-grey diamond, a box a brown square, an
/// item an orange disc, outlined black while carried and green once delivered.
fn draw_animated_bodies(
    doc: &mut SvgDocument,
    trace: &Trace,
    transform: &SceneTransform,
    seconds: f64,
    begin: &str,
) {
    let duration = format!("{}s", num_with(seconds, 3));
    for path in body_paths(trace) {
        let positions: Vec<[f64; 2]> = path.places.iter().map(|&p| transform.apply(p)).collect();
        let half = transform.length(f64::from(path.radius)).max(3.0);
        let (class, colour, turn) = match path.kind {
            BodyKind::Mover => ("animated-mover", MOVER_COLOUR, 45.0),
            BodyKind::Box => ("animated-box", BOX_COLOUR, 0.0),
            BodyKind::Item => ("animated-item", ITEM_COLOUR, 0.0),
        };
        open_moving_group(doc, class, &positions, &duration, begin, None);
        if path.kind != BodyKind::Item {
            doc.leaf(
                Tag::new("rect")
                    .num("x", -half)
                    .num("y", -half)
                    .num("width", 2.0 * half)
                    .num("height", 2.0 * half)
                    .attr("transform", format!("rotate({turn})"))
                    .attr("fill", colour)
                    .attr("fill-opacity", "0.45")
                    .attr("stroke", colour)
                    .num("stroke-width", 2.0),
            );
            doc.close();
            continue;
        }
        let looks: Vec<(&str, &str)> = path
            .item_states
            .iter()
            .map(|&(carried, delivered)| item_look(carried, delivered))
            .collect();
        let (fill, stroke) = looks[0];
        doc.open(
            Tag::new("circle")
                .num("r", half)
                .attr("fill", fill)
                .attr("stroke", stroke)
                .num("stroke-width", 1.5),
        );
        // Its look changes only when it is picked up or delivered: one discrete animation per
        // attribute, left out when the look never changes.
        if looks.iter().any(|look| *look != looks[0]) {
            for (attribute, values) in [
                ("fill", looks.iter().map(|l| l.0).collect::<Vec<_>>()),
                ("stroke", looks.iter().map(|l| l.1).collect()),
            ] {
                doc.leaf(
                    Tag::new("animate")
                        .attr("attributeName", attribute)
                        .attr("calcMode", "discrete")
                        .attr("values", values.join(";"))
                        .attr("dur", &duration)
                        .attr("begin", begin)
                        .attr("fill", "freeze"),
                );
            }
        }
        doc.close();
        doc.close();
    }
}

/// One entry of the symbol key under the legend.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum KeySymbol<'t> {
    Start,
    FinalRobot,
    Collision,
    LightFlashes,
    LightDark,
    Goal,
    Exit,
    Teammate,
    Cones,
    Animated,
    /// An item (`[[objects]]`): a ring where it started, a disc where it ended.
    Item,
    /// An item delivered in the nest.
    ItemDelivered,
    /// A mover (`[[movers]]`): its path, its disc where it ended.
    Mover,
    /// A box (`[[boxes]]`): a ring where it started, a disc where it ended.
    Box,
    /// A group of a team's other robots: its colour, name and count.
    Team(&'t TeamGroup<'t>),
}

impl KeySymbol<'_> {
    fn words(self) -> String {
        let fixed = match self {
            KeySymbol::Team(group) => return group.words(),
            KeySymbol::Start => "start",
            KeySymbol::FinalRobot => "final pose",
            KeySymbol::Collision => "collision",
            KeySymbol::LightFlashes => "light that flashes",
            KeySymbol::LightDark => "light that stays dark",
            KeySymbol::Goal => "goal",
            KeySymbol::Exit => "room exit",
            KeySymbol::Item => "item: start, end",
            KeySymbol::ItemDelivered => "item delivered",
            KeySymbol::Mover => "mover: path, end",
            KeySymbol::Box => "box: start, end",
            KeySymbol::Teammate => "teammate and its path",
            KeySymbol::Cones => "IR cones (shade = reading)",
            KeySymbol::Animated => "animated robot, 10x real time",
        };
        fixed.to_string()
    }
}

/// The symbols this picture uses, in a fixed order.
fn key_items<'t>(
    trace: &Trace,
    options: &ReplayOptions,
    team: &'t [TeamGroup<'t>],
) -> Vec<KeySymbol<'t>> {
    let mut items = vec![KeySymbol::Start, KeySymbol::FinalRobot];
    if trace.cycles.iter().any(|c| c.collided) {
        items.push(KeySymbol::Collision);
    }
    if trace.lights.iter().any(|(_, flashes)| *flashes) {
        items.push(KeySymbol::LightFlashes);
    }
    if trace.lights.iter().any(|(_, flashes)| !*flashes) {
        items.push(KeySymbol::LightDark);
    }
    if trace.goal.is_some() {
        items.push(KeySymbol::Goal);
    }
    if trace.exit.is_some() {
        items.push(KeySymbol::Exit);
    }
    if trace.cycles.iter().any(|c| c.teammate.is_some()) {
        items.push(KeySymbol::Teammate);
    }
    items.extend(team.iter().map(KeySymbol::Team));
    if !trace.items.is_empty() {
        items.push(KeySymbol::Item);
    }
    if trace.items.iter().any(|item| item.delivered) {
        items.push(KeySymbol::ItemDelivered);
    }
    if !trace.movers.is_empty() {
        items.push(KeySymbol::Mover);
    }
    if !trace.boxes.is_empty() {
        items.push(KeySymbol::Box);
    }
    if options
        .rays_at_cycles
        .iter()
        .any(|&c| (c as usize) < trace.cycles.len())
    {
        items.push(KeySymbol::Cones);
    }
    if options.animate && !trace.cycles.is_empty() {
        items.push(KeySymbol::Animated);
    }
    items
}

/// Where a key entry goes: row, and x of its symbol's left edge.
#[derive(Debug, Clone, Copy)]
struct KeySlot<'t> {
    symbol: KeySymbol<'t>,
    row: usize,
    x: f64,
}

/// Flows the key entries left to right, wrapping at the picture's width.
fn layout_key<'t>(items: &[KeySymbol<'t>]) -> Vec<KeySlot<'t>> {
    let mut slots = Vec::new();
    let (mut row, mut x) = (0, PAD);
    for &symbol in items {
        let width = 26.0 + text_width(&symbol.words(), LABEL_FONT) + 18.0;
        if x + width > WIDTH - PAD && x > PAD {
            row += 1;
            x = PAD;
        }
        slots.push(KeySlot { symbol, row, x });
        x += width;
    }
    slots
}

/// Draws the symbol key: each symbol as it appears in the scene, then its meaning.
fn draw_key(doc: &mut SvgDocument, items: &[KeySymbol<'_>], top: f64) {
    doc.open(Tag::new("g").class("key"));
    for slot in layout_key(items) {
        let y = top + slot.row as f64 * 24.0;
        let centre = [slot.x + 10.0, y - 5.0];
        match slot.symbol {
            KeySymbol::Start => {
                doc.leaf(
                    Tag::new("circle")
                        .num("cx", centre[0])
                        .num("cy", centre[1])
                        .num("r", 7.0)
                        .attr("fill", "#ffffff")
                        .attr("stroke", INK)
                        .attr("stroke-width", "2"),
                );
            }
            KeySymbol::FinalRobot => {
                draw_robot(doc, Tag::new("g"), centre, 0.0, 7.0, FINAL_ROBOT);
            }
            KeySymbol::Mover => {
                doc.leaf(
                    Tag::new("line")
                        .num("x1", centre[0] - 9.0)
                        .num("y1", centre[1])
                        .num("x2", centre[0] + 9.0)
                        .num("y2", centre[1])
                        .attr("stroke", MOVER_COLOUR)
                        .attr("stroke-width", "1"),
                );
                doc.leaf(
                    Tag::new("circle")
                        .num("cx", centre[0] + 4.0)
                        .num("cy", centre[1])
                        .num("r", 4.0)
                        .attr("fill", MOVER_COLOUR),
                );
            }
            KeySymbol::Item | KeySymbol::ItemDelivered | KeySymbol::Box => {
                let (ring, disc) = match slot.symbol {
                    KeySymbol::Item => (Some(ITEM_COLOUR), ITEM_COLOUR),
                    KeySymbol::Box => (Some(BOX_COLOUR), BOX_COLOUR),
                    _ => (None, DELIVERED_COLOUR),
                };
                if let Some(colour) = ring {
                    doc.leaf(
                        Tag::new("circle")
                            .num("cx", centre[0] - 4.0)
                            .num("cy", centre[1])
                            .num("r", 4.0)
                            .attr("fill", "none")
                            .attr("stroke", colour)
                            .attr("stroke-width", "1.2"),
                    );
                }
                doc.leaf(
                    Tag::new("circle")
                        .num("cx", centre[0] + if ring.is_some() { 5.0 } else { 0.0 })
                        .num("cy", centre[1])
                        .num("r", 4.0)
                        .attr("fill", disc),
                );
            }
            KeySymbol::Collision => {
                let d = PathData::new()
                    .move_to(centre[0] - 5.0, centre[1] - 5.0)
                    .line_to(centre[0] + 5.0, centre[1] + 5.0)
                    .move_to(centre[0] - 5.0, centre[1] + 5.0)
                    .line_to(centre[0] + 5.0, centre[1] - 5.0);
                doc.leaf(
                    Tag::new("path")
                        .attr("d", d.as_str())
                        .attr("stroke", "#000000")
                        .attr("stroke-width", "3"),
                );
            }
            KeySymbol::LightFlashes | KeySymbol::LightDark => {
                let flashes = slot.symbol == KeySymbol::LightFlashes;
                doc.leaf(
                    Tag::new("circle")
                        .num("cx", centre[0])
                        .num("cy", centre[1])
                        .num("r", 6.0)
                        .attr("fill", if flashes { LIGHT_ON_COLOUR } else { "#ffffff" })
                        .attr("stroke", if flashes { INK } else { "#888888" })
                        .attr("stroke-width", "1.5"),
                );
            }
            KeySymbol::Goal => {
                doc.leaf(
                    Tag::new("circle")
                        .num("cx", centre[0])
                        .num("cy", centre[1])
                        .num("r", 7.0)
                        .attr("fill", "none")
                        .attr("stroke", "#009E73")
                        .attr("stroke-width", "2.5"),
                );
                doc.leaf(
                    Tag::new("circle")
                        .num("cx", centre[0])
                        .num("cy", centre[1])
                        .num("r", 2.8)
                        .attr("fill", "#009E73"),
                );
            }
            KeySymbol::Exit => {
                doc.leaf(
                    Tag::new("polygon")
                        .points(&[
                            [centre[0] + 8.0, centre[1]],
                            [centre[0] - 2.0, centre[1] - 6.0],
                            [centre[0] - 2.0, centre[1] + 6.0],
                        ])
                        .attr("fill", "#009E73"),
                );
                doc.leaf(
                    Tag::new("line")
                        .num("x1", centre[0] - 10.0)
                        .num("y1", centre[1])
                        .num("x2", centre[0])
                        .num("y2", centre[1])
                        .attr("stroke", "#009E73")
                        .attr("stroke-width", "3"),
                );
            }
            KeySymbol::Teammate => {
                doc.leaf(
                    Tag::new("line")
                        .num("x1", centre[0] - 10.0)
                        .num("y1", centre[1])
                        .num("x2", centre[0] + 2.0)
                        .num("y2", centre[1])
                        .attr("stroke", TEAMMATE_COLOUR)
                        .attr("stroke-width", "2")
                        .attr("stroke-dasharray", "6 4"),
                );
                draw_robot(
                    doc,
                    Tag::new("g"),
                    [centre[0] + 4.0, centre[1]],
                    0.0,
                    6.0,
                    TEAMMATE_ROBOT,
                );
            }
            KeySymbol::Cones => {
                let d = PathData::new()
                    .move_to(centre[0] - 8.0, centre[1])
                    .line_to(centre[0] + 9.0, centre[1] - 7.0)
                    .line_to(centre[0] + 9.0, centre[1] + 7.0)
                    .close();
                doc.leaf(
                    Tag::new("path")
                        .attr("d", d.as_str())
                        .attr("fill", CONE_COLOUR)
                        .attr("fill-opacity", "0.5")
                        .attr("stroke", "#0072B2"),
                );
            }
            KeySymbol::Animated => {
                draw_robot(doc, Tag::new("g"), centre, 0.0, 7.0, ANIMATED_ROBOT);
            }
            KeySymbol::Team(group) => {
                doc.leaf(
                    Tag::new("line")
                        .num("x1", centre[0] - 10.0)
                        .num("y1", centre[1])
                        .num("x2", centre[0] + 2.0)
                        .num("y2", centre[1])
                        .attr("stroke", group.colour)
                        .num("stroke-width", TEAM_PATH_WIDTH),
                );
                draw_robot(
                    doc,
                    Tag::new("g"),
                    [centre[0] + 4.0, centre[1]],
                    0.0,
                    6.0,
                    team_final_style(group.colour),
                );
            }
        }
        doc.text(
            Tag::new("text")
                .class("key-label")
                .num("x", slot.x + 26.0)
                .num("y", y)
                .num("font-size", LABEL_FONT)
                .attr("fill", INK),
            &slot.symbol.words(),
        );
    }
    doc.close();
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::svg::PALETTE;
    use crate::svg::read_back::{Element, parse, with_class};
    use hevo_sim_core::SensorFrame;
    use hevo_sim_core::{Evaluator, Policy, Sample, TaskConfig};
    use std::collections::BTreeSet;

    /// A hand-written maze driver shaped like a controller tree: a root arbitrator over
    /// "follow wall", "turn left" and "turn right". It keeps to the middle of the corridor,
    /// remembers which side the last light flashed on, and at a junction turns that way.
    #[derive(Debug)]
    struct ScriptedMazeDriver {
        path: [usize; 2],
        turn_towards_left: Option<bool>,
        turning_cycles: u32,
    }

    impl ScriptedMazeDriver {
        fn new() -> ScriptedMazeDriver {
            ScriptedMazeDriver {
                path: [0, 1],
                turn_towards_left: None,
                turning_cycles: 0,
            }
        }

        const NAMES: [&'static str; 4] = [
            "solve_maze",
            "solve_maze/follow_wall",
            "solve_maze/turn_left",
            "solve_maze/turn_right",
        ];
    }

    impl Policy for ScriptedMazeDriver {
        fn reset(&mut self) {
            *self = ScriptedMazeDriver::new();
        }

        fn step(&mut self, frame: &SensorFrame, _dt: f32) -> [f32; 2] {
            let ir = frame.values(InputGroup::IR);
            let (front_left, left, right, front_right) = (ir[0], ir[1], ir[2], ir[3]);
            let light = frame.values(InputGroup::LIGHT);
            if light[0] > 0.5 {
                self.turn_towards_left = Some(true);
            } else if light[1] > 0.5 {
                self.turn_towards_left = Some(false);
            }
            let front = front_left.max(front_right);
            if self.turning_cycles > 0 {
                self.turning_cycles -= 1;
            } else if front > 0.2
                || (left < 0.02 && right < 0.02 && self.turn_towards_left.is_some())
            {
                // Blocked ahead, or a junction: turn to the remembered side, else to the open one.
                let towards_left = self.turn_towards_left.take().unwrap_or(left < right);
                self.path = [0, if towards_left { 2 } else { 3 }];
                self.turning_cycles = 6;
            } else {
                self.path = [0, 1];
            }
            match self.path[1] {
                2 => [0.35, 0.9],
                3 => [0.9, 0.35],
                _ => {
                    let steer = 0.6 * (left - right) + 0.4 * (front_left - front_right);
                    [
                        (0.85 + steer).clamp(0.0, 1.0),
                        (0.85 - steer).clamp(0.0, 1.0),
                    ]
                }
            }
        }

        fn active_path(&self) -> &[usize] {
            &self.path
        }

        fn n_nodes(&self) -> usize {
            4
        }
    }

    /// Drives in a slow circle, so it hits the walls of any room eventually.
    #[derive(Debug)]
    struct Circler;

    impl Policy for Circler {
        fn reset(&mut self) {}
        fn step(&mut self, _frame: &SensorFrame, _dt: f32) -> [f32; 2] {
            [1.0, 0.8]
        }
    }

    /// Every named region of a shipped scenario's sample is shaded (one group per region, a
    /// rectangle per cell, to scale) and labelled once with its name, and no two labels'
    /// boxes overlap.
    #[test]
    fn a_scenario_picture_shades_and_names_every_region() {
        for (name, seed) in [
            ("rescue", 4),
            ("solve_maze", 0),
            ("turn_right", 2),
            ("exit_room", 1),
        ] {
            let task = TaskConfig::shipped(name).unwrap();
            let evaluator = Evaluator::new(task.clone()).unwrap();
            let sample = Sample::seeded(seed);
            let trace = evaluator.evaluate_traced(&mut Circler, sample);
            let regions = hevo_sim_core::named_regions(&task, &evaluator.environment(sample));
            assert!(regions.len() >= 2, "{name}: {regions:?}");
            let svg = scenario_svg(&trace, &ReplayOptions::default(), &regions);
            let elements = parse(&svg).unwrap();
            let (scale, origin_x, origin_y) = scene_attributes(&elements);
            let labels: Vec<&Element> = with_class(&elements, "region-label");
            let label_names: BTreeSet<&str> = labels.iter().map(|l| l.text.as_str()).collect();
            let region_names: BTreeSet<&str> = regions.iter().map(|r| r.name.as_str()).collect();
            assert_eq!(label_names, region_names, "{name}");
            assert_eq!(labels.len(), regions.len(), "{name}: one label per region");
            // No controller drove it: no legend naming one.
            for class in ["legend-title", "legend", "legend-swatch", "legend-cycles"] {
                assert!(with_class(&elements, class).is_empty(), "{name}: {class}");
            }
            for region in &regions {
                let shaded: Vec<&Element> = with_class(&elements, "region-rect")
                    .into_iter()
                    .filter(|e| e.get("data-name") == region.name)
                    .collect();
                assert_eq!(shaded.len(), region.rects.len(), "{name}: {}", region.name);
                // Each of the region's rectangles is drawn where the transform puts it.
                for r in &region.rects {
                    let x = origin_x + scale * r[0] as f64;
                    let y = origin_y - scale * r[3] as f64;
                    let w = scale * (r[2] - r[0]) as f64;
                    assert!(
                        shaded.iter().any(|e| (e.number("x") - x).abs() < 0.01
                            && (e.number("y") - y).abs() < 0.01
                            && (e.number("width") - w).abs() < 0.01),
                        "{name}: {} at {r:?} not drawn to scale",
                        region.name
                    );
                }
            }
            // Labels keep clear of each other.
            let boxes: Vec<[f64; 4]> = labels
                .iter()
                .map(|l| {
                    let half = 0.5 * text_width(&l.text, LABEL_FONT);
                    let (x, y) = (l.number("x"), l.number("y"));
                    [x - half, y - LABEL_FONT + 2.0, x + half, y]
                })
                .collect();
            let overlap = |a: &[f64; 4], b: &[f64; 4]| {
                a[0] < b[2] && b[0] < a[2] && a[1] < b[3] && b[1] < a[3]
            };
            for (i, a) in boxes.iter().enumerate() {
                for b in &boxes[i + 1..] {
                    assert!(!overlap(a, b), "{name}: labels overlap: {a:?} {b:?}");
                }
            }
            // Nor do they cover the start's label.
            for start in with_class(&elements, "start-label") {
                let half = 0.5 * text_width(&start.text, LABEL_FONT);
                let (x, y) = (start.number("x"), start.number("y"));
                let start_box = [x - half, y - LABEL_FONT + 2.0, x + half, y];
                for b in &boxes {
                    assert!(
                        !overlap(&start_box, b),
                        "{name}: {b:?} covers the start label"
                    );
                }
            }
        }
    }

    /// A plain replay draws no regions.
    #[test]
    fn a_replay_has_no_region_layer() {
        let (_, trace) = maze_trace(0);
        let svg = replay_svg(&trace, &maze_options(), &|_| Vec::new());
        assert!(!svg.contains("region"));
    }

    fn maze_trace(seed: u64) -> (Evaluator, Trace) {
        let evaluator =
            Evaluator::new(TaskConfig::shipped("solve_maze").unwrap()).expect("task is valid");
        let trace = evaluator.evaluate_traced(&mut ScriptedMazeDriver::new(), Sample::seeded(seed));
        (evaluator, trace)
    }

    fn maze_options() -> ReplayOptions {
        ReplayOptions {
            node_names: ScriptedMazeDriver::NAMES
                .iter()
                .map(|s| s.to_string())
                .collect(),
            rays_at_cycles: vec![10],
            animate: false,
            title: None,
            robot_radius: 0.0375,
            caption: None,
        }
    }

    fn render(
        trace: &Trace,
        evaluator: &Evaluator,
        options: &ReplayOptions,
    ) -> (String, Vec<Element>) {
        let svg = replay_svg(trace, options, &|pose| evaluator.ir_cones(pose));
        let elements = parse(&svg).unwrap_or_else(|e| panic!("malformed SVG: {e}"));
        (svg, elements)
    }

    /// The scene's documented scale and origin attributes: pixels per metre, and the pixel
    /// position of the world's origin.
    fn scene_attributes(elements: &[Element]) -> (f64, f64, f64) {
        let scene = with_class(elements, "scene")[0];
        (
            scene.number("data-px-per-m"),
            scene.number("data-origin-x"),
            scene.number("data-origin-y"),
        )
    }

    /// Where a world point should be drawn by the scene's attributes, written out: x to the
    /// right from the origin, y upwards, so the pixel row decreases as y grows.
    fn expected_pixel(attributes: (f64, f64, f64), point: [f32; 2]) -> [f64; 2] {
        let (px_per_m, origin_x, origin_y) = attributes;
        [
            origin_x + px_per_m * f64::from(point[0]),
            origin_y - px_per_m * f64::from(point[1]),
        ]
    }

    #[test]
    fn trajectory_points_are_the_robot_positions_to_scale() {
        let (evaluator, trace) = maze_trace(7);
        assert!(
            trace.cycles.len() > 20,
            "the scripted driver should get somewhere"
        );
        let (_, elements) = render(&trace, &evaluator, &maze_options());
        let attributes = scene_attributes(&elements);
        let polylines = with_class(&elements, "trajectory");
        assert!(!polylines.is_empty());
        let mut covered = 0;
        for polyline in &polylines {
            let first = polyline.number("data-first-cycle") as usize;
            let last = polyline.number("data-last-cycle") as usize;
            let points = polyline.points();
            assert_eq!(points.len(), last - first + 1);
            for (offset, point) in points.iter().enumerate() {
                // The robot's position at the start of the cycle; after the last cycle, its
                // final position.
                let cycle = first + offset;
                let position = trace
                    .cycles
                    .get(cycle)
                    .map_or(trace.final_robot.position(), |c| c.robot.position());
                let expected = expected_pixel(attributes, position);
                // Points are written with 2 decimals, the attributes with 4.
                assert!(
                    (point[0] - expected[0]).abs() < 0.01 && (point[1] - expected[1]).abs() < 0.01,
                    "cycle {cycle}: drawn {point:?}, expected {expected:?}"
                );
            }
            let leaf = leaf_of(&trace.cycles[first].active_path)
                .map_or("none".to_string(), |n| n.to_string());
            assert_eq!(polyline.get("data-node"), leaf);
            covered += last - first;
        }
        assert_eq!(
            covered,
            trace.cycles.len(),
            "the runs cover every cycle exactly once"
        );
        // The scale fits the scene into the picture.
        let svg_width = elements[0].number("width");
        assert!(attributes.0 > 100.0 && svg_width == WIDTH);
        for polyline in &polylines {
            for [x, y] in polyline.points() {
                assert!(
                    x > 0.0 && x < svg_width && y > TITLE_HEIGHT,
                    "({x}, {y}) is off the scene"
                );
            }
        }
    }

    #[test]
    fn the_maze_is_drawn_to_its_documented_size_and_place() {
        // The double T-maze (docs/model.md 5.4): cells of 0.30 m from x = -3 to 3 and y = -5
        // to 1, walls 0.10 m thick centred on the cell borders, so the outer faces lie at
        // x = ±(3 × 0.30 + 0.15 + 0.05) = ±1.10 m, y = -5 × 0.30 - 0.20 = -1.70 m and
        // 1 × 0.30 + 0.20 = 0.50 m: 2.20 m by 2.20 m. The scripted driver stays inside, so
        // the walls are the widest thing drawn, and the picture (800 px wide, 16 px padding,
        // the scene below a 44 px title, a 0.06 m margin round the world) is fitted to them by
        // width.
        let (evaluator, trace) = maze_trace(7);
        let (_, elements) = render(&trace, &evaluator, &maze_options());
        let (px_per_m, origin_x, origin_y) = scene_attributes(&elements);
        let expected_px_per_m = (800.0 - 2.0 * 16.0) / (2.2 + 2.0 * 0.06);
        assert!(
            (px_per_m - expected_px_per_m).abs() < 1e-3,
            "{px_per_m} px per m, expected {expected_px_per_m}"
        );
        // Centred left to right on the maze's axis, x = 0; the top margin under the title.
        assert!((origin_x - 400.0).abs() < 1e-3, "origin x {origin_x}");
        let expected_origin_y = 44.0 + expected_px_per_m * (0.5 + 0.06);
        assert!(
            (origin_y - expected_origin_y).abs() < 1e-3,
            "origin y {origin_y}, expected {expected_origin_y}"
        );
        // The walls' drawn corners span exactly the maze's outer faces.
        let corners: Vec<[f64; 2]> = with_class(&elements, "wall")
            .iter()
            .flat_map(|wall| wall.points())
            .collect();
        let span = |axis: usize| {
            let values = corners.iter().map(|c| c[axis]);
            let low = values.clone().fold(f64::INFINITY, f64::min);
            let high = values.fold(f64::NEG_INFINITY, f64::max);
            [low, high]
        };
        let [left, right] = span(0);
        let [top, bottom] = span(1);
        let tolerance = 0.02;
        assert!(
            (left - (400.0 - 1.1 * expected_px_per_m)).abs() < tolerance,
            "{left}"
        );
        assert!(
            (right - (400.0 + 1.1 * expected_px_per_m)).abs() < tolerance,
            "{right}"
        );
        assert!(
            (top - (expected_origin_y - 0.5 * expected_px_per_m)).abs() < tolerance,
            "{top}"
        );
        assert!(
            (bottom - (expected_origin_y + 1.7 * expected_px_per_m)).abs() < tolerance,
            "{bottom}"
        );
    }

    #[test]
    fn legend_names_exactly_the_active_leaves() {
        let (evaluator, trace) = maze_trace(11);
        let (_, elements) = render(&trace, &evaluator, &maze_options());
        let expected: BTreeSet<String> = trace
            .cycles
            .iter()
            .filter_map(|c| c.active_path.last())
            .map(|&leaf| ScriptedMazeDriver::NAMES[leaf as usize].replace('/', " / "))
            .collect();
        let shown: BTreeSet<String> = with_class(&elements, "legend")
            .iter()
            .map(|e| e.text.clone())
            .collect();
        assert_eq!(shown, expected);
        assert!(
            expected.len() >= 2,
            "the driver should both follow walls and turn: {expected:?}"
        );
        let legend_count = with_class(&elements, "legend").len();
        assert_eq!(legend_count, expected.len(), "each leaf once");
        // The cycle counts form a column: one x for every entry (the legend has one column here).
        let count_xs: BTreeSet<String> = with_class(&elements, "legend-cycles")
            .iter()
            .map(|e| e.get("x").to_string())
            .collect();
        assert_eq!(count_xs.len(), 1, "cycle counts at {count_xs:?}");
    }

    #[test]
    fn caption_lights_and_goal_describe_the_sample() {
        let (evaluator, trace) = maze_trace(3);
        let (_, elements) = render(&trace, &evaluator, &maze_options());
        let caption: Vec<&str> = with_class(&elements, "caption")
            .iter()
            .map(|e| e.text.as_str())
            .collect();
        assert!(
            caption[0].contains("solve_maze") && caption[0].contains("seed 3"),
            "{caption:?}"
        );
        assert!(caption[0].contains(&format!("light configuration {}", trace.outcome.variant)));
        assert!(
            caption[1].contains(&format!("{} cycles", trace.outcome.cycles)),
            "{caption:?}"
        );
        assert_eq!(with_class(&elements, "light").len(), trace.lights.len());
        assert_eq!(with_class(&elements, "goal").len(), 1);
        assert_eq!(with_class(&elements, "wall").len(), trace.rects.len());
        for (index, light) in with_class(&elements, "light").iter().enumerate() {
            assert_eq!(light.get("data-flashes"), trace.lights[index].1.to_string());
            let lit = trace
                .cycles
                .iter()
                .position(|c| c.lit_lights & (1 << index) != 0);
            assert_eq!(
                light.attributes.get("data-lit-cycle").cloned(),
                lit.map(|c| c.to_string())
            );
        }
        // Ray snapshot: four cones and a robot at the requested cycle.
        let snapshot = with_class(&elements, "ray-snapshot");
        assert_eq!(snapshot.len(), 1);
        assert_eq!(snapshot[0].get("data-cycle"), "10");
        assert_eq!(with_class(&elements, "ir-cone").len(), 4);
    }

    #[test]
    fn collision_markers_appear_exactly_when_a_cycle_collided() {
        let room =
            Evaluator::new(TaskConfig::shipped("exit_room").unwrap()).expect("task is valid");
        let mut seen_collision = false;
        let mut seen_clean = false;
        for seed in 0..6 {
            // A robot that never moves never collides and one that drives straight on always
            // does, so both cases are always exercised.
            struct Straight;
            impl Policy for Straight {
                fn reset(&mut self) {}
                fn step(&mut self, _frame: &SensorFrame, _dt: f32) -> [f32; 2] {
                    [1.0, 1.0]
                }
            }
            struct Still;
            impl Policy for Still {
                fn reset(&mut self) {}
                fn step(&mut self, _frame: &SensorFrame, _dt: f32) -> [f32; 2] {
                    [0.5, 0.5]
                }
            }
            for trace in [
                room.evaluate_traced(&mut Circler, Sample::seeded(seed)),
                room.evaluate_traced(&mut ScriptedMazeDriver::new(), Sample::seeded(seed)),
                room.evaluate_traced(&mut Still, Sample::seeded(seed)),
                room.evaluate_traced(&mut Straight, Sample::seeded(seed)),
            ] {
                let (_, elements) = render(&trace, &room, &ReplayOptions::default());
                let collided = trace.cycles.iter().any(|c| c.collided);
                assert_eq!(
                    !with_class(&elements, "collision").is_empty(),
                    collided,
                    "seed {seed}"
                );
                assert_eq!(with_class(&elements, "exit").len(), 1);
                assert!(!with_class(&elements, "obstacle").is_empty());
                seen_collision |= collided;
                seen_clean |= !collided;
            }
        }
        assert!(
            seen_collision && seen_clean,
            "both cases should be exercised"
        );
    }

    #[test]
    fn animated_replay_contains_a_looping_animation() {
        let (evaluator, trace) = maze_trace(5);
        let options = ReplayOptions {
            animate: true,
            ..maze_options()
        };
        let (svg, elements) = render(&trace, &evaluator, &options);
        let animations: Vec<&Element> = elements
            .iter()
            .filter(|e| e.name == "animateTransform")
            .collect();
        assert_eq!(animations.len(), 2);
        let values = animations[0].get("values").split(';').count();
        assert_eq!(values, trace.cycles.len() + 1);
        assert!(svg.contains("replay-move.end+"), "the animation loops");
        assert_eq!(with_class(&elements, "animated-robot").len(), 1);
        let (static_svg, _) = render(&trace, &evaluator, &maze_options());
        assert!(!static_svg.contains("animateTransform"));
    }

    #[test]
    fn bad_input_is_drawn_without_panicking() {
        let (evaluator, mut trace) = maze_trace(1);
        trace.cycles[3].robot.x = f32::NAN;
        trace.cycles[4].active_path = vec![0, 99];
        trace.cycles[5].active_path.clear();
        let options = ReplayOptions {
            node_names: vec![],
            rays_at_cycles: vec![1, 1_000_000],
            animate: true,
            title: Some("<odd> & \"title\"".to_string()),
            robot_radius: f32::NAN,
            caption: Some(["<a> & b".to_string(), String::new()]),
        };
        let (svg, elements) = render(&trace, &evaluator, &options);
        assert!(!svg.contains("NaN") && !svg.contains("inf"));
        let title = with_class(&elements, "title")[0];
        assert_eq!(title.text, "<odd> & \"title\"");
        let names: BTreeSet<String> = with_class(&elements, "legend")
            .iter()
            .map(|e| e.text.clone())
            .collect();
        assert!(
            names.contains("node 99") && names.contains("no controller reported"),
            "{names:?}"
        );
        assert_eq!(with_class(&elements, "ray-snapshot").len(), 1);

        let mut empty = trace.clone();
        empty.cycles.clear();
        let (_, elements) = render(&empty, &evaluator, &options);
        assert!(with_class(&elements, "trajectory").is_empty());
        assert_eq!(with_class(&elements, "final-robot").len(), 1);
    }

    #[test]
    fn leaf_colours_follow_the_tree_not_the_trace() {
        let names: Vec<String> = [
            "rescue",
            "rescue/exit_room",
            "rescue/solve_maze",
            "rescue/solve_maze/follow_wall",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        let a = leaf_colours(&names, &[Some(3), Some(1)]);
        let b = leaf_colours(&names, &[Some(1), Some(3)]);
        assert_eq!(a, b);
        assert_eq!(a[&Some(1)], palette_colour(0));
        assert_eq!(a[&Some(3)], palette_colour(1));
        // An arbitrator reported as a leaf gets a colour of its own after the tree's leaves.
        let c = leaf_colours(&names, &[Some(2)]);
        assert_eq!(c[&Some(2)], palette_colour(2));
        assert_eq!(
            display_name(&names, Some(3)),
            "rescue / solve_maze / follow_wall"
        );
    }

    /// An open arena with a group of three wanderers (`fixtures/team_arena.toml`).
    fn team_arena() -> Evaluator {
        let text = include_str!("../fixtures/team_arena.toml");
        let scenario = hevo_sim_core::Scenario::parse(text, "team_arena.toml").unwrap();
        let task = TaskConfig::from_scenario(std::sync::Arc::new(scenario));
        Evaluator::new(task).expect("the arena is a valid task")
    }

    /// The classes of a team's drawing, each of which appears once per other robot.
    const TEAM_ROBOT_CLASSES: [&str; 4] = ["team-robot", "team-path", "team-start", "team-final"];

    #[test]
    fn a_team_trace_draws_each_other_robot() {
        let evaluator = team_arena();
        let trace = evaluator.evaluate_traced(&mut Circler, Sample::seeded(2));
        assert!(trace.cycles.len() > 20, "{:?}", trace.outcome);
        assert!(trace.cycles.iter().all(|c| c.team.len() == 3));
        assert_eq!(trace.team_groups, [("swarm".to_string(), 3)]);
        let (_, elements) = render(&trace, &evaluator, &ReplayOptions::default());
        for class in TEAM_ROBOT_CLASSES {
            assert_eq!(with_class(&elements, class).len(), 3, "{class}");
        }
        let groups = with_class(&elements, "team-group");
        assert_eq!(groups.len(), 1);
        assert_eq!(groups[0].get("data-name"), "swarm");
        assert_eq!(groups[0].get("data-count"), "3");
        // Each path runs through its robot's recorded positions, then its final one, to scale
        // (one path per robot, in document order).
        let attributes = scene_attributes(&elements);
        let robots = with_class(&elements, "team-robot");
        for (robot, path) in robots.iter().zip(with_class(&elements, "team-path")) {
            let member = robot.number("data-member") as usize;
            let points = path.points();
            assert_eq!(points.len(), trace.cycles.len() + 1);
            let positions = trace
                .cycles
                .iter()
                .map(|cycle| cycle.team[member])
                .chain([trace.final_team[member]]);
            for (pose, point) in positions.zip(&points) {
                let expected = expected_pixel(attributes, pose.position());
                assert!(
                    (point[0] - expected[0]).abs() < 0.01 && (point[1] - expected[1]).abs() < 0.01,
                    "member {member}: drawn {point:?}, expected {expected:?}"
                );
            }
        }
        // Thinner than the focal robot's path, which keeps its own colours.
        for path in with_class(&elements, "team-path") {
            assert!(path.number("stroke-width") < TRAJECTORY_WIDTH);
            assert!(!PALETTE.contains(&path.get("stroke")));
        }
        assert_eq!(with_class(&elements, "final-robot").len(), 1);
        assert_eq!(with_class(&elements, "start").len(), 1);
        // The key says how many other robots are drawn.
        let key: Vec<&str> = with_class(&elements, "key-label")
            .iter()
            .map(|e| e.text.as_str())
            .collect();
        assert!(key.contains(&"swarm: 3 other robots"), "{key:?}");
    }

    /// A field of lamps on one schedule (the swarm mission's 25, lit until cycle 300) carries
    /// one label, saying how many lamps it speaks for; a beacon lit from the start says so.
    #[test]
    fn lamps_that_light_alike_share_one_label() {
        let text = include_str!("../../../scenarios/swarm/mission.toml");
        let scenario = hevo_sim_core::Scenario::parse(text, "mission.toml").unwrap();
        let mut task = TaskConfig::from_scenario(std::sync::Arc::new(scenario));
        task.max_cycles = Some(320);
        let evaluator = Evaluator::new(task).unwrap();
        let trace = evaluator.evaluate_traced(&mut Circler, Sample::seeded(1));
        assert_eq!(trace.lights.len(), 25);
        assert_eq!(
            light_label(&trace, 0).as_deref(),
            Some("lit until cycle 300")
        );
        let (_, elements) = render(&trace, &evaluator, &ReplayOptions::default());
        let labels = with_class(&elements, "light-label");
        assert_eq!(labels.len(), 1);
        assert_eq!(labels[0].text, "lit until cycle 300 (25 lights)");
        let arena = team_arena();
        let beacon = arena.evaluate_traced(&mut Circler, Sample::seeded(2));
        assert_eq!(light_label(&beacon, 0).as_deref(), Some("lit at cycle 0"));
    }

    /// A beacon on the east wall (the crossing task's) has its label on the inner side, inside
    /// the picture, where the outer side would run off its edge.
    #[test]
    fn a_label_with_no_room_outside_goes_inside() {
        let (trace, evaluator) =
            swarm_trace(include_str!("../../../scenarios/swarm/crossing.toml"), 2);
        let (_, elements) = render(&trace, &evaluator, &ReplayOptions::default());
        let labels = with_class(&elements, "light-label");
        assert_eq!(labels.len(), 1);
        let label = &labels[0];
        let x = label.number("x");
        assert_eq!(label.get("text-anchor"), "end", "{label:?}");
        assert!(
            x - text_width(&label.text, LABEL_FONT) >= 0.0 && x <= WIDTH,
            "{x}"
        );
    }

    /// The trace of a sample of the shipped scenario `file` (in scenarios/swarm/), driven by
    /// the circling policy.
    fn swarm_trace(text: &str, seed: u64) -> (Trace, Evaluator) {
        let scenario = hevo_sim_core::Scenario::parse(text, "swarm.toml").unwrap();
        let task = TaskConfig::from_scenario(std::sync::Arc::new(scenario));
        let evaluator = Evaluator::new(task).expect("valid");
        let trace = evaluator.evaluate_traced(&mut Circler, Sample::seeded(seed));
        (trace, evaluator)
    }

    #[test]
    fn movers_are_drawn_as_their_paths_and_discs_and_boxes_as_items_are() {
        let (trace, evaluator) =
            swarm_trace(include_str!("../../../scenarios/swarm/crossing.toml"), 1);
        assert_eq!(trace.movers.len(), 3);
        let (_, elements) = render(&trace, &evaluator, &ReplayOptions::default());
        assert_eq!(with_class(&elements, "mover-path").len(), 3);
        let ends = with_class(&elements, "mover-end");
        let attributes = scene_attributes(&elements);
        for (mover, end) in trace.movers.iter().zip(&ends) {
            let expected = expected_pixel(attributes, mover.end);
            assert!((end.number("cx") - expected[0]).abs() < 0.01, "{mover:?}");
            assert!((end.number("cy") - expected[1]).abs() < 0.01, "{mover:?}");
        }
        let key = key_items(&trace, &ReplayOptions::default(), &[]);
        assert!(key.contains(&KeySymbol::Mover) && !key.contains(&KeySymbol::Box));

        let (trace, evaluator) =
            swarm_trace(include_str!("../../../scenarios/swarm/box_pushing.toml"), 1);
        assert_eq!(trace.boxes.len(), 4);
        let (_, elements) = render(&trace, &evaluator, &ReplayOptions::default());
        assert_eq!(with_class(&elements, "box-end").len(), 4);
        let moved = trace.boxes.iter().filter(|one| one.start != one.end);
        assert_eq!(with_class(&elements, "box-start").len(), moved.count());
        assert!(with_class(&elements, "mover-path").is_empty());
        let key = key_items(&trace, &ReplayOptions::default(), &[]);
        assert!(key.contains(&KeySymbol::Box) && !key.contains(&KeySymbol::Mover));
        // A trace without bodies draws none.
        let mut without = trace.clone();
        without.boxes.clear();
        let (_, elements) = render(&without, &evaluator, &ReplayOptions::default());
        assert!(with_class(&elements, "bodies").is_empty());
    }

    #[test]
    fn a_foraging_trace_draws_every_item_where_it_started_and_ended() {
        let text = include_str!("../../../scenarios/swarm/foraging.toml");
        let scenario = hevo_sim_core::Scenario::parse(text, "foraging.toml").unwrap();
        let task = TaskConfig::from_scenario(std::sync::Arc::new(scenario));
        let evaluator = Evaluator::new(task).expect("valid");
        let trace = evaluator.evaluate_traced(&mut Circler, Sample::seeded(1));
        assert_eq!(trace.items.len(), 10);
        let (_, elements) = render(&trace, &evaluator, &ReplayOptions::default());
        let group = with_class(&elements, "items");
        assert_eq!(group.len(), 1);
        let delivered = trace.items.iter().filter(|item| item.delivered).count();
        assert_eq!(group[0].get("data-delivered"), delivered.to_string());
        let ends = with_class(&elements, "item-end");
        assert_eq!(ends.len(), 10);
        let attributes = scene_attributes(&elements);
        for (item, end) in trace.items.iter().zip(&ends) {
            let expected = expected_pixel(attributes, item.end);
            assert!((end.number("cx") - expected[0]).abs() < 0.01, "{item:?}");
            assert!((end.number("cy") - expected[1]).abs() < 0.01, "{item:?}");
        }
        let moved = trace.items.iter().filter(|item| item.start != item.end);
        assert_eq!(with_class(&elements, "item-start").len(), moved.count());
        let caption: Vec<&str> = with_class(&elements, "caption")
            .iter()
            .map(|e| e.text.as_str())
            .collect();
        assert!(
            caption[1].ends_with(&format!("{delivered}/10 items delivered")),
            "{caption:?}"
        );
        // The key explains the items' marks.
        let key = key_items(&trace, &ReplayOptions::default(), &[]);
        assert!(key.contains(&KeySymbol::Item));
        assert_eq!(key.contains(&KeySymbol::ItemDelivered), delivered > 0);
        // A trace without items draws none.
        let mut without = trace.clone();
        without.items.clear();
        let (_, elements) = render(&without, &evaluator, &ReplayOptions::default());
        assert!(with_class(&elements, "items").is_empty());
        assert!(with_class(&elements, "item-end").is_empty());
        assert!(!key_items(&without, &ReplayOptions::default(), &[]).contains(&KeySymbol::Item));
    }

    #[test]
    fn a_trace_without_a_team_draws_no_other_robot() {
        let (evaluator, trace) = maze_trace(4);
        assert!(trace.team_groups.is_empty());
        let (svg, elements) = render(&trace, &evaluator, &maze_options());
        for class in ["team", "team-group"].into_iter().chain(TEAM_ROBOT_CLASSES) {
            assert!(with_class(&elements, class).is_empty(), "{class}");
        }
        assert!(!svg.contains("other robot"));
    }

    #[test]
    fn an_animated_team_replay_moves_every_robot_with_the_focal_one() {
        let evaluator = team_arena();
        let trace = evaluator.evaluate_traced(&mut Circler, Sample::seeded(2));
        let options = ReplayOptions {
            animate: true,
            ..ReplayOptions::default()
        };
        let (_, elements) = render(&trace, &evaluator, &options);
        assert_eq!(with_class(&elements, "animated-robot").len(), 1);
        assert_eq!(with_class(&elements, "animated-team-robot").len(), 3);
        let animations: Vec<&Element> = elements
            .iter()
            .filter(|e| e.name == "animateTransform")
            .collect();
        assert_eq!(animations.len(), 2 * 4, "a move and a turn per robot");
        // Every robot has a value per cycle and one for the end, over the same time, and all
        // but the focal robot's move start with it.
        let focal_duration = animations.last().unwrap().get("dur");
        for animation in &animations {
            assert_eq!(animation.get("dur"), focal_duration);
            let values = animation.get("values").split(';').count();
            assert_eq!(values, trace.cycles.len() + 1);
        }
        let led: Vec<&&Element> = animations
            .iter()
            .filter(|a| a.get("begin") == "replay-move.begin")
            .collect();
        assert_eq!(led.len(), animations.len() - 1);
    }

    /// The movers, boxes and items of an animated replay move in step with the focal robot, a
    /// place per cycle and one for the end, and an item's look follows its state.
    #[test]
    fn an_animated_replay_moves_every_mover_box_and_item() {
        let animated = ReplayOptions {
            animate: true,
            ..ReplayOptions::default()
        };
        for (text, class, count) in [
            (
                include_str!("../../../scenarios/swarm/crossing.toml"),
                "animated-mover",
                3,
            ),
            (
                include_str!("../../../scenarios/swarm/box_pushing.toml"),
                "animated-box",
                4,
            ),
            (
                include_str!("../../../scenarios/swarm/foraging.toml"),
                "animated-item",
                10,
            ),
        ] {
            let (trace, evaluator) = swarm_trace(text, 1);
            let (_, elements) = render(&trace, &evaluator, &animated);
            assert_eq!(with_class(&elements, class).len(), count, "{class}");
            let focal = elements
                .iter()
                .find(|e| e.attributes.get("id").map(String::as_str) == Some(ANIMATION_ID))
                .unwrap();
            // Each marker's group is followed by its move.
            let moves: Vec<&Element> = elements
                .windows(2)
                .filter(|pair| pair[0].get("class") == class)
                .map(|pair| &pair[1])
                .collect();
            assert_eq!(moves.len(), count, "{class}");
            let attributes = scene_attributes(&elements);
            let ends: Vec<[f32; 2]> = match class {
                "animated-mover" => trace.movers.iter().map(|m| m.end).collect(),
                "animated-box" => trace.boxes.iter().map(|b| b.end).collect(),
                _ => trace.items.iter().map(|i| i.end).collect(),
            };
            for (moved, end) in moves.iter().zip(ends) {
                assert_eq!(moved.name, "animateTransform", "{class}");
                assert_eq!(moved.get("begin"), "replay-move.begin");
                assert_eq!(moved.get("dur"), focal.get("dur"));
                let values: Vec<&str> = moved.get("values").split(';').collect();
                assert_eq!(values.len(), trace.cycles.len() + 1, "{class}");
                let (x, y) = values.last().unwrap().split_once(',').unwrap();
                let expected = expected_pixel(attributes, end);
                assert!(
                    (x.parse::<f64>().unwrap() - expected[0]).abs() < 0.01,
                    "{class}"
                );
                assert!(
                    (y.parse::<f64>().unwrap() - expected[1]).abs() < 0.01,
                    "{class}"
                );
            }
            // An item whose look changes gets a discrete animation of its fill and outline.
            let changing = trace
                .items
                .iter()
                .enumerate()
                .filter(|(index, item)| {
                    trace
                        .cycles
                        .iter()
                        .map(|c| (c.items[*index].carried, c.items[*index].delivered))
                        .chain([(item.carried, item.delivered)])
                        .any(|state| state != (false, false))
                })
                .count();
            let looks = elements.iter().filter(|e| e.name == "animate").count();
            assert_eq!(looks, 2 * changing, "{class}");
            // Without --animate, nothing moves.
            let (_, still) = render(&trace, &evaluator, &ReplayOptions::default());
            assert!(with_class(&still, class).is_empty(), "{class}");
        }
    }

    /// An item picked up halfway through is outlined black from then on.
    #[test]
    fn an_animated_item_is_outlined_while_carried() {
        let (mut trace, evaluator) =
            swarm_trace(include_str!("../../../scenarios/swarm/foraging.toml"), 1);
        for cycle in &mut trace.cycles {
            for item in &mut cycle.items {
                (item.carried, item.delivered) = (false, false);
            }
        }
        for item in &mut trace.items {
            (item.carried, item.delivered) = (false, false);
        }
        let half = trace.cycles.len() / 2;
        for cycle in &mut trace.cycles[half..] {
            cycle.items[0].carried = true;
        }
        trace.items[0].carried = true;
        let animated = ReplayOptions {
            animate: true,
            ..ReplayOptions::default()
        };
        let (_, elements) = render(&trace, &evaluator, &animated);
        let looks: Vec<&Element> = elements.iter().filter(|e| e.name == "animate").collect();
        assert_eq!(looks.len(), 2);
        let strokes: Vec<&str> = looks[1].get("values").split(';').collect();
        assert_eq!(looks[1].get("attributeName"), "stroke");
        assert_eq!(strokes.len(), trace.cycles.len() + 1);
        assert!(strokes[..half].iter().all(|s| *s == "none"));
        assert!(strokes[half..].iter().all(|s| *s == "#000000"));
        assert!(looks[0].get("values").split(';').all(|f| f == ITEM_COLOUR));
    }

    #[test]
    fn an_item_looks_as_the_dashboard_draws_it() {
        assert_eq!(item_look(false, false), (ITEM_COLOUR, "none"));
        assert_eq!(item_look(true, false), (ITEM_COLOUR, "#000000"));
        assert_eq!(item_look(false, true), (DELIVERED_COLOUR, "none"));
    }

    #[test]
    fn a_team_recorded_without_its_groups_is_drawn_as_one_group() {
        let evaluator = team_arena();
        let mut trace = evaluator.evaluate_traced(&mut Circler, Sample::seeded(5));
        trace.team_groups.clear();
        let (_, elements) = render(&trace, &evaluator, &ReplayOptions::default());
        assert_eq!(with_class(&elements, "team-robot").len(), 3);
        let groups = with_class(&elements, "team-group");
        assert_eq!(groups.len(), 1);
        assert!(!groups[0].attributes.contains_key("data-name"));
        let key: Vec<&str> = with_class(&elements, "key-label")
            .iter()
            .map(|e| e.text.as_str())
            .collect();
        assert!(key.contains(&"3 other robots"), "{key:?}");
    }

    #[test]
    fn headings_unwrap_the_short_way() {
        let degrees = unwrapped_degrees(&[3.1, -3.1, -3.0, 3.1]);
        for pair in degrees.windows(2) {
            assert!((pair[1] - pair[0]).abs() < 180.0, "{degrees:?}");
        }
    }
}
