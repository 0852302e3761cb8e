//! Errors of the command-line tool, their remedies and exit codes, and how the client's errors
//! map to them.

use std::fmt;

use fs020n_client::{Activity, Blocker, ClientError, ErrorKind, RawRefusal};

use crate::output::rounded;

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

/// Where an error is reported: remedies name what the user can do there.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Place {
    /// A one-shot command (`fs020n move …`).
    Command,
    /// The `shell` prompt.
    Shell,
}

/// The remedy of one blocker, as an action of this tool.
fn blocker_remedy(b: &Blocker, place: Place) -> String {
    match (b, place) {
        (Blocker::ProgramNotRunning, Place::Command) => {
            "start the motion program first (in `fs020n shell`, type `start`)".to_owned()
        }
        (Blocker::ProgramNotRunning, Place::Shell) => {
            "start the motion program first: type `start`".to_owned()
        }
        (other, _) => other.remedy(),
    }
}

/// Blockers as an error: one line per condition with its remedy.
fn blocked(exit: Exit, headline: String, blockers: &[Blocker], place: Place) -> CliError {
    let lines = blockers
        .iter()
        .map(|b| format!("  - {} — {}", b.condition(), blocker_remedy(b, place)))
        .collect::<Vec<_>>()
        .join("\n");
    let remedy = blockers
        .iter()
        .map(|b| blocker_remedy(b, place))
        .collect::<Vec<_>>()
        .join("; ");
    let mut e = CliError::new(exit, format!("{headline}:\n{lines}"));
    if !blockers.is_empty() {
        e = e.with_remedy(remedy);
        e.remedy_listed = true;
    }
    e
}

/// Maps a client error of a one-shot command to what the user reads and the exit code.
pub(crate) fn client_error(e: ClientError) -> CliError {
    describe(e, Place::Command)
}

/// The exit code of each kind of client failure (docs/CLI.md, "Exit codes"): the client's one
/// classification, mapped once.
pub(crate) fn exit_for(kind: ErrorKind) -> Exit {
    match kind {
        ErrorKind::Refused => Exit::Input,
        ErrorKind::NotReady => Exit::NotReady,
        ErrorKind::Connect | ErrorKind::LinkLost => Exit::Link,
        ErrorKind::Motion | ErrorKind::MoveTimeout | ErrorKind::Busy | ErrorKind::Cancelled => {
            Exit::Motion
        }
        _ => Exit::Failure,
    }
}

