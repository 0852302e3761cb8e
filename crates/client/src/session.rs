//! The session: one connection, strictly one exchange on the wire at a time.
//!
//! The rules live in [`SessionCore`] (`session/core.rs`), a state machine without I/O and
//! without a clock. This file is its tokio driver, and keeps only what needs tokio: the
//! connection behind a FIFO async mutex, the I/O of each request made by its caller's own task
//! (no hand-off), the completion of a request whose caller's future was dropped (a spawned
//! task), and the session's keeper task. A request is made by its caller's task: it takes the
//! connection, asks the core to begin the request (the core refuses it or puts it in flight),
//! writes and reads what the core asks for until the core reports the exchange, then consumes
//! the core's events: the status is published, the clock estimator, the statistics and the
//! recording are fed. The keeper task sends keep-alive polls when the core says one is due,
//! serves the stops queued by `Drop` impls, and watches the idle connection. The first failure
//! of the link kills the session: the cause is stored, every waiter gets it, and the connection
//! is dropped. Nothing is ever retried or resumed.

mod core;

use std::borrow::Cow;
use std::future::Future;
use std::ops::ControlFlow;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::task::Poll;
use std::time::Duration;

use fs020n_proto::{Command, ReplyFrame, Request, Status};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::sync::{mpsc, watch, Notify, OwnedMutexGuard};
use tokio::time::{sleep_until, timeout_at, Instant};

use self::core::{Event, Reply, SessionCore, Timeouts, Transmit, WireRequest};
pub(crate) use self::core::{Kind, MotionTag};
use crate::clock::ServerClock;
use crate::config::ClientConfig;
use crate::error::{Cancellation, ClientError, LinkError};
use crate::record::{Dir, Recorder};
use crate::stats::StatsInner;
use crate::transport::{BoxedStream, Connector};

/// The status poll: a mismatched version, so the server changes nothing.
pub(crate) const POLL: &str = "0 0 0";

/// Locks a mutex, ignoring poisoning (the data are counters and estimates: a panic elsewhere
/// cannot leave them dangerous).
pub(crate) fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

/// The latest status with when it arrived.
#[derive(Debug, Clone, PartialEq)]
pub struct StatusSnapshot {
    /// The decoded reply.
    pub status: Status,
    /// When the reply was complete (tokio's clock: virtual under a paused test runtime).
    pub received_at: Instant,
    /// Round trip of the request it answered.
    pub rtt: Duration,
    /// Number of replies in this session before this one (0 for the first).
    pub seq: u64,
}

impl StatusSnapshot {
    /// Time since the reply arrived.
    pub fn age(&self) -> Duration {
        self.received_at.elapsed()
    }
}

/// One completed round trip.
#[derive(Debug, Clone)]
pub(crate) struct Exchange {
    pub(crate) frame: ReplyFrame,
    pub(crate) sent_at: Instant,
    pub(crate) received_at: Instant,
}

impl Exchange {
    pub(crate) fn rtt(&self) -> Duration {
        self.received_at.duration_since(self.sent_at)
    }

    /// The core's reply on tokio's clock.
    fn from_reply(reply: Reply) -> Exchange {
        Exchange {
            frame: reply.frame,
            sent_at: Instant::from_std(reply.sent_at),
            received_at: Instant::from_std(reply.received_at),
        }
    }
}

/// State that outlives sessions: configuration, statistics, recording.
#[derive(Debug)]
pub(crate) struct Common {
    pub(crate) config: ClientConfig,
    pub(crate) stats: Mutex<StatsInner>,
    pub(crate) recorder: Option<Recorder>,
    pub(crate) sessions: AtomicU64,
}

impl Common {
    pub(crate) fn new(config: ClientConfig) -> Result<Common, ClientError> {
        config.validate()?;
        let recorder = match &config.record {
            Some(r) => Some(Recorder::open(r, config.late_reply_after)?),
            None => None,
        };
        Ok(Common {
            config,
            stats: Mutex::new(StatsInner::default()),
            recorder,
            sessions: AtomicU64::new(0),
        })
    }

    pub(crate) fn record(
        &self,
        at: Instant,
        session: u64,
        dir: Dir,
        kind: &'static str,
        rtt: Option<Duration>,
        text: &str,
    ) {
        if let Some(r) = &self.recorder {
            // Never blocks: the line goes to the recording's writer thread.
            if let Err(lost) = r.line(at, session, dir, kind, rtt, text) {
                lock(&self.stats).stats.record_errors += lost;
            }
        }
    }

