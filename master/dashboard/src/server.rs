//! The dashboard's HTTP server (axum): the routes, the sign-in guard in front of them, and the
//! mapping of every failure to a plain page with its status (400 malformed, 401 not signed
//! in, 404 unknown job, node or page, 409 not cancellable here, 500 unreadable files); a
//! handler never panics on input. File reads run on tokio's blocking threads.
//!
//! | route | what |
//! |---|---|
//! | `GET /` | the jobs (and the master's workers) |
//! | `GET /jobs/{id}?seed=N` | a job's page; `seed` picks the replayed sample |
//! | `GET /jobs/{id}/events` | its Server-Sent Events ([`crate::stream`]) |
//! | `GET /jobs/{id}/plot.svg?node=NAME` | a node's fitness plot |
//! | `POST /jobs/{id}/cancel` | cancels it, back to its page |
//! | `GET`, `POST /login`; `POST /logout` | the sign-in form; signing out |
//! | `GET /assets/...` | the stylesheet and the script |

use crate::auth::{
    Access, Sessions, safe_next, same_origin, same_secret, sign_in_cookie, sign_out_cookie,
};
use crate::connections::{ConnectionGate, ConnectionLimits, GatedListener};
use crate::html::{SCRIPT, SCRIPT_PATH, STYLE, STYLE_PATH, error_page, page};
use crate::replay::{ReplayFigure, replays};
use crate::stream::StreamGuard;
use crate::stream::{OpenStreams, job_events};
use crate::{Source, SourceError, pages};
use axum::extract::rejection::{FormRejection, QueryRejection};
use axum::extract::{Form, Path, Query, Request, State};
use axum::http::header::{CACHE_CONTROL, CONTENT_TYPE, LOCATION, SET_COOKIE};
use axum::http::{HeaderMap, Method, StatusCode};
use axum::middleware::Next;
use axum::response::{Html, IntoResponse, Response};
use axum::routing::{get, post};
use axum::{Router, middleware};
use std::collections::HashMap;
use std::future::Future;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use tokio::sync::watch;

/// The longest job id a request may name.
pub const MAX_JOB_ID_CHARS: usize = 128;
/// The replay seed when the page's query names none.
pub const DEFAULT_REPLAY_SEED: u64 = 1;
/// Replays kept computed (job, node, seed); the oldest go first beyond this.
const REPLAY_CACHE_ENTRIES: usize = 32;

type ReplayResult = Arc<Result<Vec<ReplayFigure>, String>>;
/// Computed replays by (job, node, seed), oldest first.
type ReplayCache = Mutex<Vec<((String, String, u64), ReplayResult)>>;
/// An error page, boxed (a response is large, and handlers pass it up with `?`).
type Refusal = Box<Response>;

struct Shared {
    source: Arc<dyn Source>,
    access: Access,
    open_streams: Arc<OpenStreams>,
    replays: ReplayCache,
    stopping: watch::Sender<bool>,
    max_streams: AtomicUsize,
    sessions: Sessions,
    secure_cookies: std::sync::atomic::AtomicBool,
}

/// Who is making a request, as the guard found out.
#[derive(Debug, Clone)]
enum Caller {
    /// Anyone: the dashboard needs no token.
    Open,
    /// A script with the token in its `Authorization` header (no browser sends one by itself).
    Bearer,
    /// A signed-in browser, with its session's CSRF token.
    Session(String),
}

/// The headers every answer carries: nothing from elsewhere runs or loads, and no other site
/// may frame a page (clickjacking the cancel button).
const SECURITY_HEADERS: [(&str, &str); 5] = [
    (
        "content-security-policy",
        "default-src 'self'; img-src 'self' data:; object-src 'none'; base-uri 'none'; \
         form-action 'self'; frame-ancestors 'none'",
    ),
    ("x-frame-options", "DENY"),
    ("x-content-type-options", "nosniff"),
    ("referrer-policy", "same-origin"),
    ("cross-origin-opener-policy", "same-origin"),
];

/// The most event streams a dashboard serves at once unless told otherwise.
pub const DEFAULT_MAX_STREAMS: usize = 256;

/// A dashboard over a source, behind an access rule. Cheap to clone.
#[derive(Clone)]
pub struct Dashboard {
    shared: Arc<Shared>,
}

