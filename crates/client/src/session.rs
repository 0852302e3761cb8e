//! The session: one connection, strictly one exchange on the wire at a time.
//!
//! The rules live in [`SessionCore`](self::core::SessionCore) (`session/core.rs`), a state
//! machine without I/O and without a clock. Around it, from the bottom up, the tokio driver
//! keeps only what needs tokio:
//!
//! * `session/conn.rs` — the connection and its core: each write, flush and read the core asks
//!   for, bounded by the core's next deadline, and fed back to it;
//! * `session/shared.rs` — the state of one session shared by its handles (the connection behind
//!   a FIFO async mutex, the cause of its end, the motion epoch, the server clock) and the state
//!   that outlives sessions (configuration, statistics, recording);
//! * `session/driver.rs` — one request: begin it in the core, drive the connection **in the
//!   caller's own task** (no hand-off), consume the core's events (the status is published, the
//!   clock estimator, the statistics and the recording are fed, an ended link is dropped), and
//!   complete a request whose caller's future was dropped (a spawned task);
//! * `session/keeper.rs` — the keeper task: keep-alive polls when the core says one is due, the
//!   stops queued by `Drop` impls, the polite close, the watch of the idle connection;
//! * this file — the handle ([`Link`]) and connecting ([`establish`]).
//!
//! The first failure of the link kills the session: the cause is stored, every waiter gets it,
//! and the connection is dropped. Nothing is ever retried or resumed.

mod conn;
mod core;
mod driver;
mod keeper;
mod shared;

use std::borrow::Cow;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use fs020n_proto::{Command, Request};
use tokio::sync::{mpsc, watch, Notify};
use tokio::time::{timeout_at, Instant};

use self::conn::{timeouts, Conn};
pub(crate) use self::conn::{Exchange, POLL};
pub(crate) use self::core::{Kind, MotionTag};
use self::driver::exchange_locked;
use self::keeper::{keeper, Op};
use self::shared::Io;
pub use self::shared::StatusSnapshot;
pub(crate) use self::shared::{lock, Common, SessionShared};
use crate::clock::ServerClock;
use crate::error::{Cancellation, ClientError, LinkError};
use crate::record::Dir;
use crate::transport::Connector;

/// A handle on a session: cheap to clone.
///
/// A request is made by its caller: it takes the connection (an async mutex, FIFO, so requests
/// from cloned handles are served in order and strictly one at a time), writes the request,
/// reads the reply and publishes it — no hand-off to another task. If the caller's future is
/// dropped while its request is on the wire, a spawned task completes the exchange (the reply
/// is read and published), so the connection stays in lock-step. The session's keeper task
/// sends the keep-alive polls, the stops queued without waiting, and watches the idle
/// connection (a close or bytes nobody asked for end the session).
#[derive(Debug, Clone)]
pub(crate) struct Link {
    tx: mpsc::Sender<Op>,
    pub(crate) status: watch::Receiver<StatusSnapshot>,
    pub(crate) shared: Arc<SessionShared>,
}

impl Link {
    /// One round trip, made by the caller. A motion goes out only once its caller polls again:
    /// a caller that stops waiting at once (a zero timeout, a `select!` that another branch
    /// wins) sends nothing — nobody would learn that it was sent, nor watch or cancel it.
    pub(crate) async fn exchange(
        &self,
        text: impl Into<Cow<'static, str>>,
        kind: Kind,
        motion: Option<MotionTag>,
    ) -> Result<Exchange, ClientError> {
        self.exchange_with(text.into(), kind, motion, motion.is_some())
            .await
    }

    /// [`exchange`](Self::exchange) for the client's own motion loops (stream, servo), which
    /// own the handle their caller watches: the motion goes out on the first poll. `epoch` is
    /// the loop's motion epoch: the motion is tagged with it, so the core refuses it once a
    /// cancel or stop has come. A cancel seen before the motion is tagged is the loop's end,
    /// not a refusal: `Cancelled(NotSent)`, not counted as refused before sending.
    pub(crate) async fn exchange_own_motion(
        &self,
        text: impl Into<Cow<'static, str>>,
        epoch: u64,
    ) -> Result<Exchange, ClientError> {
        let tag = self.shared.motion_tag();
        if tag.epoch != epoch {
            return Err(Cancellation::NotSent.into());
        }
        let tag = MotionTag { epoch, id: tag.id };
        self.exchange_with(text.into(), Kind::Motion, Some(tag), false)
            .await
    }

