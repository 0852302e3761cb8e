//! The hub: one session with the controller, shared.
//!
//! The controller serves one client at a time. The hub holds that one session (through
//! `fs020n-client`, with its keep-alive, checks and recording) and offers it to several users:
//!
//! - a protocol-1040 TCP face ([`serve_face`]) for the clients people already have: **one
//!   controlling client at a time**, forwarded in lock-step; polls from the others are answered
//!   from the latest status; acting requests from a client that does not hold control never
//!   reach the robot and are logged. When the controlling client disconnects, stops reading or
//!   goes silent ([`HubConfig::silence_timeout`]), the hub stops the robot at once (command 2);
//! - a [`Fence`] applied to everything it forwards;
//! - the web page ([`hub_app`]) with the robot's switches (shown, not switchable: the
//!   protocol cannot) and guarded Cancel (5) and Stop (2) buttons;
//! - a Foxglove live bridge (feature `foxglove`).
//!
//! docs/HUB.md describes the rules; [`Hub::state`] is what the page and the tests see.

pub mod face;
pub mod fence;
#[cfg(feature = "foxglove")]
pub mod foxglove;
pub mod http;

use std::collections::{BTreeMap, VecDeque};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

use fs020n_client::{blockers, ClientConfig, ClientError, Connector, Robot, TcpConnector};
use fs020n_kin::{JointsDeg, RobotModel, Xyzoat};
use serde::Serialize;
use tokio::sync::{watch, RwLock};
use tokio::task::JoinHandle;
use tokio::time::Instant;

pub use face::{serve_face, FaceServer};
pub use fence::{Fence, FenceError, FenceSpec, FenceViolation, JointFence, WorkspaceBox};
pub use http::{hub_app, serve_hub_page};

/// Events kept for the page ([`HubState::events`] shows the newest [`EVENTS_SHOWN`]).
pub const EVENTS_KEPT: usize = 500;
/// Events in [`HubState::events`].
pub const EVENTS_SHOWN: usize = 50;

/// How the hub runs.
#[derive(Debug, Clone)]
pub struct HubConfig {
    /// The client's configuration for the session with the controller (model, timeouts,
    /// recording). The hub polls faster than the client's default so that the page and
    /// Foxglove see the arm move smoothly: see [`HubConfig::new`].
    pub client: ClientConfig,
    /// The safety fence (`None`: the controller's limits and the client's checks only).
    pub fence: Option<Fence>,
    /// A controlling client that sends nothing for this long is taken as gone: the hub stops
    /// the robot (command 2) and closes its connection. Default 1 s (the controller would wait
    /// 5 s). Clients without control get the controller's 5 s.
    pub silence_timeout: Duration,
    /// Most clients of the protocol face at once; more are closed at once. Default 16.
    pub max_clients: usize,
    /// Pause between reconnection attempts after the controller ended the session. Default 1 s.
    pub reconnect_interval: Duration,
}

/// Keep-alive (status poll) period of the hub's session: 25 Hz, so that the live views follow
/// the arm even while no client is moving it.
pub const HUB_POLL_PERIOD: Duration = Duration::from_millis(40);

impl HubConfig {
    /// A hub for `model`: polls at [`HUB_POLL_PERIOD`], no fence, 1 s silence limit.
    pub fn new(model: RobotModel) -> HubConfig {
        HubConfig {
            client: ClientConfig {
                model,
                keepalive_period: HUB_POLL_PERIOD,
                ..ClientConfig::default()
            },
            fence: None,
            silence_timeout: Duration::from_secs(1),
            max_clients: 16,
            reconnect_interval: Duration::from_secs(1),
        }
    }
}

impl Default for HubConfig {
    fn default() -> Self {
        HubConfig::new(RobotModel::fs020n())
    }
}

/// Why a client of the face is no longer served.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ClientEnd {
    /// It closed the connection (or it was reset).
    Disconnected,
    /// It sent nothing for too long.
    Silent,
    /// It did not read its reply within 2 s.
    NotReading,
    /// It sent 255.
    EndCommand,
    /// The session with the controller was lost.
    LinkLost,
}

/// Why the hub did not forward an acting request.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Refusal {
    /// Another client holds control.
    NoControl,
    /// Command 6 or 7 without its full argument count (the controller would use stale
    /// arguments, spec §2).
    Incomplete,
    /// The safety fence.
    Fence,
    /// The client library's checks (ranges, command-7 extrapolation, speed, the controller's
    /// state).
    Checks,
}

