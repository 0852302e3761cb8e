//! What the session core is asked to send, and how it refuses.

use std::borrow::Cow;
use std::time::Duration;

use crate::error::{Cancellation, ClientError, LinkError};
use crate::safety::Blocker;

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
    pub(crate) fn as_str(self) -> &'static str {
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

/// A request as the session core handles it: its text on the wire, its kind, its motion tag.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct WireRequest {
    pub(crate) kind: Kind,
    /// The request's text, written as it is.
    pub(crate) text: Cow<'static, str>,
    /// For a motion: the epoch it was validated in. `Some` makes the motion checks apply.
    pub(crate) motion: Option<MotionTag>,
    /// This request's reply timeout instead of the session's (the connect poll's, cut to what
    /// is left of the connect timeout).
    pub(crate) reply_timeout: Option<Duration>,
}

impl WireRequest {
    pub(crate) fn new(
        kind: Kind,
        text: Cow<'static, str>,
        motion: Option<MotionTag>,
    ) -> WireRequest {
        WireRequest {
            kind,
            text,
            motion,
            reply_timeout: None,
        }
    }

    pub(crate) fn with_reply_timeout(mut self, reply_timeout: Duration) -> WireRequest {
        self.reply_timeout = Some(reply_timeout);
        self
    }
}

/// The timeouts the core enforces.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Timeouts {
    /// From the start of a request to the end of its flush.
    pub(crate) write: Duration,
    /// From the start of a request to its complete reply.
    pub(crate) reply: Duration,
    /// Nothing exchanged for this long: a keep-alive poll is due.
    pub(crate) keepalive_period: Duration,
    /// After the reply to 255: how long the server has to close the connection.
    pub(crate) close: Duration,
}

/// Why [`SessionCore::begin_request`](super::SessionCore::begin_request) sent nothing.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Refusal {
    /// Lock-step: a request is in flight.
    InFlight,
    /// 255 was answered; the session waits for the server to close the connection.
    Closing,
    /// The session has ended (the cause).
    Ended(ClientError),
    /// A motion validated before a cancel or stop (an older motion epoch).
    StaleEpoch,
    /// A motion while the latest status blocks motion.
    Blocked(Vec<Blocker>),
}

impl Refusal {
    /// The error a caller gets.
    pub(crate) fn into_error(self) -> ClientError {
        match self {
            // The driver's FIFO lock never lets a second request reach the core while one is
            // in flight; should it ever, nothing is sent and the caller learns it cannot be.
            Refusal::InFlight => ClientError::LinkLost(LinkError::SessionEnded),
            Refusal::Closing => ClientError::Closed,
            Refusal::Ended(cause) => cause,
            Refusal::StaleEpoch => Cancellation::NotSent.into(),
            Refusal::Blocked(b) => ClientError::Blocked(b),
        }
    }

    /// `true` for the checks of the request itself (counted as refused before sending).
    pub(crate) fn is_check(&self) -> bool {
        matches!(self, Refusal::StaleEpoch | Refusal::Blocked(_))
    }
}