/// Maps a client error to what the user reads (remedies as actions of this tool at `place`)
/// and the exit code ([`exit_for`] of its kind).
pub(crate) fn describe(e: ClientError, place: Place) -> CliError {
    let again = match place {
        Place::Command => "run the command again (nothing is resumed automatically)",
        Place::Shell => "type `reconnect`, then `start` again (nothing is resumed automatically)",
    };
    let exit = exit_for(e.kind());
    let speed = match place {
        Place::Command => "give a higher --speed or a longer --timeout",
        Place::Shell => "set a higher speed (`speed PCT`)",
    };
    match e {
        ClientError::Connect {
            target,
            attempts,
            waited,
            last,
        } => CliError::new(
            exit,
            format!(
                "could not connect to {target} within {} ({attempts} attempts; last error: {last})",
                rounded(waited)
            ),
        )
        .with_remedy(
            "check that the controller is on and its AS server program runs, that --robot \
             names the right address and port, and that no other client holds the session \
             (the controller serves one at a time)",
        ),
        ClientError::Address { target, message } => {
            CliError::new(exit, format!("cannot connect to {target}: {message}")).with_remedy(
                "check the host name in --robot (or FS020N_ROBOT), or give an IP address",
            )
        }
        ClientError::NotAController { target, cause } => CliError::new(
            exit,
            format!("{target} is not a protocol-1040 server: {cause}"),
        )
        .with_remedy(
            "check the address and port in --robot: the robot's port is 10050 unless configured \
             otherwise (`fs020n sim` listens on 127.0.0.1:10050)",
        ),
        ClientError::LinkLost(cause) => CliError::new(
            exit,
            format!(
                "link to the robot lost: {cause}; the controller ended the session, which stops \
                 the robot"
            ),
        )
        .with_remedy(again),
        ClientError::Closed => CliError::new(exit, "the session is closed").with_remedy(again),
        ClientError::Blocked(b) => blocked(
            exit,
            "the robot is not ready to move; nothing was sent".to_owned(),
            &b,
            place,
        ),
        ClientError::StartFailed { waited, blockers } if !blockers.is_empty() => blocked(
            exit,
            format!(
                "the motion program did not start within {}",
                rounded(waited)
            ),
            &blockers,
            place,
        ),
        ClientError::StartFailed { waited, .. } => CliError::new(
            exit,
            format!(
                "the motion program did not start within {} although no switch blocks it",
                rounded(waited)
            ),
        )
        .with_remedy("check the controller's terminal for an AS error"),
        ClientError::Aborted { during, blockers } => {
            blocked(exit, format!("{during} stopped"), &blockers, place)
        }
        ClientError::HoldTimeout { during, waited } => CliError::new(
            exit,
            format!(
                "the {during} was held (RUN/HOLD on HOLD) for {}, longer than the hold timeout; \
                 it was cancelled",
                rounded(waited)
            ),
        )
        .with_remedy(match place {
            Place::Command => {
                "switch RUN/HOLD to RUN and run the command again (or give a longer --hold-timeout)"
            }
            Place::Shell => "switch RUN/HOLD to RUN and move again",
        }),
        ClientError::MoveTimeout {
            timeout,
            remaining_deg,
        } => CliError::new(
            exit,
            format!(
                "the move did not reach its target within {} ({remaining_deg:.3} deg to go); it \
                 was cancelled",
                rounded(timeout)
            ),
        )
        .with_remedy(format!("check the robot's surroundings; {speed}")),
        ClientError::StreamUnderrun { gap, allowed } => CliError::new(
            exit,
            format!(
                "stream underrun: {} between samples (allowed {}); the stream was cancelled",
                rounded(gap),
                rounded(allowed)
            ),
        )
        .with_remedy("lower --rate, or the load on this computer"),
        ClientError::NoServerClock => CliError::new(
            exit,
            "no estimate of the controller's clock: no reply carried TIMER(1)",
        )
        .with_remedy("run the command again, or play with --mode waypoints"),
        ClientError::RawRefused(RawRefusal::Motion { text }) => CliError::new(
            exit,
            format!(
            "{text:?} is a motion command (the controller would move the robot); nothing was sent"
        ),
        )
        .with_remedy(match place {
            Place::Command => {
                "add --yes to send it; it also needs a running program, which a one-shot \
                 command does not have: type `raw … --yes` in `fs020n shell` after `start`"
            }
            Place::Shell => "add --yes to send it",
        }),
        ClientError::RawRefused(why) => CliError::new(exit, format!("raw request refused: {why}")),
        ClientError::Busy(Activity::Stream) => {
            CliError::new(exit, "a stream is running; nothing was sent").with_remedy(match place {
                Place::Command => "wait for it to end, or press Ctrl-C",
                Place::Shell => "type `cancel` first",
            })
        }
        ClientError::Busy(Activity::Servo) => {
            CliError::new(exit, "a servo is running; nothing was sent").with_remedy(match place {
                Place::Command => "wait for it to end, or press Ctrl-C",
                Place::Shell => "type `cancel` first",
            })
        }
        ClientError::Cancelled(why) => CliError::new(exit, why.to_string()),
        ClientError::Recording { path, message } => CliError::new(
            exit,
            format!("cannot open the recording file {path}: {message}"),
        ),
        e => CliError::new(exit, e.to_string()),
    }
}
