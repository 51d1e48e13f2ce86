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

use crate::auth::{Access, safe_next, sign_in_cookie, sign_out_cookie};
use crate::html::{SCRIPT, SCRIPT_PATH, STYLE, STYLE_PATH, error_page, page};
use crate::replay::{ReplayFigure, replays};
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
}

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
            }),
        }
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
            .with_state(self.clone())
    }
}

/// Serves `dashboard` on `listener` until `shutdown` resolves; then ends the streams and
/// drains.
pub async fn serve(
    listener: tokio::net::TcpListener,
    dashboard: Dashboard,
    shutdown: impl Future<Output = ()> + Send + 'static,
) -> std::io::Result<()> {
    let router = dashboard.router();
    axum::serve(listener, router)
        .with_graceful_shutdown(async move {
            shutdown.await;
            dashboard.stop_streams();
        })
        .await
}

/// Lets a request through when it is signed in, or needs no sign-in (the login form, the
/// assets); otherwise a page gets the login form and anything else a bare 401.
async fn guard(State(dashboard): State<Dashboard>, request: Request, next: Next) -> Response {
    let path = request.uri().path();
    let public = path == "/login" || path.starts_with("/assets/");
    if public || dashboard.shared.access.allows(request.headers()) {
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
    query: Result<Query<JobQuery>, QueryRejection>,
) -> Response {
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
        let mut body = pages::job_header(&job, seed);
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
            body.push_str(&pages::node_section(&id, node, replays));
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
    (
        [(CACHE_CONTROL, "no-store")],
        job_events(
            dashboard.shared.source.clone(),
            id,
            dashboard.shared.stopping.subscribe(),
            dashboard.shared.open_streams.clone(),
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

async fn cancel(State(dashboard): State<Dashboard>, Path(id): Path<String>) -> Response {
    if let Err(response) = check_job_id(&id) {
        return *response;
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
    if dashboard.shared.access.needs_token()
        && let Ok(value) = sign_in_cookie(&form.token).parse()
    {
        headers.insert(SET_COOKIE, value);
    }
    (StatusCode::SEE_OTHER, headers).into_response()
}

async fn logout() -> Response {
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

    #[tokio::test]
    async fn an_abandoned_stream_is_dropped() {
        let dashboard = dashboard(Access::Open);
        let response = dashboard
            .router()
            .oneshot(
                Request::builder()
                    .uri("/jobs/runs-wide-turn-starts/events")
                    .body(Body::empty())
                    .unwrap(),
            )
            .await
            .unwrap();
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
}
