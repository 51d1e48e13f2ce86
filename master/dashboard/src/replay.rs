//! The best controller's replays on a job page: one traced sample per variant (light
//! configuration) of the node's task, drawn by hevo-viz's replay renderer, with the robot's
//! pose at every cycle in picture coordinates (and a team's other robots' poses, and where
//! each mover, box and item is, too) so the page's script can move a marker for each along
//! its path with a cycle slider and play it. Without the script the picture is the whole
//! replay.

use crate::BestController;
use crate::html::escape;
use hevo_sim_core::{Controller, Trace};
use hevo_sim_core::{Evaluator, Pose, Sample};
use hevo_viz::replay::{BodyKind, SceneTransform, body_paths};
use hevo_viz::svg::num_with;
use serde::Serialize;

/// One replay, ready for the page.
#[derive(Debug, Clone, PartialEq)]
pub struct ReplayFigure {
    /// The variant replayed (`None` for tasks without light configurations).
    pub variant: Option<u32>,
    /// The picture (static: the script animates it).
    pub svg: String,
    /// The robot at each cycle and at the end: picture x, y and heading in degrees
    /// (clockwise, as SVG rotates).
    pub poses: Vec<[f64; 3]>,
    /// Each of a team's other robots, as `poses`: a trace records no final pose for them, so
    /// each ends on its last recorded pose again, in step with the robot. Empty without a team.
    pub team_poses: Vec<Vec<[f64; 3]>>,
    /// Each mover, then each box, then each item of the sample, in step with `poses`. Empty
    /// without `[[movers]]`, `[[boxes]]` and `[[objects]]`.
    pub bodies: Vec<BodyTrack>,
    /// The robot's radius in picture units.
    pub radius: f64,
    /// How the sample ended, in words.
    pub ending: String,
}

/// One mover, box or item of a replay, as the page's script reads it (`data-bodies`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BodyTrack {
    /// What it is.
    pub kind: BodyKind,
    /// Its radius in picture units.
    pub radius: f64,
    /// Its centre at the start of each cycle and at the end, in picture coordinates (two
    /// decimals).
    pub at: Vec<[f64; 2]>,
    /// An item's state at each entry of `at`, one letter each: `f` on the floor, `c` carried,
    /// `d` delivered. Empty for movers and boxes.
    #[serde(skip_serializing_if = "String::is_empty")]
    pub states: String,
}

/// The replays of `best` on sample `seed`, one per variant of its task.
pub fn replays(node: &str, best: &BestController, seed: u64) -> Result<Vec<ReplayFigure>, String> {
    let evaluator = Evaluator::new(best.task.clone()).map_err(|e| e.to_string())?;
    let n_variants = best.task.scenario.n_variants();
    let variants: Vec<Option<u32>> = if n_variants > 1 {
        (0..n_variants).map(Some).collect()
    } else {
        vec![None]
    };
    let mut figures = Vec::new();
    for variant in variants {
        let mut controller = Controller::new(&best.file, None).map_err(|e| e.to_string())?;
        let trace = evaluator.evaluate_traced(&mut controller, Sample { seed, variant });
        let radius_m = evaluator.task().params.robot.radius;
        let title = match variant {
            Some(k) => format!("{node}: light configuration {k}, seed {seed}"),
            None => format!("{node}: seed {seed}"),
        };
        let options = hevo_viz::ReplayOptions {
            node_names: (0..controller.n_nodes())
                .map(|i| controller.node_path(i).unwrap_or("?").to_string())
                .collect(),
            rays_at_cycles: Vec::new(),
            animate: false,
            title: Some(title),
            robot_radius: radius_m,
            caption: None,
        };
        let svg = hevo_viz::replay_svg(&trace, &options, &|pose| evaluator.ir_cones(pose));
        let transform = hevo_viz::replay_scene_transform(&trace, radius_m);
        let poses = picture_poses(
            &transform,
            trace
                .cycles
                .iter()
                .map(|c| c.robot)
                .chain(std::iter::once(trace.final_robot)),
        );
        let n_members = trace.cycles.first().map_or(0, |c| c.team.len());
        let team_poses = (0..n_members)
            .map(|member| {
                picture_poses(
                    &transform,
                    hevo_viz::team_member_poses(&trace, member).into_iter(),
                )
            })
            .collect();
        figures.push(ReplayFigure {
            variant,
            svg,
            poses,
            team_poses,
            bodies: body_tracks(&trace, &transform),
            radius: transform.length(radius_m as f64),
            ending: format!(
                "{:?} after {} cycles, fitness {:.3}",
                trace.outcome.ending, trace.outcome.cycles, trace.outcome.fitness
            ),
        });
    }
    Ok(figures)
}

/// Poses in picture coordinates, `[x, y, degrees clockwise]`, leaving out those that cannot be
/// drawn.
fn picture_poses(transform: &SceneTransform, poses: impl Iterator<Item = Pose>) -> Vec<[f64; 3]> {
    poses
        .filter(|p| p.x.is_finite() && p.y.is_finite() && p.heading.is_finite())
        .map(|p| {
            let [x, y] = transform.apply([p.x, p.y]);
            [x, y, -(p.heading as f64).to_degrees()]
        })
        .collect()
}

