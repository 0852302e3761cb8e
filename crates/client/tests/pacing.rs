//! Held command-7 targets (`TargetPacing::Held`, the default) against samples the controller
//! extrapolates on every pass (`TargetPacing::Extrapolated`), on the emulated controller on
//! virtual time: `examples/circle.csv` and a faster figure eight, at 50 and 250 Hz, each over
//! the four start phases of the motion program's 4 ms pass loop (a single run is one draw).

mod common;

use std::time::Duration;

use common::*;
use fs020n_client::{
    StreamMode, StreamOptions, StreamReport, TargetPacing, Trajectory, TrajectoryPoint,
};
use fs020n_proto::JointsDeg;
use fs020n_sim::Fault;

/// JT1/JT3 in a figure eight with JT5 turning, 5 s, the tool up to ≈ 0.7 m/s (twice the
/// circle's speed).
fn figure_eight() -> Trajectory {
    let points = (0..=250)
        .map(|k| {
            let t = f64::from(k) * 0.02;
            let u = t / 5.0;
            let tau = std::f64::consts::TAU;
            let phase = tau * (u - (tau * u).sin() / tau);
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
    Trajectory::new(points).unwrap()
}

const CMD7: StreamMode = StreamMode::Extrapolated {
    lookahead_passes: 2.0,
};

/// One stream started `phase_ms` after the program: its report and the moves the controller
/// started during it.
async fn run(
    path: Trajectory,
    mode: StreamMode,
    pacing: TargetPacing,
    period: Duration,
    phase_ms: u64,
) -> (StreamReport, u64) {
    let emu = emulator();
    let robot = ready(&emu, 100.0).await;
    tokio::time::sleep(Duration::from_millis(phase_ms)).await;
    let options = StreamOptions {
        mode,
        target_pacing: pacing,
        period,
        ..StreamOptions::default()
    };
    let before = emu.with(|c| c.counters().motions);
    let report = robot
        .stream(path, options)
        .await
        .unwrap()
        .wait()
        .await
        .unwrap();
    let motions = emu.with(|c| c.counters().motions) - before;
    robot.close().await.unwrap();
    (report, motions)
}

/// Mean rms error over the four start phases.
async fn mean_over_phases(path: fn() -> Trajectory, pacing: TargetPacing, period: Duration) -> f64 {
    let mut sum = 0.0;
    for phase_ms in 0..4 {
        sum += run(path(), CMD7, pacing, period, phase_ms)
            .await
            .0
            .tracking_error_rms_deg;
    }
    sum / 4.0
}

const HZ_50: Duration = Duration::from_millis(20);
const HZ_250: Duration = Duration::from_millis(4);

#[tokio::test(start_paused = true)]
async fn held_targets_track_the_circle_at_50_hz_within_a_tenth_of_the_waypoints_error_at_every_start_phase(
) {
    let (waypoints, _) = run(
        circle_csv(),
        StreamMode::Waypoints,
        TargetPacing::Held,
        HZ_50,
        0,
    )
    .await;
    let w = waypoints.tracking_error_rms_deg;
    assert!(w > 0.3, "the waypoints lag the circle: {w}");
    for phase_ms in 0..4 {
        let (held, _) = run(circle_csv(), CMD7, TargetPacing::Held, HZ_50, phase_ms).await;
        let (extrapolated, _) = run(
            circle_csv(),
            CMD7,
            TargetPacing::Extrapolated,
            HZ_50,
            phase_ms,
        )
        .await;
        let (h, e) = (
            held.tracking_error_rms_deg,
            extrapolated.tracking_error_rms_deg,
        );
        eprintln!("phase {phase_ms} ms: held {h:.4}°, extrapolated {e:.4}°, waypoints {w:.4}°");
        assert!(
            h <= 0.1 * w,
            "phase {phase_ms} ms: held {h}° vs waypoints {w}°"
        );
        assert!(
            h < 0.5 * e,
            "phase {phase_ms} ms: held {h}° vs extrapolated {e}°"
        );
        assert!(held.settled, "{held:?}");
        // the online lead took over from its start at half a move and stayed near it
        assert!((0.03..0.08).contains(&held.lead_s), "{held:?}");
    }
}

#[tokio::test(start_paused = true)]
async fn held_targets_track_the_faster_figure_eight_better_than_extrapolated_samples_at_50_and_250_hz(
) {
    for period in [HZ_50, HZ_250] {
        let held = mean_over_phases(figure_eight, TargetPacing::Held, period).await;
        let extrapolated = mean_over_phases(figure_eight, TargetPacing::Extrapolated, period).await;
        eprintln!("{period:?}: held {held:.4}°, extrapolated {extrapolated:.4}°");
        assert!(
            held < 0.6 * extrapolated,
            "{period:?}: held {held}° vs extrapolated {extrapolated}°"
        );
    }
}

#[tokio::test(start_paused = true)]
async fn a_held_target_starts_one_move_where_extrapolated_samples_start_one_per_pass() {
    let (held, held_moves) = run(circle_csv(), CMD7, TargetPacing::Held, HZ_50, 0).await;
    let (_, extrapolated_moves) =
        run(circle_csv(), CMD7, TargetPacing::Extrapolated, HZ_50, 0).await;
    // At most one move per sample (one per target, and a target is held for 1–4 samples)...
    assert!(
        held_moves <= held.samples_sent,
        "{held_moves} moves, {} samples",
        held.samples_sent
    );
    assert!(
        held_moves * 4 >= held.samples_sent,
        "{held_moves} moves, {} samples",
        held.samples_sent
    );
    // ...where every pass of the 4 ms loop starts one while the extrapolated target moves.
    assert!(
        extrapolated_moves > 3 * held_moves,
        "{extrapolated_moves} vs {held_moves}"
    );
}

#[tokio::test(start_paused = true)]
async fn held_targets_keep_tracking_when_replies_come_late_and_the_sender_falls_behind() {
    let (quiet, _) = run(circle_csv(), CMD7, TargetPacing::Held, HZ_50, 0).await;
    let (waypoints, _) = run(
        circle_csv(),
        StreamMode::Waypoints,
        TargetPacing::Held,
        HZ_50,
        0,
    )
    .await;
    let emu = emulator();
    let robot = ready(&emu, 100.0).await;
    // A loaded machine: through the fastest part of the circle, every reply comes 30 ms late
    // (more than the 20 ms period), so each sample leaves late, behind its schedule.
    let late = emu.clone();
    let injector = tokio::spawn(async move {
        tokio::time::sleep(Duration::from_millis(2500)).await;
        late.with(|c| {
            c.inject(Fault::DelayReplies {
                count: 25,
                delay_ms: 30,
            })
        });
    });
    let report = robot
        .stream(circle_csv(), StreamOptions::default())
        .await
        .unwrap()
        .wait()
        .await
        .unwrap();
    injector.await.unwrap();
    robot.close().await.unwrap();
    let (h, q, w) = (
        report.tracking_error_rms_deg,
        quiet.tracking_error_rms_deg,
        waypoints.tracking_error_rms_deg,
    );
    eprintln!(
        "loaded {h:.4}° ({} late replies), quiet {q:.4}°, waypoints {w:.4}°",
        report.late_replies
    );
    assert!(report.late_replies >= 20, "{report:?}");
    assert!(h <= 0.1 * w, "loaded {h}° vs quiet {q}°, waypoints {w}°");
}