impl std::fmt::Debug for Dashboard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Dashboard")
            .field("access", &self.shared.access)
            .field("open_streams", &self.shared.open_streams.count())
            .finish_non_exhaustive()
    }
}

impl Dashboard {
    /// A dashboard over `source`.
    pub fn new(source: Arc<dyn Source>, access: Access) -> Dashboard {
        Dashboard {
            shared: Arc::new(Shared {
                source,
                access,
                open_streams: Arc::default(),
                replays: Mutex::new(Vec::new()),
                stopping: watch::channel(false).0,
                max_streams: AtomicUsize::new(DEFAULT_MAX_STREAMS),
                sessions: Sessions::default(),
                secure_cookies: std::sync::atomic::AtomicBool::new(false),
            }),
        }
    }

    /// Marks session cookies `Secure`: the dashboard is reached over TLS (a master with TLS,
    /// its dashboard behind a TLS proxy). A request that says it came through a TLS proxy
    /// (`X-Forwarded-Proto: https`) gets a `Secure` cookie either way.
    pub fn set_secure_cookies(&self, secure: bool) {
        self.shared.secure_cookies.store(secure, Ordering::Relaxed);
    }

    /// Sets the most event streams served at once; one more is answered 503.
    pub fn set_max_streams(&self, max: usize) {
        self.shared.max_streams.store(max, Ordering::Relaxed);
    }

    /// The most event streams served at once.
    pub fn max_streams(&self) -> usize {
        self.shared.max_streams.load(Ordering::Relaxed)
    }

    /// Event streams open now.
    pub fn open_streams(&self) -> usize {
        self.shared.open_streams.count()
    }

    /// Ends every event stream (before a shutdown, so the server can drain).
    pub fn stop_streams(&self) {
        let _ = self.shared.stopping.send(true);
    }

    /// The routes, behind the sign-in guard.
    pub fn router(&self) -> Router {
        Router::new()
            .route("/", get(jobs_page))
            .route("/jobs/{id}", get(job_page))
            .route("/jobs/{id}/events", get(events))
            .route("/jobs/{id}/plot.svg", get(plot))
            .route("/jobs/{id}/cancel", post(cancel))
            .route("/login", get(login_page).post(login))
            .route("/logout", post(logout))
            .route(STYLE_PATH, get(style))
            .route(SCRIPT_PATH, get(script))
            .fallback(not_found)
            .layer(middleware::from_fn_with_state(self.clone(), guard))
            .layer(middleware::map_response(with_security_headers))
            .with_state(self.clone())
    }
}

/// Serves `dashboard` on `listener` until `shutdown` resolves; then ends the streams and
/// drains.
pub async fn serve(
    listener: tokio::net::TcpListener,
    dashboard: Dashboard,
    limits: ConnectionLimits,
    shutdown: impl Future<Output = ()> + Send + 'static,
) -> std::io::Result<()> {
    let router = dashboard.router();
    let listener = GatedListener::new(listener, ConnectionGate::new("http", limits));
    axum::serve(listener, router)
        .with_graceful_shutdown(async move {
            shutdown.await;
            dashboard.stop_streams();
        })
        .await
}

/// Lets a request through when it is signed in, or needs no sign-in (the login form, the
/// assets); otherwise a page gets the login form and anything else a bare 401.
async fn guard(State(dashboard): State<Dashboard>, mut request: Request, next: Next) -> Response {
    let path = request.uri().path();
    let public = path == "/login" || path.starts_with("/assets/");
    let caller = dashboard.caller(request.headers());
    // A browser's state-changing request must come from this site's own pages (the bearer
    // header is a script's, which no other site can make a browser send).
    if request.method() == Method::POST
        && !matches!(caller, Some(Caller::Bearer))
        && !same_origin(request.headers())
    {
        tracing::warn!(path, "refused a request from another site's page");
        return error_page(
            StatusCode::FORBIDDEN,
            "refused: the request comes from another site's page",
        );
    }
    if let Some(caller) = caller {
        request.extensions_mut().insert(caller);
        return next.run(request).await;
    }
    if public {
        return next.run(request).await;
    }
    let wants_page =
        request.method() == Method::GET && !path.ends_with("/events") && !path.ends_with(".svg");
    if !wants_page {
        return (
            StatusCode::UNAUTHORIZED,
            [(CACHE_CONTROL, "no-store")],
            "sign in first: the dashboard needs the clients' token (login form or Authorization: Bearer)\n",
        )
            .into_response();
    }
    let next_path = request
        .uri()
        .path_and_query()
        .map_or("/", |p| p.as_str())
        .to_string();
    login_response(StatusCode::UNAUTHORIZED, &next_path, None)
}

