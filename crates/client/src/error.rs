//! Typed errors. Every message says what happened and what to do about it.

use std::io;
use std::time::Duration;

use fs020n_kin::{IkError, LimitError};
use fs020n_proto::{DecodeError, EncodeError};

use crate::safety::{self, Blocker, SampleError};
use crate::trajectory::TrajectoryError;

/// Why the link to the controller was lost. After any of these the session is dead: the
/// controller ends it (robot stopped, program ended) and the client never resumes motion by
/// itself.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum LinkError {
    /// No complete reply within the deadline.
    #[error("no reply to {request:?} within {deadline:?}")]
    ReplyTimeout {
        /// The request text.
        request: String,
        /// The reply deadline.
        deadline: Duration,
    },
    /// The request could not be written within the deadline (the controller stopped reading).
    #[error("could not send {request:?} within {deadline:?} (the controller is not reading)")]
    WriteTimeout {
        /// The request text.
        request: String,
        /// The deadline.
        deadline: Duration,
    },
    /// The controller closed the connection (end of stream): after 255, a 5 s receive timeout,
    /// a new session on the controller side, or a restart.
    #[error("the controller closed the connection")]
    Closed,
    /// A socket error (connection reset, broken pipe, ...).
    #[error("socket error ({kind:?}): {message}")]
    Io {
        /// The I/O error kind.
        kind: io::ErrorKind,
        /// The error text.
        message: String,
    },
    /// Bytes that are not a protocol-1040 reply. The stream has no terminator, so it cannot
    /// be resynchronised: the connection is dropped.
    #[error("undecodable reply: {0}")]
    Undecodable(DecodeError),
    /// Bytes arrived that no request asked for (the server sends nothing unsolicited).
    #[error("unsolicited bytes from the controller: {excerpt:?}")]
    Unsolicited {
        /// The bytes, lossily as text (at most 40).
        excerpt: String,
    },
    /// The peer answers, but not as a protocol-1040 server.
    #[error(
        "the peer replied with protocol version {version}, not 1040: is this the robot's port?"
    )]
    NotAController {
        /// Field 1 of its reply.
        version: i64,
    },
    /// The session task ended without recording why (the runtime was shut down).
    #[error("the session task ended (was its tokio runtime shut down?)")]
    SessionEnded,
}

impl LinkError {
    pub(crate) fn io(e: &io::Error) -> LinkError {
        LinkError::Io {
            kind: e.kind(),
            message: e.to_string(),
        }
    }
}

