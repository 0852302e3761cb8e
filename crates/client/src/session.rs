//! The session: one connection, strictly one exchange on the wire at a time.
//!
//! A request is made by its caller's task: it takes the connection (a FIFO async mutex), writes
//! the request in one `write`, waits for the complete reply (strict lock-step, deadline per
//! request), publishes the status and feeds the clock estimator, the statistics and the
//! recording. A request whose caller's future is dropped mid-exchange is completed by a spawned
//! task. The session's keeper task sends keep-alive polls (`0 0 0`) whenever no request was
//! made for a keep-alive period, serves the stops queued by `Drop` impls, and watches the idle
//! connection. The first failure of the link kills the session: the cause is stored, every
//! waiter gets it, and the connection is dropped. Nothing is ever retried or resumed.

use std::borrow::Cow;
use std::future::Future;
use std::ops::ControlFlow;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::task::Poll;
use std::time::Duration;

use fs020n_proto::{Command, ReplyDecoder, ReplyFrame, Request, Status, PROTOCOL_VERSION};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::sync::{mpsc, watch, Notify, OwnedMutexGuard};
use tokio::time::{sleep_until, timeout_at, Instant};

use crate::clock::ServerClock;
use crate::config::ClientConfig;
use crate::error::{Cancellation, ClientError, LinkError};
use crate::record::{Dir, Recorder};
use crate::safety::blockers;
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

/// What a request is, for statistics, recording and the checks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Kind {
    /// A status poll asked for by the user.
    Poll,
    /// A keep-alive poll of the session task.
    KeepAlive,
    /// A command without motion (1, 2, 3, 5, ...).
    Command,
    /// A motion command (6/7): checked against the latest status and the motion epoch.
    Motion,
    /// A raw request without motion.
    Raw,
    /// 255: end the session, then wait for the server to close.
    Close,
}

impl Kind {
    fn as_str(self) -> &'static str {
        match self {
            Kind::Poll => "poll",
            Kind::KeepAlive => "keepalive",
            Kind::Command => "command",
            Kind::Motion => "motion",
            Kind::Raw => "raw",
            Kind::Close => "close",
        }
    }
}