    pub(crate) fn refused(&self) {
        lock(&self.stats).stats.refused_before_sending += 1;
    }
}

/// State of one session shared between the task and the handles.
#[derive(Debug)]
pub(crate) struct SessionShared {
    pub(crate) id: u64,
    pub(crate) common: Arc<Common>,
    dead: Mutex<Option<ClientError>>,
    pub(crate) clock: Mutex<ServerClock>,
    /// Bumped by every cancel/stop/close: motion validated in an older epoch is not sent.
    pub(crate) epoch: watch::Sender<u64>,
    next_motion_id: AtomicU64,
    /// Id of the last motion command written.
    pub(crate) last_motion: AtomicU64,
    /// A stream is running on this session.
    pub(crate) streaming: AtomicBool,
    /// The monitor speed last set by this client, percent (`f64` bits; NaN = unknown).
    speed_bits: AtomicU64,
    /// When command 2 was last sent on this session.
    pub(crate) last_stop: Mutex<Option<Instant>>,
    /// The connection: whoever holds it makes the one exchange on the wire.
    io: Arc<tokio::sync::Mutex<Io>>,
    /// From when the keeper task watches the idle connection (the core's
    /// [`watch_idle_at`](SessionCore::watch_idle_at), copied after every reply so that the
    /// keeper can sleep without holding the connection).
    idle_watch_at: Mutex<Instant>,
    /// A caller waits for the connection the keeper task holds while the link is idle.
    wanted: Notify,
}

impl SessionShared {
    pub(crate) fn death(&self) -> ClientError {
        lock(&self.dead)
            .clone()
            .unwrap_or(ClientError::LinkLost(LinkError::SessionEnded))
    }

    fn set_dead(&self, e: ClientError) {
        lock(&self.dead).get_or_insert(e);
    }

    pub(crate) fn is_dead(&self) -> bool {
        lock(&self.dead).is_some()
    }

    pub(crate) fn current_epoch(&self) -> u64 {
        *self.epoch.borrow()
    }

    /// Invalidates every motion validated so far (queued commands 6/7 are not sent).
    pub(crate) fn bump_epoch(&self) {
        self.epoch.send_modify(|e| *e += 1);
    }

    pub(crate) fn motion_tag(&self) -> MotionTag {
        MotionTag {
            epoch: self.current_epoch(),
            id: self.next_motion_id.fetch_add(1, Ordering::Relaxed) + 1,
        }
    }

    pub(crate) fn speed_percent(&self) -> Option<f64> {
        let v = f64::from_bits(self.speed_bits.load(Ordering::Relaxed));
        (!v.is_nan()).then_some(v)
    }

    pub(crate) fn set_speed_percent(&self, p: f64) {
        self.speed_bits.store(p.to_bits(), Ordering::Relaxed);
    }
}

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

/// The session core's timeouts from the client's configuration.
fn timeouts(cfg: &ClientConfig) -> Timeouts {
    Timeouts {
        write: cfg.write_timeout,
        reply: cfg.reply_timeout,
        keepalive_period: cfg.keepalive_period,
        close: cfg.close_timeout,
    }
}

/// A time to wait for when the core has no deadline (never while a request is in flight).
fn far_future() -> Instant {
    Instant::now() + Duration::from_secs(86_400 * 365)
}

/// The connection with the session core that rules it.
struct Conn {
    stream: BoxedStream,
    buf: Vec<u8>,
    core: SessionCore,
}

impl Conn {
    fn new(stream: BoxedStream, timeouts: Timeouts) -> Conn {
        Conn {
            stream,
            buf: vec![0; 1024],
            core: SessionCore::new(timeouts),
        }
    }

    /// Writes and reads what the core asks for until the request in flight is over (its reply
    /// complete, or the link ended). Cancel-safe: the progress lives in the core, so calling it
    /// again goes on where it stopped.
    async fn drive(&mut self) {
        while self.core.in_flight() {
            self.step().await;
        }
    }

    /// After 255: reads until the server closes the connection or the core's close deadline.
    async fn await_close(&mut self) {
        while self.core.is_closing() {
            self.step().await;
        }
    }

