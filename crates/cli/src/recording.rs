//! Recording files in the CLI: `--record FILE` (every request and reply of a command's
//! session), `record FILE.mcap|FILE.jsonl` (the status at a fixed rate, through the client's
//! recording) and the plot of `demo --plot`.

use std::path::{Path, PathBuf};
use std::time::Duration;

use fs020n_client::{RecordFormat, Recording, Robot};
use fs020n_record::plot::PlotOptions;
use serde_json::json;

use crate::args::RecordArgs;
use crate::error::{CliError, CliResult, Exit};
use crate::robot_cmds::MIN_RATE_HZ;
use crate::session::{client_error, close_quietly, runtime, Ctx, Interrupt, MAX_TIMEOUT_S};

/// The client recording for `--record FILE`: the format by extension (`.mcap`, `.csv`,
/// `.jsonl`); other names are refused before connecting.
pub(crate) fn recording(path: &Path) -> CliResult<Recording> {
    match RecordFormat::from_path(path) {
        Some(format) => Ok(Recording {
            path: path.to_owned(),
            format,
        }),
        None => Err(CliError::input(format!(
            "{}: name the recording .mcap, .csv or .jsonl (the extension chooses the format)",
            path.display()
        ))),
    }
}

/// `true` when `record FILE` should go through the client's recording (MCAP, JSON lines)
/// rather than write the status CSV.
pub(crate) fn is_client_recording(file: &Path) -> bool {
    matches!(
        RecordFormat::from_path(file),
        Some(RecordFormat::Mcap | RecordFormat::JsonLines)
    )
}

/// `record FILE.mcap|.jsonl`: polls the status at `--rate` until `--duration` or Ctrl-C (exit
/// 130, the file complete); the client records every request and reply (keep-alive polls
/// included). A killed process leaves an MCAP file that opens, with everything but the last
/// second. An existing file is refused unless `--force`; `--append` is for the status CSV only.
pub(crate) fn record(ctx: &Ctx, args: &RecordArgs) -> CliResult {
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

/// Where `demo --plot` records when no `--record` is given.
pub(crate) fn temporary_recording() -> PathBuf {
    std::env::temp_dir().join(format!("fs020n-demo-{}.mcap", std::process::id()))
}

/// After the demo: waits for the recording, reads it and draws it into `out`.
pub(crate) async fn plot_session(
    robot: &Robot,
    recorded: &Path,
    out: &Path,
    as_json: bool,
) -> CliResult {
    robot.flush_recording().await.map_err(client_error)?;
    let run = crate::plot::read_recording(recorded)?;
    let summary = crate::plot::draw(&run, recorded, out, PlotOptions::default())?;
    if !as_json {
        crate::plot::print_summary(out, &summary, false);
    }
    Ok(())
}