/// Identifies a motion command: the motion epoch it was validated in (bumped by every cancel
/// and stop) and its own id.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct MotionTag {
    pub(crate) epoch: u64,
    pub(crate) id: u64,
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
    /// When the last reply arrived.
    last_exchange: Mutex<Instant>,
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
    /// own the handle their caller watches: the motion goes out on the first poll.
    pub(crate) async fn exchange_own_motion(
        &self,
        text: impl Into<Cow<'static, str>>,
        tag: MotionTag,
    ) -> Result<Exchange, ClientError> {
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

/// How long bytes that form a complete reply but for the final blank wait for more before they
/// are taken as the reply (the controller sends the blank in the same write: this is only for a
/// peer that omits it).
const OPEN_REPLY_QUIET: Duration = Duration::from_millis(20);

/// The connection with its decoder and the request in flight.
struct Conn {
    stream: BoxedStream,
    decoder: ReplyDecoder,
    buf: Vec<u8>,
    /// The request on the wire, kept here so that a dropped caller's exchange can be resumed.
    flight: Option<Flight>,
}

/// A request being written or awaiting its reply.
struct Flight {
    text: Cow<'static, str>,
    written: usize,
    sent_at: Instant,
    write_deadline: Instant,
    write_timeout: Duration,
    deadline: Instant,
    reply_timeout: Duration,
}

impl Conn {
    fn new(stream: BoxedStream) -> Conn {
        Conn {
            stream,
            decoder: ReplyDecoder::new(),
            buf: vec![0; 1024],
            flight: None,
        }
    }

    fn unsolicited(&self) -> Option<LinkError> {
        (!self.decoder.is_empty()).then(|| LinkError::Unsolicited {
            excerpt: String::from_utf8_lossy(
                &self.decoder.buffered()[..self.decoder.buffered().len().min(40)],
            )
            .into_owned(),
        })
    }

    /// Writes `text` in one write and reads its complete reply before `reply_timeout`.
    async fn exchange(
        &mut self,
        text: Cow<'static, str>,
        write_timeout: Duration,
        reply_timeout: Duration,
    ) -> Result<Exchange, LinkError> {
        self.begin(text, write_timeout, reply_timeout)?;
        self.drive().await
    }

    /// Puts `text` in flight (nothing is written yet).
    fn begin(
        &mut self,
        text: Cow<'static, str>,
        write_timeout: Duration,
        reply_timeout: Duration,
    ) -> Result<(), LinkError> {
        if let Some(e) = self.unsolicited() {
            return Err(e);
        }
        let sent_at = Instant::now();
        self.flight = Some(Flight {
            text,
            written: 0,
            sent_at,
            write_deadline: sent_at + write_timeout,
            write_timeout,
            deadline: sent_at + reply_timeout,
            reply_timeout,
        });
        Ok(())
    }

    /// Writes what remains of the request in flight and reads its reply. Cancel-safe: if this
    /// future is dropped, calling it again goes on where it stopped.
    async fn drive(&mut self) -> Result<Exchange, LinkError> {
        let Some(f) = self.flight.as_mut() else {
            return Err(LinkError::SessionEnded);
        };
        while f.written < f.text.len() {
            let rest = &f.text.as_bytes()[f.written..];
            match timeout_at(f.write_deadline, self.stream.write(rest)).await {
                Err(_) => {
                    return Err(LinkError::WriteTimeout {
                        request: f.text.clone().into_owned(),
                        deadline: f.write_timeout,
                    })
                }
                Ok(Err(e)) => return Err(LinkError::io(&e)),
                Ok(Ok(0)) => return Err(LinkError::Closed),
                Ok(Ok(n)) => f.written += n,
            }
        }
        match timeout_at(f.write_deadline, self.stream.flush()).await {
            Err(_) => {
                return Err(LinkError::WriteTimeout {
                    request: f.text.clone().into_owned(),
                    deadline: f.write_timeout,
                })
            }
            Ok(Err(e)) => return Err(LinkError::io(&e)),
            Ok(Ok(())) => {}
        }
        let (sent_at, deadline) = (f.sent_at, f.deadline);
        let mut quiet = false;
        loop {
            let next = if std::mem::take(&mut quiet) {
                self.decoder.take_open_reply()
            } else {
                self.decoder.next_reply()
            };
            match next {
                Err(e) => return Err(LinkError::Undecodable(e)),
                Ok(Some(frame)) => {
                    let received_at = Instant::now();
                    self.flight = None;
                    if let Some(e) = self.unsolicited() {
                        return Err(e);
                    }
                    if frame.status.version != PROTOCOL_VERSION {
                        return Err(LinkError::NotAController {
                            version: frame.status.version,
                        });
                    }
                    return Ok(Exchange {
                        frame,
                        sent_at,
                        received_at,
                    });
                }
                Ok(None) => {}
            }
            // The controller sends its final blank with the reply. Bytes that would be a
            // complete reply but for it are taken once the peer has been quiet for a moment.
            let quiet_at = if self.decoder.may_be_open_reply() {
                Some(Instant::now() + OPEN_REPLY_QUIET).filter(|&at| at < deadline)
            } else {
                None
            };
            let n = match timeout_at(
                quiet_at.unwrap_or(deadline),
                self.stream.read(&mut self.buf),
            )
            .await
            {
                Err(_) if quiet_at.is_some() => {
                    quiet = true;
                    continue;
                }
                Err(_) => {
                    let (request, deadline) = match &self.flight {
                        Some(f) => (f.text.clone().into_owned(), f.reply_timeout),
                        None => (String::new(), Duration::ZERO),
                    };
                    return Err(LinkError::ReplyTimeout { request, deadline });
                }
                Ok(Err(e)) => return Err(LinkError::io(&e)),
                Ok(Ok(0)) => return Err(LinkError::Closed),
                Ok(Ok(n)) => n,
            };
            self.decoder
                .push(&self.buf[..n])
                .map_err(LinkError::Undecodable)?;
        }
    }

    /// Bytes that arrived while no request was outstanding.
    fn idle_bytes(&mut self, n: usize) -> Result<(), LinkError> {
        if n == 0 {
            return Err(LinkError::Closed);
        }
        self.decoder
            .push(&self.buf[..n])
            .map_err(LinkError::Undecodable)?;
        match self.unsolicited() {
            Some(e) => Err(e),
            None => Ok(()),
        }
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
                let mut conn = Conn::new(stream);
                let reply_timeout = cfg.reply_timeout.min(
                    deadline
                        .saturating_duration_since(Instant::now())
                        .max(Duration::from_millis(1)),
                );
                match conn
                    .exchange(POLL.into(), cfg.write_timeout, reply_timeout)
                    .await
                {
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
            seq: 0,
        })),
        last_exchange: Mutex::new(first.received_at),
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
    seq: u64,
}

