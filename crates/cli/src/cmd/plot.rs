//! `plot`: a picture of a recording (PNG or SVG).

use std::path::Path;

use fs020n_record::plot::{plot_to_file, PlotOptions, PlotSummary};
use serde_json::json;

use crate::args::PlotArgs;
use crate::error::{CliError, CliResult};

/// Maps a recording error to the CLI's: bad options and unreadable files are input errors.
pub(crate) fn record_error(e: fs020n_record::RecordError) -> CliError {
    use fs020n_record::RecordError as E;
    match e {
        E::Draw(_) | E::Replay(_) => CliError::failure(e.to_string()),
        E::Io { .. } | E::Format { .. } | E::Mcap(_) | E::Empty(_) | E::Options(_) => {
            CliError::input(e.to_string())
        }
    }
}

/// Reads a recording, naming the file in errors.
pub(crate) fn read_recording(path: &Path) -> CliResult<fs020n_record::Run> {
    fs020n_record::read(path).map_err(|e| match e {
        fs020n_record::RecordError::Io { .. } => record_error(e),
        other => CliError::input(format!("{}: {other}", path.display())),
    })
}

/// Checks `--joints`: numbers from 1 to 6.
fn joints(list: &[usize]) -> CliResult<Vec<usize>> {
    if list.is_empty() {
        return Ok((1..=6).collect());
    }
    if let Some(bad) = list.iter().find(|j| !(1..=6).contains(*j)) {
        return Err(CliError::input(format!(
            "--joints {bad}: give joint numbers from 1 to 6, e.g. --joints 1,2"
        )));
    }
    Ok(list.to_vec())
}

/// Draws `run` (read from `source`) into `out`.
pub(crate) fn draw(
    run: &fs020n_record::Run,
    source: &Path,
    out: &Path,
    mut opts: PlotOptions,
) -> CliResult<PlotSummary> {
    opts.name = source.file_name().map(|n| n.to_string_lossy().into_owned());
    plot_to_file(run, out, &opts).map_err(record_error)
}

/// Prints what was drawn.
pub(crate) fn print_summary(out: &Path, s: &PlotSummary, as_json: bool) {
    if as_json {
        println!(
            "{}",
            json!({ "plot": out.display().to_string(), "summary": s })
        );
    } else {
        println!(
            "plot: {} ({}x{} px, {} panels, {:.1} to {:.1} s: {} samples, {} commanded, {} round trips, {} late)",
            out.display(),
            s.width,
            s.height,
            s.panels,
            s.from_s,
            s.to_s,
            s.states,
            s.commanded,
            s.round_trips,
            s.late_replies
        );
    }
}

/// `plot`.
pub(crate) fn plot(args: &PlotArgs, as_json: bool) -> CliResult {
    for (name, v) in [("--from", args.from), ("--to", args.to)] {
        if v.is_some_and(|v| !v.is_finite()) {
            return Err(CliError::input(format!(
                "{name} must be a number of seconds"
            )));
        }
    }
    let run = read_recording(&args.recording)?;
    let opts = PlotOptions {
        joints: joints(&args.joints)?,
        from_s: args.from,
        to_s: args.to,
        width: args.width,
        height: args.height,
        ..PlotOptions::default()
    };
    let summary = draw(&run, &args.recording, &args.output, opts)?;
    print_summary(&args.output, &summary, as_json);
    Ok(())
}