async fn with_security_headers(mut response: Response) -> Response {
    let headers = response.headers_mut();
    for (name, value) in SECURITY_HEADERS {
        headers.insert(name, axum::http::HeaderValue::from_static(value));
    }
    response
}

impl Dashboard {
    /// Who makes a request with these headers, if anyone the dashboard lets in.
    fn caller(&self, headers: &HeaderMap) -> Option<Caller> {
        let access = &self.shared.access;
        if !access.needs_token() {
            return Some(Caller::Open);
        }
        if access.allows_bearer(headers) {
            return Some(Caller::Bearer);
        }
        self.shared.sessions.csrf_of(headers).map(Caller::Session)
    }

    /// Whether a session cookie set in answer to a request with these headers is `Secure`.
    fn secure_cookie(&self, headers: &HeaderMap) -> bool {
        self.shared.secure_cookies.load(Ordering::Relaxed)
            || headers
                .get("x-forwarded-proto")
                .and_then(|value| value.to_str().ok())
                .is_some_and(|proto| proto.eq_ignore_ascii_case("https"))
    }
}

fn login_response(status: StatusCode, next: &str, message: Option<&str>) -> Response {
    (
        status,
        [(CACHE_CONTROL, "no-store")],
        Html(page(
            "hevo",
            "Sign in",
            &pages::login_body(safe_next(next), message),
            false,
        )),
    )
        .into_response()
}

fn signed_in(dashboard: &Dashboard) -> bool {
    dashboard.shared.access.needs_token()
}

fn source_refusal(error: SourceError) -> Refusal {
    Box::new(source_error(error))
}

fn source_error(error: SourceError) -> Response {
    let status = match &error {
        SourceError::NotFound(_) => StatusCode::NOT_FOUND,
        SourceError::Invalid(_) => StatusCode::BAD_REQUEST,
        SourceError::Unsupported(_) => StatusCode::CONFLICT,
        SourceError::Failed(_) => StatusCode::INTERNAL_SERVER_ERROR,
    };
    error_page(status, &error.to_string())
}

/// A job id as requests may name one: 1 to [`MAX_JOB_ID_CHARS`] of `A-Z a-z 0-9 - _ .`.
fn check_job_id(id: &str) -> Result<(), Refusal> {
    let ok = !id.is_empty()
        && id.len() <= MAX_JOB_ID_CHARS
        && id
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_.".contains(c));
    if ok {
        Ok(())
    } else {
        Err(Box::new(error_page(
            StatusCode::BAD_REQUEST,
            &format!("malformed job id: 1 to {MAX_JOB_ID_CHARS} letters, digits, '-', '_' or '.'"),
        )))
    }
}

fn bad_query(rejection: QueryRejection) -> Response {
    error_page(
        StatusCode::BAD_REQUEST,
        &format!("malformed query: {}", rejection.body_text()),
    )
}

/// Runs `read` on a blocking thread; a panic there (a bug) is a 500, not a crash.
async fn blocking<T: Send + 'static>(
    read: impl FnOnce() -> Result<T, Refusal> + Send + 'static,
) -> Result<T, Refusal> {
    match tokio::task::spawn_blocking(read).await {
        Ok(result) => result,
        Err(_) => Err(Box::new(error_page(
            StatusCode::INTERNAL_SERVER_ERROR,
            "the page could not be made",
        ))),
    }
}

async fn jobs_page(State(dashboard): State<Dashboard>) -> Response {
    let source = dashboard.shared.source.clone();
    let body = blocking(move || {
        Ok(pages::jobs_body(
            &source.title(),
            &source.jobs(),
            source.workers().as_ref(),
        ))
    })
    .await;
    match body {
        Ok(body) => {
            let title = dashboard.shared.source.title();
            Html(page(&title, "jobs", &body, signed_in(&dashboard))).into_response()
        }
        Err(response) => *response,
    }
}

/// The job page's query.
#[derive(Debug, serde::Deserialize)]
struct JobQuery {
    seed: Option<u64>,
}

