//! Typed errors. Every message says what happened and what to do about it.

use std::io;
use std::time::Duration;

use fs020n_kin::{IkError, LimitError};
use fs020n_proto::{DecodeError, EncodeError};

use crate::display::Rounded;
use crate::safety::{self, Blocker, SampleError};
use crate::trajectory::TrajectoryError;

/// Why the link to the controller was lost. After any of these the session is dead: the
/// controller ends it (robot stopped, program ended) and the client never resumes motion by
/// itself.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum LinkError {
    /// No complete reply within the deadline.
    #[error("no reply to {request:?} within {}", Rounded(*.deadline))]
    ReplyTimeout {
        /// The request text.
        request: String,
        /// The reply deadline.
        deadline: Duration,
    },
    /// The request could not be written within the deadline (the controller stopped reading).
    #[error("could not send {request:?} within {} (the controller is not reading)", Rounded(*.deadline))]
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

/// Why a motion was not sent, or stopped being followed: it was cancelled or replaced.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum Cancellation {
    /// A cancel, stop or close was requested after the motion was checked and before it was
    /// sent: nothing was sent.
    #[error("not sent: a cancel, stop or close was requested after it was checked")]
    NotSent,
    /// The motion was cancelled (a cancel, stop or close was requested) while it ran.
    #[error("the motion was cancelled (a cancel, stop or close was requested)")]
    Cancelled,
    /// A newer motion command replaced it (the controller follows only the newest).
    #[error("the motion was superseded by a newer motion command")]
    Superseded,
    /// A servo was stopped by its user ([`ServoHandle::stop`](crate::ServoHandle::stop) or a
    /// dropped handle): the arm was stopped for sure (commands 5 then 2).
    #[error("the servo was stopped (ServoHandle::stop; the motion program was stopped too); start it again (Robot::start) and open a new servo to move again")]
    ServoStopped,
    /// A servo's watchdog fired: no sample was pushed within its watchdog time, and the arm was
    /// stopped ([`WatchdogAction`](crate::WatchdogAction)).
    #[error("the servo's watchdog fired: no sample was pushed within its watchdog time, so the arm was stopped (commands 5 and 2 unless the servo was opened to brake only); start the program again if it was stopped (Robot::start) and open a new servo, pushing at least once per watchdog period")]
    ServoWatchdog,
}

/// What holds the motion channel when a request is refused as [`ClientError::Busy`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum Activity {
    /// A stream ([`Robot::stream`](crate::Robot::stream)) is running.
    #[error("a stream is running; cancel it first (StreamHandle::cancel or Robot::cancel)")]
    Stream,
    /// A servo ([`Robot::servo`](crate::Robot::servo)) is running.
    #[error("a servo is running; stop it first (ServoHandle::stop or Robot::cancel)")]
    Servo,
}

/// Why [`Robot::send_raw`](crate::Robot::send_raw) refuses a text; nothing was sent.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum RawRefusal {
    /// The text is empty.
    #[error("the request is empty")]
    Empty,
    /// Longer than the controller reads.
    #[error("the request is {bytes} bytes; the controller reads only the first {max}")]
    TooLong {
        /// Its length.
        bytes: usize,
        /// What the controller reads.
        max: usize,
    },
    /// Control characters or non-ASCII text.
    #[error("only printable ASCII and blanks are allowed (the protocol has no terminator)")]
    NotPrintable,
    /// A command the controller would execute as a motion (1040 6 or 1040 7, read with the
    /// controller's own parsing).
    #[error("{text:?} is a motion command (the controller would move the robot); pass allow_motion to send it")]
    Motion {
        /// The text.
        text: String,
    },
}