    /// One I/O operation the core asks for — write, flush, or read — bounded by the core's next
    /// deadline; its outcome goes to the core.
    async fn step(&mut self) {
        let deadline = self
            .core
            .poll_timeout()
            .map_or_else(far_future, Instant::from_std);
        match self.core.poll_transmit() {
            Some(Transmit::Bytes(bytes)) => {
                match timeout_at(deadline, self.stream.write(bytes)).await {
                    Ok(Ok(n)) if n > 0 => self.core.handle_written(n),
                    Ok(Ok(_)) => self.core.handle_closed(Instant::now().into_std()),
                    Ok(Err(e)) => self
                        .core
                        .handle_failure(Instant::now().into_std(), LinkError::io(&e)),
                    Err(_) => self.core.handle_timeout(Instant::now().into_std()),
                }
            }
            Some(Transmit::Flush) => {
                let r = timeout_at(deadline, self.stream.flush()).await;
                let now = Instant::now().into_std();
                match r {
                    Err(_) => self.core.handle_timeout(now),
                    Ok(Err(e)) => self.core.handle_failure(now, LinkError::io(&e)),
                    Ok(Ok(())) => self.core.handle_flushed(now),
                }
            }
            None => {
                let r = timeout_at(deadline, self.stream.read(&mut self.buf)).await;
                self.feed(r);
            }
        }
    }

    /// The outcome of a read (bounded by a deadline) to the core.
    fn feed(&mut self, r: Result<std::io::Result<usize>, tokio::time::error::Elapsed>) {
        let now = Instant::now().into_std();
        match r {
            Err(_) => self.core.handle_timeout(now),
            Ok(r) => self.feed_read(now, r),
        }
    }

    fn feed_read(&mut self, now: std::time::Instant, r: std::io::Result<usize>) {
        match r {
            Err(e) => self.core.handle_failure(now, LinkError::io(&e)),
            Ok(0) => self.core.handle_closed(now),
            Ok(n) => self.core.handle_input(now, &self.buf[..n]),
        }
    }

    /// The connect poll: the first exchange, whose reply timeout is cut to what is left of the
    /// connect timeout.
    async fn first_poll(&mut self, reply_timeout: Duration) -> Result<Exchange, LinkError> {
        let request =
            WireRequest::new(Kind::Poll, POLL.into(), None).with_reply_timeout(reply_timeout);
        if let Err(refusal) = self
            .core
            .begin_request(Instant::now().into_std(), 0, request)
        {
            return Err(match refusal.into_error() {
                ClientError::LinkLost(e) => e,
                _ => LinkError::SessionEnded,
            });
        }
        self.drive().await;
        while let Some(event) = self.core.poll_event() {
            match event {
                Event::ExchangeDone { reply, .. } => return Ok(Exchange::from_reply(reply)),
                Event::ExchangeFailed { cause, .. } => return Err(cause),
                _ => {}
            }
        }
        Err(LinkError::SessionEnded)
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

/// What the connection mutex guards.
pub(crate) struct Io {
    /// `None` once the session has ended (the connection is closed).
    conn: Option<Conn>,
    /// `None` once the session has ended (subscribers see the end).
    status_tx: Option<watch::Sender<StatusSnapshot>>,
}

impl std::fmt::Debug for Io {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Io")
            .field("open", &self.conn.is_some())
            .finish()
    }
}

/// A request queued for the keeper task (a stop that nobody awaits).
struct Op {
    text: Cow<'static, str>,
    kind: Kind,
}

/// What the driver learned from the core's events.
#[derive(Default)]
struct Drained {
    /// The outcome of the request that was in flight, if it ended.
    exchange: Option<Result<Exchange, ClientError>>,
    /// A keep-alive poll is due.
    keepalive_due: bool,
}

impl SessionShared {
    /// Takes the connection; if the keeper task holds it while watching the idle connection,
    /// asks it to let go (after queueing, so the mutex's FIFO order hands it to this caller).
    async fn lock_io(&self) -> OwnedMutexGuard<Io> {
        let acquire = self.io.clone().lock_owned();
        tokio::pin!(acquire);
        let first = std::future::poll_fn(|cx| Poll::Ready(acquire.as_mut().poll(cx))).await;
        match first {
            Poll::Ready(io) => io,
            Poll::Pending => {
                self.wanted.notify_one();
                acquire.await
            }
        }
    }

