//! # fs020n-proto
//!
//! The sans-IO core of protocol 1040, the TCP text protocol spoken by the AS server program on a
//! Kawasaki FS020N controller. No sockets, no clocks: only types, exact encoders and tolerant
//! decoders, shared by the client (`fs020n-client`) and the emulator (`fs020n-sim`).
//!
//! * [`Request`] / [`Command`] — what the PC sends, encoded exactly ([`Request::encode`]).
//! * [`Status`] — the reply, encoded as the controller formats it and decoded tolerantly;
//!   [`ReplyDecoder`] decodes a byte stream split anywhere.
//! * [`ServerRequest`] — how the controller parses a request (`VAL` semantics).
//! * [`ErrorCode`] — AS error numbers (−31088 ↔ `E1088`) with messages.
//! * The session's timing and size rules as constants ([`RECEIVE_TIMEOUT`], [`ACCEPT_WINDOW`],
//!   [`MAX_REQUEST_BYTES`], …).
//! * [`format`](mod@format) — every AS print format (`/D`, `/Fm.n`, `/Em.n`, …) for `PRINT`/`$ENCODE`.
//! * [`number`] — AS numbers: `VAL`, request numbers, the reply's `/F10.3`.
//!
//! The modules are private but for the two namespaces `format` and `number`: every other item
//! is exported once, here.
//! * [`JointsDeg`] / [`JointsRad`] — joint vectors with the unit in the type.
//!
//! ```
//! use fs020n_proto::{Command, JointsDeg, Request, ReplyDecoder};
//! let bytes = Request::new(Command::SetSpeed { percent: 20.0 }).encode().unwrap();
//! assert_eq!(bytes, "1040 3 1 20");
//! let mut decoder = ReplyDecoder::new();
//! decoder.push(b" 1040 0 -1 -1 0 -1 0     0.105     0.000     0.000   -90.000     0.000   -90.000     0.000 ").unwrap();
//! let reply = decoder.next_reply().unwrap().expect("complete");
//! assert_eq!(reply.status.joints, JointsDeg::new([0.0, 0.0, -90.0, 0.0, -90.0, 0.0]));
//! ```
#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod decoder;
mod error;
mod error_code;
pub mod format;
mod joints;
pub mod number;
mod reply;
mod request;
mod rules;
mod server;

pub use decoder::{ReplyDecoder, ReplyFrame, MAX_BUFFERED};
pub use error::{DecodeError, EncodeError};
pub use error_code::{ErrorClass, ErrorCode};
pub use joints::{JointsDeg, JointsRad, JOINT_COUNT};
pub use reply::{
    ReplyEncoder, Status, Timer, REPLY_FIELDS, TIMER_COARSE_AFTER_S, TIMER_WIRE_STEP_S,
};
pub use request::{Command, Request, StreamSample};
pub use rules::{
    ACCEPT_WINDOW, ACCURACY_MM, AS_FALSE, AS_TRUE, COMMAND_RING_LEN, DEFAULT_PORT,
    MAX_REQUEST_BYTES, PROTOCOL_VERSION, RECEIVE_TIMEOUT, SEND_TIMEOUT,
    SINGULAR_JMOVE_SPEED_PERCENT, SINGULAR_ZONE_DEG, STEP_AVERAGE_WEIGHT, STREAM_LMOVE_TIME_S,
};
pub use server::{server_tokens, ServerRequest, MAX_ARGS};

/// The README's examples, compiled as doctests.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