/// One entry of the hub's log (also written to `tracing`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct HubEvent {
    /// Seconds since the hub started.
    pub t_s: f64,
    /// The face client concerned, if any.
    pub client: Option<u64>,
    /// What happened: `"control"`, `"forwarded"`, `"refused"`, `"stop"`, `"cancel"`,
    /// `"client"`, `"link"`.
    pub kind: &'static str,
    /// The request, when there is one (at most 80 characters).
    pub request: Option<String>,
    /// Why a request was refused.
    pub refusal: Option<Refusal>,
    /// In words.
    pub message: String,
}

/// Counters since the hub started.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct HubCounters {
    /// Face clients accepted.
    pub clients: u64,
    /// Requests received from face clients.
    pub requests: u64,
    /// Requests forwarded to the controller.
    pub forwarded: u64,
    /// Polls answered from the latest status without reaching the controller.
    pub answered_locally: u64,
    /// Acting requests refused because another client held control.
    pub refused_no_control: u64,
    /// Requests refused for an incomplete argument count.
    pub refused_incomplete: u64,
    /// Requests refused by the fence.
    pub refused_fence: u64,
    /// Requests refused by the client library's checks.
    pub refused_checks: u64,
    /// Stops (command 2) sent because the controlling client went away or went silent.
    pub stops_on_client_end: u64,
    /// Stops and cancels sent from the page.
    pub page_actions: u64,
    /// Sessions with the controller lost (and re-established).
    pub links_lost: u64,
}

/// A face client as the page shows it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ClientView {
    /// Its number.
    pub id: u64,
    /// Its address.
    pub peer: String,
    /// `true` while it holds control.
    pub controlling: bool,
    /// Requests received from it.
    pub requests: u64,
    /// Of them, refused.
    pub refused: u64,
    /// Seconds since it connected.
    pub connected_s: f64,
}

/// The robot's latest status as the page shows it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StatusView {
    /// Motor power ON.
    pub power: bool,
    /// RUN (false: HOLD).
    pub run: bool,
    /// REPEAT (false: TEACH).
    pub repeat: bool,
    /// TEACH LOCK ON.
    pub teach_lock: bool,
    /// The motion program runs (reply field 7).
    pub task_running: bool,
    /// The error code as reply field 2 carries it (0 none).
    pub error_code: i32,
    /// The error's name (`"E1088"`, `"none"`).
    pub error_name: String,
    /// Its message, when known.
    pub error_message: Option<String>,
    /// TIMER(1), seconds (`None` on overflow).
    pub timer_s: Option<f64>,
    /// Joints, degrees.
    pub joints_deg: JointsDeg,
    /// What blocks motion, each with its remedy.
    pub blockers: Vec<String>,
    /// Age of the status, milliseconds.
    pub age_ms: f64,
}

/// The session with the controller.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LinkView {
    /// The controller's address.
    pub robot: String,
    /// `true` while the session is open.
    pub connected: bool,
    /// Why the session was lost (while reconnecting).
    pub error: Option<String>,
    /// Requests sent to the controller (with keep-alive polls).
    pub requests: u64,
    /// Of them, the session's own keep-alive polls.
    pub keepalive_polls: u64,
    /// Round trip, mean, milliseconds.
    pub rtt_mean_ms: f64,
    /// Round trip, 99th percentile, milliseconds.
    pub rtt_p99_ms: f64,
}

/// Everything the hub shows: the page's live feed, `GET /state`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct HubState {
    /// Seconds since the hub started.
    pub time_s: f64,
    /// The robot model's name.
    pub model: String,
    /// The session with the controller.
    pub link: LinkView,
    /// The latest status (`None` only before the first reply).
    pub status: Option<StatusView>,
    /// The flange pose of the latest joints.
    pub tool: Option<Xyzoat>,
    /// The target of the latest forwarded motion (6, or the position of a 7), until a stop or
    /// cancel.
    pub target_deg: Option<JointsDeg>,
    /// The client holding control.
    pub controller: Option<u64>,
    /// The clients of the protocol face.
    pub clients: Vec<ClientView>,
    /// The newest events, oldest first.
    pub events: Vec<HubEvent>,
    /// Counters.
    pub counters: HubCounters,
    /// The fence in force.
    pub fence: Option<FenceSpec>,
    /// The silence limit of the controlling client, seconds.
    pub silence_timeout_s: f64,
}