    fn idle_watch_at(&self) -> Instant {
        *lock(&self.idle_watch_at)
    }

    /// Asks the core to begin `request` at `now`. A refusal is returned as the caller's error
    /// (the checks of a motion are counted as refused before sending).
    fn begin(&self, io: &mut Io, now: Instant, request: WireRequest) -> Result<(), ClientError> {
        let Some(conn) = io.conn.as_mut() else {
            return Err(self.death());
        };
        let kind = request.kind;
        match conn
            .core
            .begin_request(now.into_std(), self.current_epoch(), request)
        {
            Ok(()) => {
                if self.common.recorder.is_some() {
                    if let Some(text) = conn.core.request_in_flight().map(|r| &r.text) {
                        self.common
                            .record(now, self.id, Dir::Tx, kind.as_str(), None, text);
                    }
                }
                Ok(())
            }
            Err(refusal) => {
                if refusal.is_check() {
                    self.common.refused();
                }
                let e = refusal.into_error();
                // Unsolicited bytes found before the request end the link.
                self.drain(io);
                Err(e)
            }
        }
    }

    /// Consumes the core's events: a reply is published and counted, a failed request counted,
    /// an ended link closed.
    fn drain(&self, io: &mut Io) -> Drained {
        let mut drained = Drained::default();
        while let Some(conn) = io.conn.as_mut() {
            let Some(event) = conn.core.poll_event() else {
                break;
            };
            match event {
                Event::ExchangeDone { request, reply } => {
                    let seq = reply.seq;
                    let ex = Exchange::from_reply(reply);
                    if let Some(at) = conn.core.watch_idle_at() {
                        *lock(&self.idle_watch_at) = Instant::from_std(at);
                    }
                    self.completed(io, &request.text, request.kind, &ex, seq);
                    if let Some(tag) = request.motion {
                        self.last_motion.store(tag.id, Ordering::Relaxed);
                    }
                    drained.exchange = Some(Ok(ex));
                }
                Event::ExchangeFailed { request, cause } => {
                    tracing::debug!(session = self.id, kind = request.kind.as_str(), request = ?request.text, error = %cause, "exchange failed");
                    lock(&self.common.stats).stats.requests += 1;
                    drained.exchange = Some(Err(ClientError::LinkLost(cause)));
                }
                Event::KeepAliveDue => drained.keepalive_due = true,
                Event::CloseUnconfirmed(e) => {
                    tracing::warn!(error = %e, "the controller did not close the connection after 255");
                }
                Event::LinkEnded { at, cause } => self.ended(io, Instant::from_std(at), cause),
            }
        }
        drained
    }

    /// Statistics, clock, recording, log and status of a completed round trip.
    fn completed(&self, io: &mut Io, text: &str, kind: Kind, ex: &Exchange, seq: u64) {
        let common = &self.common;
        let cfg = &common.config;
        let id = self.id;
        let rtt = ex.rtt();
        common.record(
            ex.received_at,
            id,
            Dir::Rx,
            kind.as_str(),
            Some(rtt),
            &ex.frame.text,
        );
        {
            let mut st = lock(&common.stats);
            st.stats.requests += 1;
            if kind == Kind::KeepAlive {
                st.stats.keepalive_polls += 1;
            }
            st.record_rtt(rtt, rtt > cfg.late_reply_after);
        }
        if let Some(t) = ex.frame.status.timer.seconds() {
            lock(&self.clock).add(ex.sent_at, ex.received_at, t);
        }
        if kind == Kind::KeepAlive {
            tracing::trace!(
                session = id,
                kind = kind.as_str(),
                request = ?text,
                reply = ?ex.frame.text,
                rtt_us = u64::try_from(rtt.as_micros()).unwrap_or(u64::MAX),
                "exchange"
            );
        } else {
            tracing::debug!(
                session = id,
                kind = kind.as_str(),
                request = ?text,
                reply = ?ex.frame.text,
                rtt_us = u64::try_from(rtt.as_micros()).unwrap_or(u64::MAX),
                "exchange"
            );
        }
        if let Some(status_tx) = &io.status_tx {
            status_tx.send_replace(StatusSnapshot {
                status: ex.frame.status.clone(),
                received_at: ex.received_at,
                rtt,
                seq,
            });
        }
    }

