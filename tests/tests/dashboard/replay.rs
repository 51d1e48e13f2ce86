//! The replay on a dashboard page in a real browser, over the checked-in run directories
//! (`hevo dashboard experiments/...`): each finished node's best controller is drawn with a
//! robot marker, the cycle slider moves the marker (by keyboard, as a user would) and the play
//! button runs it forward.

use fantoccini::Locator;
use fantoccini::key::Key;
use hevo_tests::browser::{Browser, require_browser};
use hevo_tests::dashboard::local_dashboard;
use hevo_tests::service::runtime;
use hevo_tests::{Scratch, cluster_turn, repo_root};
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
