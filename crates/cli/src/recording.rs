//! Recording files in the CLI: `--record FILE` (every request and reply of a command's
//! session), `record FILE.mcap|FILE.jsonl` (the status at a fixed rate, through the client's
//! recording) and the plot of `demo --plot`.

use std::path::{Path, PathBuf};
use std::time::Duration;

use fs020n_client::{RecordFormat, Recording, Robot};
use fs020n_record::plot::PlotOptions;
use serde_json::json;

use crate::error::{CliError, CliResult};
use crate::robot_cmds::MIN_RATE_HZ;
use crate::session::{client_error, close_quietly, runtime, Ctx, Interrupt, MAX_TIMEOUT_S};

/// The client recording for `--record FILE`: the format by extension (`.mcap`, `.csv`,
/// `.jsonl`); other names are refused before connecting.
pub fn recording(path: &Path) -> CliResult<Recording> {
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
pub fn is_client_recording(file: &Path) -> bool {
    matches!(
        RecordFormat::from_path(file),
        Some(RecordFormat::Mcap | RecordFormat::JsonLines)
    )
}

/// `record FILE.mcap|.jsonl`: polls the status at `rate` until `duration` or Ctrl-C; the
/// client records every request and reply (keep-alive polls included). A killed process leaves
/// an MCAP file that opens, with everything but the last second.
pub fn record(ctx: &Ctx, file: &Path, rate: f64, duration: Option<f64>) -> CliResult {
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
        let result = loop {
            let r = tokio::select! {
                _ = stop.wait() => break Ok(()),
                _ = async {
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
        Ok(())
    })
}

/// Where `demo --plot` records when no `--record` is given.
pub fn temporary_recording() -> PathBuf {
    std::env::temp_dir().join(format!("fs020n-demo-{}.mcap", std::process::id()))
}

/// After the demo: waits for the recording, reads it and draws it into `out`.
pub async fn plot_session(robot: &Robot, recorded: &Path, out: &Path, as_json: bool) -> CliResult {
    robot.flush_recording().await.map_err(client_error)?;
    let run = crate::plot::read_recording(recorded)?;
    let summary = crate::plot::draw(&run, recorded, out, PlotOptions::default())?;
    if !as_json {
        crate::plot::print_summary(out, &summary, false);
    }
    Ok(())
}
