//! Where command 7's tracking error comes from: `examples/circle.csv` streamed to an emulated
//! controller on virtual time (reproducible, no scheduling jitter), once per source switched
//! off or changed, and the error of each run (docs/PERFORMANCE.md, "Command-7 tracking").
//!
//! ```text
//! cargo run --release -p fs020n-client --features sim --example tracking_budget
//! ```
//!
//! Rows: the default stream (command 7 at 50 Hz, lead estimated online); the same with the lead
//! fixed at the lag measured without compensation (what a perfect estimate of the controller's
//! pipeline would give); a sweep of fixed leads; at 250 Hz; the waypoints (command 6) it is compared with; and the
//! floors computed from the trajectory: the 0.001° resolution of the reply's joints and the
//! 1 ms resolution of its TIMER(1), by which the report finds the trajectory's time of each reply.
//! Last, the default and the boost over four start phases against the controller's 4 ms pass
//! loop: a single run's figure depends on that phase (the circle at 50 Hz: 0.091–0.157°).
//! Rows with a fixed curvature boost (`CurvatureCompensation::Fixed`, off by default) show what
//! a feed-forward on the path's acceleration does on both paths.
//! Then the same comparison on a second, faster path (a figure eight), so that a change is
//! judged on more than the circle.

use std::time::Duration;

use fs020n_client::emulated::{ControllerConfig, Emulator, EmulatorConnector};
use fs020n_client::{
    ClientConfig, ClientError, CurvatureCompensation, JointsDeg, LagCompensation, Robot,
    StreamMode, StreamOptions, StreamReport, TargetPacing, Trajectory, TrajectoryPoint,
};

fn circle() -> Result<Trajectory, Box<dyn std::error::Error>> {
    let text = include_str!("../../../examples/circle.csv");
    let points: Vec<TrajectoryPoint> = text
        .lines()
        .filter(|l| !l.starts_with('#') && !l.starts_with("time") && !l.trim().is_empty())
        .filter_map(|l| {
            let v: Vec<f64> = l.split(',').filter_map(|x| x.trim().parse().ok()).collect();
            (v.len() == 7).then(|| {
                TrajectoryPoint::new(v[0], JointsDeg::new([v[1], v[2], v[3], v[4], v[5], v[6]]))
            })
        })
        .collect();
    Ok(Trajectory::new(points)?)
}

/// A second path, unlike the circle: a figure eight of JT1/JT3 with JT5 turning, 5 s, slower
/// in one axis and twice as fast in the other, at 50 Hz.
fn figure_eight() -> Result<Trajectory, Box<dyn std::error::Error>> {
    let points: Vec<TrajectoryPoint> = (0..=250)
        .map(|k| {
            let t = f64::from(k) * 0.02;
            // Smooth start and stop: the phase follows a cycloid from 0 to 2π.
            let u = t / 5.0;
            let phase = std::f64::consts::TAU
                * (u - (std::f64::consts::TAU * u).sin() / std::f64::consts::TAU);
            TrajectoryPoint::new(
                t,
                JointsDeg::new([
                    15.0 * phase.sin(),
                    0.0,
                    -90.0 + 6.0 * (2.0 * phase).sin(),
                    0.0,
                    -90.0 + 10.0 * (1.0 - phase.cos()),
                    0.0,
                ]),
            )
        })
        .collect();
    Ok(Trajectory::new(points)?)
}

async fn run(
    mode: StreamMode,
    lag: LagCompensation,
    period: Duration,
) -> Result<StreamReport, Box<dyn std::error::Error>> {
    Ok(run_path(circle()?, mode, lag, CurvatureCompensation::Off, period).await?)
}

/// One run with every sample extrapolated by the controller (the pacing before held targets).
async fn run_path(
    path: Trajectory,
    mode: StreamMode,
    lag: LagCompensation,
    curvature: CurvatureCompensation,
    period: Duration,
) -> Result<StreamReport, ClientError> {
    let pacing = TargetPacing::Extrapolated;
    run_phase(path, mode, lag, curvature, pacing, period, Duration::ZERO).await
}

/// One run with held targets (the default).
async fn run_held(
    path: Trajectory,
    lag: LagCompensation,
    period: Duration,
) -> Result<StreamReport, ClientError> {
    let (flat, held) = (CurvatureCompensation::Off, TargetPacing::Held);
    run_phase(path, LOOK, lag, flat, held, period, Duration::ZERO).await
}

/// Command 7 with the default look-ahead of two passes.
const LOOK: StreamMode = StreamMode::Extrapolated {
    lookahead_passes: 2.0,
};

/// One run, the stream started `phase` later than the others: the controller's motion
/// program passes every 4 ms, so a start 1, 2 or 3 ms later meets its passes at another phase.
async fn run_phase(
    path: Trajectory,
    mode: StreamMode,
    lag: LagCompensation,
    curvature: CurvatureCompensation,
    pacing: TargetPacing,
    period: Duration,
    phase: Duration,
) -> Result<StreamReport, ClientError> {
    let emulator = Emulator::new(ControllerConfig::default());
    let robot =
        Robot::connect_with(EmulatorConnector::new(&emulator), ClientConfig::default()).await?;
    robot.set_speed(100.0).await?;
    robot.start().await?;
    let options = StreamOptions {
        mode,
        lag_compensation: lag,
        curvature_compensation: curvature,
        target_pacing: pacing,
        period,
        ..StreamOptions::default()
    };
    tokio::time::sleep(phase).await;
    let report = robot.stream(path, options).await?.wait().await?;
    robot.close().await?;
    Ok(report)
}

