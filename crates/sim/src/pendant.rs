//! The pendant API: HTTP + JSON on its own port, to watch the emulated controller and to do
//! what an operator does at the panel and teach pendant (switches, emergency stop, error reset,
//! monitor speed) — plus fault injection.
//!
//! Every endpoint is documented with curl examples in docs/EMULATOR.md. Errors are JSON
//! `{ "error": "...", "remedy": "..." }` with a fitting status code.
//!
//! Security: bound to a loopback address by default. Bound to any other address it requires a
//! bearer token (`Authorization: Bearer <token>`) and refuses to start without one; a token given
//! on loopback is required too. Because a web page in the user's browser can reach loopback,
//! every request must also pass the browser checks ([`RequestGuard`]): its `Host` must name
//! the address the pendant is bound to (no DNS rebinding), an `Origin` header, when present,
//! must be the pendant's own origin, and a POST must carry `Content-Type: application/json`
//! (which a cross-site form cannot send without a CORS preflight this API never grants).

use std::io;
use std::net::SocketAddr;
use std::sync::Arc;

use axum::extract::rejection::JsonRejection;
use axum::extract::{Request, State};
use axum::http::{header, StatusCode};
use axum::middleware::{self, Next};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use axum::{Json, Router};
use fs020n_proto::ErrorCode;
use serde::{Deserialize, Serialize};
use serde_json::Value;
use tokio::task::JoinHandle;

use crate::fault::Fault;
use crate::guard::{GuardRefusal, RequestGuard};
use crate::machine::{PanelChange, PanelError};
use crate::server::Emulator;
use crate::snapshot::Snapshot;

/// An API error: HTTP status, what went wrong, and what to do about it.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct ApiError {
    /// HTTP status.
    #[serde(skip)]
    pub status: StatusCode,
    /// What went wrong.
    pub error: String,
    /// How to fix it.
    pub remedy: String,
}

impl ApiError {
    fn new(status: StatusCode, error: impl Into<String>, remedy: impl Into<String>) -> ApiError {
        ApiError {
            status,
            error: error.into(),
            remedy: remedy.into(),
        }
    }
}

impl IntoResponse for ApiError {
    fn into_response(self) -> Response {
        (self.status, Json(&self)).into_response()
    }
}

impl From<PanelError> for ApiError {
    fn from(e: PanelError) -> ApiError {
        match e {
            PanelError::EstopPressed => ApiError::new(
                StatusCode::CONFLICT,
                e.to_string(),
                "release the emergency stop first: POST /estop/release",
            ),
            PanelError::Speed(_) => ApiError::new(
                StatusCode::UNPROCESSABLE_ENTITY,
                e.to_string(),
                "send a monitor speed greater than 0 and at most 100, e.g. {\"percent\": 10}",
            ),
        }
    }
}

fn bad_json(rejection: JsonRejection, example: &str) -> ApiError {
    ApiError::new(
        rejection.status(),
        format!("bad request body: {}", rejection.body_text()),
        format!("send a JSON body with Content-Type: application/json, e.g. {example}"),
    )
}

