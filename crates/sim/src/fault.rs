//! Fault injection: what the emulator can do wrong on purpose, for tests and for users
//! rehearsing failures.

use std::collections::VecDeque;
use std::time::Duration;

use fs020n_proto::ErrorCode;
use serde::{Deserialize, Serialize};

/// A fault to inject. Reply faults apply to the next replies, in the order injected.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Fault {
    /// Delay each of the next `count` replies by `delay_ms`.
    DelayReplies {
        /// How many replies.
        count: u32,
        /// Delay in milliseconds.
        delay_ms: u64,
    },
    /// Do not send the next `count` replies (the requests still take effect).
    WithholdReplies {
        /// How many replies.
        count: u32,
    },
    /// Replace the next reply by these bytes.
    GarbageReply {
        /// The bytes sent instead (as text).
        text: String,
    },
    /// Send the next reply in `parts` writes, `gap_ms` apart.
    SplitReply {
        /// Number of pieces (≥ 2).
        parts: u32,
        /// Pause between pieces, milliseconds.
        gap_ms: u64,
    },
    /// Close the connection at once (the session ends as after a communication error).
    CloseConnection,
    /// Stop reading from the connection for `duration_ms` (the client's writes stall once the
    /// buffers fill; the 5 s receive timeout keeps running).
    StopReading {
        /// How long, milliseconds.
        duration_ms: u64,
    },
    /// Raise a controller error (e.g. `E1130`): the robot brakes and the program stops.
    RaiseError {
        /// The error code.
        code: ErrorCode,
    },
}

/// What to do with one reply.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ReplyFault {
    /// Send it after this delay.
    Delay(Duration),
    /// Do not send it.
    Withhold,
    /// Send these bytes instead.
    Garbage(Vec<u8>),
    /// Send it in this many pieces with this pause between them.
    Split {
        /// Number of pieces.
        parts: usize,
        /// Pause between pieces.
        gap: Duration,
    },
}

/// Pending reply faults.
#[derive(Debug, Clone, Default)]
pub struct FaultQueue {
    replies: VecDeque<ReplyFault>,
}

impl FaultQueue {
    /// Queues reply faults for `fault` (other kinds are applied by the controller directly).
    pub(crate) fn push(&mut self, fault: &Fault) {
        match fault {
            Fault::DelayReplies { count, delay_ms } => {
                for _ in 0..*count {
                    self.replies
                        .push_back(ReplyFault::Delay(Duration::from_millis(*delay_ms)));
                }
            }
            Fault::WithholdReplies { count } => {
                for _ in 0..*count {
                    self.replies.push_back(ReplyFault::Withhold);
                }
            }
            Fault::GarbageReply { text } => self
                .replies
                .push_back(ReplyFault::Garbage(text.as_bytes().to_vec())),
            Fault::SplitReply { parts, gap_ms } => self.replies.push_back(ReplyFault::Split {
                parts: (*parts as usize).max(2),
                gap: Duration::from_millis(*gap_ms),
            }),
            Fault::CloseConnection | Fault::StopReading { .. } | Fault::RaiseError { .. } => {}
        }
    }

    /// The fault for the next reply, if any.
    pub(crate) fn next_reply(&mut self) -> Option<ReplyFault> {
        self.replies.pop_front()
    }

    /// Number of reply faults waiting.
    pub fn pending(&self) -> usize {
        self.replies.len()
    }

    /// Drops all pending faults.
    pub fn clear(&mut self) {
        self.replies.clear();
    }
}
