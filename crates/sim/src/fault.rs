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
pub(crate) struct FaultQueue {
    replies: VecDeque<ReplyFault>,
}

/// Most replies one fault may affect (`count`), and most pending reply faults.
pub const MAX_FAULT_COUNT: u32 = 10_000;
/// Longest delay, gap or reading pause of a fault, milliseconds (10 minutes).
pub const MAX_FAULT_MS: u64 = 600_000;
/// Most bytes of a garbage reply, and most pieces of a split reply.
pub const MAX_FAULT_BYTES: usize = 4096;

impl Fault {
    /// Checks the fault's numbers against the limits ([`MAX_FAULT_COUNT`], [`MAX_FAULT_MS`],
    /// [`MAX_FAULT_BYTES`]), so that a fault cannot exhaust memory or wedge the emulator.
    pub fn validate(&self) -> Result<(), String> {
        let count = |c: u32| {
            if c > MAX_FAULT_COUNT {
                Err(format!("count {c} is above the limit {MAX_FAULT_COUNT}"))
            } else {
                Ok(())
            }
        };
        let ms = |what: &str, v: u64| {
            if v > MAX_FAULT_MS {
                Err(format!("{what} {v} is above the limit {MAX_FAULT_MS} ms"))
            } else {
                Ok(())
            }
        };
        match self {
            Fault::DelayReplies { count: c, delay_ms } => {
                count(*c)?;
                ms("delay_ms", *delay_ms)
            }
            Fault::WithholdReplies { count: c } => count(*c),
            Fault::GarbageReply { text } if text.len() > MAX_FAULT_BYTES => Err(format!(
                "the garbage text is {} bytes, above the limit {MAX_FAULT_BYTES}",
                text.len()
            )),
            Fault::SplitReply { parts, gap_ms } => {
                if *parts < 2 {
                    return Err(format!("parts {parts}: a split reply has at least 2 parts"));
                }
                if *parts as usize > MAX_FAULT_BYTES {
                    return Err(format!(
                        "parts {parts} is above the limit {MAX_FAULT_BYTES}"
                    ));
                }
                ms("gap_ms", *gap_ms)
            }
            Fault::StopReading { duration_ms } => ms("duration_ms", *duration_ms),
            _ => Ok(()),
        }
    }
}

impl FaultQueue {
    /// Queues reply faults for `fault` (other kinds are applied by the controller directly).
    /// The queue never holds more than [`MAX_FAULT_COUNT`] entries; numbers above the limits
    /// are clamped to them.
    pub(crate) fn push(&mut self, fault: &Fault) {
        let room = (MAX_FAULT_COUNT as usize).saturating_sub(self.replies.len());
        let count = |c: &u32| (*c as usize).min(room);
        let ms = |v: &u64| Duration::from_millis((*v).min(MAX_FAULT_MS));
        match fault {
            Fault::DelayReplies { count: c, delay_ms } => {
                for _ in 0..count(c) {
                    self.replies.push_back(ReplyFault::Delay(ms(delay_ms)));
                }
            }
            Fault::WithholdReplies { count: c } => {
                for _ in 0..count(c) {
                    self.replies.push_back(ReplyFault::Withhold);
                }
            }
            _ if room == 0 => {}
            Fault::GarbageReply { text } => {
                let bytes = text.as_bytes();
                self.replies.push_back(ReplyFault::Garbage(
                    bytes[..bytes.len().min(MAX_FAULT_BYTES)].to_vec(),
                ))
            }
            Fault::SplitReply { parts, gap_ms } => self.replies.push_back(ReplyFault::Split {
                parts: (*parts as usize).clamp(2, MAX_FAULT_BYTES),
                gap: ms(gap_ms),
            }),
            Fault::CloseConnection | Fault::StopReading { .. } | Fault::RaiseError { .. } => {}
        }
    }

    /// The fault for the next reply, if any.
    pub(crate) fn next_reply(&mut self) -> Option<ReplyFault> {
        self.replies.pop_front()
    }

    /// Number of reply faults waiting.
    pub(crate) fn pending(&self) -> usize {
        self.replies.len()
    }

    /// Drops all pending faults.
    pub(crate) fn clear(&mut self) {
        self.replies.clear();
    }
}
