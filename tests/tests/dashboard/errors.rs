//! Bad requests to the dashboard, in a real browser and in raw requests: an unknown job is a
//! 404 page naming it, a malformed query or job id a 400 page, an unknown page a 404; never a
//! panic (the master keeps serving afterwards).

use hevo_tests::browser::{Browser, require_browser};
use hevo_tests::dashboard::{dashboard_url, master_with_dashboard, request, submit, watchable};
use hevo_tests::service::{CLIENT_TOKEN, runtime};
use hevo_tests::{Scratch, cluster_turn};

#[test]
fn an_unknown_job_is_a_404_naming_it_and_a_bad_query_a_400() {
    // A master, a browser and often a worker: the browser tests take turns, as the cluster
    // tests do.
    let _turn = cluster_turn();
    let Some(tools) = require_browser("dashboard::errors") else {
        return;
    };
    let scratch = Scratch::new("dashboard-errors");
    let master = master_with_dashboard(&scratch);
    let url = dashboard_url(&master).to_string();
    runtime().block_on(async {
        let job = submit(&master, &watchable()).await;
        let bearer = format!("Authorization: Bearer {CLIENT_TOKEN}");
        let cases: [(String, u16, &str); 7] = [
            (
                "/jobs/job-does-not-exist".into(),
                404,
                "no job job-does-not-exist",
            ),
            (
                "/jobs/job-does-not-exist/events".into(),
                404,
                "no job job-does-not-exist",
            ),
            (format!("/jobs/{job}?seed=lots"), 400, "malformed query"),
            (format!("/jobs/{job}/plot.svg"), 400, "malformed query"),
            (
                format!("/jobs/{job}/plot.svg?node=nope"),
                404,
                "has no node nope",
            ),
            ("/jobs/%3Cscript%3E".into(), 400, "malformed job id"),
            ("/no/such/page".into(), 404, "no page /no/such/page"),
        ];
        for (path, status, says) in &cases {
            let answer = request(&url, "GET", path, &[&bearer], "");
            assert_eq!(answer.status, *status, "GET {path}: {answer:?}");
            assert!(
                answer.body.contains(says),
                "GET {path} says {says:?}: {}",
                answer.body
            );
        }
        let cancel = request(
            &url,
            "POST",
            "/jobs/job-does-not-exist/cancel",
            &[&bearer],
            "",
        );
        assert_eq!(cancel.status, 404, "{cancel:?}");

        let browser = Browser::start(&tools, &scratch).await;
        browser.sign_in(&url, CLIENT_TOKEN).await;
        browser
            .goto(&format!("{url}/jobs/job-does-not-exist"))
            .await;
        let text = browser.text().await;
        assert!(text.contains("404"), "{text}");
        assert!(text.contains("no job job-does-not-exist"), "{text}");
        browser.goto(&format!("{url}/jobs/{job}?seed=lots")).await;
        let text = browser.text().await;
        assert!(text.contains("400"), "{text}");
        assert!(text.contains("malformed query"), "{text}");
        // Still serving.
        browser.goto(&format!("{url}/jobs/{job}")).await;
        assert!(browser.text().await.contains("exit_room"));
        browser.close().await;
    });
}