impl std::fmt::Debug for Io {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Io")
            .field("open", &self.conn.is_some())
            .field("seq", &self.seq)
            .finish()
    }
}

/// A request queued for the keeper task (a stop that nobody awaits).
struct Op {
    text: Cow<'static, str>,
    kind: Kind,
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

    fn last_exchange(&self) -> Instant {
        *lock(&self.last_exchange)
    }

    /// A motion is sent only if no cancel/stop came after it was validated and the latest
    /// status allows motion.
    fn check_motion(&self, io: &Io, tag: MotionTag) -> Result<(), ClientError> {
        if tag.epoch != self.current_epoch() {
            return Err(Cancellation::NotSent.into());
        }
        let Some(status_tx) = &io.status_tx else {
            return Err(self.death());
        };
        let b = blockers(&status_tx.borrow().status, true);
        if b.is_empty() {
            Ok(())
        } else {
            Err(ClientError::Blocked(b))
        }
    }

    /// Statistics, clock, recording, log and status of a completed round trip.
    fn completed(&self, io: &mut Io, text: &str, kind: Kind, ex: &Exchange) {
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
        io.seq += 1;
        if let Some(status_tx) = &io.status_tx {
            status_tx.send_replace(StatusSnapshot {
                status: ex.frame.status.clone(),
                received_at: ex.received_at,
                rtt,
                seq: io.seq,
            });
        }
        *lock(&self.last_exchange) = ex.received_at;
    }

    /// Ends the session: the cause is stored for every caller, the connection closed, the
    /// status subscribers see the end.
    /// Records a request about to be written (when recording).
    fn record_request(&self, kind: Kind, text: &str) {
        if self.common.recorder.is_some() {
            self.common
                .record(Instant::now(), self.id, Dir::Tx, kind.as_str(), None, text);
        }
    }

    /// The outcome of an exchange on the connection held by `io`: a reply is published and
    /// counted; a link error ends the session.
    fn settle(
        &self,
        io: &mut Io,
        text: &str,
        kind: Kind,
        r: Result<Exchange, LinkError>,
    ) -> Result<Exchange, ClientError> {
        match r {
            Ok(ex) => {
                self.completed(io, text, kind, &ex);
                Ok(ex)
            }
            Err(e) => {
                tracing::debug!(session = self.id, kind = kind.as_str(), request = ?text, error = %e, "exchange failed");
                lock(&self.common.stats).stats.requests += 1;
                let e = ClientError::LinkLost(e);
                self.end(io, e.clone());
                Err(e)
            }
        }
    }

    fn end(&self, io: &mut Io, end: ClientError) {
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
        common.record(
            Instant::now(),
            self.id,
            Dir::Event,
            "end",
            None,
            &end.to_string(),
        );
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
    text: Cow<'static, str>,
    kind: Kind,
    motion: Option<MotionTag>,
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
        let r = conn.drive().await;
        // From here on nothing awaits: the exchange is complete whether or not the caller
        // is still there.
        self.settle(r)
    }

    fn settle(&mut self, r: Result<Exchange, LinkError>) -> Result<Exchange, ClientError> {
        let Some(io) = self.io.as_mut() else {
            return Err(self.shared.death());
        };
        let ex = self.shared.settle(io, &self.text, self.kind, r)?;
        if let Some(tag) = self.motion {
            self.shared.last_motion.store(tag.id, Ordering::Relaxed);
        }
        Ok(ex)
    }
}

