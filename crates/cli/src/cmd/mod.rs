//! The commands, one file each, and what the robot commands share: a session that always
//! ends cleanly, Ctrl-C, progress bars and the hold notice.

pub(crate) mod as_check;
pub(crate) mod bench;
pub(crate) mod decode;
pub(crate) mod demo;
pub(crate) mod deploy;
pub(crate) mod doctor;
pub(crate) mod fk;
pub(crate) mod hub;
pub(crate) mod ik;
pub(crate) mod move_cmd;
pub(crate) mod play;
pub(crate) mod plot;
pub(crate) mod raw;
pub(crate) mod record;
pub(crate) mod replay;
#[cfg(feature = "ros2")]
pub(crate) mod ros2;
pub(crate) mod shell;
pub(crate) mod sim;
pub(crate) mod speed;
pub(crate) mod status;

use std::time::Duration;

use fs020n_client::Robot;
use fs020n_proto::JointsDeg;
use indicatif::{ProgressBar, ProgressStyle};

use crate::context::{close_quietly, connect, runtime, Ctx, Interrupt, MAX_TIMEOUT_S};
use crate::error::{CliError, CliResult, Exit};
use crate::output::rounded;

pub(crate) fn interrupted() -> CliError {
    CliError::new(
        Exit::Interrupted,
        "interrupted: motion cancelled and the session closed",
    )
}

/// Runs `body` in a session with the robot and always ends the session cleanly (255). The body
/// gets the Ctrl-C flag; Ctrl-C while connecting gives up at once.
pub(crate) fn with_robot<T>(
    ctx: &Ctx,
    body: impl AsyncFnOnce(&Robot, &Interrupt) -> CliResult<T>,
) -> CliResult<T> {
    with_robot_on(runtime()?, ctx, body)
}

/// [`with_robot`] on a given runtime.
pub(crate) fn with_robot_on<T>(
    rt: tokio::runtime::Runtime,
    ctx: &Ctx,
    body: impl AsyncFnOnce(&Robot, &Interrupt) -> CliResult<T>,
) -> CliResult<T> {
    rt.block_on(async {
        let stop = Interrupt::install();
        let addr = ctx.addr_or_default();
        let robot = tokio::select! {
            r = connect(&addr, ctx) => r?,
            () = stop.wait() => {
                return Err(CliError::new(
                    Exit::Interrupted,
                    "interrupted while connecting; nothing was sent",
                ))
            }
        };
        let result = body(&robot, &stop).await;
        close_quietly(&robot).await;
        result
    })
}

pub(crate) fn bar(ctx: &Ctx, show: bool, len: u64, template: &str) -> ProgressBar {
    if !show || ctx.json {
        return ProgressBar::hidden();
    }
    let pb = ProgressBar::new(len);
    if let Ok(style) = ProgressStyle::with_template(template) {
        pb.set_style(style.progress_chars("=> "));
    }
    pb
}

/// Says when the controller holds the motion and when it goes on: above the progress bar, or
/// as a line on stderr (not with `--json`, whose stderr is for the error object).
pub(crate) struct HoldNotice {
    held: bool,
    limit: Option<Duration>,
    json: bool,
}

impl HoldNotice {
    pub(crate) fn new(ctx: &Ctx, limit: Option<Duration>) -> HoldNotice {
        HoldNotice {
            held: false,
            limit,
            json: ctx.json,
        }
    }

    pub(crate) fn update(&mut self, held: bool, pb: &ProgressBar) {
        if held == self.held {
            return;
        }
        self.held = held;
        let line = match (held, self.limit) {
            (true, Some(limit)) => format!(
                "held — switch RUN/HOLD to RUN to resume (waiting up to {})",
                rounded(limit)
            ),
            (true, None) => "held — switch RUN/HOLD to RUN to resume".to_owned(),
            (false, _) => "resumed".to_owned(),
        };
        if !pb.is_hidden() {
            pb.println(line);
        } else if !self.json {
            eprintln!("{line}");
        }
    }
}

/// Checks `--hold-timeout` (seconds): 0 means fail at once (`None`).
pub(crate) fn hold_limit(seconds: f64) -> CliResult<Option<Duration>> {
    if !(seconds.is_finite() && (0.0..=MAX_TIMEOUT_S).contains(&seconds)) {
        return Err(CliError::input(format!(
            "--hold-timeout {seconds} must be from 0 to {MAX_TIMEOUT_S} s"
        )));
    }
    Ok((seconds > 0.0).then(|| Duration::from_secs_f64(seconds)))
}

/// Lowest sampling rate of `status --watch` and `record`, Hz.
pub(crate) const MIN_RATE_HZ: f64 = 0.01;

/// Six joint values from the command line, finite (`what` names the argument in errors).
pub(crate) fn joints_from(values: &[f64], what: &str) -> CliResult<JointsDeg> {
    let arr: [f64; 6] = values
        .try_into()
        .map_err(|_| CliError::input(format!("{what}: expected 6 values, got {}", values.len())))?;
    let j = JointsDeg::new(arr);
    if !j.is_finite() {
        return Err(CliError::input(format!(
            "{what}: values must be finite numbers"
        )));
    }
    Ok(j)
}