/// rms error over the four start phases against the 4 ms pass loop (1 ms apart, the
/// resolution of TIMER(1)): mean, least, largest. A single run is one draw of these.
async fn over_phases(
    path: fn() -> Result<Trajectory, Box<dyn std::error::Error>>,
    mode: StreamMode,
    lag: LagCompensation,
    curvature: CurvatureCompensation,
    pacing: TargetPacing,
    period: Duration,
) -> Result<(f64, f64, f64), Box<dyn std::error::Error>> {
    let mut rms = Vec::new();
    for ms in 0..4u64 {
        let r = run_phase(
            path()?,
            mode,
            lag,
            curvature,
            pacing,
            period,
            Duration::from_millis(ms),
        )
        .await?;
        rms.push(r.tracking_error_rms_deg);
    }
    let mean = rms.iter().sum::<f64>() / rms.len() as f64;
    let min = rms.iter().copied().fold(f64::INFINITY, f64::min);
    let max = rms.iter().copied().fold(0.0, f64::max);
    Ok((mean, min, max))
}

fn row(name: &str, r: &StreamReport) {
    println!(
        "{name:<62} rms {:.4}°  max {:.4}°  lag {:>7}  lead {:.1} ms  gain {:.4} s²",
        r.tracking_error_rms_deg,
        r.tracking_error_max_deg,
        r.lag_s
            .map_or("-".to_string(), |l| format!("{:.1} ms", l * 1e3)),
        r.lead_s * 1e3,
        r.curvature_gain_s2
    );
}

