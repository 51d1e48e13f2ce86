//! The dashboard's cancel, as another site would try it, against a live master with raw
//! requests (no browser needed): the sign-in cookie holds a random session id, not the token;
//! a cancel from another site's page is refused even with the cookie and the form's token; a
//! cancel from the dashboard's own page needs the session's form token, which the job page
//! carries; every answer forbids framing and foreign content.

use hevo_tests::Scratch;
use hevo_tests::dashboard::{dashboard_url, master_with_dashboard, request, submit, watchable};
use hevo_tests::service::{CLIENT_TOKEN, runtime};

#[test]
fn a_cancel_needs_the_dashboards_own_page() {
    let scratch = Scratch::new("dashboard-csrf");
    let master = master_with_dashboard(&scratch);
    let url = dashboard_url(&master).to_string();
    let host = url.trim_start_matches("http://").to_string();
    let job = runtime().block_on(submit(&master, &watchable()));
    let form = "Content-Type: application/x-www-form-urlencoded";

    let login = request(
        &url,
        "POST",
        "/login",
        &[form, &format!("Origin: http://{host}")],
        &format!("token={CLIENT_TOKEN}&next=%2F"),
    );
    assert_eq!(login.status, 303, "{login:?}");
    let set_cookie = login
        .headers
        .lines()
        .find(|l| l.to_ascii_lowercase().starts_with("set-cookie:"))
        .expect("a session cookie")
        .to_string();
    assert!(!set_cookie.contains(CLIENT_TOKEN), "{set_cookie}");
    let session = set_cookie["set-cookie:".len()..]
        .trim()
        .split(';')
        .next()
        .unwrap()
        .to_string();
    assert!(session.starts_with("hevo_session="), "{session}");
    let cookie = format!("Cookie: {session}");

    let page = request(&url, "GET", &format!("/jobs/{job}"), &[&cookie], "");
    assert_eq!(page.status, 200, "{page:?}");
    for header in [
        "content-security-policy: default-src 'self'",
        "frame-ancestors 'none'",
        "x-frame-options: DENY",
    ] {
        assert!(
            page.headers
                .to_ascii_lowercase()
                .contains(&header.to_ascii_lowercase()),
            "{header}: {}",
            page.headers
        );
    }
    let marker = "name=\"csrf\" value=\"";
    let at = page
        .body
        .find(marker)
        .expect("the cancel form carries a token")
        + marker.len();
    let csrf = &page.body[at..at + 64];

    let cancel = |origin: &str, body: &str| {
        request(
            &url,
            "POST",
            &format!("/jobs/{job}/cancel"),
            &[form, &cookie, &format!("Origin: {origin}")],
            body,
        )
    };
    let evil = cancel("http://evil.example", &format!("csrf={csrf}"));
    assert_eq!(evil.status, 403, "another site's page: {evil:?}");
    let tokenless = cancel(&format!("http://{host}"), "");
    assert_eq!(tokenless.status, 403, "no form token: {tokenless:?}");
    let page = request(&url, "GET", &format!("/jobs/{job}"), &[&cookie], "");
    assert!(page.body.contains("Cancel job"), "still running");

    let own = cancel(&format!("http://{host}"), &format!("csrf={csrf}"));
    assert_eq!(own.status, 303, "the dashboard's own page: {own:?}");
    let page = request(&url, "GET", &format!("/jobs/{job}"), &[&cookie], "");
    assert!(page.body.contains("cancelled"), "{}", page.body);
}
