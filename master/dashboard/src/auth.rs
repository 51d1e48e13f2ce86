//! Who may see the dashboard: the same tokens as the master's gRPC client role. A browser signs
//! in once through the login form, which puts the token in an `HttpOnly`, `SameSite=Strict`
//! cookie (scripts cannot read it, other sites cannot send it); a script sends
//! `Authorization: Bearer TOKEN` instead. Without either, every page answers with the login
//! form (status 401) and every stream with a bare 401: nothing of a job shows.

use axum::http::HeaderMap;
use axum::http::header::{AUTHORIZATION, COOKIE};
use std::sync::Arc;

/// The cookie that holds the token.
pub const COOKIE_NAME: &str = "hevo_token";

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

    /// Whether a request's headers carry an accepted token.
    pub fn allows(&self, headers: &HeaderMap) -> bool {
        match self {
            Access::Open => true,
            Access::Tokens(check) => presented_tokens(headers).any(|token| check(&token)),
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

/// The tokens a request presents: the bearer token and the cookie's.
fn presented_tokens(headers: &HeaderMap) -> impl Iterator<Item = String> + '_ {
    let bearer = headers
        .get_all(AUTHORIZATION)
        .into_iter()
        .filter_map(|value| value.to_str().ok())
        .filter_map(|value| value.strip_prefix("Bearer "))
        .map(|token| token.trim().to_string());
    let cookies = headers
        .get_all(COOKIE)
        .into_iter()
        .filter_map(|value| value.to_str().ok())
        .flat_map(|value| value.split(';'))
        .filter_map(|pair| pair.trim().split_once('='))
        .filter(|(name, _)| *name == COOKIE_NAME)
        .filter_map(|(_, value)| percent_decode(value));
    bearer.chain(cookies)
}

/// The `Set-Cookie` value that signs a browser in.
pub fn sign_in_cookie(token: &str) -> String {
    format!(
        "{COOKIE_NAME}={}; HttpOnly; SameSite=Strict; Path=/",
        percent_encode(token)
    )
}

/// The `Set-Cookie` value that signs a browser out.
pub fn sign_out_cookie() -> String {
    format!("{COOKIE_NAME}=; HttpOnly; SameSite=Strict; Path=/; Max-Age=0")
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
    fn a_cookie_or_a_bearer_header_signs_in() {
        let access = Access::tokens(vec!["s3cret; with=odd chars".into()]);
        let cookie = sign_in_cookie("s3cret; with=odd chars");
        let value = cookie.split(';').next().unwrap();
        assert!(access.allows(&headers(&[("cookie", &format!("a=b; {value}"))])));
        assert!(access.allows(&headers(&[(
            "authorization",
            "Bearer s3cret; with=odd chars"
        )])));
        assert!(!access.allows(&headers(&[])));
        assert!(!access.allows(&headers(&[("cookie", "hevo_token=wrong")])));
        assert!(!access.allows(&headers(&[("authorization", "Basic czNjcmV0")])));
        assert!(!access.accepts(""));
        assert!(Access::Open.allows(&headers(&[])));
    }

    #[test]
    fn the_cookie_cannot_be_read_by_scripts_nor_sent_by_other_sites() {
        let cookie = sign_in_cookie("t");
        assert!(cookie.contains("HttpOnly"));
        assert!(cookie.contains("SameSite=Strict"));
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
