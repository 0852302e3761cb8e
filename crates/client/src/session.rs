//! The session task: the single owner of the connection.
//!
//! Every request goes through one task that writes it in one `write`, waits for the complete
//! reply (strict lock-step, deadline per request), publishes the status, feeds the clock
//! estimator, the statistics and the recording, and sends keep-alive polls (`0 0 0`) whenever
//! no request was made for a keep-alive period. The first failure of the link kills the
//! session: the cause is stored, every waiter gets it, and the task ends (dropping the
//! connection). Nothing is ever retried or resumed.

use std::borrow::Cow;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

use fs020n_proto::{Command, ReplyDecoder, ReplyFrame, Request, Status, PROTOCOL_VERSION};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::sync::{mpsc, oneshot, watch};
use tokio::time::{sleep_until, timeout, timeout_at, Instant};

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

struct Op {
    text: Cow<'static, str>,
    kind: Kind,
    motion: Option<MotionTag>,
    reply: oneshot::Sender<Result<Exchange, ClientError>>,
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
#[derive(Debug, Clone)]
pub(crate) struct Link {
    tx: mpsc::Sender<Op>,
    pub(crate) status: watch::Receiver<StatusSnapshot>,
    pub(crate) shared: Arc<SessionShared>,
}

impl Link {
    /// One round trip through the session task.
    pub(crate) async fn exchange(
        &self,
        text: impl Into<Cow<'static, str>>,
        kind: Kind,
        motion: Option<MotionTag>,
    ) -> Result<Exchange, ClientError> {
        let (reply, rx) = oneshot::channel();
        self.tx
            .send(Op {
                text: text.into(),
                kind,
                motion,
                reply,
            })
            .await
            .map_err(|_| self.shared.death())?;
        rx.await.map_err(|_| self.shared.death())?
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
    /// await): queues commands 5 and 2 (in this order: the queue is FIFO).
    pub(crate) fn halt_detached(&self) {
        self.shared.bump_epoch();
        *lock(&self.shared.last_stop) = Some(Instant::now());
        for command in [Command::CancelMotion, Command::StopProgram] {
            let Ok(text) = Request::new(command).encode() else {
                return;
            };
            let (reply, _) = oneshot::channel();
            let op = Op {
                text: text.into(),
                kind: Kind::Command,
                motion: None,
                reply,
            };
            if let Err(e) = self.tx.try_send(op) {
                tracing::warn!(error = %e, "could not queue the stop of a dropped motion handle");
                return;
            }
        }
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

/// The connection with its decoder.
struct Conn {
    stream: BoxedStream,
    decoder: ReplyDecoder,
    buf: Vec<u8>,
}

impl Conn {
    fn new(stream: BoxedStream) -> Conn {
        Conn {
            stream,
            decoder: ReplyDecoder::new(),
            buf: vec![0; 1024],
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
        text: &str,
        write_timeout: Duration,
        reply_timeout: Duration,
    ) -> Result<Exchange, LinkError> {
        if let Some(e) = self.unsolicited() {
            return Err(e);
        }
        let sent_at = Instant::now();
        let deadline = sent_at + reply_timeout;
        let write = async {
            self.stream.write_all(text.as_bytes()).await?;
            self.stream.flush().await
        };
        match timeout(write_timeout, write).await {
            Err(_) => {
                return Err(LinkError::WriteTimeout {
                    request: text.to_owned(),
                    deadline: write_timeout,
                })
            }
            Ok(Err(e)) => return Err(LinkError::io(&e)),
            Ok(Ok(())) => {}
        }
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
                    return Err(LinkError::ReplyTimeout {
                        request: text.to_owned(),
                        deadline: reply_timeout,
                    })
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
/// first status poll and starts the session task.
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
                match conn.exchange(POLL, cfg.write_timeout, reply_timeout).await {
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
    let task = Task {
        conn,
        rx,
        status_tx,
        shared: shared.clone(),
        last_exchange: first.received_at,
        seq: 0,
    };
    tokio::spawn(task.run());
    Link {
        tx,
        status: status_rx,
        shared,
    }
}

struct Task {
    conn: Conn,
    rx: mpsc::Receiver<Op>,
    status_tx: watch::Sender<StatusSnapshot>,
    shared: Arc<SessionShared>,
    last_exchange: Instant,
    seq: u64,
}

enum Event {
    Read(std::io::Result<usize>),
    Op(Option<Op>),
    KeepAlive,
}

impl Task {
    async fn run(mut self) {
        let cfg = self.shared.common.config.clone();
        let keepalive = sleep_until(self.last_exchange + cfg.keepalive_period);
        tokio::pin!(keepalive);
        let end = loop {
            let event = tokio::select! {
                biased;
                r = self.conn.stream.read(&mut self.conn.buf) => Event::Read(r),
                op = self.rx.recv() => Event::Op(op),
                _ = &mut keepalive => Event::KeepAlive,
            };
            match event {
                Event::Read(Ok(n)) => {
                    if let Err(e) = self.conn.idle_bytes(n) {
                        break ClientError::LinkLost(e);
                    }
                }
                Event::Read(Err(e)) => break ClientError::LinkLost(LinkError::io(&e)),
                Event::KeepAlive => {
                    // The timer is re-armed only when it fires (cheaper than on every request):
                    // poll only if nothing was exchanged for a whole period.
                    let due = self.last_exchange + cfg.keepalive_period;
                    if Instant::now() < due {
                        keepalive.as_mut().reset(due);
                        continue;
                    }
                    if let Err(e) = self.round_trip(POLL, Kind::KeepAlive, &cfg).await {
                        break e;
                    }
                    keepalive
                        .as_mut()
                        .reset(self.last_exchange + cfg.keepalive_period);
                }
                Event::Op(None) => {
                    // Every handle is gone: end the session politely.
                    let text = "1040 255 0";
                    let _ = self.round_trip(text, Kind::Close, &cfg).await;
                    break ClientError::Closed;
                }
                Event::Op(Some(op)) => {
                    if let Some(stop) = self.handle(op, &cfg).await {
                        break stop;
                    }
                }
            }
        };
        self.finish(end);
    }

    /// Handles one request; `Some(cause)` ends the session.
    async fn handle(&mut self, op: Op, cfg: &ClientConfig) -> Option<ClientError> {
        if let Some(tag) = op.motion {
            // Nobody waits for this motion any more (its future was dropped, e.g. by a
            // timeout): nobody would learn that it was sent, nor watch or cancel it.
            if op.reply.is_closed() {
                self.shared.common.refused();
                tracing::debug!(request = %op.text, "motion not sent: its caller is gone");
                return None;
            }
            if let Err(e) = self.check_motion(tag) {
                self.shared.common.refused();
                let _ = op.reply.send(Err(e));
                return None;
            }
        }
        match self.round_trip(&op.text, op.kind, cfg).await {
            Ok(ex) => {
                if let Some(tag) = op.motion {
                    self.shared.last_motion.store(tag.id, Ordering::Relaxed);
                }
                if op.kind == Kind::Close {
                    let waited = self.await_close(cfg.close_timeout).await;
                    let _ = op.reply.send(Ok(ex));
                    if let Err(e) = waited {
                        tracing::warn!(error = %e, "the controller did not close the connection after 255");
                    }
                    return Some(ClientError::Closed);
                }
                let _ = op.reply.send(Ok(ex));
                None
            }
            Err(e) => {
                let _ = op.reply.send(Err(e.clone()));
                Some(e)
            }
        }
    }

    /// A motion is sent only if no cancel/stop came after it was validated and the latest
    /// status allows motion.
    fn check_motion(&self, tag: MotionTag) -> Result<(), ClientError> {
        if tag.epoch != self.shared.current_epoch() {
            return Err(Cancellation::NotSent.into());
        }
        let b = blockers(&self.status_tx.borrow().status, true);
        if b.is_empty() {
            Ok(())
        } else {
            Err(ClientError::Blocked(b))
        }
    }

    async fn round_trip(
        &mut self,
        text: &str,
        kind: Kind,
        cfg: &ClientConfig,
    ) -> Result<Exchange, ClientError> {
        let common = &self.shared.common;
        let id = self.shared.id;
        if common.recorder.is_some() {
            common.record(Instant::now(), id, Dir::Tx, kind.as_str(), None, text);
        }
        let r = self
            .conn
            .exchange(text, cfg.write_timeout, cfg.reply_timeout)
            .await;
        match r {
            Ok(ex) => {
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
                    lock(&self.shared.clock).add(ex.sent_at, ex.received_at, t);
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
                self.seq += 1;
                self.status_tx.send_replace(StatusSnapshot {
                    status: ex.frame.status.clone(),
                    received_at: ex.received_at,
                    rtt,
                    seq: self.seq,
                });
                self.last_exchange = ex.received_at;
                Ok(ex)
            }
            Err(e) => {
                tracing::debug!(session = id, kind = kind.as_str(), request = ?text, error = %e, "exchange failed");
                lock(&common.stats).stats.requests += 1;
                Err(ClientError::LinkLost(e))
            }
        }
    }

    /// After 255: waits for the server to close the connection.
    async fn await_close(&mut self, limit: Duration) -> Result<(), LinkError> {
        let deadline = Instant::now() + limit;
        loop {
            match timeout_at(deadline, self.conn.stream.read(&mut self.conn.buf)).await {
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

    fn finish(mut self, end: ClientError) {
        let common = self.shared.common.clone();
        let now = Instant::now();
        if end != ClientError::Closed {
            lock(&common.stats).stats.links_lost += 1;
            // The cause is returned to every caller; this is only a trace for the logs.
            tracing::info!(session = self.shared.id, error = %end, "link lost");
        } else {
            tracing::info!(session = self.shared.id, "session closed");
        }
        common.record(
            now,
            self.shared.id,
            Dir::Event,
            "end",
            None,
            &end.to_string(),
        );
        // Record the cause before the queued requests see their channels close.
        self.shared.set_dead(end.clone());
        self.rx.close();
        while let Ok(op) = self.rx.try_recv() {
            let _ = op.reply.send(Err(end.clone()));
        }
        // Dropping `self` drops the connection and the status sender: subscribers see the end.
    }
}
