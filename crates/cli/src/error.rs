//! Errors of the command-line tool, their remedies and exit codes.

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
    /// 5: the motion failed (controller error, E-stop, HOLD beyond --hold-timeout, timeout).
    Motion = 5,
    /// 130: interrupted by Ctrl-C (motion cancelled, session closed).
    Interrupted = 130,
}

/// An error to report to the user: what happened and, when known, what to do — naming what
/// the user can do with this tool (a switch to move, an option to give, a command to run).
#[derive(Debug)]
pub(crate) struct CliError {
    /// Exit code.
    pub(crate) exit: Exit,
    /// What happened.
    pub(crate) message: String,
    /// What to do about it.
    pub(crate) remedy: Option<String>,
    /// The message already lists the remedy (one per condition): do not repeat it.
    pub(crate) remedy_listed: bool,
}

impl CliError {
    /// A new error.
    pub(crate) fn new(exit: Exit, message: impl Into<String>) -> CliError {
        CliError {
            exit,
            message: message.into(),
            remedy: None,
            remedy_listed: false,
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

    /// The same error with a remedy.
    pub(crate) fn with_remedy(mut self, remedy: impl Into<String>) -> CliError {
        self.remedy = Some(remedy.into());
        self
    }

    /// The exit code as a number.
    pub(crate) fn code(&self) -> u8 {
        self.exit as u8
    }

    /// The error as the one JSON object printed on stderr with `--json`.
    pub(crate) fn to_json(&self) -> serde_json::Value {
        serde_json::json!({
            "error": self.message,
            "remedy": self.remedy,
            "exit_code": self.code(),
        })
    }
}

impl fmt::Display for CliError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)?;
        match &self.remedy {
            Some(r) if !self.remedy_listed => write!(f, "\n  what to do: {r}"),
            _ => Ok(()),
        }?;
        Ok(())
    }
}

impl From<std::io::Error> for CliError {
    fn from(e: std::io::Error) -> Self {
        CliError::failure(e.to_string())
    }
}

/// Result of a command.
pub(crate) type CliResult<T = ()> = Result<T, CliError>;