#[derive(Debug)]
struct ClientEntry {
    peer: String,
    requests: u64,
    refused: u64,
    since: Instant,
}

#[derive(Debug, Default)]
struct Book {
    controller: Option<u64>,
    clients: BTreeMap<u64, ClientEntry>,
    events: VecDeque<HubEvent>,
    counters: HubCounters,
    target: Option<JointsDeg>,
    link_error: Option<String>,
}

/// The state of the session with the controller, as face sessions watch it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct LinkState {
    /// Bumped on every loss and every reconnection.
    pub(crate) generation: u64,
    /// `true` while the session is open.
    pub(crate) up: bool,
}

pub(crate) struct Inner {
    pub(crate) robot: RwLock<Arc<Robot>>,
    pub(crate) model: RobotModel,
    pub(crate) config: HubConfig,
    describe: String,
    book: Mutex<Book>,
    pub(crate) link: watch::Sender<LinkState>,
    started: Instant,
    pub(crate) next_client: AtomicU64,
    closing: AtomicBool,
    supervisor: Mutex<Option<JoinHandle<()>>>,
}

/// A running hub. Cheap to clone; all clones share the one session.
#[derive(Clone)]
pub struct Hub {
    pub(crate) inner: Arc<Inner>,
}

impl std::fmt::Debug for Hub {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Hub")
            .field("robot", &self.inner.describe)
            .finish_non_exhaustive()
    }
}

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

/// Cuts a request for the log.
fn excerpt(text: &str) -> String {
    let mut s: String = text
        .chars()
        .map(|c| if c.is_control() { '·' } else { c })
        .take(80)
        .collect();
    if text.chars().count() > 80 {
        s.push('…');
    }
    s
}

impl Hub {
    /// Connects to the controller at `addr` (`host:port`) and starts holding the session.
    pub async fn connect(addr: &str, config: HubConfig) -> Result<Hub, ClientError> {
        Hub::connect_with(TcpConnector::new(addr), config).await
    }

    /// Connects through any [`Connector`] (an in-memory emulator in tests). With a fence that
    /// has a speed cap, the hub sets the monitor speed to the cap at once (command 3, while the
    /// program is not running): the protocol cannot read the monitor speed, so this is the
    /// only way to know it is not above the cap.
    pub async fn connect_with(
        connector: impl Connector,
        config: HubConfig,
    ) -> Result<Hub, ClientError> {
        let describe = connector.describe();
        let robot = Robot::connect_with(connector, config.client.clone()).await?;
        if let Some(cap) = config.fence.as_ref().and_then(Fence::speed_cap) {
            robot.set_speed(cap).await?;
        }
        let (link, _) = watch::channel(LinkState {
            generation: 0,
            up: true,
        });
        let hub = Hub {
            inner: Arc::new(Inner {
                robot: RwLock::new(Arc::new(robot)),
                model: config.client.model.clone(),
                config,
                describe,
                book: Mutex::new(Book::default()),
                link,
                started: Instant::now(),
                next_client: AtomicU64::new(1),
                closing: AtomicBool::new(false),
                supervisor: Mutex::new(None),
            }),
        };
        hub.log(
            None,
            "link",
            None,
            None,
            format!("session with {} open", hub.inner.describe),
        );
        let task = tokio::spawn(supervise(Arc::downgrade(&hub.inner)));
        *lock(&hub.inner.supervisor) = Some(task);
        Ok(hub)
    }

    /// The robot model (ranges, geometry) the hub checks against and the page draws.
    pub fn model(&self) -> &RobotModel {
        &self.inner.model
    }

    /// The fence in force.
    pub fn fence(&self) -> Option<&Fence> {
        self.inner.config.fence.as_ref()
    }

    /// What the hub connects to.
    pub fn robot_addr(&self) -> &str {
        &self.inner.describe
    }

    /// The client holding control of the protocol face, if any.
    pub fn controller(&self) -> Option<u64> {
        lock(&self.inner.book).controller
    }

    /// The session with the controller, for an in-process user (the ROS 2 node); `None` while
    /// the hub reconnects. Hold it only while using it: a reconnection waits until every such
    /// handle is dropped. Acting through it bypasses the hub's rules: ask
    /// [`Hub::claim_control`] and check with [`Hub::check_path`] / [`Hub::check_speed`] first.
    pub fn robot(&self) -> Option<Arc<Robot>> {
        if !self.is_connected() {
            return None;
        }
        self.inner.robot.try_read().ok().map(|r| Arc::clone(&r))
    }