fn cached_replays(dashboard: &Dashboard, id: &str, node: &str, seed: u64) -> Option<ReplayResult> {
    let key = (id.to_string(), node.to_string(), seed);
    if let Some((_, found)) = dashboard
        .shared
        .replays
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .iter()
        .find(|(k, _)| *k == key)
    {
        return Some(found.clone());
    }
    let computed: ReplayResult = match dashboard.shared.source.best_controller(id, node) {
        Ok(Some(best)) => Arc::new(replays(node, &best, seed)),
        Ok(None) => return None,
        Err(error) => Arc::new(Err(error.to_string())),
    };
    let mut cache = dashboard
        .shared
        .replays
        .lock()
        .unwrap_or_else(|p| p.into_inner());
    if cache.len() >= REPLAY_CACHE_ENTRIES {
        cache.remove(0);
    }
    cache.push((key, computed.clone()));
    Some(computed)
}

async fn job_page(
    State(dashboard): State<Dashboard>,
    Path(id): Path<String>,
    caller: Option<axum::Extension<Caller>>,
    query: Result<Query<JobQuery>, QueryRejection>,
) -> Response {
    let csrf = match caller {
        Some(axum::Extension(Caller::Session(csrf))) => Some(csrf),
        _ => None,
    };
    if let Err(response) = check_job_id(&id) {
        return *response;
    }
    let seed = match query {
        Ok(Query(query)) => query.seed.unwrap_or(DEFAULT_REPLAY_SEED),
        Err(rejection) => return bad_query(rejection),
    };
    let reader = dashboard.clone();
    let made = blocking(move || {
        let source = &reader.shared.source;
        let job = source.job(&id).map_err(source_refusal)?;
        let nodes = source.nodes(&id).map_err(source_refusal)?;
        let mut body = pages::job_header(&job, seed, csrf.as_deref());
        let job_running = job.state == "running";
        for node in &nodes {
            let replays = node
                .finished()
                .then(|| cached_replays(&reader, &id, &node.name, seed))
                .flatten();
            let replays = replays.as_ref().map(|r| {
                r.as_ref()
                    .as_ref()
                    .map(Vec::as_slice)
                    .map_err(String::as_str)
            });
            body.push_str(&pages::node_section(&id, node, job_running, replays));
        }
        Ok((job.name, body))
    })
    .await;
    match made {
        Ok((name, body)) => (
            [(CACHE_CONTROL, "no-store")],
            Html(page(
                &dashboard.shared.source.title(),
                &name,
                &body,
                signed_in(&dashboard),
            )),
        )
            .into_response(),
        Err(response) => *response,
    }
}

async fn events(State(dashboard): State<Dashboard>, Path(id): Path<String>) -> Response {
    if let Err(response) = check_job_id(&id) {
        return *response;
    }
    let source = dashboard.shared.source.clone();
    let checked = {
        let id = id.clone();
        blocking(move || source.job(&id).map(|_| ()).map_err(source_refusal)).await
    };
    if let Err(response) = checked {
        return *response;
    }
    let max_streams = dashboard.max_streams();
    let Some(guard) = StreamGuard::try_new(dashboard.shared.open_streams.clone(), max_streams)
    else {
        tracing::warn!(
            max_streams,
            "event stream limit reached: a stream was refused"
        );
        return (
            StatusCode::SERVICE_UNAVAILABLE,
            [(CACHE_CONTROL, "no-store")],
            format!("{max_streams} event streams are open, the most this dashboard serves; try again later\n"),
        )
            .into_response();
    };
    (
        [(CACHE_CONTROL, "no-store")],
        job_events(
            dashboard.shared.source.clone(),
            id,
            dashboard.shared.stopping.subscribe(),
            guard,
        ),
    )
        .into_response()
}

/// The plot's query.
#[derive(Debug, serde::Deserialize)]
struct PlotQuery {
    node: String,
}

