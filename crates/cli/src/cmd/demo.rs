//! `demo`: the newcomer's first run, on the embedded emulator.

use std::time::Duration;

use fs020n_client::{Completion, Robot, StreamOptions, Trajectory, TrajectoryPoint};
use fs020n_kin::Pose;
use fs020n_proto::JointsDeg;
use nalgebra::Vector3;
use serde_json::json;

use crate::cmd::bench::measure;
use crate::cmd::play::print_stream_report;
use crate::context::{
    check_speed, close_quietly, connect, robot_or_embedded, runtime, Ctx, Interrupt,
};
use crate::error::client_error;
use crate::error::{CliError, CliResult, Exit};
use crate::output::{joints_json, rtt_line};

/// The poses the demo visits (degrees).
pub(crate) const POSES: [[f64; 6]; 4] = [
    [20.0, 10.0, -80.0, 0.0, -80.0, 0.0],
    [-20.0, 20.0, -70.0, 30.0, -60.0, 45.0],
    [0.0, -10.0, -100.0, -30.0, -70.0, -45.0],
    [0.0, 0.0, -90.0, 0.0, -90.0, 0.0],
];

/// Radius of the demo's streamed circle, metres.
const CIRCLE_RADIUS_M: f64 = 0.10;
/// Duration of the circle, seconds.
const CIRCLE_TIME_S: f64 = 4.0;
/// Trajectory sample spacing, seconds.
const CIRCLE_DT_S: f64 = 0.02;

/// A horizontal circle of the flange starting and ending at `start`, with a smooth start and
/// stop, as joint points with velocities (the solution nearest the previous point at each step).
pub(crate) fn circle(ctx: &Ctx, start: JointsDeg) -> CliResult<Trajectory> {
    let model = &ctx.model;
    let p0 = model.forward(&start.to_rad());
    let centre = p0.position_m() + Vector3::new(0.0, CIRCLE_RADIUS_M, 0.0);
    let n = (CIRCLE_TIME_S / CIRCLE_DT_S).round() as usize;
    let mut seed = start.to_rad();
    let mut positions = Vec::with_capacity(n + 1);
    for k in 0..=n {
        let u = k as f64 / n as f64;
        // Smooth phase: zero speed at both ends.
        let s = u - (2.0 * std::f64::consts::PI * u).sin() / (2.0 * std::f64::consts::PI);
        let angle = -std::f64::consts::FRAC_PI_2 + 2.0 * std::f64::consts::PI * s;
        let pos = centre
            + Vector3::new(
                CIRCLE_RADIUS_M * angle.cos(),
                CIRCLE_RADIUS_M * angle.sin(),
                0.0,
            );
        let q = model
            .inverse_nearest(&Pose::new(pos, p0.rotation()), &seed)
            .map_err(|e| CliError::failure(format!("demo circle: {e}")))?;
        positions.push(q.to_deg());
        seed = q;
    }
    let points: Vec<TrajectoryPoint> = (0..=n)
        .map(|k| {
            let prev = positions[k.saturating_sub(1)];
            let next = positions[(k + 1).min(n)];
            let span = CIRCLE_DT_S * ((k + 1).min(n) - k.saturating_sub(1)) as f64;
            let mut p = TrajectoryPoint::new(k as f64 * CIRCLE_DT_S, positions[k]);
            p.velocity = Some(next.zip_with(&prev, |a, b| (a - b) / span));
            p
        })
        .collect();
    Trajectory::new(points).map_err(|e| CliError::failure(format!("demo circle: {e}")))
}

/// `demo`; with `plot`, a picture of the run (drawn from `ctx.record`).
pub(crate) fn demo(ctx: &Ctx, speed: f64, yes: bool, plot: Option<&std::path::Path>) -> CliResult {
    let speed = check_speed(speed)?;
    if ctx.addr.is_some() && !yes {
        return Err(CliError::input(
            "the demo moves the arm: to run it on the robot given by --robot, add --yes \
             (without --robot it runs on the embedded emulator)",
        ));
    }
    let rt = runtime()?;
    rt.block_on(async {
        let (addr, embedded) = robot_or_embedded(ctx).await?;
        say(ctx, &format!(
            "fs020n demo — {} at {addr}",
            if embedded.is_some() { "embedded FS020N emulator" } else { "robot" }
        ));
        let stop = Interrupt::install();
        let robot = connect(&addr, ctx).await?;
        let result = tokio::select! {
            r = tour(ctx, &robot, speed) => r,
            _ = stop.wait() => {
                let _ = robot.cancel().await;
                Err(CliError::new(Exit::Interrupted, "interrupted: motion cancelled and the session closed"))
            }
        };
        close_quietly(&robot).await;
        let report = result?;
        if let (Some(out), Some(rec)) = (plot, &ctx.record) {
            crate::recording::plot_session(&robot, &rec.path, out, ctx.json).await?;
        }
        if let Some(e) = &embedded {
            let c = e.emulator.with(|c| c.counters());
            say(ctx, &format!(
                "emulator: {} session(s), {} requests ({} acting), {} motions planned, {} program passes, {} errors",
                c.sessions, c.requests, c.effective_requests, c.motions, c.passes, c.errors
            ));
        }
        if ctx.json {
            println!("{report}");
        } else {
            say(ctx, "demo finished: every target reached, the stream tracked, the session closed cleanly");
        }
        Ok(())
    })
}

