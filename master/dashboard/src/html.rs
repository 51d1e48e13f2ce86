//! The small HTML toolkit the pages share: escaping (hevo-viz's, which suits HTML text and
//! attributes too), the page frame with the embedded stylesheet and script, the plain error
//! page, and UTC times without a date library.

use axum::http::StatusCode;
use axum::response::{Html, IntoResponse, Response};

/// The stylesheet, served at [`STYLE_PATH`].
pub const STYLE: &str = include_str!("assets/dashboard.css");
/// The script, served at [`SCRIPT_PATH`].
pub const SCRIPT: &str = include_str!("assets/dashboard.js");
/// Where the stylesheet is served.
pub const STYLE_PATH: &str = "/assets/dashboard.css";
/// Where the script is served.
pub const SCRIPT_PATH: &str = "/assets/dashboard.js";

/// Text made safe for HTML text and quoted attribute values.
pub fn escape(text: &str) -> String {
    hevo_viz::svg::escape(text)
}

/// A whole page: `title` in the tab and the header, `body` inside `<main>`; `signed_in` adds
/// the sign-out button.
pub fn page(site: &str, title: &str, body: &str, signed_in: bool) -> String {
    let sign_out = if signed_in {
        r#"<form class="sign-out" method="post" action="/logout"><button type="submit">Sign out</button></form>"#
    } else {
        ""
    };
    format!(
        r#"<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>{title} · {site}</title>
<link rel="stylesheet" href="{STYLE_PATH}">
<script src="{SCRIPT_PATH}" defer></script>
</head>
<body>
<header><a class="home" href="/">hevo dashboard</a> <span class="site">{site}</span>{sign_out}</header>
<main>
{body}
</main>
</body>
</html>
"#,
        title = escape(title),
        site = escape(site),
    )
}

/// A plain error page with `status`, saying `message`.
pub fn error_page(status: StatusCode, message: &str) -> Response {
    let title = status.canonical_reason().unwrap_or("error");
    let body = format!(
        "<h1>{} {}</h1>\n<p class=\"error-message\">{}</p>\n<p><a href=\"/\">All jobs</a></p>",
        status.as_u16(),
        escape(title),
        escape(message)
    );
    (status, Html(page("hevo", title, &body, false))).into_response()
}

/// `2026-12-01 23:14:36 UTC` for a time in ms since the Unix epoch.
pub fn utc(unix_ms: i64) -> String {
    let seconds = unix_ms.div_euclid(1000);
    let days = seconds.div_euclid(86_400);
    let second_of_day = seconds.rem_euclid(86_400);
    let (year, month, day) = civil_from_days(days);
    format!(
        "{year:04}-{month:02}-{day:02} {:02}:{:02}:{:02} UTC",
        second_of_day / 3600,
        second_of_day / 60 % 60,
        second_of_day % 60
    )
}

/// (year, month, day) of a day count since 1970-01-01 (Howard Hinnant's algorithm).
fn civil_from_days(days: i64) -> (i64, u32, u32) {
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let day_of_era = z.rem_euclid(146_097);
    let year_of_era =
        (day_of_era - day_of_era / 1460 + day_of_era / 36_524 - day_of_era / 146_096) / 365;
    let day_of_year = day_of_era - (365 * year_of_era + year_of_era / 4 - year_of_era / 100);
    let mp = (5 * day_of_year + 2) / 153;
    let day = (day_of_year - (153 * mp + 2) / 5 + 1) as u32;
    let month = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    let year = year_of_era + era * 400 + i64::from(month <= 2);
    (year, month, day)
}

/// A share as `83.7 %`, or a dash.
pub fn percent(share: Option<f64>) -> String {
    match share {
        Some(share) if share.is_finite() => format!("{:.1} %", 100.0 * share),
        _ => "–".to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn utc_times_match_known_dates() {
        assert_eq!(utc(0), "1970-01-01 00:00:00 UTC");
        assert_eq!(utc(951_782_400_000), "2000-02-29 00:00:00 UTC");
        assert_eq!(utc(1_796_166_876_000), "2026-12-01 23:14:36 UTC");
    }

    #[test]
    fn pages_escape_their_titles() {
        let html = page("a<b", "<script>", "<p>ok</p>", false);
        assert!(html.contains("&lt;script&gt;"));
        assert!(!html.contains("<title><script>"));
        assert!(html.contains("<p>ok</p>"));
    }

    #[test]
    fn percentages_read_like_the_reports() {
        assert_eq!(percent(Some(0.837)), "83.7 %");
        assert_eq!(percent(None), "–");
        assert_eq!(percent(Some(f64::NAN)), "–");
    }
}