/// Every error of the client. `Clone`, so that one cause can be reported to every waiter.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ClientError {
    /// Connecting failed for the whole connect timeout.
    #[error(
        "could not connect to {target} within {waited:?} ({attempts} attempts; last error: {last}); \
         check that the controller is on and its AS server program runs, that the address and port \
         are right, and that no other client holds the session (the server serves one at a time)"
    )]
    Connect {
        /// What was connected to (e.g. `192.168.0.2:10050`).
        target: String,
        /// Connection attempts made.
        attempts: u32,
        /// Time spent.
        waited: Duration,
        /// The last attempt's error.
        last: String,
    },
    /// The link was lost; the handle is dead.
    #[error(
        "link to the robot lost: {0}; the controller ends the session and stops the robot — \
         reconnect explicitly (Robot::reconnect) and start the program again; motion is never \
         resumed automatically"
    )]
    LinkLost(LinkError),
    /// The session was closed with [`Robot::close`](crate::Robot::close).
    #[error("the session is closed; reconnect (Robot::reconnect) to continue")]
    Closed,
    /// Motion (or starting the program) is blocked by the controller's state.
    #[error("motion is blocked — {}", safety::list(.0))]
    Blocked(Vec<Blocker>),
    /// A motion was stopped by the controller's state while in progress.
    #[error("{during} stopped — {}", safety::list(.blockers))]
    Aborted {
        /// What was in progress ("joint move", "stream").
        during: &'static str,
        /// What stopped it, each with its remedy.
        blockers: Vec<Blocker>,
    },
    /// A joint target outside the model's ranges; nothing was sent.
    #[error("target refused before sending: {0}; choose a target inside the joint range")]
    Limit(LimitError),
    /// A NaN or infinite value; nothing was sent.
    #[error("{what} is not a finite number; refusing to send it")]
    NonFinite {
        /// Which value.
        what: String,
    },
    /// A request that cannot be encoded (too long, out of range); nothing was sent.
    #[error("request refused before sending: {0}")]
    Encode(EncodeError),
    /// A command-7 sample (raw) that could send the robot out of its ranges, or with a
    /// velocity or acceleration above the model's; nothing was sent.
    #[error("command-7 sample refused before sending: {0}")]
    Sample(SampleError),
    /// A speed outside 1–100 %; nothing was sent.
    #[error("speed {percent} % refused: give a speed from 1 to 100 %")]
    Speed {
        /// The requested speed.
        percent: f64,
    },
    /// An invalid trajectory; nothing was sent.
    #[error("trajectory refused before sending: {0}")]
    Trajectory(TrajectoryError),
    /// No inverse-kinematics solution; nothing was sent.
    #[error("no joint solution for the pose: {0}; choose a reachable pose whose joints are inside the ranges")]
    Ik(IkError),
    /// A joint move did not finish in time; it was cancelled (command 5).
    #[error(
        "the move did not reach its target within {timeout:?} ({remaining_deg:.3} deg to go); \
         it was cancelled — check the speed (set_speed) and the robot's surroundings, or give a \
         longer timeout"
    )]
    MoveTimeout {
        /// The timeout.
        timeout: Duration,
        /// Largest per-joint distance to the target when it expired, degrees.
        remaining_deg: f64,
    },
    /// Command 1 was sent but the program did not report running in time.
    #[error(
        "the motion program did not start within {waited:?}{}",
        if .blockers.is_empty() {
            " although no switch blocks it; check the controller's terminal for an AS error".to_string()
        } else {
            format!(" — {}", safety::list(.blockers))
        }
    )]
    StartFailed {
        /// How long the client waited for field 7 to become −1.
        waited: Duration,
        /// Conditions seen in the last status.
        blockers: Vec<Blocker>,
    },
    /// A raw request that is refused.
    #[error("raw request refused: {reason}")]
    RawRefused {
        /// Why.
        reason: String,
    },
    /// Another operation holds the motion channel.
    #[error("busy: {0}")]
    Busy(&'static str),
    /// The operation was cancelled (by [`Robot::cancel`](crate::Robot::cancel), a stop, or a
    /// newer motion).
    #[error("{0}")]
    Cancelled(&'static str),
    /// A stream fell behind by more than the allowed gap; it was cancelled (command 5).
    #[error(
        "stream underrun: {gap:?} between samples (allowed {allowed:?}); the stream was cancelled — \
         lower the sample rate or the load on this computer"
    )]
    StreamUnderrun {
        /// The gap.
        gap: Duration,
        /// The allowed gap.
        allowed: Duration,
    },
    /// The recording file cannot be opened.
    #[error("cannot open the recording file {path}: {message}")]
    Recording {
        /// The path.
        path: String,
        /// The error text.
        message: String,
    },
    /// An invalid configuration value ([`ClientConfig`](crate::ClientConfig), a
    /// [`Completion`](crate::Completion)), or the blocking API used inside an async runtime.
    #[error("invalid configuration: {0}")]
    Config(String),
}

impl From<LinkError> for ClientError {
    fn from(e: LinkError) -> Self {
        ClientError::LinkLost(e)
    }
}

impl From<EncodeError> for ClientError {
    fn from(e: EncodeError) -> Self {
        ClientError::Encode(e)
    }
}

impl From<SampleError> for ClientError {
    fn from(e: SampleError) -> Self {
        ClientError::Sample(e)
    }
}

impl From<LimitError> for ClientError {
    fn from(e: LimitError) -> Self {
        ClientError::Limit(e)
    }
}

impl From<TrajectoryError> for ClientError {
    fn from(e: TrajectoryError) -> Self {
        ClientError::Trajectory(e)
    }
}

impl From<IkError> for ClientError {
    fn from(e: IkError) -> Self {
        ClientError::Ik(e)
    }
}

impl ClientError {
    /// `true` when the session is gone (link lost or closed) and only a reconnect helps.
    pub fn is_link_dead(&self) -> bool {
        matches!(self, ClientError::LinkLost(_) | ClientError::Closed)
    }

    /// The blockers carried by this error, if any.
    pub fn blockers(&self) -> &[Blocker] {
        match self {
            ClientError::Blocked(b)
            | ClientError::Aborted { blockers: b, .. }
            | ClientError::StartFailed { blockers: b, .. } => b,
            _ => &[],
        }
    }
}
