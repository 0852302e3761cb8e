//! `play`: a trajectory file streamed with command 7 (or as waypoints with command 6).

use std::time::Duration;

use fs020n_client::{
    Completion, Robot, StreamMode, StreamOptions, StreamOutcome, StreamReport, Trajectory,
    TrajectoryPoint,
};
use serde_json::json;

use crate::args::{PlayArgs, PlayMode};
use crate::cmd::bar;
use crate::cmd::hold_limit;
use crate::cmd::interrupted;
use crate::cmd::with_robot_on;
use crate::cmd::HoldNotice;
use crate::context::{check_speed, runtime_one_thread, Ctx, Interrupt};
use crate::error::{client_error, CliError, CliResult, Exit};
use crate::trajectory_file;

/// Streams `trajectory` with a progress bar (when `show_bar`), HOLD notices and Ctrl-C;
/// fails unless the stream completes.
pub(crate) async fn stream(
    ctx: &Ctx,
    robot: &Robot,
    stop: &Interrupt,
    trajectory: Trajectory,
    options: StreamOptions,
    show_bar: bool,
) -> CliResult<StreamReport> {
    let handle = robot
        .stream(trajectory, options)
        .await
        .map_err(client_error)?;
    let pb = bar(
        ctx,
        show_bar,
        1000,
        "{spinner} playing [{bar:40}] {percent:>3}% {msg}",
    );
    let mut notice = HoldNotice::new(ctx, options.hold_timeout);
    let wait = handle.wait();
    tokio::pin!(wait);
    let mut tick = tokio::time::interval(Duration::from_millis(100));
    let report = loop {
        tokio::select! {
            r = &mut wait => break r,
            _ = tick.tick() => {
                let p = handle.progress();
                notice.update(p.held, &pb);
                pb.set_position((p.fraction.clamp(0.0, 1.0) * 1000.0) as u64);
                pb.set_message(format!("t = {:.2} s, tracking error max {:.3} deg", p.time_s, p.tracking_error_max_deg));
            }
            () = stop.wait() => {
                pb.abandon_with_message("cancelled");
                let _ = handle.cancel().await;
                return Err(interrupted());
            }
        }
    };
    pb.finish_and_clear();
    let report = report.map_err(client_error)?;
    if report.outcome != StreamOutcome::Completed {
        print_stream_report(&report, ctx.json);
        return Err(CliError::new(Exit::Motion, "the stream did not complete"));
    }
    Ok(report)
}

/// Converts file points to the client's trajectory type.
fn to_trajectory(points: &[trajectory_file::FilePoint]) -> CliResult<Trajectory> {
    Trajectory::new(
        points
            .iter()
            .map(|p| TrajectoryPoint {
                time_s: p.time_s,
                position: p.position,
                velocity: p.velocity,
                acceleration: p.acceleration,
            })
            .collect(),
    )
    .map_err(|e| CliError::input(format!("trajectory refused: {e}")))
}