async fn plot(
    State(dashboard): State<Dashboard>,
    Path(id): Path<String>,
    query: Result<Query<PlotQuery>, QueryRejection>,
) -> Response {
    if let Err(response) = check_job_id(&id) {
        return *response;
    }
    let node = match query {
        Ok(Query(query)) => query.node,
        Err(rejection) => return bad_query(rejection),
    };
    let source = dashboard.shared.source.clone();
    let svg = blocking(move || {
        let nodes = source.nodes(&id).map_err(source_refusal)?;
        let found = nodes.iter().find(|n| n.name == node).ok_or_else(|| {
            Box::new(error_page(
                StatusCode::NOT_FOUND,
                &format!("job {id} has no node {node}"),
            ))
        })?;
        Ok(pages::plot_svg(found))
    })
    .await;
    match svg {
        Ok(svg) => (
            [
                (CONTENT_TYPE, "image/svg+xml; charset=utf-8"),
                (CACHE_CONTROL, "no-store"),
            ],
            svg,
        )
            .into_response(),
        Err(response) => *response,
    }
}

/// The cancel form's fields.
#[derive(Debug, Default, serde::Deserialize)]
struct CancelForm {
    #[serde(default)]
    csrf: String,
}

async fn cancel(
    State(dashboard): State<Dashboard>,
    Path(id): Path<String>,
    caller: Option<axum::Extension<Caller>>,
    form: Result<Form<CancelForm>, FormRejection>,
) -> Response {
    if let Err(response) = check_job_id(&id) {
        return *response;
    }
    // A signed-in browser's cancel must carry its session's token, which only this site's
    // own page holds.
    if let Some(axum::Extension(Caller::Session(csrf))) = &caller {
        let sent = form.map(|Form(form)| form.csrf).unwrap_or_default();
        if !same_secret(&sent, csrf) {
            tracing::warn!(job = %id, "refused a cancel without the session's CSRF token");
            return error_page(
                StatusCode::FORBIDDEN,
                "refused: the request lacks this session's form token; reload the job's page and try again",
            );
        }
    }
    match dashboard.shared.source.cancel(&id).await {
        Ok(()) => (StatusCode::SEE_OTHER, [(LOCATION, format!("/jobs/{id}"))]).into_response(),
        Err(error) => source_error(error),
    }
}

async fn login_page(query: Result<Query<HashMap<String, String>>, QueryRejection>) -> Response {
    let next = match &query {
        Ok(Query(query)) => query.get("next").map_or("/", String::as_str),
        Err(_) => "/",
    };
    login_response(StatusCode::OK, next, None)
}

/// The login form's fields.
#[derive(Debug, serde::Deserialize)]
struct LoginForm {
    token: String,
    #[serde(default)]
    next: String,
}

async fn login(
    State(dashboard): State<Dashboard>,
    request_headers: HeaderMap,
    form: Result<Form<LoginForm>, FormRejection>,
) -> Response {
    let Ok(Form(form)) = form else {
        return login_response(StatusCode::BAD_REQUEST, "/", Some("the form needs a token"));
    };
    if !dashboard.shared.access.accepts(&form.token) {
        return login_response(
            StatusCode::UNAUTHORIZED,
            &form.next,
            Some("that token is not accepted"),
        );
    }
    let mut headers = HeaderMap::new();
    if let Ok(value) = safe_next(&form.next).parse() {
        headers.insert(LOCATION, value);
    }
    if dashboard.shared.access.needs_token() {
        let session = dashboard.shared.sessions.start();
        let secure = dashboard.secure_cookie(&request_headers);
        if let Ok(value) = sign_in_cookie(&session, secure).parse() {
            headers.insert(SET_COOKIE, value);
        }
    }
    (StatusCode::SEE_OTHER, headers).into_response()
}

async fn logout(State(dashboard): State<Dashboard>, request_headers: HeaderMap) -> Response {
    dashboard.shared.sessions.end(&request_headers);
    let mut headers = HeaderMap::new();
    headers.insert(LOCATION, "/login".parse().expect("a valid header"));
    if let Ok(value) = sign_out_cookie().parse() {
        headers.insert(SET_COOKIE, value);
    }
    (StatusCode::SEE_OTHER, headers).into_response()
}

async fn style() -> Response {
    ([(CONTENT_TYPE, "text/css; charset=utf-8")], STYLE).into_response()
}

async fn script() -> Response {
    ([(CONTENT_TYPE, "text/javascript; charset=utf-8")], SCRIPT).into_response()
}

