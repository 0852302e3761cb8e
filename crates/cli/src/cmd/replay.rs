//! `replay`: a recording's requests sent again with their original timing, to the embedded
//! emulator (started in the recorded state) or to `--robot`, and where the replies differ.

use fs020n_record::replay::{initial_status, replay, replay_tcp, ReplayOptions, ReplayReport};
use fs020n_sim::{ControllerConfig, Emulator, Panel};
use serde_json::json;

use crate::args::ReplayArgs;
use crate::cmd::plot::{read_recording, record_error};
use crate::context::{check_speed, runtime, Ctx};
use crate::error::{CliError, CliResult, Exit};

/// Largest `--tolerance`, degrees.
pub(crate) const MAX_TOLERANCE_DEG: f64 = 90.0;

/// `replay`.
pub(crate) fn run(ctx: &Ctx, args: &ReplayArgs) -> CliResult {
    if !(args.tolerance.is_finite() && (0.0..=MAX_TOLERANCE_DEG).contains(&args.tolerance)) {
        return Err(CliError::input(format!(
            "--tolerance must be from 0 to {MAX_TOLERANCE_DEG} degrees"
        )));
    }
    let speed = args.monitor_speed.map(check_speed).transpose()?;
    if ctx.addr.is_some() && !args.yes {
        return Err(CliError::input(
            "replay sends the recorded requests, motions included: to replay on the robot given \
             by --robot, add --yes (without --robot it replays on the embedded emulator)",
        ));
    }
    let run = read_recording(&args.recording)?;
    let first = initial_status(&run).ok_or_else(|| {
        CliError::input(format!(
            "{}: no request with a reply to replay (a status CSV of `fs020n record` holds no \
             requests: record to .mcap, .csv or .jsonl with --record)",
            args.recording.display()
        ))
    })?;
    let opts = ReplayOptions {
        tolerance_deg: args.tolerance,
        connect_timeout: ctx.connect_timeout,
        ..ReplayOptions::default()
    };
    let rt = runtime()?;
    let (report, target) = rt
        .block_on(async {
            match &ctx.addr {
                Some(addr) => replay_tcp(&run, addr, &opts)
                    .await
                    .map(|r| (r, addr.clone())),
                None => {
                    // The emulator starts where the recording starts: joints, switches, error.
                    let mut cfg = ControllerConfig::new(ctx.model.clone());
                    cfg.joints = first.joints;
                    cfg.error = first.error;
                    cfg.panel = Panel {
                        power: first.power,
                        run: first.run,
                        repeat: first.repeat,
                        teach_lock: first.teach_lock,
                        estop: false,
                    };
                    if let Some(p) = speed {
                        cfg.monitor_speed_percent = p;
                    }
                    let emu = Emulator::new(cfg);
                    replay(&run, || std::future::ready(emu.connect()), &opts)
                        .await
                        .map(|r| (r, "the embedded emulator".to_owned()))
                }
            }
        })
        .map_err(record_error)?;
    print_report(&report, &target, ctx.json);
    if report.matches() {
        Ok(())
    } else {
        Err(CliError::new(
            Exit::Failure,
            format!(
                "{} of {} replies differ from the recording",
                report.divergent, report.compared
            ),
        ))
    }
}

fn print_report(r: &ReplayReport, target: &str, as_json: bool) {
    if as_json {
        println!("{}", json!({ "target": target, "report": r }));
        return;
    }
    println!(
        "replayed {} session(s), {} requests with their original timing to {target}; {} replies compared (largest lag {:.1} ms)",
        r.sessions,
        r.requests,
        r.compared,
        r.max_lag_s * 1e3
    );
    let d = r.max_joint_diff_deg;
    println!(
        "largest joint difference (deg): {:.3} {:.3} {:.3} {:.3} {:.3} {:.3} (tolerance {} deg)",
        d[0], d[1], d[2], d[3], d[4], d[5], r.tolerance_deg
    );
    if r.matches() {
        println!("no divergence: every reply matched the recording");
        return;
    }
    let fields: Vec<String> = r
        .by_field
        .iter()
        .map(|(f, n)| format!("{f}: {n}"))
        .collect();
    println!(
        "{} of {} replies differ ({}):",
        r.divergent,
        r.compared,
        fields.join(", ")
    );
    for d in &r.divergences {
        let what: Vec<String> = d
            .fields
            .iter()
            .map(|f| {
                format!(
                    "{} recorded {} replayed {}",
                    f.field, f.recorded, f.replayed
                )
            })
            .collect();
        println!(
            "  t = {:8.3} s  session {}  {:<28}  {}",
            d.t_s,
            d.session,
            shorten(&d.request, 28),
            what.join("; ")
        );
    }
    if r.divergences.len() < r.divergent {
        println!("  … and {} more", r.divergent - r.divergences.len());
    }
}

fn shorten(s: &str, n: usize) -> String {
    if s.chars().count() <= n {
        s.to_owned()
    } else {
        let mut t: String = s.chars().take(n - 1).collect();
        t.push('…');
        t
    }
}
