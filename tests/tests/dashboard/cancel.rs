//! Cancelling from the dashboard in a real browser: the job page's cancel button stops a job
//! that is waiting for workers, the page says so, and the master agrees.

use fantoccini::Locator;
use hevo_proto::v1;
use hevo_tests::browser::{Browser, require_browser};
use hevo_tests::dashboard::{dashboard_url, master_with_dashboard, submit, watchable};
use hevo_tests::service::{CLIENT_TOKEN, jobs, runtime, wait_until_final};
use hevo_tests::{Scratch, cluster_turn};
use std::time::Duration;

#[test]
fn the_cancel_button_cancels_the_job() {
    // A master, a browser and often a worker: the browser tests take turns, as the cluster
    // tests do.
    let _turn = cluster_turn();
    let Some(tools) = require_browser("dashboard::cancel") else {
        return;
    };
    let scratch = Scratch::new("dashboard-cancel");
    let master = master_with_dashboard(&scratch);
    let url = dashboard_url(&master).to_string();
    runtime().block_on(async {
        let job = submit(&master, &watchable()).await;
        let browser = Browser::start(&tools, &scratch).await;
        browser.sign_in(&url, CLIENT_TOKEN).await;
        browser.goto(&format!("{url}/jobs/{job}")).await;
        browser
            .client
            .find(Locator::Css("form.cancel button"))
            .await
            .expect("a running job has a cancel button")
            .click()
            .await
            .expect("clicking cancel");
        browser
            .wait_for(
                "the cancelled state",
                "var s = document.querySelector('.job-state'); return s && s.textContent === 'cancelled';",
                Duration::from_secs(20),
            )
            .await;
        assert!(
            browser
                .eval("return !document.querySelector('form.cancel');")
                .await
                .as_bool()
                .unwrap_or(false),
            "no cancel button once cancelled"
        );
        let info = wait_until_final(&mut jobs(&master.url, CLIENT_TOKEN), &job, Duration::from_secs(10)).await;
        assert_eq!(info.state, v1::JobState::Cancelled as i32);
        browser.close().await;
    });
}
