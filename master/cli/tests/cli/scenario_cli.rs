//! `hevo scenario check` and `hevo scenario draw` as a user runs them, on the examples with a
//! wandering teammate, with a room joined under a corridor, with the authors' room, with a
//! random maze and with a corridor beyond a map, and on the rescue: check
//! accepts them, and every region `draw` should name (the map's, the generators') is in the
//! picture, shaded and labelled. On a team's arena, `draw` shows where each other robot starts.

use crate::support::{hevo_ok, repo_root};
use hevo_sim_core::{Evaluator, Sample, Scenario, TaskConfig};

/// The names the picture's region labels carry, in order.
fn region_labels(svg: &str) -> Vec<String> {
    svg.split("<text class=\"region-label\"")
        .skip(1)
        .map(|rest| {
            let text = &rest[rest.find('>').unwrap() + 1..];
            text[..text.find("</text>").unwrap()].to_string()
        })
        .collect()
}

#[test]
fn check_accepts_and_draw_names_every_region() {
    let dir = tempfile::tempdir().unwrap();
    for (file, seed, expected) in [
        (
            "scenarios/examples/find_wanderer.toml",
            "3",
            &["den", "dock"][..],
        ),
        (
            "scenarios/examples/room_to_corridor.toml",
            "2",
            &["room", "room.exit", "corridor.start", "corridor.end"][..],
        ),
        (
            "scenarios/examples/exit_room_authors.toml",
            "3",
            &["room", "room.exit"][..],
        ),
        (
            "scenarios/examples/random_maze.toml",
            "4",
            &["corridor.start", "corridor.end"][..],
        ),
        (
            "scenarios/examples/map_to_corridor.toml",
            "1",
            &[
                "dead_end",
                "entrance",
                "exit",
                "corridor.start",
                "corridor.end",
            ][..],
        ),
        (
            "rescue",
            "0",
            &[
                "branch_a",
                "branch_b",
                "branch_c",
                "branch_d",
                "entrance",
                "room",
                "room.exit",
            ][..],
        ),
    ] {
        let checked = String::from_utf8(hevo_ok(&["scenario", "check", file]).stdout).unwrap();
        assert!(checked.contains(": ok ("), "{file}: {checked}");
        let regions = checked
            .lines()
            .find_map(|line| line.trim().strip_prefix("regions: "))
            .unwrap_or_else(|| panic!("{file}: no regions line in {checked}"));
        let regions: Vec<&str> = regions.split(", ").collect();
        for name in expected {
            assert!(regions.contains(name), "{file}: {name} not in {regions:?}");
        }
        assert!(
            checked.contains("sensors: ir (4), light (2), near_robot (1)")
                && checked.contains("genome over all 7 inputs: 44 / 82 / 212 genes"),
            "{file}: {checked}"
        );
        let out = dir.path().join("world.svg");
        hevo_ok(&[
            "scenario",
            "draw",
            file,
            "--seed",
            seed,
            "--out",
            out.to_str().unwrap(),
        ]);
        let svg = std::fs::read_to_string(&out).unwrap();
        let mut labels = region_labels(&svg);
        labels.sort();
        let mut expected: Vec<String> = expected.iter().map(|s| s.to_string()).collect();
        expected.sort();
        assert_eq!(labels, expected, "{file}");
        for name in &expected {
            assert!(
                svg.contains(&format!("class=\"region-rect\" data-name=\"{name}\"")),
                "{file}: {name} is not shaded"
            );
        }
    }
}

/// The value of attribute `key` in the first tag of `text` that has it.
fn attribute(text: &str, key: &str) -> f64 {
    let start = text.find(&format!(" {key}=\"")).unwrap() + key.len() + 3;
    let end = start + text[start..].find('"').unwrap();
    text[start..end].parse().unwrap()
}

#[test]
fn draw_shows_where_each_robot_of_a_team_starts() {
    let file = "master/viz/fixtures/team_arena.toml";
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("team.svg");
    let seed = 3;
    hevo_ok(&[
        "scenario",
        "draw",
        file,
        "--seed",
        &seed.to_string(),
        "--out",
        out.to_str().unwrap(),
    ]);
    let svg = std::fs::read_to_string(&out).unwrap();
    // The starts the sample's world draws for the team, group by group.
    let text = std::fs::read_to_string(repo_root().join(file)).unwrap();
    let task =
        TaskConfig::from_scenario(std::sync::Arc::new(Scenario::parse(&text, file).unwrap()));
    let starts = Evaluator::for_drawing(task)
        .unwrap()
        .environment(Sample::seeded(seed))
        .team;
    assert_eq!(starts.len(), 3);
    let scene = &svg[svg.find("<g class=\"scene\"").unwrap()..];
    let (scale, origin_x, origin_y) = (
        attribute(scene, "data-px-per-m"),
        attribute(scene, "data-origin-x"),
        attribute(scene, "data-origin-y"),
    );
    let drawn: Vec<&str> = svg.split("<g class=\"team-start\">").skip(1).collect();
    assert_eq!(drawn.len(), starts.len());
    for (ring, start) in drawn.iter().zip(&starts) {
        let expected = [
            origin_x + scale * f64::from(start.x),
            origin_y - scale * f64::from(start.y),
        ];
        let at = [attribute(ring, "cx"), attribute(ring, "cy")];
        assert!(
            (at[0] - expected[0]).abs() < 0.01 && (at[1] - expected[1]).abs() < 0.01,
            "drawn at {at:?}, the world starts it at {expected:?}"
        );
    }
    assert!(svg.contains("swarm: 3 other robots"));
}