/// Every error of the client. `Clone`, so that one cause can be reported to every waiter.
///
/// The message (`Display`) is complete: what happened and what to do. Errors that wrap a more
/// specific one also return it as their [`source`](std::error::Error::source), for programs
/// that match on it; a report that prints the whole chain repeats that part.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ClientError {
    /// Connecting failed for the whole connect timeout.
    #[error(
        "could not connect to {target} within {} ({attempts} attempts; last error: {last}); \
         check that the controller is on and its AS server program runs, that the address and port \
         are right, and that no other client holds the session (the server serves one at a time)",
        Rounded(*.waited)
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
    /// The address cannot be used at all (the name does not resolve, or it is malformed):
    /// retrying cannot help, so the client did not.
    #[error("cannot connect to {target}: {message}; check the host name and port, or give an IP address")]
    Address {
        /// The address as given.
        target: String,
        /// Why.
        message: String,
    },
    /// Something answers at the address, but not as a protocol-1040 server (an HTTP server, a
    /// wrong port): retrying cannot help, so the client did not.
    #[error("{target} is not a protocol-1040 server: {cause}; check the address and port (the robot's is 10050 unless configured otherwise)")]
    NotAController {
        /// The address.
        target: String,
        /// What the peer did.
        #[source]
        cause: LinkError,
    },
    /// The link was lost; the handle is dead.
    #[error(
        "link to the robot lost: {0}; the controller ends the session and stops the robot — \
         reconnect explicitly (Robot::reconnect) and start the program again; motion is never \
         resumed automatically"
    )]
    LinkLost(#[from] LinkError),
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
    /// A motion stayed paused by HOLD for longer than its hold timeout
    /// ([`Completion::hold_timeout`](crate::Completion::hold_timeout),
    /// [`StreamOptions::hold_timeout`](crate::StreamOptions::hold_timeout)); it was cancelled
    /// (commands 5 then 2).
    #[error(
        "the {during} was held (RUN/HOLD on HOLD) for {}, longer than its hold timeout; it was \
         cancelled — switch RUN/HOLD to RUN and move again",
        Rounded(*.waited)
    )]
    HoldTimeout {
        /// What was held ("joint move", "stream").
        during: &'static str,
        /// How long it was held.
        waited: Duration,
    },
    /// A joint target outside the model's ranges; nothing was sent.
    #[error("target refused before sending: {0}; choose a target inside the joint range")]
    Limit(#[from] LimitError),
    /// A NaN or infinite value; nothing was sent.
    #[error("{what} is not a finite number; refusing to send it")]
    NonFinite {
        /// Which value.
        what: String,
    },
    /// A request that cannot be encoded (too long, out of range); nothing was sent.
    #[error("request refused before sending: {0}")]
    Encode(#[from] EncodeError),
    /// A command-7 sample (raw) that could send the robot out of its ranges, or with a
    /// velocity or acceleration above the model's; nothing was sent.
    #[error("command-7 sample refused before sending: {0}")]
    Sample(#[from] SampleError),
    /// A speed outside 1–100 %; nothing was sent.
    #[error("speed {percent} % refused: give a speed from 1 to 100 %")]
    Speed {
        /// The requested speed.
        percent: f64,
    },
    /// An invalid trajectory or stream option; nothing was sent.
    #[error("trajectory refused before sending: {0}")]
    Trajectory(#[from] TrajectoryError),
    /// No inverse-kinematics solution; nothing was sent.
    #[error("no joint solution for the pose: {0}; choose a reachable pose whose joints are inside the ranges")]
    Ik(#[from] IkError),
    /// A joint move did not finish in time; it was cancelled (commands 5 then 2).
    #[error(
        "the move did not reach its target within {} ({remaining_deg:.3} deg to go); \
         it was cancelled — check the speed (set_speed) and the robot's surroundings, or give a \
         longer timeout",
        Rounded(*.timeout)
    )]
    MoveTimeout {
        /// The timeout.
        timeout: Duration,
        /// Largest per-joint distance to the target when it expired, degrees.
        remaining_deg: f64,
    },
    /// Command 1 was sent but the program did not report running in time.
    #[error(
        "the motion program did not start within {}{}",
        Rounded(*.waited),
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
    /// A raw request that is refused; nothing was sent.
    #[error("raw request refused: {0}")]
    RawRefused(#[source] RawRefusal),
    /// Another operation holds the motion channel; nothing was sent.
    #[error("busy: {0}")]
    Busy(#[source] Activity),
    /// The motion was cancelled, superseded, or not sent because a cancel came first.
    #[error("{0}")]
    Cancelled(#[source] Cancellation),
    /// A stream fell behind by more than the allowed gap; it was cancelled (commands 5 then 2).
    #[error(
        "stream underrun: {} between samples (allowed {}); the stream was cancelled — \
         lower the sample rate or the load on this computer",
        Rounded(*.gap), Rounded(*.allowed)
    )]
    StreamUnderrun {
        /// The gap.
        gap: Duration,
        /// The allowed gap.
        allowed: Duration,
    },
    /// No reply carried TIMER(1) (it shows asterisks after 11.6 days of one session), so
    /// command-7 samples cannot be stamped.
    #[error(
        "no estimate of the controller's clock: no reply carried TIMER(1) (it overflows after \
         11.6 days of one session); reconnect, or stream with waypoints (command 6)"
    )]
    NoServerClock,
    /// The recording file cannot be opened.
    #[error("cannot open the recording file {path}: {message}")]
    Recording {
        /// The path.
        path: String,
        /// The error text.
        message: String,
    },
    /// An invalid configuration value ([`ClientConfig`](crate::ClientConfig), a
    /// [`Completion`](crate::Completion)).
    #[error("invalid configuration: {0}")]
    Config(String),
    /// The blocking API was called inside an async runtime, where blocking is not allowed.
    #[error(
        "the blocking client cannot be used inside an async runtime (blocking there is not \
         allowed); use fs020n_client::Robot, the async API, instead"
    )]
    InsideAsyncRuntime,
}