fn say(ctx: &Ctx, line: &str) {
    if !ctx.json {
        println!("{line}");
    }
}

async fn tour(ctx: &Ctx, robot: &Robot, speed: f64) -> CliResult<serde_json::Value> {
    robot.preflight().await.map_err(client_error)?;
    say(
        ctx,
        "preflight: power ON, RUN, REPEAT, TEACH LOCK OFF, no error — ready",
    );
    robot.set_speed(speed).await.map_err(client_error)?;
    say(ctx, &format!("speed: monitor speed set to {speed} %"));
    robot.start().await.map_err(client_error)?;
    say(ctx, "program: ros_move started (reply field 7 = -1)");

    let mut moves = Vec::new();
    for (i, p) in POSES.iter().enumerate() {
        let target = JointsDeg::new(*p);
        let h = robot.move_joints(target).await.map_err(client_error)?;
        let timeout = h.planned_duration() * 2 + Duration::from_secs(5);
        let r = h
            .wait(Completion {
                tolerance_deg: 0.05,
                settle: Duration::from_millis(50),
                timeout: Some(timeout),
                hold_timeout: None,
            })
            .await
            .map_err(client_error)?;
        say(ctx, &format!(
            "move {}/{}: reached {target} in {:.2} s (planned {:.2} s), largest joint error {:.4} deg",
            i + 1,
            POSES.len(),
            r.elapsed.as_secs_f64(),
            h.planned_duration().as_secs_f64(),
            r.error_deg
        ));
        moves.push(json!({
            "target_deg": joints_json(&target),
            "final_deg": joints_json(&r.final_joints),
            "error_deg": r.error_deg,
            "elapsed_s": r.elapsed.as_secs_f64(),
        }));
    }

    // Streaming: full speed so the 0.1 s straight-line moves of command 7 keep up.
    robot.set_speed(100.0).await.map_err(client_error)?;
    robot.start().await.map_err(client_error)?;
    let here = robot.poll().await.map_err(client_error)?.joints;
    let trajectory = circle(ctx, here)?;
    say(ctx, &format!(
        "stream: a circle of {:.0} mm radius with the flange in {CIRCLE_TIME_S} s, {} samples, command 7 stamped with the estimated controller clock",
        CIRCLE_RADIUS_M * 1000.0,
        trajectory.points().len()
    ));
    // The defaults: the controller's look-ahead of 2 passes (a few ms: `step` is its loop
    // overhead) and the client's online lag compensation, which leads the samples by the lag it
    // measures so that the arm is on the path rather than behind it.
    let options = StreamOptions::default();
    let handle = robot
        .stream(trajectory, options)
        .await
        .map_err(client_error)?;
    let report = handle.wait().await.map_err(client_error)?;
    if !ctx.json {
        print_stream_report(&report, false);
    }
    if let Some(fit) = robot.server_clock() {
        say(ctx, &format!(
            "controller clock estimate: offset {:+.3} ms, rate {:+.0} ppm, from {} reply pairs (residual {:.0} µs)",
            fit.offset_s * 1e3,
            (fit.rate - 1.0) * 1e6,
            fit.pairs,
            fit.residual_s * 1e6
        ));
    }
    let bench = measure(robot, 200).await?;
    let stats = robot.stats();
    say(
        ctx,
        &format!(
        "round trips: {} in this session, {}; late replies {}; 200 back-to-back polls at {:.0}/s",
        stats.rtt.count,
        rtt_line(&stats.rtt),
        stats.late_replies,
        bench.rate_hz
    ),
    );
    if report.outcome != fs020n_client::StreamOutcome::Completed {
        return Err(CliError::new(
            Exit::Motion,
            "the demo stream did not complete",
        ));
    }
    Ok(json!({
        "moves": moves,
        "stream": report,
        "rtt": stats.rtt,
        "bench": bench,
    }))
}