async fn not_found(request: Request) -> Response {
    error_page(
        StatusCode::NOT_FOUND,
        &format!("no page {}", request.uri().path()),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rundirs::RunDirSource;
    use axum::body::Body;
    use tower::ServiceExt;

    fn dashboard(access: Access) -> Dashboard {
        let runs = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../experiments/runs-wide-turn-starts");
        let source = RunDirSource::new(&[runs]).unwrap();
        Dashboard::new(Arc::new(source), access)
    }

    async fn get(dashboard: &Dashboard, uri: &str, token: Option<&str>) -> (StatusCode, String) {
        let mut request = Request::builder().uri(uri);
        if let Some(token) = token {
            request = request.header("authorization", format!("Bearer {token}"));
        }
        let response = dashboard
            .router()
            .oneshot(request.body(Body::empty()).unwrap())
            .await
            .unwrap();
        let status = response.status();
        let bytes = axum::body::to_bytes(response.into_body(), 1 << 24)
            .await
            .unwrap();
        (status, String::from_utf8_lossy(&bytes).into_owned())
    }

    #[tokio::test]
    async fn without_a_token_there_is_only_the_login_page() {
        let dashboard = dashboard(Access::tokens(vec!["t".into()]));
        for uri in ["/", "/jobs/runs-wide-turn-starts"] {
            let (status, body) = get(&dashboard, uri, None).await;
            assert_eq!(status, StatusCode::UNAUTHORIZED, "{uri}");
            assert!(body.contains("Sign in"), "{uri}");
            assert!(!body.contains("turn_left"), "{uri}");
        }
        let (status, body) = get(&dashboard, "/jobs/runs-wide-turn-starts/events", None).await;
        assert_eq!(status, StatusCode::UNAUTHORIZED);
        assert!(!body.contains("turn_left"));
        let (status, body) = get(&dashboard, "/", Some("t")).await;
        assert_eq!(status, StatusCode::OK);
        assert!(body.contains("runs-wide-turn-starts"));
    }

    #[tokio::test]
    async fn bad_requests_get_plain_errors() {
        let dashboard = dashboard(Access::Open);
        let (status, body) = get(&dashboard, "/jobs/job-nope", None).await;
        assert_eq!(status, StatusCode::NOT_FOUND);
        assert!(body.contains("no job job-nope"));
        let (status, _) = get(&dashboard, "/jobs/runs-wide-turn-starts?seed=x", None).await;
        assert_eq!(status, StatusCode::BAD_REQUEST);
        let (status, _) = get(&dashboard, "/jobs/runs-wide-turn-starts/plot.svg", None).await;
        assert_eq!(status, StatusCode::BAD_REQUEST);
        let (status, body) = get(
            &dashboard,
            "/jobs/runs-wide-turn-starts/plot.svg?node=nope",
            None,
        )
        .await;
        assert_eq!(status, StatusCode::NOT_FOUND);
        assert!(body.contains("has no node nope"));
        let (status, _) = get(&dashboard, "/jobs/%3Cx%3E", None).await;
        assert_eq!(status, StatusCode::BAD_REQUEST);
        let (status, _) = get(&dashboard, "/nothing/here", None).await;
        assert_eq!(status, StatusCode::NOT_FOUND);
    }

    #[tokio::test]
    async fn a_finished_run_directory_shows_tables_plots_and_replays() {
        let dashboard = dashboard(Access::Open);
        let (status, body) = get(&dashboard, "/jobs/runs-wide-turn-starts", None).await;
        assert_eq!(status, StatusCode::OK);
        assert!(body.contains("class=\"post-evaluation\""));
        assert!(body.contains("class=\"replay\""));
        assert!(body.contains("class=\"fitness\""));
        let (status, svg) = get(
            &dashboard,
            "/jobs/runs-wide-turn-starts/plot.svg?node=turn_left",
            None,
        )
        .await;
        assert_eq!(status, StatusCode::OK);
        assert!(svg.starts_with("<svg"));
    }

    /// Opens the event stream of a run directory's job page.
    async fn open_events(dashboard: Dashboard) -> axum::response::Response {
        dashboard
            .router()
            .oneshot(
                Request::builder()
                    .uri("/jobs/runs-wide-turn-starts/events")
                    .body(Body::empty())
                    .unwrap(),
            )
            .await
            .unwrap()
    }

    #[tokio::test]
    async fn an_abandoned_stream_is_dropped() {
        let dashboard = dashboard(Access::Open);
        let response = open_events(dashboard.clone()).await;
        assert_eq!(response.status(), StatusCode::OK);
        for _ in 0..100 {
            if dashboard.open_streams() == 1 {
                break;
            }
            tokio::time::sleep(std::time::Duration::from_millis(10)).await;
        }
        assert_eq!(dashboard.open_streams(), 1);
        drop(response);
        for _ in 0..200 {
            if dashboard.open_streams() == 0 {
                break;
            }
            tokio::time::sleep(std::time::Duration::from_millis(10)).await;
        }
        assert_eq!(dashboard.open_streams(), 0);
    }

    /// Sends a request; returns its status, headers and body.
    async fn send(
        dashboard: &Dashboard,
        method: &str,
        uri: &str,
        headers: &[(&str, &str)],
        body: &str,
    ) -> (StatusCode, HeaderMap, String) {
        let mut request = Request::builder().method(method).uri(uri);
        for (name, value) in headers {
            request = request.header(*name, *value);
        }
        let response = dashboard
            .router()
            .oneshot(request.body(Body::from(body.to_string())).unwrap())
            .await
            .unwrap();
        let (status, headers) = (response.status(), response.headers().clone());
        let bytes = axum::body::to_bytes(response.into_body(), 1 << 24)
            .await
            .unwrap();
        (
            status,
            headers,
            String::from_utf8_lossy(&bytes).into_owned(),
        )
    }

    const FORM: (&str, &str) = ("content-type", "application/x-www-form-urlencoded");
    const HOST: (&str, &str) = ("host", "127.0.0.1:8080");
    const JOB: &str = "/jobs/runs-wide-turn-starts";

    /// Signs in with token `t`; returns the `Cookie` header value of the session.
    async fn sign_in(dashboard: &Dashboard) -> String {
        let (status, headers, _) = send(
            dashboard,
            "POST",
            "/login",
            &[FORM, HOST, ("origin", "http://127.0.0.1:8080")],
            "token=t&next=%2F",
        )
        .await;
        assert_eq!(status, StatusCode::SEE_OTHER);
        let cookie = headers[SET_COOKIE].to_str().unwrap().to_string();
        assert!(cookie.starts_with("hevo_session="), "{cookie}");
        assert!(
            !cookie.contains("=t;"),
            "the cookie holds no token: {cookie}"
        );
        cookie.split(';').next().unwrap().to_string()
    }

    #[tokio::test]
    async fn a_session_cookie_signs_in_and_signing_out_ends_it() {
        let dashboard = dashboard(Access::tokens(vec!["t".into()]));
        let cookie = sign_in(&dashboard).await;
        let (status, _, body) = send(&dashboard, "GET", "/", &[("cookie", &cookie)], "").await;
        assert_eq!(status, StatusCode::OK);
        assert!(body.contains("runs-wide-turn-starts"));
        // The raw token as a cookie is no session.
        let (status, _, _) =
            send(&dashboard, "GET", "/", &[("cookie", "hevo_session=t")], "").await;
        assert_eq!(status, StatusCode::UNAUTHORIZED);
        let (status, _, _) = send(
            &dashboard,
            "POST",
            "/logout",
            &[HOST, ("cookie", &cookie)],
            "",
        )
        .await;
        assert_eq!(status, StatusCode::SEE_OTHER);
        let (status, _, _) = send(&dashboard, "GET", "/", &[("cookie", &cookie)], "").await;
        assert_eq!(status, StatusCode::UNAUTHORIZED, "the session ended");
    }

    #[tokio::test]
    async fn session_cookies_are_secure_under_tls() {
        let dashboard = dashboard(Access::tokens(vec!["t".into()]));
        let login = |headers: &'static [(&'static str, &'static str)]| {
            let dashboard = dashboard.clone();
            async move {
                let (_, headers, _) = send(&dashboard, "POST", "/login", headers, "token=t").await;
                headers[SET_COOKIE].to_str().unwrap().to_string()
            }
        };
        assert!(!login(&[FORM]).await.contains("Secure"));
        assert!(
            login(&[FORM, ("x-forwarded-proto", "https")])
                .await
                .ends_with("; Secure")
        );
        dashboard.set_secure_cookies(true);
        assert!(login(&[FORM]).await.ends_with("; Secure"));
    }

    #[tokio::test]
    async fn a_cancel_needs_this_sites_origin_and_the_sessions_form_token() {
        let dashboard = dashboard(Access::tokens(vec!["t".into()]));
        let cookie = sign_in(&dashboard).await;
        let (_, _, page) = send(&dashboard, "GET", JOB, &[("cookie", &cookie)], "").await;
        let csrf = dashboard
            .shared
            .sessions
            .csrf_of(&{
                let mut headers = HeaderMap::new();
                headers.insert("cookie", cookie.parse().unwrap());
                headers
            })
            .unwrap();
        let cancel = |headers: Vec<(&'static str, String)>, body: String| {
            let dashboard = dashboard.clone();
            async move {
                let headers: Vec<(&str, &str)> =
                    headers.iter().map(|(n, v)| (*n, v.as_str())).collect();
                send(
                    &dashboard,
                    "POST",
                    &format!("{JOB}/cancel"),
                    &headers,
                    &body,
                )
                .await
                .0
            }
        };
        let base = |origin: &str| {
            vec![
                ("content-type", FORM.1.to_string()),
                ("host", HOST.1.to_string()),
                ("cookie", cookie.clone()),
                ("origin", origin.to_string()),
            ]
        };
        // Another site's page, even with the cookie and the token: refused.
        assert_eq!(
            cancel(base("http://evil.example"), format!("csrf={csrf}")).await,
            StatusCode::FORBIDDEN
        );
        // This site, but no token or a wrong one: refused.
        assert_eq!(
            cancel(base("http://127.0.0.1:8080"), String::new()).await,
            StatusCode::FORBIDDEN
        );
        assert_eq!(
            cancel(base("http://127.0.0.1:8080"), "csrf=0000".into()).await,
            StatusCode::FORBIDDEN
        );
        // This site with the session's token gets through to the source (which cannot
        // cancel a run directory: 409).
        assert_eq!(
            cancel(base("http://127.0.0.1:8080"), format!("csrf={csrf}")).await,
            StatusCode::CONFLICT
        );
        // A script with the bearer token needs neither.
        assert_eq!(
            cancel(vec![("authorization", "Bearer t".into())], String::new()).await,
            StatusCode::CONFLICT
        );
        // An open dashboard still refuses another site's page.
        let open = super::tests::dashboard(Access::Open);
        let (status, _, _) = send(
            &open,
            "POST",
            &format!("{JOB}/cancel"),
            &[HOST, ("origin", "http://evil.example")],
            "",
        )
        .await;
        assert_eq!(status, StatusCode::FORBIDDEN);
        // The page carries the token only for its own session, hidden in the form (the run
        // directory is finished, so the form itself is absent; the header test is in pages).
        assert!(!page.contains(&cookie));
    }

    #[tokio::test]
    async fn every_answer_forbids_framing_and_foreign_content() {
        let dashboard = dashboard(Access::tokens(vec!["t".into()]));
        for (uri, auth) in [
            ("/", true),
            ("/login", false),
            ("/nothing", true),
            (JOB, false),
        ] {
            let headers: &[(&str, &str)] = if auth {
                &[("authorization", "Bearer t")]
            } else {
                &[]
            };
            let (_, headers, _) = send(&dashboard, "GET", uri, headers, "").await;
            let csp = headers["content-security-policy"].to_str().unwrap();
            assert!(csp.contains("frame-ancestors 'none'"), "{uri}: {csp}");
            assert!(csp.contains("default-src 'self'"), "{uri}: {csp}");
            assert_eq!(headers["x-frame-options"], "DENY", "{uri}");
            assert_eq!(headers["x-content-type-options"], "nosniff", "{uri}");
        }
    }

    #[tokio::test]
    async fn event_streams_beyond_the_cap_are_refused_until_one_closes() {
        let dashboard = dashboard(Access::Open);
        dashboard.set_max_streams(1);
        let first = open_events(dashboard.clone()).await;
        assert_eq!(first.status(), StatusCode::OK);
        let second = open_events(dashboard.clone()).await;
        assert_eq!(second.status(), StatusCode::SERVICE_UNAVAILABLE);
        drop(first);
        for _ in 0..200 {
            if dashboard.open_streams() == 0 {
                break;
            }
            tokio::time::sleep(std::time::Duration::from_millis(10)).await;
        }
        assert_eq!(
            open_events(dashboard.clone()).await.status(),
            StatusCode::OK
        );
    }
}