impl From<Cancellation> for ClientError {
    fn from(c: Cancellation) -> Self {
        ClientError::Cancelled(c)
    }
}

/// What kind of failure a [`ClientError`] is: the one classification every face maps — the
/// command line to its exit codes, the Python package to its exception classes, the ROS 2 node
/// and the hub to their results. The remedies stay per face (each names its own actions); the
/// kind says only which family of failure it is.
///
/// | kind | CLI exit code | Python exception |
/// |---|---|---|
/// | [`Refused`](ErrorKind::Refused) | 2 | `LimitError` |
/// | [`NotReady`](ErrorKind::NotReady) | 4 | `NotReadyError` |
/// | [`Connect`](ErrorKind::Connect) | 3 | `ConnectError` |
/// | [`LinkLost`](ErrorKind::LinkLost) | 3 | `LinkLostError` |
/// | [`Motion`](ErrorKind::Motion) | 5 | `MotionError` |
/// | [`MoveTimeout`](ErrorKind::MoveTimeout) | 5 | `MoveTimeoutError` |
/// | [`Busy`](ErrorKind::Busy) | 5 | `BusyError` |
/// | [`Cancelled`](ErrorKind::Cancelled) | 5 | `Error` |
/// | [`Other`](ErrorKind::Other) | 1 | `Error` |
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum ErrorKind {
    /// A value, trajectory, raw text or configuration refused by a check: nothing was sent.
    Refused,
    /// The controller's state blocks motion (a switch, an error), or the program did not
    /// start: nothing moved.
    NotReady,
    /// The controller could not be reached, or the peer is not a protocol-1040 server.
    Connect,
    /// The link was lost or the session closed: only a reconnect helps.
    LinkLost,
    /// A motion was stopped by the controller's state, a stream fell behind, or streaming
    /// has no clock estimate.
    Motion,
    /// A motion did not finish in time, or stayed on HOLD beyond its hold timeout.
    MoveTimeout,
    /// Another operation holds the motion channel: nothing was sent.
    Busy,
    /// A motion was cancelled or superseded on request.
    Cancelled,
    /// Anything else (a recording file, the blocking API inside a runtime).
    Other,
}

impl ClientError {
    /// The kind of failure: the one classification the faces map to exit codes and
    /// exception classes ([`ErrorKind`]).
    pub fn kind(&self) -> ErrorKind {
        match self {
            ClientError::Limit(_)
            | ClientError::NonFinite { .. }
            | ClientError::Encode(_)
            | ClientError::Sample(_)
            | ClientError::Speed { .. }
            | ClientError::Trajectory(_)
            | ClientError::Ik(_)
            | ClientError::RawRefused(_)
            | ClientError::Config(_) => ErrorKind::Refused,
            ClientError::Blocked(_) | ClientError::StartFailed { .. } => ErrorKind::NotReady,
            ClientError::Connect { .. }
            | ClientError::Address { .. }
            | ClientError::NotAController { .. } => ErrorKind::Connect,
            ClientError::LinkLost(_) | ClientError::Closed => ErrorKind::LinkLost,
            ClientError::Aborted { .. }
            | ClientError::StreamUnderrun { .. }
            | ClientError::NoServerClock => ErrorKind::Motion,
            ClientError::MoveTimeout { .. } | ClientError::HoldTimeout { .. } => {
                ErrorKind::MoveTimeout
            }
            ClientError::Busy(_) => ErrorKind::Busy,
            ClientError::Cancelled(_) => ErrorKind::Cancelled,
            ClientError::Recording { .. } | ClientError::InsideAsyncRuntime => ErrorKind::Other,
        }
    }