/// Each mover, box and item of `trace` ([`body_paths`]), in picture coordinates.
fn body_tracks(trace: &Trace, transform: &SceneTransform) -> Vec<BodyTrack> {
    body_paths(trace)
        .into_iter()
        .map(|path| BodyTrack {
            kind: path.kind,
            radius: round2(transform.length(f64::from(path.radius))),
            at: path
                .places
                .into_iter()
                .map(|point| transform.apply(point).map(round2))
                .collect(),
            states: path.item_states.iter().map(item_state_letter).collect(),
        })
        .collect()
}

/// An item's state as [`BodyTrack::states`] spells it.
fn item_state_letter(&(carried, delivered): &(bool, bool)) -> char {
    match (carried, delivered) {
        (_, true) => 'd',
        (true, false) => 'c',
        (false, false) => 'f',
    }
}

/// `value` to two decimals, as the page's coordinates are written.
fn round2(value: f64) -> f64 {
    (value * 100.0).round() / 100.0
}

/// The poses as the `data-poses` attribute's JSON: `[[x,y,deg],...]`, two decimals.
fn poses_json(poses: &[[f64; 3]]) -> String {
    let items: Vec<String> = poses
        .iter()
        .map(|[x, y, d]| {
            format!(
                "[{},{},{}]",
                num_with(*x, 2),
                num_with(*y, 2),
                num_with(*d, 1)
            )
        })
        .collect();
    format!("[{}]", items.join(","))
}

