//! Recording files in the CLI: `--record FILE` (every request and reply of a command's
//! session), which files `record` writes through the client's recording, and the plot of
//! `demo --plot`.

use std::path::{Path, PathBuf};

use fs020n_client::{RecordFormat, Recording, Robot};
use fs020n_record::plot::PlotOptions;

use crate::error::client_error;
use crate::error::{CliError, CliResult};

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
    let run = crate::cmd::plot::read_recording(recorded)?;
    let summary = crate::cmd::plot::draw(&run, recorded, out, PlotOptions::default())?;
    if !as_json {
        crate::cmd::plot::print_summary(out, &summary, false);
    }
    Ok(())
}