    /// Ends the session for a reason of the driver's (the first cause wins).
    fn end(&self, io: &mut Io, end: ClientError) {
        if let Some(conn) = io.conn.as_mut() {
            conn.core.end(Instant::now().into_std(), end);
        }
        self.drain(io);
    }

    /// The core ended the session: the cause is stored for every caller, the connection
    /// closed, the status subscribers see the end.
    fn ended(&self, io: &mut Io, at: Instant, end: ClientError) {
        if io.conn.is_none() {
            return;
        }
        let common = &self.common;
        if end != ClientError::Closed {
            lock(&common.stats).stats.links_lost += 1;
            // The cause is returned to every caller; this is only a trace for the logs.
            tracing::info!(session = self.id, error = %end, "link lost");
        } else {
            tracing::info!(session = self.id, "session closed");
        }
        common.record(at, self.id, Dir::Event, "end", None, &end.to_string());
        // Record the cause before anyone sees the connection gone.
        self.set_dead(end);
        io.conn = None;
        io.status_tx = None;
        // The keeper may be watching the connection: let it see the end.
        self.wanted.notify_one();
    }
}

/// Carries a request's exchange; if dropped before the reply is in (the caller's future was
/// dropped), a spawned task completes it so the connection stays in lock-step.
struct InFlight {
    shared: Arc<SessionShared>,
    io: Option<OwnedMutexGuard<Io>>,
    /// This is already the spawned completion: if it is dropped too (the runtime shuts down),
    /// the session ends.
    fallback: bool,
}

impl InFlight {
    /// Completes the exchange (in the caller's task or the fallback).
    async fn run(&mut self) -> Result<Exchange, ClientError> {
        let Some(io) = self.io.as_mut() else {
            return Err(self.shared.death());
        };
        let Some(conn) = io.conn.as_mut() else {
            return Err(self.shared.death());
        };
        conn.drive().await;
        // From here on nothing awaits: the exchange is complete whether or not the caller
        // is still there.
        match self.shared.drain(io).exchange {
            Some(r) => r,
            None => Err(self.shared.death()),
        }
    }
}

impl Drop for InFlight {
    fn drop(&mut self) {
        let Some(io) = self.io.take() else { return };
        if io.conn.as_ref().is_none_or(|c| !c.core.in_flight()) {
            return;
        }
        let mut rest = InFlight {
            shared: self.shared.clone(),
            io: Some(io),
            fallback: true,
        };
        match tokio::runtime::Handle::try_current() {
            Ok(rt) if !self.fallback => {
                rt.spawn(async move {
                    // Completed (or the session ended): dropping `rest` releases the connection.
                    let _ = rest.run().await;
                });
            }
            // No runtime to finish it on: the connection cannot stay in lock-step.
            _ => {
                if let Some(io) = rest.io.as_mut() {
                    rest.shared
                        .end(io, ClientError::LinkLost(LinkError::SessionEnded));
                }
            }
        }
    }
}

/// Counts a motion as refused before sending if its caller's future is dropped while this lives.
struct CallerGone<'a>(&'a Common);

impl Drop for CallerGone<'_> {
    fn drop(&mut self) {
        self.0.refused();
        tracing::debug!("motion not sent: its caller is gone");
    }
}

/// One exchange on the connection held by `io`.
async fn exchange_locked(
    shared: &Arc<SessionShared>,
    mut io: OwnedMutexGuard<Io>,
    text: Cow<'static, str>,
    kind: Kind,
    motion: Option<MotionTag>,
    second_poll: bool,
) -> Result<Exchange, ClientError> {
    if io.conn.is_none() {
        return Err(shared.death());
    }
    if motion.is_some() && second_poll {
        let gone = CallerGone(&shared.common);
        tokio::task::yield_now().await;
        std::mem::forget(gone);
    }
    shared.begin(
        &mut io,
        Instant::now(),
        WireRequest::new(kind, text, motion),
    )?;
    let mut flight = InFlight {
        shared: shared.clone(),
        io: Some(io),
        fallback: false,
    };
    let r = flight.run().await;
    let Some(mut io) = flight.io.take() else {
        return Err(shared.death());
    };
    let ex = r?;
    if kind == Kind::Close {
        if let Some(conn) = io.conn.as_mut() {
            conn.await_close().await;
        }
        shared.drain(&mut io);
        shared.end(&mut io, ClientError::Closed);
    }
    Ok(ex)
}

