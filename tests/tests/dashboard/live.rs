//! The master's dashboard in a real browser, live: a client signs in through the login form,
//! sees a submitted job in the list, opens its page before any worker runs it, and watches the
//! fitness curve gain points as generations finish (the page is not reloaded: the stream
//! brings them); when the job ends the page shows the post-evaluation table and the replay.

use hevo_tests::browser::{Browser, require_browser};
use hevo_tests::dashboard::{
    dashboard_url, master_with_dashboard, plot_points_script, submit, watchable,
};
use hevo_tests::service::{CLIENT_TOKEN, WORKER_TOKEN, runtime};
use hevo_tests::{Scratch, cluster_turn, start_worker};
use std::time::Duration;

#[test]
fn a_jobs_fitness_curve_grows_while_the_page_is_open() {
    // A master, a browser and often a worker: the browser tests take turns, as the cluster
    // tests do.
    let _turn = cluster_turn();
    let Some(tools) = require_browser("dashboard::live") else {
        return;
    };
    let scratch = Scratch::new("dashboard-live");
    let master = master_with_dashboard(&scratch);
    let url = dashboard_url(&master).to_string();
    runtime().block_on(async {
        let job = submit(&master, &watchable()).await;
        let browser = Browser::start(&tools, &scratch).await;

        let list = browser.sign_in(&url, CLIENT_TOKEN).await;
        assert!(list.contains(&job), "the job list shows the job:\n{list}");
        assert!(list.contains("watchable"), "{list}");

        browser.goto(&format!("{url}/jobs/{job}")).await;
        browser
            .wait_for(
                "the page's event stream",
                "return document.querySelector('.job').dataset.live === 'open';",
                Duration::from_secs(10),
            )
            .await;
        let before = browser.eval(&plot_points_script("exit_room", 0)).await;
        assert_eq!(before.as_i64(), Some(0), "no worker yet, so no points");
        // Marks this page load: a reload would lose it.
        browser.eval("window.hevoSamePage = true; return true;").await;

        let _worker = start_worker(
            &master.url,
            WORKER_TOKEN,
            "dashboard-worker",
            &[],
            &scratch.join("worker.log"),
        );
        let points_now = format!(
            "if (!window.hevoSamePage) return 'reloaded'; {}",
            plot_points_script("exit_room", 0)
        );
        let first = browser
            .wait_for(
                "the curve's first points",
                &format!("var n = (function () {{ {points_now} }})(); return (n === 'reloaded' || n >= 2) ? n : 0;"),
                Duration::from_secs(60),
            )
            .await;
        let first = first
            .as_i64()
            .unwrap_or_else(|| panic!("the page reloaded before the curve grew: {first}"));
        let grown = browser
            .wait_for(
                "more points on the same page",
                &format!("var n = (function () {{ {points_now} }})(); return (n === 'reloaded' || n > {first}) ? n : 0;"),
                Duration::from_secs(60),
            )
            .await;
        assert!(
            grown.as_i64().is_some_and(|n| n > first),
            "the curve grew from {first} points without a reload: {grown}"
        );
        let line = browser
            .eval("return document.querySelector('ul.runs li').textContent;")
            .await;
        assert!(line.as_str().unwrap_or_default().contains("of 15"), "{line}");

        // The end: the page reloads itself and shows the table and the replay.
        browser
            .wait_for(
                "the post-evaluation table",
                "return !!document.querySelector('table.post-evaluation');",
                Duration::from_secs(120),
            )
            .await;
        let text = browser.text().await;
        assert!(text.contains("succeeded"), "{text}");
        assert!(text.contains("Post-evaluation"), "{text}");
        assert_eq!(
            browser.eval(&plot_points_script("exit_room", 0)).await.as_i64(),
            Some(15)
        );
        browser
            .wait_for(
                "the replay's robot marker",
                "return !!document.querySelector('figure.replay .robot-marker');",
                Duration::from_secs(10),
            )
            .await;
        assert!(
            browser
                .eval("return !document.querySelector('form.cancel');")
                .await
                .as_bool()
                .unwrap_or(false),
            "a finished job has no cancel button"
        );
        browser.close().await;
    });
}