    async fn exchange_with(
        &self,
        text: Cow<'static, str>,
        kind: Kind,
        motion: Option<MotionTag>,
        second_poll: bool,
    ) -> Result<Exchange, ClientError> {
        if self.shared.is_dead() {
            return Err(self.shared.death());
        }
        let io = self.shared.lock_io().await;
        exchange_locked(&self.shared, io, text, kind, motion, second_poll).await
    }

    /// Stops the arm for sure: command 5 (`BRAKE`: the current motion stops at once), then
    /// command 2 (the motion program ends once signal 2007 has been stable for 50 ms). A 5
    /// alone is not enough: the controller may then execute a motion its look-ahead had
    /// already planned — during a joint move, the program's re-issue of the same target — so
    /// the arm would go on (spec §2.1, §4). Motion validated before this call is not sent.
    /// Returns the status of the reply to the 2.
    pub(crate) async fn halt(&self) -> Result<Exchange, ClientError> {
        self.shared.bump_epoch();
        self.command(&Request::new(Command::CancelMotion)).await?;
        *lock(&self.shared.last_stop) = Some(Instant::now());
        self.command(&Request::new(Command::StopProgram)).await
    }

    /// A fresh status poll.
    pub(crate) async fn poll(&self) -> Result<Exchange, ClientError> {
        self.exchange(POLL, Kind::Poll, None).await
    }

    /// Encodes and sends a non-motion command.
    pub(crate) async fn command(&self, request: &Request) -> Result<Exchange, ClientError> {
        let text = request
            .encode()
            .inspect_err(|_| self.shared.common.refused())?;
        self.exchange(text, Kind::Command, None).await
    }

    pub(crate) fn latest(&self) -> StatusSnapshot {
        self.status.borrow().clone()
    }

    /// [`halt`](Self::halt) without waiting for the replies (for `Drop`, where nothing can
    /// await): queues commands 5 and 2 (in this order: the queue is FIFO) for the keeper task.
    pub(crate) fn halt_detached(&self) {
        self.shared.bump_epoch();
        *lock(&self.shared.last_stop) = Some(Instant::now());
        for command in [Command::CancelMotion, Command::StopProgram] {
            let Ok(text) = Request::new(command).encode() else {
                return;
            };
            let op = Op {
                text: text.into(),
                kind: Kind::Command,
            };
            if let Err(e) = self.tx.try_send(op) {
                tracing::warn!(error = %e, "could not queue the stop of a dropped motion handle");
                return;
            }
        }
        // The keeper may be watching the idle connection: it serves the queue at once.
    }

    pub(crate) async fn close(&self) -> Result<Exchange, ClientError> {
        self.shared.bump_epoch();
        let text = Request::new(fs020n_proto::Command::EndSession).encode()?;
        self.exchange(text, Kind::Close, None).await
    }
}

