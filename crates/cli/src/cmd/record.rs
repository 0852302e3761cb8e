//! `record`: the status at a fixed rate, as CSV rows or through the client's recording (MCAP, JSON lines).

use std::io::Write;
use std::path::Path;
use std::time::{Duration, Instant};

use fs020n_client::Robot;
use fs020n_proto::{Status, Timer};
use serde_json::json;

use crate::args::RecordArgs;
use crate::cmd::with_robot;
use crate::cmd::MIN_RATE_HZ;
use crate::context::{close_quietly, runtime, Ctx, Interrupt, MAX_TIMEOUT_S};
use crate::error::{client_error, CliError, CliResult, Exit};
use crate::recording::{is_client_recording, recording};

/// `record FILE`: the status CSV, or with a `.mcap`/`.jsonl` name the client's recording of
/// every request and reply. `session_recorded` is `--record` given as well, which the second
/// form already is.
pub(crate) fn record(ctx: &Ctx, args: &RecordArgs, session_recorded: bool) -> CliResult {
    if !is_client_recording(&args.file) {
        return record_csv(ctx, args);
    }
    if session_recorded {
        return Err(CliError::input(
            "record FILE already records every request and reply: leave out --record",
        ));
    }
    record_through_client(ctx, args)
}

/// The header of `record` files.
pub(crate) const RECORD_HEADER: &str =
    "time_s,timer_s,error_code,error,run,repeat,teach_lock,power,task_running,j1,j2,j3,j4,j5,j6";

/// Opens the file of `record` before connecting: a new file, or with `--force` a truncated
/// one, or with `--append` the end of one (which must be a recording: its first line is the
/// header). Returns the file and whether the header must be written.
fn open_record_file(args: &RecordArgs) -> CliResult<(std::fs::File, bool)> {
    let path = &args.file;
    let cannot =
        |e: std::io::Error| CliError::input(format!("cannot open {}: {e}", path.display()));
    if args.append {
        let existing = match std::fs::read_to_string(path) {
            Ok(text) => Some(text),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
            Err(e) => return Err(cannot(e)),
        };
        if let Some(text) = &existing {
            if !text.is_empty() && text.lines().next() != Some(RECORD_HEADER) {
                return Err(CliError::input(format!(
                    "{} is not a recording of `fs020n record` (its first line is not the \
                     header); nothing was added",
                    path.display()
                ))
                .with_remedy("give another file, or --force to overwrite it"));
            }
        }
        let file = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(path)
            .map_err(cannot)?;
        let needs_header = existing.is_none_or(|t| t.is_empty());
        return Ok((file, needs_header));
    }
    let mut options = std::fs::OpenOptions::new();
    options.write(true);
    if args.force {
        options.create(true).truncate(true);
    } else {
        options.create_new(true);
    }
    match options.open(path) {
        Ok(file) => Ok((file, true)),
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => Err(CliError::input(format!(
            "{} exists; nothing was written",
            path.display()
        ))
        .with_remedy("add --force to overwrite it or --append to add to it, or give another file")),
        Err(e) => Err(cannot(e)),
    }
}

/// `record`. Ctrl-C ends it like every command (exit 130); the file is complete up to the last
/// row, which is flushed as it is written.
fn record_csv(ctx: &Ctx, args: &RecordArgs) -> CliResult {
    let (rate, duration) = (args.rate, args.duration);
    if !(rate.is_finite() && (MIN_RATE_HZ..=1000.0).contains(&rate)) {
        return Err(CliError::input(format!(
            "--rate must be from {MIN_RATE_HZ} to 1000 Hz"
        )));
    }
    if let Some(d) = duration {
        if !(d.is_finite() && d > 0.0 && d <= MAX_TIMEOUT_S) {
            return Err(CliError::input(format!(
                "--duration must be above 0 and at most {MAX_TIMEOUT_S} s"
            )));
        }
    }
    let (file, needs_header) = open_record_file(args)?;
    let mut out = std::io::BufWriter::new(file);
    let path: &Path = &args.file;
    with_robot(ctx, async |robot: &Robot, stop: &Interrupt| {
        if needs_header {
            writeln!(out, "{RECORD_HEADER}")?;
            out.flush()?;
        }
        let start = Instant::now();
        let end = duration.map(|d| start + Duration::from_secs_f64(d));
        let mut tick = tokio::time::interval(Duration::from_secs_f64(1.0 / rate));
        let mut rows = 0u64;
        let mut by_ctrl_c = false;
        loop {
            let s = tokio::select! {
                () = stop.wait() => {
                    by_ctrl_c = true;
                    break;
                }
                s = async {
                    tick.tick().await;
                    robot.poll().await
                } => s.map_err(client_error)?,
            };
            if end.is_some_and(|e| Instant::now() >= e) {
                break;
            }
            write_row(&mut out, start.elapsed().as_secs_f64(), &s)?;
            out.flush()?;
            rows += 1;
        }
        if ctx.json {
            println!(
                "{}",
                json!({ "rows": rows, "file": path.display().to_string() })
            );
        } else {
            println!("recorded {rows} row(s) to {}", path.display());
        }
        if by_ctrl_c {
            return Err(CliError::new(
                Exit::Interrupted,
                format!(
                    "stopped by Ctrl-C after {rows} row(s); the file is complete and the session \
                     closed"
                ),
            ));
        }
        Ok(())
    })
}

