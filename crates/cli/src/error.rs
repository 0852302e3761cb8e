//! Errors of the command-line tool and their exit codes.

use std::fmt;

/// Exit codes (documented in docs/CLI.md).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Exit {
    /// 1: a failure not covered below (I/O, internal).
    Failure = 1,
    /// 2: bad arguments or input (malformed file, target out of range, undecodable text,
    /// unreachable pose). Nothing was sent.
    Input = 2,
    /// 3: the robot could not be reached, or the link was lost.
    Link = 3,
    /// 4: the robot is not ready to move (a switch, an error); nothing moved.
    NotReady = 4,
    /// 5: the motion failed (controller error, E-stop, HOLD, timeout).
    Motion = 5,
    /// 130: interrupted by Ctrl-C (motion cancelled, session closed).
    Interrupted = 130,
}

/// An error to report to the user: what happened and, when known, what to do.
#[derive(Debug)]
pub(crate) struct CliError {
    /// Exit code.
    pub exit: Exit,
    /// What happened.
    pub message: String,
}

impl CliError {
    /// A new error.
    pub(crate) fn new(exit: Exit, message: impl Into<String>) -> CliError {
        CliError {
            exit,
            message: message.into(),
        }
    }

    /// Bad input.
    pub(crate) fn input(message: impl Into<String>) -> CliError {
        CliError::new(Exit::Input, message)
    }

    /// Other failure.
    pub(crate) fn failure(message: impl Into<String>) -> CliError {
        CliError::new(Exit::Failure, message)
    }
}

impl fmt::Display for CliError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

impl From<std::io::Error> for CliError {
    fn from(e: std::io::Error) -> Self {
        CliError::failure(e.to_string())
    }
}

/// Result of a command.
pub(crate) type CliResult<T = ()> = Result<T, CliError>;