/// The session's keeper task: keep-alive polls when the core says one is due, queued stops,
/// the polite close when every handle is gone, and — from when the core says the connection is
/// idle — watching it for its close or for bytes nobody asked for.
async fn keeper(shared: Arc<SessionShared>, mut rx: mpsc::Receiver<Op>) {
    loop {
        if shared.is_dead() {
            break;
        }
        let idle_at = shared.idle_watch_at();
        tokio::select! {
            biased;
            op = rx.recv() => {
                let mut io = shared.lock_io().await;
                if serve(&shared, &mut io, op).await.is_break() {
                    break;
                }
                continue;
            }
            () = sleep_until(idle_at) => {}
        }
        let mut io = shared.io.clone().lock_owned().await;
        let Some(conn) = io.conn.as_ref() else {
            break;
        };
        if conn
            .core
            .watch_idle_at()
            .is_some_and(|at| Instant::now() < Instant::from_std(at))
        {
            continue;
        }
        // Idle: hold the connection and watch it until a caller wants it.
        loop {
            let Some(conn) = io.conn.as_mut() else {
                return;
            };
            let due = conn
                .core
                .poll_timeout()
                .map_or_else(far_future, Instant::from_std);
            let wake = tokio::select! {
                biased;
                r = conn.stream.read(&mut conn.buf) => Wake::Read(r),
                () = shared.wanted.notified() => Wake::Wanted,
                op = rx.recv() => Wake::Op(op),
                () = sleep_until(due) => Wake::Timeout,
            };
            let step = match wake {
                Wake::Read(r) => {
                    conn.feed_read(Instant::now().into_std(), r);
                    shared.drain(&mut io);
                    if io.conn.is_none() {
                        ControlFlow::Break(())
                    } else {
                        ControlFlow::Continue(())
                    }
                }
                Wake::Wanted => break,
                Wake::Op(op) => serve(&shared, &mut io, op).await,
                Wake::Timeout => {
                    conn.core.handle_timeout(Instant::now().into_std());
                    if shared.drain(&mut io).keepalive_due {
                        let r = exchange_in(&shared, &mut io, POLL.into(), Kind::KeepAlive).await;
                        if r.is_err() {
                            ControlFlow::Break(())
                        } else {
                            ControlFlow::Continue(())
                        }
                    } else if io.conn.is_none() {
                        ControlFlow::Break(())
                    } else {
                        ControlFlow::Continue(())
                    }
                }
            };
            if step.is_break() {
                return;
            }
        }
        drop(io);
    }
    // The session ended elsewhere: fail what is still queued.
    rx.close();
    while rx.try_recv().is_ok() {}
}

/// What woke the keeper task while it watched the idle connection.
enum Wake {
    Read(std::io::Result<usize>),
    Wanted,
    Op(Option<Op>),
    Timeout,
}

/// Serves one queued request (`None`: every handle is gone, end the session politely).
async fn serve(
    shared: &Arc<SessionShared>,
    io: &mut OwnedMutexGuard<Io>,
    op: Option<Op>,
) -> ControlFlow<()> {
    if io.conn.is_none() {
        return ControlFlow::Break(());
    }
    match op {
        None => {
            let _ = exchange_in(shared, io, "1040 255 0".into(), Kind::Close).await;
            shared.end(io, ClientError::Closed);
            ControlFlow::Break(())
        }
        Some(op) => match exchange_in(shared, io, op.text, op.kind).await {
            Ok(_) => ControlFlow::Continue(()),
            Err(_) => ControlFlow::Break(()),
        },
    }
}

/// An exchange of the keeper task on the connection it holds (not cancelled: the keeper is
/// never dropped mid-exchange except with the runtime).
async fn exchange_in(
    shared: &Arc<SessionShared>,
    io: &mut OwnedMutexGuard<Io>,
    text: Cow<'static, str>,
    kind: Kind,
) -> Result<Exchange, ClientError> {
    shared.begin(io, Instant::now(), WireRequest::new(kind, text, None))?;
    if let Some(conn) = io.conn.as_mut() {
        conn.drive().await;
    }
    match shared.drain(io).exchange {
        Some(r) => r,
        None => Err(shared.death()),
    }
}