fn write_row(out: &mut impl Write, t: f64, s: &Status) -> std::io::Result<()> {
    let timer = match s.timer {
        Timer::Seconds(v) => format!("{v:.3}"),
        Timer::Overflow => String::new(),
    };
    let b = |v: bool| if v { "1" } else { "0" };
    let error = if s.error.is_none() {
        String::new()
    } else {
        s.error.to_string()
    };
    let j = s.joints.values();
    writeln!(
        out,
        "{t:.4},{timer},{},{error},{},{},{},{},{},{:.3},{:.3},{:.3},{:.3},{:.3},{:.3}",
        s.error.raw(),
        b(s.run),
        b(s.repeat),
        b(s.teach_lock),
        b(s.power),
        b(s.task_running),
        j[0],
        j[1],
        j[2],
        j[3],
        j[4],
        j[5]
    )
}

/// `record FILE.mcap|.jsonl`: polls the status at `--rate` until `--duration` or Ctrl-C (exit
/// 130, the file complete); the client records every request and reply (keep-alive polls
/// included). A killed process leaves an MCAP file that opens, with everything but the last
/// second. An existing file is refused unless `--force`; `--append` is for the status CSV only.
fn record_through_client(ctx: &Ctx, args: &RecordArgs) -> CliResult {
    let (file, rate, duration) = (args.file.as_path(), args.rate, args.duration);
    if !(rate.is_finite() && (MIN_RATE_HZ..=1000.0).contains(&rate)) {
        return Err(CliError::input(format!(
            "--rate must be from {MIN_RATE_HZ} to 1000 Hz"
        )));
    }
    if let Some(d) = duration {
        if !(d.is_finite() && d > 0.0 && d <= MAX_TIMEOUT_S) {
            return Err(CliError::input(format!(
                "--duration must be above 0 and at most {MAX_TIMEOUT_S} s"
            )));
        }
    }
    if args.append {
        return Err(CliError::input(format!(
            "{}: --append adds rows to a status CSV; an MCAP or JSON-lines recording is written \
             whole",
            file.display()
        ))
        .with_remedy("give a new file name, or --force to overwrite it"));
    }
    if file.exists() && !args.force {
        return Err(
            CliError::input(format!("{} exists; nothing was recorded", file.display()))
                .with_remedy("give another file, or --force to overwrite it"),
        );
    }
    let mut config = ctx.client_config();
    config.record = Some(recording(file)?);
    let rt = runtime()?;
    rt.block_on(async {
        let stop = Interrupt::install();
        let robot = Robot::connect(&ctx.addr_or_default(), config)
            .await
            .map_err(client_error)?;
        let start = tokio::time::Instant::now();
        let end = duration.map(|d| start + Duration::from_secs_f64(d));
        let mut tick = tokio::time::interval(Duration::from_secs_f64(1.0 / rate));
        let mut polls = 0u64;
        let mut by_ctrl_c = false;
        let result = loop {
            let r = tokio::select! {
                () = stop.wait() => {
                    by_ctrl_c = true;
                    break Ok(());
                }
                () = async {
                    match end {
                        Some(e) => tokio::time::sleep_until(e).await,
                        None => std::future::pending().await,
                    }
                } => break Ok(()),
                r = async {
                    tick.tick().await;
                    robot.poll().await
                } => r,
            };
            match r {
                Ok(_) => polls += 1,
                Err(e) => break Err(client_error(e)),
            }
        };
        close_quietly(&robot).await;
        if let Err(e) = robot.flush_recording().await {
            tracing::warn!("{e}");
        }
        let stats = robot.stats();
        result?;
        if ctx.json {
            println!(
                "{}",
                json!({
                    "file": file.display().to_string(),
                    "polls": polls,
                    "requests": stats.requests,
                    "record_errors": stats.record_errors,
                })
            );
        } else {
            println!(
                "recorded {polls} status poll(s) and every request and reply ({} in all) to {}",
                stats.requests,
                file.display()
            );
        }
        if by_ctrl_c {
            return Err(CliError::new(
                Exit::Interrupted,
                format!(
                    "stopped by Ctrl-C after {polls} poll(s); the recording is complete and the \
                     session closed"
                ),
            ));
        }
        Ok(())
    })
}
