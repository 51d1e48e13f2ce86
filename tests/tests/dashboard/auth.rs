//! The dashboard's guard, in a real browser and in raw requests: without the clients' token a
//! browser gets only the login form on every page (no job id, no data) and the event stream a
//! bare 401; a wrong token is refused; the login sets an HttpOnly, SameSite=Strict cookie
//! that the browser's scripts cannot read; a script's `Authorization: Bearer` header works;
//! the workers' token is no client's.

use hevo_tests::browser::{Browser, require_browser};
use hevo_tests::dashboard::{dashboard_url, master_with_dashboard, request, submit, watchable};
use hevo_tests::service::{CLIENT_TOKEN, WORKER_TOKEN, runtime};
use hevo_tests::{Scratch, cluster_turn};

#[test]
fn without_the_token_only_the_login_page_shows() {
    // A master, a browser and often a worker: the browser tests take turns, as the cluster
    // tests do.
    let _turn = cluster_turn();
    let Some(tools) = require_browser("dashboard::auth") else {
        return;
    };
    let scratch = Scratch::new("dashboard-auth");
    let master = master_with_dashboard(&scratch);
    let url = dashboard_url(&master).to_string();
    runtime().block_on(async {
        let job = submit(&master, &watchable()).await;

        for path in [
            "/".to_string(),
            format!("/jobs/{job}"),
            format!("/jobs/{job}/plot.svg?node=exit_room"),
            format!("/jobs/{job}/events"),
        ] {
            let answer = request(&url, "GET", &path, &[], "");
            assert_eq!(answer.status, 401, "GET {path}: {answer:?}");
            // (The login form keeps the requested path, to come back to it: the only place the
            // id the requester typed appears.)
            let without_next = answer.body.replace(&format!("value=\"{path}\""), "");
            assert!(
                !without_next.contains(&job),
                "GET {path} names no job: {answer:?}"
            );
            assert!(!answer.body.contains("exit_room"), "GET {path}: {answer:?}");
            assert!(!answer.body.contains("watchable"), "GET {path}: {answer:?}");
            let with_worker_token = request(
                &url,
                "GET",
                &path,
                &[&format!("Authorization: Bearer {WORKER_TOKEN}")],
                "",
            );
            assert_eq!(with_worker_token.status, 401, "a worker's token on {path}");
        }
        let cancel = request(&url, "POST", &format!("/jobs/{job}/cancel"), &[], "");
        assert_eq!(cancel.status, 401, "{cancel:?}");

        let bearer = format!("Authorization: Bearer {CLIENT_TOKEN}");
        let page = request(&url, "GET", &format!("/jobs/{job}"), &[&bearer], "");
        assert_eq!(page.status, 200, "{page:?}");
        assert!(page.body.contains("exit_room"));
        let stream = request(&url, "GET", &format!("/jobs/{job}/events"), &[&bearer], "");
        assert_eq!(stream.status, 200);
        assert!(
            stream.headers.contains("text/event-stream"),
            "{}",
            stream.headers
        );
        assert!(stream.body.contains("event: job"), "{}", stream.body);

        let login = request(
            &url,
            "POST",
            "/login",
            &["Content-Type: application/x-www-form-urlencoded"],
            &format!("token={CLIENT_TOKEN}&next=%2F"),
        );
        assert_eq!(login.status, 303, "{login:?}");
        let cookie = login
            .headers
            .lines()
            .find(|l| l.to_ascii_lowercase().starts_with("set-cookie:"))
            .unwrap_or_else(|| panic!("a cookie: {}", login.headers));
        assert!(
            cookie.contains("HttpOnly") && cookie.contains("SameSite=Strict"),
            "{cookie}"
        );

        let browser = Browser::start(&tools, &scratch).await;
        browser.goto(&format!("{url}/jobs/{job}")).await;
        let text = browser.text().await;
        assert!(text.contains("Sign in"), "{text}");
        assert!(!text.contains(&job), "the login page names no job:\n{text}");
        assert!(!text.contains("exit_room"), "{text}");

        let refused = browser.sign_in(&url, "not-the-token").await;
        assert!(refused.contains("not accepted"), "{refused}");
        assert!(!refused.contains(&job), "{refused}");

        // Signing in from the job's page comes back to it.
        browser.goto(&format!("{url}/jobs/{job}")).await;
        let field = browser
            .client
            .find(fantoccini::Locator::Css("form.login input[name=token]"))
            .await
            .expect("the login form");
        field.send_keys(CLIENT_TOKEN).await.expect("typing");
        field.send_keys("\n").await.expect("submitting");
        browser
            .wait_for(
                "the job's page",
                "return !!document.querySelector('section.node');",
                std::time::Duration::from_secs(10),
            )
            .await;
        assert!(browser.text().await.contains(&job));
        let visible_cookies = browser.eval("return document.cookie;").await;
        assert_eq!(
            visible_cookies.as_str(),
            Some(""),
            "scripts cannot read the token"
        );

        browser.close().await;
    });
}