#[derive(Clone)]
struct AppState {
    emulator: Emulator,
    guard: Arc<RequestGuard>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SpeedBody {
    percent: f64,
}

/// The pendant API as an axum router (for embedding it in another server bound to `bound`).
/// `token`, when given, is required on every request; the browser checks of
/// [`crate::PendantAccess::bound_to`]`(bound)` apply to every request.
pub fn pendant_router(emulator: Emulator, token: Option<String>, bound: SocketAddr) -> Router {
    let state = AppState {
        emulator,
        guard: Arc::new(RequestGuard::new(bound, token)),
    };
    Router::new()
        .route("/api", get(index))
        .route("/state", get(state_handler))
        .route("/model", get(model))
        .route("/panel", get(panel_get).post(panel_post))
        .route("/estop/press", post(estop_press))
        .route("/estop/release", post(estop_release))
        .route("/reset", post(reset))
        .route("/power-cycle", post(power_cycle))
        .route("/speed", post(speed))
        .route("/faults", post(faults_post).delete(faults_delete))
        .route("/abs_speed", get(abs_speed_get).post(abs_speed_post))
        .route("/tasks", get(tasks_get))
        .route("/interface-panel", get(interface_panel_get))
        .route("/network", get(network_get))
        .route("/network/hosts", post(network_hosts_post))
        .fallback(not_found)
        .method_not_allowed_fallback(method_not_allowed)
        .layer(middleware::from_fn_with_state(state.clone(), guard))
        .with_state(state)
}

/// Refuses what a foreign web page could send (a `Host` that is not the pendant's, a foreign
/// `Origin`, a POST without `Content-Type: application/json`) and a request without the token.
async fn guard(State(st): State<AppState>, req: Request, next: Next) -> Response {
    match st.guard.check(req.method(), req.headers(), true) {
        Ok(()) => next.run(req).await,
        Err(refusal) => refused(refusal).into_response(),
    }
}

/// A refusal of the guard, in the pendant's words.
fn refused(refusal: GuardRefusal) -> Response {
    match refusal {
        GuardRefusal::ForeignHost(host) => ApiError::new(
            StatusCode::MISDIRECTED_REQUEST,
            format!(
                "the Host header {:?} does not name this pendant",
                host.as_deref().unwrap_or("(none)")
            ),
            "call the pendant by the address it listens on (e.g. http://127.0.0.1:10051/)",
        )
        .into_response(),
        GuardRefusal::ForeignOrigin(origin) => ApiError::new(
            StatusCode::FORBIDDEN,
            format!("requests from the web origin {origin:?} are refused"),
            "only the pendant's own page may call it from a browser; use curl or the CLI otherwise",
        )
        .into_response(),
        GuardRefusal::NotJson => ApiError::new(
            StatusCode::UNSUPPORTED_MEDIA_TYPE,
            "a POST to the pendant API must carry Content-Type: application/json",
            "send the header `Content-Type: application/json` (curl: --json '{}' or -H 'Content-Type: application/json')",
        )
        .into_response(),
        GuardRefusal::NoToken | GuardRefusal::WrongToken => {
            let mut r = ApiError::new(
                StatusCode::UNAUTHORIZED,
                if refusal == GuardRefusal::WrongToken {
                    "wrong pendant token"
                } else {
                    "this pendant API requires a token"
                },
                "send the header `Authorization: Bearer <token>` with the token the emulator was started with",
            )
            .into_response();
            r.headers_mut().insert(
                header::WWW_AUTHENTICATE,
                header::HeaderValue::from_static("Bearer"),
            );
            r
        }
    }
}

async fn index() -> Json<Value> {
    Json(serde_json::json!({
        "service": "fs020n emulator pendant API",
        "endpoints": [
            "GET /api", "GET /state", "GET /model", "GET /panel", "POST /panel",
            "POST /estop/press", "POST /estop/release", "POST /reset", "POST /power-cycle",
            "POST /speed",
            "GET /abs_speed", "POST /abs_speed", "POST /faults", "DELETE /faults",
            "GET /tasks", "GET /interface-panel", "GET /network", "POST /network/hosts"
        ],
        "docs": "docs/EMULATOR.md"
    }))
}

async fn not_found(uri: axum::http::Uri) -> ApiError {
    ApiError::new(
        StatusCode::NOT_FOUND,
        format!("no such endpoint: {}", uri.path()),
        "GET /api lists the endpoints; docs/EMULATOR.md describes them",
    )
}

async fn method_not_allowed(method: axum::http::Method, uri: axum::http::Uri) -> ApiError {
    ApiError::new(
        StatusCode::METHOD_NOT_ALLOWED,
        format!("{method} is not allowed on {}", uri.path()),
        "GET /api lists the endpoints with their methods",
    )
}

async fn state_handler(State(st): State<AppState>) -> Json<Snapshot> {
    Json(st.emulator.snapshot())
}

async fn model(State(st): State<AppState>) -> Json<Value> {
    let v = st
        .emulator
        .with(|c| serde_json::to_value(c.model()).unwrap_or(Value::Null));
    Json(v)
}

async fn panel_get(State(st): State<AppState>) -> Json<Value> {
    Json(st.emulator.with(|c| serde_json::json!(c.panel())))
}

async fn panel_post(
    State(st): State<AppState>,
    body: Result<Json<PanelChange>, JsonRejection>,
) -> Result<Json<Snapshot>, ApiError> {
    let Json(change) =
        body.map_err(|e| bad_json(e, r#"{"run": false} or {"power": true, "repeat": true}"#))?;
    st.emulator.with(|c| c.apply_panel(change))?;
    Ok(Json(st.emulator.snapshot()))
}

async fn estop_press(State(st): State<AppState>) -> Json<Snapshot> {
    st.emulator.with(|c| c.set_estop(true));
    Json(st.emulator.snapshot())
}

async fn estop_release(State(st): State<AppState>) -> Json<Snapshot> {
    st.emulator.with(|c| c.set_estop(false));
    Json(st.emulator.snapshot())
}

/// Switches the controller off and on (`Controller::power_cycle`): tasks stop, sockets
/// close, programs and switches stay, the AUTOSTART programs start.
async fn power_cycle(State(st): State<AppState>) -> Json<Snapshot> {
    st.emulator.with(|c| c.power_cycle());
    Json(st.emulator.snapshot())
}

async fn reset(State(st): State<AppState>) -> Result<Json<Snapshot>, ApiError> {
    st.emulator.with(|c| c.reset_error())?;
    Ok(Json(st.emulator.snapshot()))
}

async fn speed(
    State(st): State<AppState>,
    body: Result<Json<SpeedBody>, JsonRejection>,
) -> Result<Json<Snapshot>, ApiError> {
    let Json(b) = body.map_err(|e| bad_json(e, r#"{"percent": 50}"#))?;
    st.emulator.with(|c| c.set_monitor_speed(b.percent))?;
    Ok(Json(st.emulator.snapshot()))
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct AbsSpeedBody {
    on: bool,
}

/// The AS program's tasks (program, line, state, what they wait for) and terminal.
async fn tasks_get(
    State(st): State<AppState>,
) -> Result<Json<crate::snapshot::ProgramInfo>, ApiError> {
    st.emulator.snapshot().program.map(Json).ok_or_else(|| {
        ApiError::new(
            StatusCode::NOT_FOUND,
            "this emulator runs the native server, not an AS program",
            "start the emulator with an AS program (fs020n sim --as-program FILE) to see its tasks",
        )
    })
}

/// What the AS program's interface panel shows (`IFPWPRINT` …): its windows' rows, the icons'
/// labels, the pages' titles.
async fn interface_panel_get(
    State(st): State<AppState>,
) -> Result<Json<fs020n_as::InterfacePanel>, ApiError> {
    st.emulator
        .with(|c| c.program().interface_panel().cloned())
        .map(Json)
        .ok_or_else(|| {
            ApiError::new(
                StatusCode::NOT_FOUND,
                "this emulator runs the native server, not an AS program",
                "start the emulator with an AS program (fs020n sim --as-program FILE) to see \
                 its interface panel",
            )
        })
}

/// The emulated controller's place on the network: its address, the host map, the port map,
/// the ports its AS program listens on and where each is served on the host.
#[derive(Debug, Serialize)]
struct NetworkView {
    address: std::net::Ipv4Addr,
    hosts: std::collections::BTreeMap<std::net::Ipv4Addr, std::net::IpAddr>,
    port_map: Option<crate::network::PortMap>,
    listening: Vec<u16>,
    served: std::collections::BTreeMap<u16, SocketAddr>,
}

fn network_view(emulator: &Emulator) -> NetworkView {
    let (network, listening) =
        emulator.with(|c| (c.network().clone(), c.program().listening_ports()));
    NetworkView {
        address: network.address,
        hosts: network.hosts,
        port_map: emulator.port_map(),
        listening,
        served: emulator.program_ports(),
    }
}

async fn network_get(State(st): State<AppState>) -> Json<NetworkView> {
    Json(network_view(&st.emulator))
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct HostsBody {
    hosts: std::collections::BTreeMap<std::net::Ipv4Addr, std::net::IpAddr>,
}

/// Replaces the host map (from the program's next `TCP_CONNECT`/`UDP_SENDTO` on); the
/// controller's address and the port map stay.
async fn network_hosts_post(
    State(st): State<AppState>,
    body: Result<Json<HostsBody>, JsonRejection>,
) -> Result<Json<NetworkView>, ApiError> {
    let Json(b) = body.map_err(|e| {
        bad_json(
            e,
            r#"{"hosts": {"192.168.0.10": "127.0.0.1"}} (cell address -> real host)"#,
        )
    })?;
    tracing::info!(hosts = ?b.hosts, "host map replaced through the pendant API");
    st.emulator.with(|c| {
        let mut network = c.network().clone();
        network.hosts = b.hosts;
        c.set_network(network);
    });
    Ok(Json(network_view(&st.emulator)))
}

async fn abs_speed_get(State(st): State<AppState>) -> Json<Value> {
    Json(serde_json::json!({ "on": st.emulator.with(|c| c.abs_speed()) }))
}

/// ABS.SPEED is a system switch: command 3 switches it on; only the pendant switches it off.
async fn abs_speed_post(
    State(st): State<AppState>,
    body: Result<Json<AbsSpeedBody>, JsonRejection>,
) -> Result<Json<Snapshot>, ApiError> {
    let Json(b) = body.map_err(|e| bad_json(e, r#"{"on": false}"#))?;
    st.emulator.with(|c| c.set_abs_speed(b.on));
    Ok(Json(st.emulator.snapshot()))
}

/// Parses a fault, also accepting an error name (`"E1088"`) for `raise_error`'s code.
pub fn parse_fault(mut v: Value) -> Result<Fault, String> {
    if let Some(code) = v.get_mut("code") {
        if let Some(name) = code.as_str() {
            let parsed: ErrorCode = name.parse().map_err(|e| format!("{e}"))?;
            *code = Value::from(parsed.raw());
        }
    }
    let fault: Fault = serde_json::from_value(v).map_err(|e| e.to_string())?;
    fault.validate()?;
    Ok(fault)
}

async fn faults_post(
    State(st): State<AppState>,
    body: Result<Json<Value>, JsonRejection>,
) -> Result<Json<Snapshot>, ApiError> {
    const EXAMPLE: &str = r#"{"kind": "delay_replies", "count": 3, "delay_ms": 1500}"#;
    let Json(v) = body.map_err(|e| bad_json(e, EXAMPLE))?;
    let fault = parse_fault(v).map_err(|e| {
        ApiError::new(
            StatusCode::UNPROCESSABLE_ENTITY,
            format!("not a fault: {e}"),
            format!(
                "kinds: delay_replies {{count, delay_ms}}, withhold_replies {{count}}, garbage_reply {{text}}, \
                 split_reply {{parts, gap_ms}}, close_connection, stop_reading {{duration_ms}}, \
                 raise_error {{code: \"E1130\" or -31130}}; e.g. {EXAMPLE}"
            ),
        )
    })?;
    if let Fault::RaiseError { code } = fault {
        if code.is_none() {
            return Err(ApiError::new(
                StatusCode::UNPROCESSABLE_ENTITY,
                "raise_error needs a non-zero code",
                "give a code such as \"E1130\" (or -31130); to clear an error use POST /reset",
            ));
        }
    }
    st.emulator.with(|c| c.inject(fault));
    Ok(Json(st.emulator.snapshot()))
}

async fn faults_delete(State(st): State<AppState>) -> Json<Snapshot> {
    st.emulator.with(|c| c.clear_faults());
    Json(st.emulator.snapshot())
}

/// A running pendant API server. Dropping it does not stop it; call [`PendantServer::stop`].
#[derive(Debug)]
pub struct PendantServer {
    addr: SocketAddr,
    task: JoinHandle<()>,
}

impl PendantServer {
    /// The bound address (useful with port 0).
    pub fn local_addr(&self) -> SocketAddr {
        self.addr
    }

    /// Stops serving.
    pub fn stop(self) {
        self.task.abort();
    }
}

/// Serves the pendant API of `emulator` on `addr`. Off loopback a `token` is mandatory
/// (`InvalidInput` otherwise); with a token every request must carry
/// `Authorization: Bearer <token>`.
pub async fn serve_pendant(
    emulator: Emulator,
    addr: SocketAddr,
    token: Option<String>,
) -> io::Result<PendantServer> {
    let token = token.filter(|t| !t.is_empty());
    if !addr.ip().is_loopback() && token.is_none() {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            format!(
                "refusing to serve the pendant API on {addr} without a token: it can move the \
                 panel switches and inject faults; bind it to 127.0.0.1 or give a token"
            ),
        ));
    }
    let listener = tokio::net::TcpListener::bind(addr).await?;
    let local = listener.local_addr()?;
    let app = pendant_router(emulator, token, local);
    tracing::info!(addr = %local, "pendant API listening");
    let task = tokio::spawn(async move {
        if let Err(e) = axum::serve(listener, app).await {
            tracing::warn!(error = %e, "pendant API stopped");
        }
    });
    Ok(PendantServer { addr: local, task })
}
