//! Who may see the dashboard: the same tokens as the master's gRPC client role. A browser signs
//! in once through the login form and gets a session: a random id, kept by the server with
//! the session's CSRF token, in an `HttpOnly`, `SameSite=Strict` cookie (`Secure` under TLS),
//! so the long-lived token never sits in the browser. A script sends `Authorization: Bearer
//! TOKEN` instead. Without either, every page answers with the login form (status 401) and
//! every stream with a bare 401: nothing of a job shows.

use axum::http::HeaderMap;
use axum::http::header::{AUTHORIZATION, COOKIE, HOST, ORIGIN};
use std::sync::Arc;

/// The cookie that holds the session id.
pub const COOKIE_NAME: &str = "hevo_session";

/// How long a session lasts after sign-in.
pub const SESSION_LIFETIME: std::time::Duration = std::time::Duration::from_secs(12 * 3600);

/// The most sessions kept at once; signing in beyond it ends the oldest.
pub const MAX_SESSIONS: usize = 1024;

/// A check of a presented token (constant time, in the caller's token set).
pub type TokenCheck = Arc<dyn Fn(&str) -> bool + Send + Sync>;

/// Who may see the pages.
#[derive(Clone)]
pub enum Access {
    /// Anyone who reaches the port (a master run with `--insecure-no-token`, or a local
    /// dashboard without a token).
    Open,
    /// Whoever presents a token the check accepts.
    Tokens(TokenCheck),
}

impl std::fmt::Debug for Access {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Access::Open => f.write_str("Access::Open"),
            Access::Tokens(_) => f.write_str("Access::Tokens(..)"),
        }
    }
}

impl Access {
    /// Tokens from a list (the local dashboard's `--token-file`).
    pub fn tokens(tokens: Vec<String>) -> Access {
        Access::Tokens(Arc::new(move |presented: &str| {
            tokens.iter().fold(false, |found, token| {
                found | constant_time_equal(token.as_bytes(), presented.as_bytes())
            })
        }))
    }

    /// Whether the pages need a token.
    pub fn needs_token(&self) -> bool {
        matches!(self, Access::Tokens(_))
    }

    /// Whether a request's headers carry an accepted bearer token.
    pub fn allows_bearer(&self, headers: &HeaderMap) -> bool {
        match self {
            Access::Open => true,
            Access::Tokens(check) => bearer_tokens(headers).any(|token| check(&token)),
        }
    }

    /// Whether `token` is accepted (the login form).
    pub fn accepts(&self, token: &str) -> bool {
        match self {
            Access::Open => true,
            Access::Tokens(check) => !token.is_empty() && check(token),
        }
    }
}

fn constant_time_equal(a: &[u8], b: &[u8]) -> bool {
    a.len() == b.len() && a.iter().zip(b).fold(0u8, |acc, (x, y)| acc | (x ^ y)) == 0
}

/// The bearer tokens a request presents.
fn bearer_tokens(headers: &HeaderMap) -> impl Iterator<Item = String> + '_ {
    headers
        .get_all(AUTHORIZATION)
        .into_iter()
        .filter_map(|value| value.to_str().ok())
        .filter_map(|value| value.strip_prefix("Bearer "))
        .map(|token| token.trim().to_string())
}

/// The session ids a request's cookies name.
fn session_ids(headers: &HeaderMap) -> impl Iterator<Item = String> + '_ {
    headers
        .get_all(COOKIE)
        .into_iter()
        .filter_map(|value| value.to_str().ok())
        .flat_map(|value| value.split(';'))
        .filter_map(|pair| pair.trim().split_once('='))
        .filter(|(name, _)| *name == COOKIE_NAME)
        .filter_map(|(_, value)| percent_decode(value))
}