#[tokio::main(flavor = "current_thread", start_paused = true)]
async fn main() -> Result<(), Box<dyn std::error::Error>> {
    let look = LOOK;
    let p50 = Duration::from_millis(20);
    let p250 = Duration::from_millis(4);
    let online = LagCompensation::default();
    // The curvature boost that fared best on the circle in the sweep below.
    let curved = CurvatureCompensation::Fixed {
        gain_s2: 0.002,
        max_deg: 1.0,
    };
    let flat = CurvatureCompensation::Off;

    // Held targets (the default pacing), then every sample extrapolated (the pacing before).
    let held = run_held(circle()?, online, p50).await?;
    row(
        "command 7, 50 Hz, held targets, lead online (the default)",
        &held,
    );
    let held_fast = run_held(circle()?, online, p250).await?;
    row("command 7, 250 Hz, held targets, lead online", &held_fast);
    let held_off = run_held(circle()?, LagCompensation::Off, p50).await?;
    row("command 7, 50 Hz, held targets, no lead", &held_off);
    let base = run(look, online, p50).await?;
    row("command 7, 50 Hz, extrapolated, lead online", &base);
    let lead_only = base.clone();
    let off = run(look, LagCompensation::Off, p50).await?;
    row("command 7, 50 Hz, no lead, curvature off", &off);
    let lag = Duration::from_secs_f64(off.lag_s.unwrap_or(0.0).clamp(0.0, 0.5));
    let oracle = run(look, LagCompensation::Fixed(lag), p50).await?;
    row("command 7, 50 Hz, lead fixed at the measured lag", &oracle);
    // The error against a fixed lead: where its minimum lies, and how flat it is.
    for lead_ms in [30u64, 42, 54] {
        let r = run(
            look,
            LagCompensation::Fixed(Duration::from_millis(lead_ms)),
            p50,
        )
        .await?;
        row(&format!("command 7, 50 Hz, lead fixed at {lead_ms} ms"), &r);
    }
    // The error against a fixed curvature gain, with the lead online.
    for gain_s2 in [0.001, 0.002, 0.004, 0.006] {
        let fixed = CurvatureCompensation::Fixed {
            gain_s2,
            max_deg: 1.0,
        };
        let r = run_path(circle()?, look, online, fixed, p50).await?;
        row(
            &format!("command 7, 50 Hz, lead online, gain fixed at {gain_s2} s²"),
            &r,
        );
    }
    let fast_lead_only = run(look, online, p250).await?;
    row(
        "command 7, 250 Hz, extrapolated, lead online",
        &fast_lead_only,
    );
    let fast = run_path(circle()?, look, online, curved, p250).await?;
    row(
        "command 7, 250 Hz, lead online, gain fixed at 0.002 s²",
        &fast,
    );
    let boosted = run_path(circle()?, look, online, curved, p50).await?;
    let waypoints = run(StreamMode::Waypoints, LagCompensation::Off, p50).await?;
    row("command 6 waypoints, 50 Hz", &waypoints);

    // Floors of the measurement itself, from the trajectory: a reply's joints are rounded to
    // 0.001° (uniform error, rms 0.001/√12 per joint), and its TIMER(1) to 1 ms, so the
    // trajectory is read up to 1 ms off: rms of (largest joint speed × uniform 0–1 ms), with the
    // mean half millisecond a constant lag the lead absorbs, the rest ±0.5 ms.
    let t = circle()?;
    let (t0, t1) = (t.start_s(), t.end_s());
    let (mut sq, mut n) = (0.0, 0u32);
    let mut tau = t0;
    while tau + 0.001 <= t1 {
        let step = t
            .sample(tau + 0.001)
            .position
            .max_abs_diff(&t.sample(tau).position);
        // Uniform over ±0.5 ms: rms = speed × 1 ms / √12.
        sq += (step / 12f64.sqrt()).powi(2);
        n += 1;
        tau += 0.02;
    }
    let timer_floor = (sq / f64::from(n.max(1))).sqrt();
    println!(
        "{:<62} rms {:.4}°",
        "floor: reply joints rounded to 0.001°",
        0.001 / 12f64.sqrt()
    );
    println!(
        "{:<62} rms {:.4}°",
        "floor: TIMER(1) in whole milliseconds (±0.5 ms)", timer_floor
    );
    // The same comparison on another path, so that a choice is not tuned to the circle.
    let e50_held = run_held(figure_eight()?, online, p50).await?;
    row(
        "figure eight: command 7, 50 Hz, held targets (default)",
        &e50_held,
    );
    let e250_held = run_held(figure_eight()?, online, p250).await?;
    row("figure eight: command 7, 250 Hz, held targets", &e250_held);
    let e50_flat = run_path(figure_eight()?, look, online, flat, p50).await?;
    row(
        "figure eight: command 7, 50 Hz, extrapolated, lead online",
        &e50_flat,
    );
    let e250_flat = run_path(figure_eight()?, look, online, flat, p250).await?;
    row(
        "figure eight: command 7, 250 Hz, extrapolated, lead online",
        &e250_flat,
    );
    let e50 = run_path(figure_eight()?, look, online, curved, p50).await?;
    row(
        "figure eight: command 7, 50 Hz, gain fixed at 0.002 s²",
        &e50,
    );
    let e250 = run_path(figure_eight()?, look, online, curved, p250).await?;
    row(
        "figure eight: command 7, 250 Hz, gain fixed at 0.002 s²",
        &e250,
    );
    let eight_waypoints = run_path(
        figure_eight()?,
        StreamMode::Waypoints,
        LagCompensation::Off,
        flat,
        p50,
    )
    .await?;
    row("figure eight: command 6 waypoints, 50 Hz", &eight_waypoints);
    let ratio =
        |r: &StreamReport, w: &StreamReport| r.tracking_error_rms_deg / w.tracking_error_rms_deg;
    println!(
        "ratio command 7 held ÷ command 6: circle 50 Hz {:.3}, 250 Hz {:.3}; figure eight 50 Hz {:.3}, 250 Hz {:.3}",
        ratio(&held, &waypoints),
        ratio(&held_fast, &waypoints),
        ratio(&e50_held, &eight_waypoints),
        ratio(&e250_held, &eight_waypoints),
    );
    println!(
        "circle, ratio command 7 extrapolated ÷ command 6: lead online 50 Hz {:.3}, 250 Hz {:.3}; gain 0.002 s² 50 Hz {:.3}, 250 Hz {:.3}",
        ratio(&lead_only, &waypoints),
        ratio(&fast_lead_only, &waypoints),
        ratio(&boosted, &waypoints),
        ratio(&fast, &waypoints),
    );
    println!(
        "figure eight, ratio command 7 extrapolated ÷ command 6: lead online 50 Hz {:.3}, 250 Hz {:.3}; gain 0.002 s² 50 Hz {:.3}, 250 Hz {:.3}",
        ratio(&e50_flat, &eight_waypoints),
        ratio(&e250_flat, &eight_waypoints),
        ratio(&e50, &eight_waypoints),
        ratio(&e250, &eight_waypoints),
    );
    // The same, over the four start phases against the controller's pass loop: every figure
    // above is one of four draws.
    println!("over 4 start phases (0–3 ms later), rms mean (least–largest), ratio of the mean to command 6's:");
    for (name, path, w) in [
        ("circle", circle as fn() -> _, &waypoints),
        ("figure eight", figure_eight as fn() -> _, &eight_waypoints),
    ] {
        for (rate, period) in [("50 Hz", p50), ("250 Hz", p250)] {
            for (what, c, pacing) in [
                ("held (default)", flat, TargetPacing::Held),
                ("extrapolated", flat, TargetPacing::Extrapolated),
                ("extr. + gain 0.002 s²", curved, TargetPacing::Extrapolated),
            ] {
                let (mean, min, max) = over_phases(path, look, online, c, pacing, period).await?;
                println!(
                    "  {name:<12} {rate:<6} {what:<22} {mean:.4}° ({min:.4}–{max:.4}°)  ratio {:.3}",
                    mean / w.tracking_error_rms_deg
                );
            }
        }
    }
    Ok(())
}