    /// Takes control for an in-process user named `who` (e.g. `"ROS 2 node"`), shown among the
    /// clients while it holds it. Refused (with the reason) while another client holds
    /// control; the claim is released when the returned value is dropped. While it is held, the
    /// face's clients may only watch, exactly as when another face client holds control.
    pub fn claim_control(&self, who: &str) -> Result<ControlClaim, String> {
        let id = {
            let mut book = lock(&self.inner.book);
            if let Some(holder) = book.controller {
                let name = book.clients.get(&holder).map_or_else(
                    || format!("client {holder}"),
                    |c| format!("client {holder} ({})", c.peer),
                );
                return Err(format!(
                    "{name} holds control of the hub; try again when it has released it (or stop it from the hub's page)"
                ));
            }
            let id = self.inner.next_client.fetch_add(1, Ordering::SeqCst);
            book.clients.insert(
                id,
                ClientEntry {
                    peer: who.to_owned(),
                    requests: 0,
                    refused: 0,
                    since: Instant::now(),
                },
            );
            book.controller = Some(id);
            id
        };
        self.log(
            Some(id),
            "control",
            None,
            None,
            format!("{who} (client {id}) takes control"),
        );
        Ok(ControlClaim {
            hub: self.clone(),
            id,
            who: who.to_owned(),
        })
    }

    /// Checks a path the robot is about to follow (joint positions in time order, degrees,
    /// starting near the current position) against the fence: every position and the straight
    /// joint-space pieces from the current joints through them. `Ok` without a fence.
    pub fn check_path(&self, path: &[JointsDeg]) -> Result<(), FenceViolation> {
        let Some(fence) = &self.inner.config.fence else {
            return Ok(());
        };
        let current = self
            .inner
            .robot
            .try_read()
            .ok()
            .map(|r| r.status().status.joints);
        self.fence_verdict("a path", fence.check_path(current.as_ref(), path))
    }

    /// Checks a monitor speed (percent) against the fence's speed cap. `Ok` without a fence.
    pub fn check_speed(&self, percent: f64) -> Result<(), FenceViolation> {
        let Some(fence) = &self.inner.config.fence else {
            return Ok(());
        };
        let r = fence.check(
            &fs020n_proto::Command::SetSpeed { percent },
            &JointsDeg([0.0; 6]),
        );
        self.fence_verdict("a speed", r)
    }

    /// Checks a command-7 sample an in-process user is about to send (a servo's) against the
    /// fence: the client's sample check against the fenced model, and the flange inside the
    /// workspace box over every time the controller can extrapolate it to. Takes nothing
    /// (call it for every sample while holding control). `Ok` without a fence.
    pub fn check_sample(&self, sample: &fs020n_proto::StreamSample) -> Result<(), FenceViolation> {
        let Some(fence) = &self.inner.config.fence else {
            return Ok(());
        };
        let r = fence.check(
            &fs020n_proto::Command::StreamedMove(*sample),
            &sample.position,
        );
        self.fence_verdict("a servo sample", r)
    }

    /// Counts and logs a fence refusal of an in-process user's `what` (a path, a speed).
    fn fence_verdict(
        &self,
        what: &str,
        r: Result<(), FenceViolation>,
    ) -> Result<(), FenceViolation> {
        if let Err(v) = &r {
            lock(&self.inner.book).counters.refused_fence += 1;
            self.log(
                None,
                "refused",
                None,
                Some(Refusal::Fence),
                format!("{what} was refused by the fence: {v}"),
            );
        }
        r
    }

    /// Counters since the hub started.
    pub fn counters(&self) -> HubCounters {
        lock(&self.inner.book).counters
    }

    /// `true` while the session with the controller is open.
    pub fn is_connected(&self) -> bool {
        self.inner.link.borrow().up
    }

    fn now_s(&self) -> f64 {
        self.inner.started.elapsed().as_secs_f64()
    }

    /// Adds an event to the log and to `tracing`.
    pub(crate) fn log(
        &self,
        client: Option<u64>,
        kind: &'static str,
        request: Option<&str>,
        refusal: Option<Refusal>,
        message: String,
    ) {
        match kind {
            "refused" | "stop" | "link" => {
                tracing::warn!(client, request, ?refusal, "{message}")
            }
            _ => tracing::info!(client, request, "{message}"),
        }
        let ev = HubEvent {
            t_s: (self.now_s() * 1e3).round() / 1e3,
            client,
            kind,
            request: request.map(excerpt),
            refusal,
            message,
        };
        let mut book = lock(&self.inner.book);
        if book.events.len() >= EVENTS_KEPT {
            book.events.pop_front();
        }
        book.events.push_back(ev);
    }

