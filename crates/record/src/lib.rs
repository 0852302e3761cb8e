//! # fs020n-record
//!
//! Reads, plots and replays the recordings of `fs020n-client` (`docs/RECORDING.md`):
//!
//! * [`read()`](read::read) — CSV, JSON lines or MCAP into one [`Run`]: every request with
//!   its reply, the measured joints, the commanded positions, the events. A file cut short by a
//!   killed recorder reads up to its last complete record ([`Run::truncated`]).
//! * [`plot`] — a picture of a run (PNG or SVG, no system fonts needed): one panel per joint
//!   with commanded against actual, the tracking error, the round-trip histogram with the late
//!   replies, a title with robot, date and duration.
//! * [`replay`] — sends a run's requests again with their original timing and lists where the
//!   replies differ (joints beyond a tolerance, switches, error, program).
#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod error;
pub mod plot;
pub mod read;
pub mod replay;

pub use error::RecordError;
pub use read::{read, Commanded, Event, Exchange, Run, SourceFormat, State, StatusFields};
