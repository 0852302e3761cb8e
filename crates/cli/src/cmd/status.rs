//! `status`: one status, or a live table with `--watch`.

use std::io::{IsTerminal, Write};
use std::time::Duration;

use fs020n_client::Robot;
use fs020n_proto::Status;

use crate::cmd::with_robot;
use crate::cmd::MIN_RATE_HZ;
use crate::context::{Ctx, Interrupt};
use crate::error::{client_error, CliError, CliResult, Exit};
use crate::output::{robot_status_json, robot_status_table};

/// `status`.
pub(crate) fn status(ctx: &Ctx, watch: bool, rate: f64) -> CliResult {
    if watch && !(rate.is_finite() && (MIN_RATE_HZ..=100.0).contains(&rate)) {
        return Err(CliError::input(format!(
            "--rate must be from {MIN_RATE_HZ} to 100 Hz"
        )));
    }
    let redraw = watch && std::io::stdout().is_terminal();
    with_robot(ctx, async |robot: &Robot, stop: &Interrupt| {
        let s = robot.poll().await.map_err(client_error)?;
        print_status(ctx, &s, redraw)?;
        if !watch {
            return Ok(());
        }
        let mut tick = tokio::time::interval(Duration::from_secs_f64(1.0 / rate));
        loop {
            let s = tokio::select! {
                () = stop.wait() => {
                    return Err(CliError::new(Exit::Interrupted, "stopped by Ctrl-C; the session is closed"));
                }
                s = async {
                    tick.tick().await;
                    robot.poll().await
                } => s.map_err(client_error)?,
            };
            match print_status(ctx, &s, redraw) {
                // The reader went away (e.g. `| head`): a normal end.
                Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => return Ok(()),
                r => r?,
            }
        }
    })
}

fn print_status(ctx: &Ctx, s: &Status, redraw: bool) -> std::io::Result<()> {
    let mut out = std::io::stdout().lock();
    if ctx.json {
        writeln!(out, "{}", robot_status_json(s, &ctx.model))?;
    } else {
        if redraw {
            // Clear the screen and go home (only on a terminal).
            write!(out, "\x1b[2J\x1b[H")?;
        }
        write!(out, "{}", robot_status_table(s, &ctx.model))?;
        if redraw {
            writeln!(out, "(Ctrl-C to stop)")?;
        }
    }
    out.flush()
}