/// A random 256-bit value as hex, from the operating system's generator.
fn random_hex() -> String {
    let mut bytes = [0u8; 32];
    getrandom::fill(&mut bytes).expect("the operating system's random generator");
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// A signed-in browser's session.
#[derive(Debug, Clone)]
struct Session {
    /// The token its forms must carry (the cancel button's).
    csrf: String,
    started: std::time::Instant,
}

/// The sessions of signed-in browsers, by id. Only their ids travel, in the cookie.
#[derive(Debug, Default)]
pub struct Sessions {
    open: std::sync::Mutex<std::collections::HashMap<String, Session>>,
}

impl Sessions {
    fn lock(&self) -> std::sync::MutexGuard<'_, std::collections::HashMap<String, Session>> {
        self.open
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
    }

    /// Starts a session; returns its id.
    pub fn start(&self) -> String {
        let id = random_hex();
        let mut open = self.lock();
        let now = std::time::Instant::now();
        open.retain(|_, session| now.duration_since(session.started) < SESSION_LIFETIME);
        if open.len() >= MAX_SESSIONS
            && let Some(oldest) = open
                .iter()
                .min_by_key(|(_, session)| session.started)
                .map(|(id, _)| id.clone())
        {
            open.remove(&oldest);
        }
        open.insert(
            id.clone(),
            Session {
                csrf: random_hex(),
                started: now,
            },
        );
        id
    }

    /// The CSRF token of the live session a request's cookie names, if it names one.
    pub fn csrf_of(&self, headers: &HeaderMap) -> Option<String> {
        let open = self.lock();
        session_ids(headers).find_map(|id| {
            open.get(&id)
                .filter(|session| session.started.elapsed() < SESSION_LIFETIME)
                .map(|session| session.csrf.clone())
        })
    }

    /// Ends the sessions a request's cookies name.
    pub fn end(&self, headers: &HeaderMap) {
        let mut open = self.lock();
        for id in session_ids(headers) {
            open.remove(&id);
        }
    }
}

/// Whether `a` and `b` are equal, in time that does not depend on where they differ.
pub fn same_secret(a: &str, b: &str) -> bool {
    constant_time_equal(a.as_bytes(), b.as_bytes())
}

/// The `Set-Cookie` value that carries session `id`; `Secure` when the dashboard is reached
/// over TLS.
pub fn sign_in_cookie(id: &str, secure: bool) -> String {
    format!(
        "{COOKIE_NAME}={}; HttpOnly; SameSite=Strict; Path=/{}",
        percent_encode(id),
        if secure { "; Secure" } else { "" }
    )
}

/// The `Set-Cookie` value that signs a browser out.
pub fn sign_out_cookie() -> String {
    format!("{COOKIE_NAME}=; HttpOnly; SameSite=Strict; Path=/; Max-Age=0")
}

/// Whether a state-changing request comes from this site as far as its `Origin` header says:
/// a browser sends one with every cross-site POST, and it must name the host the request was
/// sent to. A request without one comes from no browser page (curl, a script), which no
/// other site can make a browser send.
pub fn same_origin(headers: &HeaderMap) -> bool {
    let Some(origin) = headers.get(ORIGIN) else {
        return true;
    };
    let (Ok(origin), Some(Ok(host))) = (
        origin.to_str(),
        headers.get(HOST).map(|value| value.to_str()),
    ) else {
        return false;
    };
    let authority = origin
        .strip_prefix("http://")
        .or_else(|| origin.strip_prefix("https://"));
    authority.is_some_and(|authority| authority.eq_ignore_ascii_case(host))
}

/// Cookie values may not hold spaces, quotes, commas, semicolons or backslashes; a token may.
fn percent_encode(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for byte in text.bytes() {
        if byte.is_ascii_alphanumeric() || b"-._~".contains(&byte) {
            out.push(byte as char);
        } else {
            out.push_str(&format!("%{byte:02X}"));
        }
    }
    out
}

fn percent_decode(text: &str) -> Option<String> {
    let bytes = text.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            let hex = std::str::from_utf8(bytes.get(i + 1..i + 3)?).ok()?;
            out.push(u8::from_str_radix(hex, 16).ok()?);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    String::from_utf8(out).ok()
}

/// Where to go after signing in: a path on this site only (`/jobs/x`), never another site
/// (`//evil.example`, `https://...`); anything else goes to the job list.
pub fn safe_next(next: &str) -> &str {
    let local = next.starts_with('/')
        && !next.starts_with("//")
        && !next.contains('\\')
        && next.chars().all(|c| c.is_ascii_graphic());
    if local { next } else { "/" }
}

