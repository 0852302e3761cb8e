//! Errors of reading, plotting and replaying recordings.

use thiserror::Error;

/// What went wrong, with what to do about it.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum RecordError {
    /// The file cannot be read or written.
    #[error("{path}: {message}")]
    Io {
        /// The file.
        path: String,
        /// The operating system's message.
        message: String,
    },
    /// A CSV or JSON-lines recording is malformed.
    #[error("line {line}: {message}")]
    Format {
        /// 1-based line number (0: the whole file).
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// An MCAP file cannot be read.
    #[error("MCAP: {0}")]
    Mcap(String),
    /// Nothing to plot or replay.
    #[error("{0}")]
    Empty(String),
    /// A plot option is invalid.
    #[error("{0}")]
    Options(String),
    /// Drawing failed.
    #[error("cannot draw the plot: {0}")]
    Draw(String),
    /// Replay could not talk to the robot or emulator.
    #[error("replay: {0}")]
    Replay(String),
}
