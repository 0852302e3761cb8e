//! The state of one session shared by its handles, its requests and its keeper task; the
//! state that outlives sessions.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

use fs020n_proto::Status;
use tokio::sync::{watch, Notify};
use tokio::time::Instant;

use super::conn::Conn;
use super::core::MotionTag;
use crate::clock::ServerClock;
use crate::config::ClientConfig;
use crate::error::{ClientError, LinkError};
use crate::record::{Dir, Recorder};
use crate::stats::StatsInner;

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
    pub(super) dead: Mutex<Option<ClientError>>,
    pub(crate) clock: Mutex<ServerClock>,
    /// Bumped by every cancel/stop/close: motion validated in an older epoch is not sent.
    pub(crate) epoch: watch::Sender<u64>,
    pub(super) next_motion_id: AtomicU64,
    /// Id of the last motion command written.
    pub(crate) last_motion: AtomicU64,
    /// A stream is running on this session.
    pub(crate) streaming: AtomicBool,
    /// The monitor speed last set by this client, percent (`f64` bits; NaN = unknown).
    pub(super) speed_bits: AtomicU64,
    /// When command 2 was last sent on this session.
    pub(crate) last_stop: Mutex<Option<Instant>>,
    /// The connection: whoever holds it makes the one exchange on the wire.
    pub(super) io: Arc<tokio::sync::Mutex<Io>>,
    /// From when the keeper task watches the idle connection (the core's
    /// [`watch_idle_at`](super::core::SessionCore::watch_idle_at), copied after every reply so that the
    /// keeper can sleep without holding the connection).
    pub(super) idle_watch_at: Mutex<Instant>,
    /// A caller waits for the connection the keeper task holds while the link is idle.
    pub(super) wanted: Notify,
}

impl SessionShared {
    pub(crate) fn death(&self) -> ClientError {
        lock(&self.dead)
            .clone()
            .unwrap_or(ClientError::LinkLost(LinkError::SessionEnded))
    }

    pub(super) fn set_dead(&self, e: ClientError) {
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

/// What the connection mutex guards.
pub(crate) struct Io {
    /// `None` once the session has ended (the connection is closed).
    pub(super) conn: Option<Conn>,
    /// `None` once the session has ended (subscribers see the end).
    pub(super) status_tx: Option<watch::Sender<StatusSnapshot>>,
}

impl std::fmt::Debug for Io {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Io")
            .field("open", &self.conn.is_some())
            .finish()
    }
}