#[cfg(test)]
mod tests {
    use super::*;
    use axum::http::HeaderValue;

    fn headers(pairs: &[(&'static str, &str)]) -> HeaderMap {
        let mut map = HeaderMap::new();
        for (name, value) in pairs {
            map.append(*name, HeaderValue::from_str(value).unwrap());
        }
        map
    }

    #[test]
    fn a_bearer_header_or_a_session_signs_in_and_the_cookie_holds_no_token() {
        let access = Access::tokens(vec!["s3cret; with=odd chars".into()]);
        assert!(access.allows_bearer(&headers(&[(
            "authorization",
            "Bearer s3cret; with=odd chars"
        )])));
        assert!(!access.allows_bearer(&headers(&[])));
        assert!(!access.allows_bearer(&headers(&[("authorization", "Basic czNjcmV0")])));
        assert!(!access.accepts(""));
        assert!(Access::Open.allows_bearer(&headers(&[])));

        let sessions = Sessions::default();
        let id = sessions.start();
        let cookie = sign_in_cookie(&id, false);
        assert!(!cookie.contains("s3cret"), "{cookie}");
        let value = cookie.split(';').next().unwrap();
        let signed_in = headers(&[("cookie", &format!("a=b; {value}"))]);
        let csrf = sessions.csrf_of(&signed_in).expect("a live session");
        assert_eq!(csrf.len(), 64);
        assert_ne!(csrf, id, "the CSRF token is not the session id");
        assert!(
            sessions
                .csrf_of(&headers(&[("cookie", "hevo_session=guessed")]))
                .is_none()
        );
        // A cookie holding the token itself is no session.
        assert!(
            sessions
                .csrf_of(&headers(&[(
                    "cookie",
                    "hevo_session=s3cret%3B%20with%3Dodd%20chars"
                )]))
                .is_none()
        );
        sessions.end(&signed_in);
        assert!(sessions.csrf_of(&signed_in).is_none(), "signed out");
        assert_ne!(sessions.start(), sessions.start(), "ids are random");
    }

    #[test]
    fn the_cookie_cannot_be_read_by_scripts_nor_sent_by_other_sites() {
        let cookie = sign_in_cookie("t", false);
        assert!(cookie.contains("HttpOnly"));
        assert!(cookie.contains("SameSite=Strict"));
        assert!(!cookie.contains("Secure"));
        assert!(sign_in_cookie("t", true).ends_with("; Secure"));
    }

    #[test]
    fn sessions_are_bounded() {
        let sessions = Sessions::default();
        for _ in 0..MAX_SESSIONS + 10 {
            sessions.start();
        }
        assert_eq!(sessions.lock().len(), MAX_SESSIONS);
    }

    #[test]
    fn only_this_sites_pages_may_change_state() {
        let host = ("host", "127.0.0.1:8080");
        assert!(same_origin(&headers(&[host])), "no Origin: no browser page");
        assert!(same_origin(&headers(&[
            host,
            ("origin", "http://127.0.0.1:8080")
        ])));
        assert!(same_origin(&headers(&[
            host,
            ("origin", "https://127.0.0.1:8080")
        ])));
        for evil in [
            "http://evil.example",
            "null",
            "http://127.0.0.1:8081",
            "127.0.0.1:8080",
        ] {
            assert!(!same_origin(&headers(&[host, ("origin", evil)])), "{evil}");
        }
        assert!(
            !same_origin(&headers(&[("origin", "http://127.0.0.1:8080")])),
            "no Host"
        );
    }

    #[test]
    fn sign_in_only_redirects_within_the_site() {
        assert_eq!(safe_next("/jobs/job-1"), "/jobs/job-1");
        assert_eq!(safe_next("//evil.example/"), "/");
        assert_eq!(safe_next("https://evil.example/"), "/");
        assert_eq!(safe_next("/\\evil"), "/");
        assert_eq!(safe_next(""), "/");
    }
}