    /// `true` when the session is gone (link lost or closed) and only a reconnect helps.
    pub fn is_link_dead(&self) -> bool {
        self.kind() == ErrorKind::LinkLost
    }

    /// `true` when nothing was sent because the request was refused by a check before sending
    /// (a value, a trajectory, a raw text, a configuration, a blocked status, a busy channel,
    /// a cancel that came first).
    pub fn refused_before_sending(&self) -> bool {
        match self.kind() {
            ErrorKind::Refused | ErrorKind::Busy => true,
            ErrorKind::NotReady => matches!(self, ClientError::Blocked(_)),
            ErrorKind::Cancelled => matches!(self, ClientError::Cancelled(Cancellation::NotSent)),
            _ => false,
        }
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

#[cfg(test)]
mod tests {
    use super::*;
    use std::error::Error as _;

    #[test]
    fn durations_are_rounded_in_messages() {
        assert_eq!(
            Rounded(Duration::from_nanos(9_983_816_934)).to_string(),
            "10.0 s"
        );
        assert_eq!(Rounded(Duration::from_millis(250)).to_string(), "250 ms");
        let e = ClientError::Connect {
            target: "x:1".into(),
            attempts: 3,
            waited: Duration::from_nanos(9_983_816_934),
            last: "refused".into(),
        };
        assert!(e.to_string().contains("within 10.0 s (3 attempts"), "{e}");
    }

    #[test]
    fn wrapped_causes_are_sources() {
        let e = ClientError::from(LinkError::Closed);
        assert_eq!(
            e.source().map(ToString::to_string),
            Some(LinkError::Closed.to_string())
        );
        let e = ClientError::RawRefused(RawRefusal::Empty);
        assert!(e
            .source()
            .is_some_and(|s| s.downcast_ref::<RawRefusal>().is_some()));
        let e = ClientError::from(Cancellation::Superseded);
        assert!(e.to_string().contains("superseded"));
        assert!(e.source().is_some());
    }

    #[test]
    fn every_refusal_is_one_kind_and_counts_as_refused_before_sending() {
        let refused = [
            ClientError::Speed { percent: 0.0 },
            ClientError::NonFinite { what: "x".into() },
            ClientError::RawRefused(RawRefusal::Empty),
            ClientError::Config("x".into()),
        ];
        for e in refused {
            assert_eq!(e.kind(), ErrorKind::Refused, "{e}");
            assert!(e.refused_before_sending(), "{e}");
        }
        let busy = ClientError::Busy(Activity::Servo);
        assert_eq!(busy.kind(), ErrorKind::Busy);
        assert!(busy.refused_before_sending());
        let blocked = ClientError::Blocked(vec![]);
        assert_eq!(blocked.kind(), ErrorKind::NotReady);
        assert!(blocked.refused_before_sending());
    }

    #[test]
    fn a_start_that_was_sent_or_a_running_motion_is_not_refused_before_sending() {
        let started = ClientError::StartFailed {
            waited: Duration::from_secs(3),
            blockers: vec![],
        };
        assert_eq!(started.kind(), ErrorKind::NotReady);
        assert!(!started.refused_before_sending());
        let cancelled = ClientError::from(Cancellation::Cancelled);
        assert_eq!(cancelled.kind(), ErrorKind::Cancelled);
        assert!(!cancelled.refused_before_sending());
        assert!(ClientError::from(Cancellation::NotSent).refused_before_sending());
        let lost = ClientError::from(LinkError::Closed);
        assert_eq!(lost.kind(), ErrorKind::LinkLost);
        assert!(lost.is_link_dead() && !lost.refused_before_sending());
        assert_eq!(ClientError::NoServerClock.kind(), ErrorKind::Motion);
        assert_eq!(
            ClientError::HoldTimeout {
                during: "stream",
                waited: Duration::from_secs(1)
            }
            .kind(),
            ErrorKind::MoveTimeout
        );
    }
}