impl Drop for InFlight {
    fn drop(&mut self) {
        let Some(io) = self.io.take() else { return };
        if io.conn.as_ref().is_none_or(|c| c.flight.is_none()) {
            return;
        }
        let mut rest = InFlight {
            shared: self.shared.clone(),
            io: Some(io),
            text: self.text.clone(),
            kind: self.kind,
            motion: self.motion,
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
    if let Some(tag) = motion {
        if second_poll {
            let gone = CallerGone(&shared.common);
            tokio::task::yield_now().await;
            std::mem::forget(gone);
        }
        if let Err(e) = shared.check_motion(&io, tag) {
            shared.common.refused();
            return Err(e);
        }
    }
    let cfg = &shared.common.config;
    shared.record_request(kind, &text);
    let Some(conn) = io.conn.as_mut() else {
        return Err(shared.death());
    };
    if let Err(e) = conn.begin(text.clone(), cfg.write_timeout, cfg.reply_timeout) {
        let e = ClientError::LinkLost(e);
        shared.end(&mut io, e.clone());
        return Err(e);
    }
    let mut flight = InFlight {
        shared: shared.clone(),
        io: Some(io),
        text,
        kind,
        motion,
        fallback: false,
    };
    let r = flight.run().await;
    let Some(mut io) = flight.io.take() else {
        return Err(shared.death());
    };
    let ex = r?;
    if kind == Kind::Close {
        let limit = cfg.close_timeout;
        if let Some(conn) = io.conn.as_mut() {
            if let Err(e) = conn.await_close(limit).await {
                tracing::warn!(error = %e, "the controller did not close the connection after 255");
            }
        }
        shared.end(&mut io, ClientError::Closed);
    }
    Ok(ex)
}

impl Conn {
    /// After 255: waits for the server to close the connection.
    async fn await_close(&mut self, limit: Duration) -> Result<(), LinkError> {
        let deadline = Instant::now() + limit;
        loop {
            match timeout_at(deadline, self.stream.read(&mut self.buf)).await {
                Err(_) => {
                    return Err(LinkError::ReplyTimeout {
                        request: "end of stream after 255".into(),
                        deadline: limit,
                    })
                }
                Ok(Ok(0)) => return Ok(()),
                Ok(Ok(_)) => {}
                Ok(Err(e)) => return Err(LinkError::io(&e)),
            }
        }
    }
}

/// The session's keeper task: keep-alive polls, queued stops, the polite close when every
/// handle is gone, and — once nothing was exchanged for half a keep-alive period — watching
/// the idle connection for its close or for bytes nobody asked for.
async fn keeper(shared: Arc<SessionShared>, mut rx: mpsc::Receiver<Op>) {
    let period = shared.common.config.keepalive_period;
    let idle_after = period / 2;
    loop {
        if shared.is_dead() {
            break;
        }
        let idle_at = shared.last_exchange() + idle_after;
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
        if io.conn.is_none() {
            break;
        }
        if Instant::now() < shared.last_exchange() + idle_after {
            continue;
        }
        // Idle: hold the connection and watch it until a caller wants it.
        loop {
            let due = shared.last_exchange() + period;
            let Some(conn) = io.conn.as_mut() else {
                return;
            };
            let event = tokio::select! {
                biased;
                r = conn.stream.read(&mut conn.buf) => Event::Read(r),
                () = shared.wanted.notified() => Event::Wanted,
                op = rx.recv() => Event::Op(op),
                () = sleep_until(due) => Event::KeepAlive,
            };
            let step = match event {
                Event::Read(r) => {
                    let r = r
                        .map_err(|e| LinkError::io(&e))
                        .and_then(|n| conn.idle_bytes(n));
                    match r {
                        Ok(()) => ControlFlow::Continue(()),
                        Err(e) => {
                            shared.end(&mut io, ClientError::LinkLost(e));
                            ControlFlow::Break(())
                        }
                    }
                }
                Event::Wanted => break,
                Event::Op(op) => serve(&shared, &mut io, op).await,
                Event::KeepAlive => {
                    if Instant::now() < shared.last_exchange() + period {
                        ControlFlow::Continue(())
                    } else {
                        let r = exchange_in(&shared, &mut io, POLL.into(), Kind::KeepAlive).await;
                        if r.is_err() {
                            ControlFlow::Break(())
                        } else {
                            ControlFlow::Continue(())
                        }
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

enum Event {
    Read(std::io::Result<usize>),
    Wanted,
    Op(Option<Op>),
    KeepAlive,
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
    let cfg = &shared.common.config;
    shared.record_request(kind, &text);
    let Some(conn) = io.conn.as_mut() else {
        return Err(shared.death());
    };
    let r = conn
        .exchange(text.clone(), cfg.write_timeout, cfg.reply_timeout)
        .await;
    shared.settle(io, &text, kind, r)
}