/// `play`: everything that can be checked is checked before connecting; then the start
/// position before anything is sent that acts; then preflight, speed, start, (approach), stream.
pub(crate) fn play(ctx: &Ctx, args: &PlayArgs) -> CliResult {
    let speed = check_speed(args.speed)?;
    if !(args.rate.is_finite() && args.rate >= MIN_PLAY_RATE_HZ && args.rate <= MAX_PLAY_RATE_HZ) {
        return Err(CliError::input(format!(
            "--rate must be from {MIN_PLAY_RATE_HZ} to {MAX_PLAY_RATE_HZ} Hz"
        )));
    }
    let hold = hold_limit(args.hold_timeout)?;
    let points = trajectory_file::load(&args.file, &ctx.model)?;
    let trajectory = to_trajectory(&points)?;
    let defaults = StreamOptions::default();
    let period = Duration::from_secs_f64(1.0 / args.rate);
    let options = StreamOptions {
        mode: match args.mode {
            PlayMode::Stream => defaults.mode,
            PlayMode::Waypoints => StreamMode::Waypoints,
        },
        period,
        // A gap of two periods (at least the default) before the stream counts as starved.
        max_gap: defaults.max_gap.max(period * 2),
        hold_timeout: hold,
        ..defaults
    };
    // The same check the client makes before it sends (rate, ranges, speeds, steps, and for
    // command 7 every target the controller can extrapolate to).
    options.validate(&ctx.model, &trajectory).map_err(|e| {
        let e = CliError::input(format!("{}: {e}", args.file.display()));
        match e.message.contains("steps") {
            true => e.with_remedy("slow the trajectory down, or play it at a higher --rate"),
            false => e,
        }
    })?;
    // One thread: the stream's pacing, its round trips and the keep-alive task share it, so a
    // sample wakes no other thread (docs/PERFORMANCE.md, "Client").
    with_robot_on(
        runtime_one_thread()?,
        ctx,
        async |robot: &Robot, stop: &Interrupt| {
            let first = trajectory.first();
            let here = robot.poll().await.map_err(client_error)?.joints;
            let away = here.max_abs_diff(&first) > options.start_tolerance_deg;
            if away && !args.approach {
                return Err(CliError::input(format!(
                    "the robot is at {here} but the trajectory starts at {first}; nothing was sent"
                ))
                .with_remedy(format!(
                "move there first (fs020n move …), or add --approach to do it with a joint move \
                 at --speed ({speed} %)"
            )));
            }
            robot.preflight().await.map_err(client_error)?;
            robot.set_speed(speed).await.map_err(client_error)?;
            robot.start().await.map_err(client_error)?;
            if away {
                let h = robot.move_joints(first).await.map_err(client_error)?;
                let timeout = h.planned_duration() * 2 + Duration::from_secs(5);
                let completion = Completion {
                    timeout: Some(timeout),
                    hold_timeout: hold,
                    ..Completion::default()
                };
                tokio::select! {
                    r = h.wait(completion) => {
                        r.map_err(client_error)?;
                    }
                    () = stop.wait() => {
                        let _ = h.cancel().await;
                        return Err(interrupted());
                    }
                }
            }
            let report = stream(ctx, robot, stop, trajectory, options, true).await?;
            print_stream_report(&report, ctx.json);
            Ok(())
        },
    )
}

/// Lowest `play --rate`, Hz (the client allows at most 500 ms between samples).
pub(crate) const MIN_PLAY_RATE_HZ: f64 = 4.0;
/// Highest `play --rate`, Hz.
pub(crate) const MAX_PLAY_RATE_HZ: f64 = 500.0;

/// A stream report as JSON, durations in seconds.
pub(crate) fn stream_report_json(r: &StreamReport) -> serde_json::Value {
    json!({
        "outcome": r.outcome,
        "samples_sent": r.samples_sent,
        "late_replies": r.late_replies,
        "underruns": r.underruns,
        "tracking_error_max_deg": r.tracking_error_max_deg,
        "tracking_error_rms_deg": r.tracking_error_rms_deg,
        "tracking_samples": r.tracking_samples,
        "final_error_deg": r.final_error_deg,
        "settled": r.settled,
        "duration_s": r.duration.as_secs_f64(),
        "rtt_mean_s": r.rtt_mean.as_secs_f64(),
        "rtt_max_s": r.rtt_max.as_secs_f64(),
        "lag_s": r.lag_s,
        "lead_s": r.lead_s,
    })
}

/// Prints a stream report.
pub(crate) fn print_stream_report(r: &StreamReport, as_json: bool) {
    if as_json {
        println!("{}", stream_report_json(r));
        return;
    }
    println!(
        "stream {}: {} samples in {:.2} s; tracking error max {:.3} deg, rms {:.3} deg, lag {}, lead {:.0} ms; final error {:.3} deg ({}); late replies {}, underruns {}; round trip mean {:.2} ms, max {:.2} ms",
        match r.outcome {
            StreamOutcome::Completed => "completed",
            StreamOutcome::Cancelled => "cancelled",
        },
        r.samples_sent,
        r.duration.as_secs_f64(),
        r.tracking_error_max_deg,
        r.tracking_error_rms_deg,
        r.lag_s
            .map_or_else(|| "n/a".to_owned(), |l| format!("{:.0} ms", l * 1e3)),
        r.lead_s * 1e3,
        r.final_error_deg,
        if r.settled { "settled" } else { "not settled" },
        r.late_replies,
        r.underruns,
        r.rtt_mean.as_secs_f64() * 1e3,
        r.rtt_max.as_secs_f64() * 1e3,
    );
}