    /// The newest events (at most [`EVENTS_KEPT`]), oldest first.
    pub fn events(&self) -> Vec<HubEvent> {
        lock(&self.inner.book).events.iter().cloned().collect()
    }

    /// Everything the page shows, now.
    pub fn state(&self) -> HubState {
        // The robot is behind an async lock; `try_read` never waits (a reconnection holds it
        // for writing: then the status is not available).
        let (status, stats, link_err) = match self.inner.robot.try_read() {
            Ok(r) => (Some(r.status()), Some(r.stats()), r.link_error()),
            Err(_) => (None, None, None),
        };
        let up = self.is_connected();
        let status_view = status.as_ref().map(|s| {
            let st = &s.status;
            StatusView {
                power: st.power,
                run: st.run,
                repeat: st.repeat,
                teach_lock: st.teach_lock,
                task_running: st.task_running,
                error_code: st.error.raw(),
                error_name: st.error.to_string(),
                error_message: st.error.message().map(str::to_owned),
                timer_s: st.timer.seconds(),
                joints_deg: st.joints,
                blockers: blockers(st, true).iter().map(ToString::to_string).collect(),
                age_ms: s.age().as_secs_f64() * 1e3,
            }
        });
        let tool = status.as_ref().and_then(|s| {
            let j = s.status.joints;
            j.is_finite()
                .then(|| self.inner.model.forward(&j.to_rad()).to_xyzoat())
        });
        let book = lock(&self.inner.book);
        let now = Instant::now();
        let skip = book.events.len().saturating_sub(EVENTS_SHOWN);
        HubState {
            time_s: self.now_s(),
            model: self.inner.model.name().to_owned(),
            link: LinkView {
                robot: self.inner.describe.clone(),
                connected: up,
                error: if up {
                    None
                } else {
                    book.link_error
                        .clone()
                        .or_else(|| link_err.map(|e| e.to_string()))
                },
                requests: stats.as_ref().map_or(0, |s| s.requests),
                keepalive_polls: stats.as_ref().map_or(0, |s| s.keepalive_polls),
                rtt_mean_ms: stats
                    .as_ref()
                    .map_or(0.0, |s| s.rtt.mean.as_secs_f64() * 1e3),
                rtt_p99_ms: stats
                    .as_ref()
                    .map_or(0.0, |s| s.rtt.p99.as_secs_f64() * 1e3),
            },
            status: status_view,
            tool,
            target_deg: book.target,
            controller: book.controller,
            clients: book
                .clients
                .iter()
                .map(|(id, c)| ClientView {
                    id: *id,
                    peer: c.peer.clone(),
                    controlling: book.controller == Some(*id),
                    requests: c.requests,
                    refused: c.refused,
                    connected_s: now.saturating_duration_since(c.since).as_secs_f64(),
                })
                .collect(),
            events: book.events.iter().skip(skip).cloned().collect(),
            counters: book.counters,
            fence: self.inner.config.fence.as_ref().map(|f| f.spec().clone()),
            silence_timeout_s: self.inner.config.silence_timeout.as_secs_f64(),
        }
    }

    /// Stops the robot: command 2 (the robot stops at once, the program ends). Used by the
    /// page's Stop button; `source` names who asked, for the log.
    pub async fn stop_robot(&self, source: &str) -> Result<(), ClientError> {
        let r = self.inner.robot.read().await.stop_program().await;
        lock(&self.inner.book).target = None;
        match &r {
            Ok(_) => self.log(
                None,
                "stop",
                None,
                None,
                format!("{source}: stop (command 2) sent"),
            ),
            Err(e) => self.log(
                None,
                "stop",
                None,
                None,
                format!("{source}: stop failed: {e}"),
            ),
        }
        r.map(|_| ())
    }

    /// Cancels the current motion: command 5 alone (the robot brakes, the program keeps
    /// running; a motion the controller had already planned may still run — [`Hub::stop_robot`]
    /// is the sure stop). Used by the page's Cancel button.
    pub async fn cancel_motion(&self, source: &str) -> Result<(), ClientError> {
        let r = self
            .inner
            .robot
            .read()
            .await
            .send_raw("1040 5 0", false)
            .await;
        lock(&self.inner.book).target = None;
        match &r {
            Ok(_) => self.log(
                None,
                "cancel",
                None,
                None,
                format!("{source}: cancel (command 5) sent"),
            ),
            Err(e) => self.log(
                None,
                "cancel",
                None,
                None,
                format!("{source}: cancel failed: {e}"),
            ),
        }
        r.map(|_| ())
    }