/// A replay as a `<figure>`: the picture, and the slider and play button the script shows.
pub fn figure_html(node: &str, figure: &ReplayFigure) -> String {
    let last = figure.poses.len().saturating_sub(1);
    let label = match figure.variant {
        Some(k) => format!("light configuration {k}"),
        None => "the sample".to_string(),
    };
    // Only a team's replay carries the attribute, so other pages stay as they were.
    let team_poses = if figure.team_poses.is_empty() {
        String::new()
    } else {
        let members: Vec<String> = figure.team_poses.iter().map(|p| poses_json(p)).collect();
        format!(r#" data-team-poses="[{}]""#, members.join(","))
    };
    // Likewise the movers', boxes' and items' tracks.
    let bodies = if figure.bodies.is_empty() {
        String::new()
    } else {
        let json = serde_json::to_string(&figure.bodies).expect("tracks are plain numbers");
        format!(r#" data-bodies="{}""#, escape(&json))
    };
    format!(
        r#"<figure class="replay" data-node="{node}" data-variant="{variant}" data-radius="{radius}" data-poses="{poses}"{team_poses}{bodies}>
{svg}
<figcaption>{label}: {ending}</figcaption>
<div class="replay-controls" hidden>
<button type="button" class="play">Play</button>
<label>cycle <input type="range" class="cycle-slider" min="0" max="{last}" value="{last}" step="1"></label>
<output class="cycle-label">{last} of {last}</output>
</div>
</figure>"#,
        node = escape(node),
        variant = figure.variant.map_or("none".to_string(), |k| k.to_string()),
        radius = num_with(figure.radius, 2),
        poses = poses_json(&figure.poses),
        svg = figure.svg,
        label = escape(&label),
        ending = escape(&figure.ending),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use hevo_sim_core::{ControllerFile, TaskConfig};

    /// A controller shipped in `controllers/`.
    fn shipped_controller(json: &str) -> ControllerFile {
        ControllerFile::from_json_str(json).unwrap()
    }

    #[test]
    fn a_replay_has_a_pose_per_cycle_inside_its_picture() {
        let file = shipped_controller(include_str!("../../../controllers/follow_wall.json"));
        let best = BestController {
            file,
            task: TaskConfig::shipped("follow_wall").unwrap(),
        };
        let figures = replays("follow_wall", &best, 1).unwrap();
        assert_eq!(figures.len(), 1);
        let figure = &figures[0];
        assert!(figure.poses.len() > 10);
        assert!(figure.poses.iter().all(|p| (0.0..=800.0).contains(&p[0])));
        let html = figure_html("follow_wall", figure);
        assert!(html.contains(r#"class="cycle-slider""#));
        assert!(html.contains("<svg"));
        assert!(figure.team_poses.is_empty() && !html.contains("data-team-poses"));
        assert!(figure.bodies.is_empty() && !html.contains("data-bodies"));
    }

    #[test]
    fn a_team_replay_has_each_other_robots_poses_in_step() {
        let text = include_str!("../../viz/fixtures/team_arena.toml");
        let scenario = hevo_sim_core::Scenario::parse(text, "team_arena.toml").unwrap();
        let best = BestController {
            // Reads the IR sensors only, which the arena's robots carry.
            file: shipped_controller(include_str!("../../../controllers/follow_wall.json")),
            task: TaskConfig::from_scenario(std::sync::Arc::new(scenario)),
        };
        let figures = replays("team_arena", &best, 2).unwrap();
        let figure = &figures[0];
        assert_eq!(figure.team_poses.len(), 3);
        for member in &figure.team_poses {
            assert_eq!(member.len(), figure.poses.len());
            assert!(member.iter().all(|p| (0.0..=800.0).contains(&p[0])));
        }
        assert!(figure.svg.contains(r#"class="team-robot""#));
        let html = figure_html("team_arena", figure);
        let attribute = html
            .split(r#"data-team-poses=""#)
            .nth(1)
            .and_then(|rest| rest.split('"').next())
            .expect("the figure carries the team's poses");
        let parsed: Vec<Vec<[f64; 3]>> = serde_json::from_str(attribute).unwrap();
        assert_eq!(parsed.len(), 3);
    }

    /// The picture's width and height, from its `viewBox`.
    fn picture_size(svg: &str) -> [f64; 2] {
        let view_box = svg
            .split(r#"viewBox="0 0 "#)
            .nth(1)
            .and_then(|rest| rest.split('"').next())
            .expect("the picture has a viewBox");
        let mut sizes = view_box.split(' ').map(|v| v.parse::<f64>().unwrap());
        [sizes.next().unwrap(), sizes.next().unwrap()]
    }

    /// A shipped swarm scenario's replay: its movers', boxes' or items' tracks hold one
    /// centre per cycle and the end, each inside the picture, and the page carries them.
    fn swarm_replay(scenario: &str, text: &str, controller: &str) -> ReplayFigure {
        let file_name = format!("{scenario}.toml");
        let scenario = hevo_sim_core::Scenario::parse(text, &file_name).unwrap();
        let best = BestController {
            file: shipped_controller(controller),
            task: TaskConfig::from_scenario(std::sync::Arc::new(scenario)),
        };
        let figures = replays(&file_name, &best, 1).unwrap();
        let figure = figures.into_iter().next().unwrap();
        let [width, height] = picture_size(&figure.svg);
        for track in &figure.bodies {
            assert_eq!(track.at.len(), figure.poses.len(), "{track:?}");
            assert!(
                track
                    .at
                    .iter()
                    .all(|&[x, y]| (0.0..=width).contains(&x) && (0.0..=height).contains(&y)),
                "{track:?} leaves the {width} by {height} picture"
            );
            assert!(track.radius > 0.0);
        }
        let html = figure_html(&file_name, &figure);
        let attribute = html
            .split(r#"data-bodies=""#)
            .nth(1)
            .and_then(|rest| rest.split('"').next())
            .expect("the figure carries the bodies' tracks");
        let parsed: Vec<serde_json::Value> =
            serde_json::from_str(&attribute.replace("&quot;", "\"")).unwrap();
        assert_eq!(parsed.len(), figure.bodies.len());
        figure
    }

    /// The tracks of one kind in `figure`.
    fn tracks_of(figure: &ReplayFigure, kind: BodyKind) -> Vec<&BodyTrack> {
        figure.bodies.iter().filter(|t| t.kind == kind).collect()
    }

    #[test]
    fn a_swarm_replay_moves_each_mover_box_and_item() {
        let crossing = swarm_replay(
            "crossing",
            include_str!("../../../scenarios/swarm/crossing.toml"),
            include_str!("../../../controllers/crossing.json"),
        );
        let movers = tracks_of(&crossing, BodyKind::Mover);
        assert_eq!((movers.len(), crossing.bodies.len()), (3, 3));
        // Movers patrol: each is somewhere else at the end than at the start.
        assert!(movers.iter().all(|t| t.at[0] != t.at[t.at.len() - 1]));
        assert!(movers.iter().all(|t| t.states.is_empty()));

        let box_pushing = swarm_replay(
            "box_pushing",
            include_str!("../../../scenarios/swarm/box_pushing.toml"),
            include_str!("../../../controllers/follow_wall.json"),
        );
        assert_eq!(tracks_of(&box_pushing, BodyKind::Box).len(), 4);
        assert_eq!(box_pushing.bodies.len(), 4);

        let foraging = swarm_replay(
            "foraging",
            include_str!("../../../scenarios/swarm/foraging.toml"),
            include_str!("../../../controllers/foraging.json"),
        );
        let items = tracks_of(&foraging, BodyKind::Item);
        assert_eq!((items.len(), foraging.bodies.len()), (10, 10));
        for item in &items {
            assert_eq!(item.states.chars().count(), item.at.len());
            assert!(item.states.starts_with('f'), "{}", item.states);
        }
        // The shipped forager picks items up: the page can tell carried ones apart.
        assert!(items.iter().any(|t| t.states.contains('c')));
    }

    #[test]
    fn maze_tasks_replay_every_light_configuration() {
        let file = shipped_controller(include_str!("../../../controllers/solve_maze.json"));
        let best = BestController {
            file,
            task: TaskConfig::shipped("solve_maze").unwrap(),
        };
        let figures = replays("solve_maze", &best, 1).unwrap();
        let n = TaskConfig::shipped("solve_maze")
            .unwrap()
            .scenario
            .n_variants() as usize;
        assert_eq!(figures.len(), n);
        assert!(figures.iter().all(|f| f.variant.is_some()));
    }
}
