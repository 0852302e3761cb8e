//! The optional curvature boost of command 7 (`CurvatureCompensation`) against the emulator on
//! virtual time: a boosted sample that would leave a joint range is sent unboosted, the stream
//! completes and the arm stays inside its ranges; out-of-range options are refused before
//! anything is sent.

mod common;

use common::*;
use fs020n_client::{
    CurvatureCompensation, StreamOptions, TargetPacing, Trajectory, TrajectoryPoint,
};
use fs020n_kin::RobotModel;
use fs020n_proto::JointsDeg;

/// JT1 from home to `crest_deg` and at rest there: 40°/s² of acceleration, then 40°/s² of
/// deceleration to the crest (2 s each at a 160° crest), then 1 s still. Every command-7 sample
/// of the deceleration extrapolates along the path itself (a parabola whose vertex is the
/// crest); boosted by `g · 40°/s²` it would overshoot the crest by that much.
fn brake_to(crest_deg: f64) -> Trajectory {
    let accel = 40.0;
    let half = (crest_deg / accel).sqrt();
    let points = (0..)
        .map(|k| f64::from(k) * 0.01)
        .take_while(|&t| t <= 2.0 * half + 1.0)
        .map(|t| {
            let j1 = if t <= half {
                0.5 * accel * t * t
            } else if t <= 2.0 * half {
                crest_deg - 0.5 * accel * (2.0 * half - t).powi(2)
            } else {
                crest_deg
            };
            TrajectoryPoint::new(t, JointsDeg::new([j1, 0.0, -90.0, 0.0, -90.0, 0.0]))
        })
        .collect();
    Trajectory::new(points).unwrap()
}

#[tokio::test(start_paused = true)]
async fn a_boost_that_would_leave_a_joint_range_is_sent_unboosted_and_the_stream_completes() {
    let model = RobotModel::fs020n();
    let limit = model.joints[0].max_deg;
    let boost = CurvatureCompensation::Fixed {
        gain_s2: CurvatureCompensation::LIMIT_S2,
        max_deg: CurvatureCompensation::MAX_CORRECTION_DEG,
    };
    let options = StreamOptions {
        curvature_compensation: boost,
        target_pacing: TargetPacing::Extrapolated,
        ..StreamOptions::default()
    };
    // The plain samples pass every check; boosted by 0.02 s² × 40°/s² = 0.8° near the crest,
    // they would be 0.5° beyond the limit.
    let crest = limit - 0.3;
    options.validate(&model, &brake_to(crest)).unwrap();

    let emu = emulator();
    let robot = ready(&emu, 100.0).await;
    let report = robot
        .stream(brake_to(crest), options)
        .await
        .unwrap()
        .wait()
        .await
        .unwrap();
    robot.close().await.unwrap();
    assert_eq!(report.curvature_gain_s2, CurvatureCompensation::LIMIT_S2);
    // A target outside the range would have raised E1088 and failed the stream above.
    assert!(report.final_error_deg < 0.5, "{report:?}");
    let j1 = emu.with(|c| c.arm().joints()[0]);
    assert!(j1 <= limit && (j1 - crest).abs() < 0.5, "JT1 at {j1}°");
}

#[tokio::test(start_paused = true)]
async fn a_curvature_gain_or_bound_out_of_range_or_a_boost_of_held_targets_is_refused_before_sending(
) {
    let emu = emulator();
    let robot = ready(&emu, 100.0).await;
    for curvature in [
        CurvatureCompensation::Fixed {
            gain_s2: 0.5,
            max_deg: 1.0,
        },
        CurvatureCompensation::Fixed {
            gain_s2: 0.002,
            max_deg: 10.0,
        },
        CurvatureCompensation::Fixed {
            gain_s2: f64::NAN,
            max_deg: 1.0,
        },
    ] {
        let options = StreamOptions {
            curvature_compensation: curvature,
            target_pacing: TargetPacing::Extrapolated,
            ..StreamOptions::default()
        };
        let before = emu.with(|c| c.counters().effective_requests);
        let err = robot.stream(brake_to(100.0), options).await.unwrap_err();
        assert!(err.to_string().contains("must be from 0"), "{err}");
        assert_eq!(emu.with(|c| c.counters().effective_requests), before);
    }
    // A valid boost with held targets (the default pacing), which carry no velocity to
    // correct, is refused too.
    let options = StreamOptions {
        curvature_compensation: CurvatureCompensation::Fixed {
            gain_s2: 0.002,
            max_deg: 1.0,
        },
        ..StreamOptions::default()
    };
    let before = emu.with(|c| c.counters().effective_requests);
    let err = robot.stream(brake_to(100.0), options).await.unwrap_err();
    assert!(err.to_string().contains("target_pacing"), "{err}");
    assert_eq!(emu.with(|c| c.counters().effective_requests), before);
    robot.close().await.unwrap();
}