/// Connects (retrying across listen gaps until the connect timeout), checks the peer with a
/// first status poll and starts the session.
pub(crate) async fn establish(
    connector: &dyn Connector,
    common: &Arc<Common>,
) -> Result<Link, ClientError> {
    let cfg = &common.config;
    let started = Instant::now();
    let deadline = started + cfg.connect_timeout;
    let mut attempts = 0u32;
    let mut last: String;
    loop {
        attempts += 1;
        match timeout_at(deadline, connector.connect()).await {
            Err(_) => {
                last = "the connection attempt did not complete in time".into();
                break;
            }
            // The address itself is unusable (a name that does not resolve): say so at once.
            Ok(Err(e)) if e.kind() == std::io::ErrorKind::InvalidInput => {
                return Err(ClientError::Address {
                    target: connector.describe(),
                    message: e.to_string(),
                })
            }
            Ok(Err(e)) => last = e.to_string(),
            Ok(Ok(stream)) => {
                let mut conn = Conn::new(stream, timeouts(cfg));
                let reply_timeout = cfg.reply_timeout.min(
                    deadline
                        .saturating_duration_since(Instant::now())
                        .max(Duration::from_millis(1)),
                );
                match conn.first_poll(reply_timeout).await {
                    Ok(ex) => return Ok(spawn(conn, ex, common.clone(), connector.describe())),
                    // Something answered, but not as a controller: retrying cannot help.
                    Err(
                        cause @ (LinkError::NotAController { .. }
                        | LinkError::Undecodable(_)
                        | LinkError::Unsolicited { .. }),
                    ) => {
                        return Err(ClientError::NotAController {
                            target: connector.describe(),
                            cause,
                        })
                    }
                    // Accepted by the kernel but dropped by the server (another session,
                    // listen gap), or silent: try again.
                    Err(e) => last = format!("connected, but the first status poll failed: {e}"),
                }
            }
        }
        tracing::debug!(attempt = attempts, error = %last, "connection attempt failed");
        let now = Instant::now();
        if now + cfg.connect_retry_interval >= deadline {
            break;
        }
        tokio::time::sleep(cfg.connect_retry_interval).await;
    }
    Err(ClientError::Connect {
        target: connector.describe(),
        attempts,
        waited: started.elapsed(),
        last,
    })
}

fn spawn(conn: Conn, first: Exchange, common: Arc<Common>, target: String) -> Link {
    let id = common.sessions.fetch_add(1, Ordering::Relaxed) + 1;
    let mut clock = ServerClock::new(first.sent_at);
    if let Some(t) = first.frame.status.timer.seconds() {
        clock.add(first.sent_at, first.received_at, t);
    }
    let snapshot = StatusSnapshot {
        status: first.frame.status.clone(),
        received_at: first.received_at,
        rtt: first.rtt(),
        seq: 0,
    };
    let (status_tx, status_rx) = watch::channel(snapshot);
    let (epoch, _) = watch::channel(0);
    let idle_watch_at = conn
        .core
        .watch_idle_at()
        .map_or(first.received_at, Instant::from_std);
    let shared = Arc::new(SessionShared {
        id,
        common: common.clone(),
        dead: Mutex::new(None),
        clock: Mutex::new(clock),
        epoch,
        next_motion_id: AtomicU64::new(0),
        last_motion: AtomicU64::new(0),
        streaming: AtomicBool::new(false),
        speed_bits: AtomicU64::new(f64::NAN.to_bits()),
        last_stop: Mutex::new(None),
        io: Arc::new(tokio::sync::Mutex::new(Io {
            conn: Some(conn),
            status_tx: Some(status_tx),
        })),
        idle_watch_at: Mutex::new(idle_watch_at),
        wanted: Notify::new(),
    });
    {
        let late = first.rtt() > common.config.late_reply_after;
        let mut st = lock(&common.stats);
        st.stats.requests += 1;
        st.record_rtt(first.rtt(), late);
        st.record_timer(first.frame.status.timer);
    }
    common.record(first.sent_at, id, Dir::Event, "connect", None, &target);
    common.record(first.sent_at, id, Dir::Tx, "poll", None, POLL);
    common.record(
        first.received_at,
        id,
        Dir::Rx,
        "poll",
        Some(first.rtt()),
        &first.frame.text,
    );
    tracing::debug!(
        session = id,
        kind = "poll",
        request = ?POLL,
        reply = ?first.frame.text,
        rtt_us = u64::try_from(first.rtt().as_micros()).unwrap_or(u64::MAX),
        "exchange"
    );
    tracing::info!(session = id, %target, "connected");
    let (tx, rx) = mpsc::channel(32);
    tokio::spawn(keeper(shared.clone(), rx));
    Link {
        tx,
        status: status_rx,
        shared,
    }
}
