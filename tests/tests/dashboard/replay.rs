//! The replay on a dashboard page in a real browser, over the checked-in run directories
//! (`hevo dashboard experiments/...`): each finished node's best controller is drawn with a
//! robot marker, the cycle slider moves the marker (by keyboard, as a user would) and the play
//! button runs it forward. A swarm's replay (a short job on a master, over the shipped
//! crossing and foraging scenarios, which only a job's own task can replay) moves the movers'
//! and the items' markers with the slider too.

use fantoccini::Locator;
use fantoccini::key::Key;
use hevo_tests::browser::{Browser, require_browser};
use hevo_tests::dashboard::{dashboard_url, local_dashboard, master_with_dashboard};
use hevo_tests::service::{CLIENT_TOKEN, WORKER_TOKEN, jobs, runtime, submission};
use hevo_tests::{Scratch, cluster_turn, repo_root, start_worker};
use std::time::Duration;

const MARKER: &str = "return document.querySelector('figure.replay[data-node=\"turn_left\"] .robot-marker').getAttribute('transform');";
const LABEL: &str = "return document.querySelector('figure.replay[data-node=\"turn_left\"] .cycle-label').textContent;";

#[test]
fn the_cycle_slider_moves_the_robot() {
    // A dashboard and a browser: the browser tests take turns, as the cluster tests do.
    let _turn = cluster_turn();
    let Some(tools) = require_browser("dashboard::replay") else {
        return;
    };
    let scratch = Scratch::new("dashboard-replay");
    let runs = repo_root().join("experiments/runs-wide-turn-starts");
    let dashboard = local_dashboard(&[&runs], &[]);
    runtime().block_on(async {
        let browser = Browser::start(&tools, &scratch).await;
        browser.goto(&dashboard.url).await;
        let list = browser.text().await;
        assert!(list.contains("runs-wide-turn-starts"), "{list}");
        browser
            .goto(&format!("{}/jobs/runs-wide-turn-starts", dashboard.url))
            .await;
        browser
            .wait_for("the robot marker", MARKER, Duration::from_secs(10))
            .await;
        let at_end = browser.eval(MARKER).await;
        let label = browser.eval(LABEL).await;
        let last: u64 = label
            .as_str()
            .and_then(|l| l.split(" of ").nth(1))
            .and_then(|n| n.parse().ok())
            .unwrap_or_else(|| panic!("the label names the last cycle: {label}"));
        assert!(last > 10, "{label}");

        let slider = browser
            .client
            .find(Locator::Css(
                "figure.replay[data-node=\"turn_left\"] input.cycle-slider",
            ))
            .await
            .expect("a slider");
        slider
            .send_keys(&char::from(Key::Home).to_string())
            .await
            .expect("Home on the slider");
        assert_eq!(browser.eval(LABEL).await.as_str(), Some(format!("0 of {last}").as_str()));
        let at_start = browser.eval(MARKER).await;
        assert_ne!(at_start, at_end, "the marker moved to the start");
        for _ in 0..5 {
            slider
                .send_keys(&char::from(Key::Right).to_string())
                .await
                .expect("a right arrow on the slider");
        }
        assert_eq!(browser.eval(LABEL).await.as_str(), Some(format!("5 of {last}").as_str()));
        let at_five = browser.eval(MARKER).await;
        assert_ne!(at_five, at_start, "five cycles on, the marker is elsewhere");

        browser
            .client
            .find(Locator::Css("figure.replay[data-node=\"turn_left\"] button.play"))
            .await
            .expect("a play button")
            .click()
            .await
            .expect("clicking play");
        browser
            .wait_for(
                "the animation to run past cycle 20",
                "var l = document.querySelector('figure.replay[data-node=\"turn_left\"] .cycle-label').textContent; return parseInt(l, 10) > 20;",
                Duration::from_secs(10),
            )
            .await;
        browser.close().await;
    });
}

/// Two nodes of one generation over the shipped swarm scenarios with movers and items: enough
/// for a best controller to replay.
const SWARM: &str = r#"
[experiment]
name = "swarm_replay"
seed = 7

[evolution]
population = 6
elites = 1
post_evaluation_samples = 1

[[node]]
name = "crossing"
kind = "primitive"
inputs = ["ir"]
hidden = 2
scenario = "crossing.toml"
samples = 1
generations = 1
runs = 1

[[node]]
name = "foraging"
kind = "primitive"
inputs = ["ir", "light", "items"]
hidden = 2
scenario = "foraging.toml"
samples = 1
generations = 1
runs = 1
"#;

/// The `transform` and `data-state` of every marker of `class` in the replay of `node`, one
/// string per marker.
fn markers(node: &str, class: &str) -> String {
    format!(
        "return Array.from(document.querySelectorAll('figure.replay[data-node=\"{node}\"] .{class}')).map(function (m) {{ return m.getAttribute('transform') + ' ' + (m.dataset.state || ''); }});"
    )
}

#[test]
fn the_cycle_slider_moves_the_movers_and_the_items() {
    let _turn = cluster_turn();
    let Some(tools) = require_browser("dashboard::replay") else {
        return;
    };
    let scratch = Scratch::new("dashboard-replay-bodies");
    let master = master_with_dashboard(&scratch);
    let url = dashboard_url(&master).to_string();
    let swarm = repo_root().join("scenarios/swarm");
    let mut request = submission(SWARM);
    for name in ["crossing.toml", "foraging.toml"] {
        let text = std::fs::read_to_string(swarm.join(name)).expect("a shipped scenario");
        request.files.insert(name.to_string(), text);
    }
    let _worker = start_worker(
        &master.url,
        WORKER_TOKEN,
        "replay-worker",
        &[],
        &scratch.join("worker.log"),
    );
    runtime().block_on(async {
        let job = jobs(&master.url, CLIENT_TOKEN)
            .submit_job(request)
            .await
            .expect("the submission is accepted")
            .into_inner()
            .job_id;
        let browser = Browser::start(&tools, &scratch).await;
        browser.sign_in(&url, CLIENT_TOKEN).await;
        browser.goto(&format!("{url}/jobs/{job}")).await;
        // (node, marker class, markers): three movers cross the room; ten items.
        for (node, class, count) in [
            ("crossing", "mover-marker", 3),
            ("foraging", "item-marker", 10),
        ] {
            let script = markers(node, class);
            browser
                .wait_for(
                    "the bodies' markers, once the job ended",
                    &format!("var m = (function () {{ {script} }})(); return m.length > 0;"),
                    Duration::from_secs(240),
                )
                .await;
            let at_end: Vec<String> =
                serde_json::from_value(browser.eval(&script).await).expect("a list");
            assert_eq!(at_end.len(), count, "{node}: {at_end:?}");
            browser
                .client
                .find(Locator::Css(&format!(
                    "figure.replay[data-node=\"{node}\"] input.cycle-slider"
                )))
                .await
                .expect("a slider")
                .send_keys(&char::from(Key::Home).to_string())
                .await
                .expect("Home on the slider");
            let at_start: Vec<String> =
                serde_json::from_value(browser.eval(&script).await).expect("a list");
            assert_eq!(at_start.len(), count);
            if class == "mover-marker" {
                assert_ne!(
                    at_start, at_end,
                    "the movers' markers went back to the start"
                );
            } else {
                // Every item lies on the floor at the start, each marker a state's look.
                assert!(at_start.iter().all(|m| m.ends_with(" f")), "{at_start:?}");
                assert!(
                    at_end
                        .iter()
                        .all(|m| [" f", " c", " d"].iter().any(|s| m.ends_with(s)))
                );
            }
        }
        browser.close().await;
    });
}