    pub(crate) fn count_page_action(&self) {
        lock(&self.inner.book).counters.page_actions += 1;
    }

    /// Ends the session with the controller (255: the controller stops the robot and ends the
    /// program) and stops reconnecting. Face clients are disconnected.
    pub async fn close(&self) -> Result<(), ClientError> {
        self.inner.closing.store(true, Ordering::SeqCst);
        if let Some(t) = lock(&self.inner.supervisor).take() {
            t.abort();
        }
        let r = self.inner.robot.read().await.close().await;
        self.inner.link.send_modify(|l| {
            l.generation += 1;
            l.up = false;
        });
        r
    }
}

/// Control of the hub held by an in-process user ([`Hub::claim_control`]); dropping it releases
/// control.
#[derive(Debug)]
pub struct ControlClaim {
    hub: Hub,
    id: u64,
    who: String,
}

impl ControlClaim {
    /// The client number the claim is shown with.
    pub fn id(&self) -> u64 {
        self.id
    }
}

impl Drop for ControlClaim {
    fn drop(&mut self) {
        {
            let mut book = lock(&self.hub.inner.book);
            if book.controller == Some(self.id) {
                book.controller = None;
            }
            book.clients.remove(&self.id);
        }
        self.hub.log(
            Some(self.id),
            "control",
            None,
            None,
            format!("{} (client {}) releases control", self.who, self.id),
        );
    }
}

/// Watches the session with the controller; when it is lost, tells the face clients (their
/// connections close, as the controller's would), releases control and reconnects. A new
/// session starts with the program stopped: nothing is resumed.
async fn supervise(inner: std::sync::Weak<Inner>) {
    loop {
        let mut rx = {
            let Some(inner) = inner.upgrade() else { return };
            let r = inner.robot.read().await;
            r.subscribe()
        };
        while rx.changed().await.is_ok() {}
        let Some(strong) = inner.upgrade() else {
            return;
        };
        if strong.closing.load(Ordering::SeqCst) {
            return;
        }
        let hub = Hub { inner: strong };
        let why = hub
            .inner
            .robot
            .read()
            .await
            .link_error()
            .map_or_else(|| "the session ended".to_owned(), |e| e.to_string());
        {
            let mut book = lock(&hub.inner.book);
            book.counters.links_lost += 1;
            book.controller = None;
            book.target = None;
            book.link_error = Some(why.clone());
        }
        hub.inner.link.send_modify(|l| {
            l.generation += 1;
            l.up = false;
        });
        hub.log(
            None,
            "link",
            None,
            None,
            format!("session with the controller lost: {why}; reconnecting"),
        );
        loop {
            tokio::time::sleep(hub.inner.config.reconnect_interval).await;
            if hub.inner.closing.load(Ordering::SeqCst) {
                return;
            }
            let r = {
                let mut guard = hub.inner.robot.write().await;
                // An in-process user (the ROS 2 node) may still hold the old session for a
                // moment: try again at the next interval.
                match Arc::get_mut(&mut guard) {
                    Some(robot) => robot.reconnect().await,
                    None => {
                        lock(&hub.inner.book).link_error = Some(
                            "reconnecting: waiting for the hub's in-process users to let go of \
                             the old session"
                                .into(),
                        );
                        continue;
                    }
                }
            };
            match r {
                Ok(()) => break,
                Err(e) => {
                    lock(&hub.inner.book).link_error = Some(e.to_string());
                    tracing::warn!(error = %e, "reconnecting to the controller failed");
                }
            }
        }
        if let Some(cap) = hub.fence().and_then(Fence::speed_cap) {
            if let Err(e) = hub.inner.robot.read().await.set_speed(cap).await {
                tracing::warn!(error = %e, "cannot set the fence's speed cap after reconnecting");
            }
        }
        lock(&hub.inner.book).link_error = None;
        hub.inner.link.send_modify(|l| {
            l.generation += 1;
            l.up = true;
        });
        hub.log(
            None,
            "link",
            None,
            None,
            "session with the controller open again (program stopped; nothing resumed)".into(),
        );
        drop(hub);
    }
}
