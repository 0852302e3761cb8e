//! # fs020n-as
//!
//! Kawasaki's AS robot language: a parser for AS program files and an interpreter that runs
//! several tasks concurrently on a clock it is given — so that an AS program (the
//! protocol-1040 server, or your own) runs offline, deterministically, in tests and CI.
//!
//! - [`parse_bytes`] (and [`parse`] for text): a program file as bytes in any code page —
//!   `.PROGRAM` … `.END` blocks, the `.REALS`, `.STRINGS`, `.JOINTS`, `.TRANS` data sections
//!   and every other section of a controller backup ([`sections`]), controller-saved syntax,
//!   abbreviated keywords — into a syntax tree with spans ([`ast`]); errors say
//!   file:line:column and what was expected. Instructions the emulator does not model load
//!   and are listed as warnings; [`LoadOptions`] stubs them.
//! - [`check`]: loads a file exactly as the emulator does and lints it against the real
//!   controller's limits ([`lint`]) — what `fs020n as check` prints.
//! - [`Interpreter`]: robot task 1 and PC tasks 1–5, globals shared and dot-locals per program,
//!   a documented [`CostModel`] (statements take time, so tasks interleave and a busy loop never
//!   freezes the clock), motion look-ahead as the controller does it, `ON`/`ONI` interrupts,
//!   TCP sockets with timeouts and AS result codes, runtime errors with AS codes ([`RuntimeError`]).
//! - [`System`]: the controller side (motion, panel, error, sockets, terminal). The emulator
//!   (`fs020n-sim`) implements it with its motion planner; [`testing::VirtualSystem`] (feature
//!   `testing`) is a minimal one for program-logic tests.
//! - [`SERVER_1040`]: this project's own AS text of the protocol-1040 server
//!   (`autostart.pc` + `ros_move`), written from the protocol specification.
//!
//! ```
//! use std::time::Duration;
//! use fs020n_as::{Config, Interpreter};
//! use fs020n_as::testing::VirtualSystem;
//!
//! let mut interp = Interpreter::from_source("server1040.as", fs020n_as::SERVER_1040, Config::default())?;
//! let mut sys = VirtualSystem::new();
//! interp.start(&mut sys);                              // autostart.pc runs in PC task 1
//! interp.run_until(&mut sys, Duration::from_millis(10));
//! let client = sys.connect(10050).expect("the server listens");
//! sys.send(client, b"1040 0 0");
//! interp.run_until(&mut sys, Duration::from_millis(100));
//! let reply = String::from_utf8(sys.recv(client)).unwrap();
//! assert!(reply.starts_with(" 1040 0 -1 -1 0 -1 0 "), "{reply:?}");
//! # Ok::<(), fs020n_as::LoadError>(())
//! ```
//!
//! Everything supported, the cost model and the choices made where the manuals are silent:
//! docs/AS.md.
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod ast;
mod compile;
pub mod error;
pub mod flange;
mod interp;
pub mod keywords;
pub mod lexer;
pub mod lint;
mod load;
mod options;
pub mod parser;
pub mod sections;
pub mod sockets;
pub mod span;
pub mod system;
#[cfg(any(test, feature = "testing"))]
pub mod testing;
mod value;

pub use error::{LoadError, ParseError, RuntimeError};
pub use interp::{
    BlockSettings, Config, CostModel, HandSignals, ImmediateError, InterfacePanel, Interpreter,
    ListKind, PanelWindow, Payload, Refusal, ReloadError, TaskInfo, TaskState, TerminalLine,
    TraceLine, MAX_STRING, MAX_TRANSFER,
};
pub use load::{check, check_memory, CheckReport, Loaded};
pub use options::LoadOptions;
pub use parser::{parse, parse_bytes};
pub use span::Span;
pub use system::{
    Datagram, Issued, Joints, MotionKind, MotionRequest, PanelState, SockPoll, SocketStatus, Speed,
    System, Target, TaskId, Trans,
};

/// This project's AS text of the protocol-1040 server (`crates/as/programs/server1040.as`):
/// the communication task `autostart.pc` (PC task 1) and the motion program `ros_move`
/// (robot task 1), written from the protocol specification.
pub const SERVER_1040: &str = include_str!("../programs/server1040.as");
