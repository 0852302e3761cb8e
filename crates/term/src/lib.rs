//! # fs020n-term
//!
//! The sans-IO core of the Kawasaki controller's AS monitor terminal (telnet, port 23): the
//! protocol both the emulator's terminal and the deploy client speak. No sockets, no clocks.
//!
//! * [`text`] — every text and prompt a program matches on, with how sure each fact is: the
//!   one place to correct a fact.
//! * [`telnet`] — the controller's opening negotiation; a filter taking telnet commands out
//!   of a stream.
//! * [`line`](mod@line) — input lines as the controller reads them (CR, LF, CR LF; 128 characters).
//! * [`frame`] — the `LOAD`/`SAVE` block-transfer frames, and a scanner for either side.
//! * [`client`] — [`TerminalClient`]: login, commands, `LOAD` and `SAVE` as a state machine,
//!   answering the controller's questions the safe way.
//! * [`server`] — [`TerminalSession`]: the controller's side of a session over a [`Monitor`],
//!   which the emulator implements.
//! * `connection` (feature `tokio`) — the client over TCP, with a transcript of every byte.
//! * `testing` (feature `testing`) — a monitor that answers anything, for property tests and
//!   fuzzing.
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod client;
#[cfg(feature = "tokio")]
pub mod connection;
pub mod frame;
pub mod line;
pub mod server;
pub mod telnet;
#[cfg(feature = "testing")]
pub mod testing;
pub mod text;

pub use client::{ClientConfig, Event, Question, TerminalClient, TerminalError};
pub use server::{
    Generation, LoadAnswer, LoadEnding, Monitor, Reply, SessionConfig, SyntaxError, TerminalSession,
};
