//! The emulator's planner for the motions an AS program asks beyond JMOVE and LMOVE, on
//! virtual time: the circle of `C1MOVE`/`C2MOVE` (through the via point, on the circle,
//! at the program's speed), its E1099, the orientation of `DRAW`/`TDRAW` with rotations, and
//! `XMOVE … TILL` cut short by a scripted input.
#![allow(clippy::expect_used, clippy::unwrap_used)] // test code: a failure is a failed test

use std::time::Duration;

use fs020n_kin::{Pose, Xyzoat};
use fs020n_proto::ErrorCode;
use fs020n_sim::{Controller, ControllerConfig, ServerProgram};

fn ms(v: u64) -> Duration {
    Duration::from_millis(v)
}

/// A controller at monitor speed 100 % whose `autostart.pc` starts the robot program `rob`
/// with `body`.
fn controller(body: &str) -> Controller {
    let src =
        format!(".PROGRAM autostart.pc()\n  MC EXECUTE rob\n.END\n.PROGRAM rob()\n{body}\n.END\n");
    let program = ServerProgram::from_source("t.as", &src).unwrap();
    assert!(program.warnings().is_empty(), "{:?}", program.warnings());
    let mut c = Controller::with_program(ControllerConfig::default(), program);
    c.set_monitor_speed(100.0).unwrap();
    c
}

fn flange(c: &Controller) -> Pose {
    c.model().forward(&c.joints().to_rad())
}

fn position_mm(p: &Pose) -> [f64; 3] {
    let v = p.position_m() * 1000.0;
    [v[0], v[1], v[2]]
}

fn distance_mm(a: [f64; 3], b: [f64; 3]) -> f64 {
    (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt()
}

fn pose(v: [f64; 6]) -> Pose {
    Pose::from_xyzoat(Xyzoat {
        x_mm: v[0],
        y_mm: v[1],
        z_mm: v[2],
        o_deg: v[3],
        a_deg: v[4],
        t_deg: v[5],
    })
}

/// A half circle of radius 100 mm in the horizontal plane z = 600, centre (1000, 0), the tool
/// pointing down, at 100 mm/s: 314 mm in about 3.14 s.
const ARC: &str = "  SPEED 100 MM/S ALWAYS\n  LMOVE TRANS(900, 0, 600, 0, 180, 0)\n  BREAK\n  SIGNAL 1\n  C1MOVE TRANS(1000, 100, 600, 0, 180, 0)\n  C2MOVE TRANS(1100, 0, 600, 0, 180, 0)\n  BREAK\n  SIGNAL 2";

#[test]
fn the_arm_follows_the_circle_through_the_via_point_at_the_program_speed() {
    let mut c = controller(ARC);
    // To the start.
    let mut t = 0;
    while c.program().signal(1) != Some(true) {
        c.advance_by(ms(2));
        t += 2;
        assert!(t < 20_000, "never reached the start");
    }
    let started = t;
    let centre = [1000.0, 0.0, 600.0];
    let (mut worst_radius, mut nearest_via, mut worst_z) = (0.0f64, f64::MAX, 0.0f64);
    let mut moving_since = None;
    while c.program().signal(2) != Some(true) {
        c.advance_by(ms(2));
        t += 2;
        assert!(t < 40_000, "never reached the end");
        let p = position_mm(&flange(&c));
        if moving_since.is_none() && distance_mm(p, [900.0, 0.0, 600.0]) > 0.01 {
            moving_since = Some(t);
        }
        let r = ((p[0] - centre[0]).powi(2) + (p[1] - centre[1]).powi(2)).sqrt();
        worst_radius = worst_radius.max((r - 100.0).abs());
        worst_z = worst_z.max((p[2] - 600.0).abs());
        nearest_via = nearest_via.min(distance_mm(p, [1000.0, 100.0, 600.0]));
        // The tool keeps pointing down (start, via and end all do).
        assert!(flange(&c).z_axis()[2] < -0.9999, "tilted at {p:?}");
    }
    assert!(c.error().is_none(), "{}", c.error());
    assert!(worst_radius < 0.5, "off the circle by {worst_radius} mm");
    assert!(worst_z < 0.5, "off the plane by {worst_z} mm");
    assert!(
        nearest_via < 0.5,
        "missed the via point by {nearest_via} mm"
    );
    let end = position_mm(&flange(&c));
    assert!(distance_mm(end, [1100.0, 0.0, 600.0]) < 0.01, "{end:?}");
    // Arc length / speed: π · 100 mm at 100 mm/s (from the C2MOVE, issued when the program
    // set output 1, to the BREAK after it).
    assert!(moving_since.is_some_and(|m| m > started));
    let took_s = (t - started) as f64 / 1000.0;
    assert!(
        (took_s - std::f64::consts::PI).abs() < 0.05,
        "took {took_s} s"
    );
}

#[test]
fn collinear_circle_points_raise_e1099_and_the_arm_stays() {
    let mut c = controller(
        "  SPEED 100 MM/S ALWAYS\n  LMOVE TRANS(900, 0, 600, 0, 180, 0)\n  BREAK\n  C1MOVE TRANS(1000, 0, 600, 0, 180, 0)\n  C2MOVE TRANS(1100, 0, 600, 0, 180, 0)",
    );
    c.advance_by(ms(20_000));
    assert_eq!(c.error(), ErrorCode::NO_ARC_THROUGH_POINTS);
    let p = position_mm(&flange(&c));
    assert!(distance_mm(p, [900.0, 0.0, 600.0]) < 0.01, "{p:?}");
}

#[test]
fn a_circle_out_of_reach_raises_e1088() {
    // A circle of 1.5 m radius around the base: most of it beyond the arm's reach.
    let mut c = controller(
        "  LMOVE TRANS(900, 0, 600, 0, 180, 0)\n  BREAK\n  C1MOVE TRANS(-600, 1500, 600, 0, 180, 0)\n  C2MOVE TRANS(900, 10, 600, 0, 180, 0)",
    );
    c.advance_by(ms(20_000));
    assert_eq!(c.error(), ErrorCode::DESTINATION_OUT_OF_RANGE);
}

#[test]
fn draw_and_tdraw_with_rotations_reach_the_turned_pose() {
    let mut c = controller(
        "  LMOVE TRANS(900, 100, 600, 0, 180, 0)\n  BREAK\n  DRAW 10, 0, -20, 30, 0, 0\n  BREAK\n  SIGNAL 1\n  SWAIT 1001\n  TDRAW 0, 0, 10, 0, 15, 0\n  BREAK\n  SIGNAL 2",
    );
    let mut t = 0;
    while c.program().signal(1) != Some(true) {
        c.advance_by(ms(10));
        t += 10;
        assert!(t < 30_000);
    }
    // About the world's Z by 30°, at the offset position.
    let want = pose([910.0, 100.0, 580.0, 30.0, 180.0, 0.0]);
    let got = flange(&c);
    assert!(got.distance_m(&want) < 1e-5, "{:?}", got.to_xyzoat());
    assert!(got.angle_to_rad(&want) < 1e-5, "{:?}", got.to_xyzoat());
    c.program_mut().set_input(1001, true);
    while c.program().signal(2) != Some(true) {
        c.advance_by(ms(10));
        t += 10;
        assert!(t < 60_000);
    }
    // Then 10 mm along and 15° about the tool's own Y.
    let want = want * pose([0.0, 0.0, 10.0, 0.0, 15.0, 0.0]);
    let got = flange(&c);
    assert!(got.distance_m(&want) < 1e-5, "{:?}", got.to_xyzoat());
    assert!(got.angle_to_rad(&want) < 1e-5, "{:?}", got.to_xyzoat());
    assert!(c.error().is_none());
}

#[test]
fn xmove_stops_on_the_scripted_input_and_the_program_goes_on() {
    let mut c = controller(
        "  SPEED 100 MM/S ALWAYS\n  LMOVE TRANS(900, -200, 600, 0, 180, 0)\n  BREAK\n  SIGNAL 1\n  XMOVE TRANS(900, 200, 600, 0, 180, 0) TILL 1001\n  SIGNAL 2",
    );
    let mut t = 0;
    while c.program().signal(1) != Some(true) {
        c.advance_by(ms(2));
        t += 2;
        assert!(t < 20_000);
    }
    // 1 s into the 4 s line: about 100 mm along (the profile is slower at its start).
    c.advance_by(ms(1000));
    assert_eq!(c.program().signal(2), Some(false), "XMOVE waits");
    let at_signal = position_mm(&flange(&c));
    assert!(at_signal[1] > -195.0 && at_signal[1] < 0.0, "{at_signal:?}");
    c.program_mut().set_input(1001, true);
    c.advance_by(ms(10));
    assert_eq!(c.program().signal(2), Some(true), "the program went on");
    c.advance_by(ms(3000));
    let rest = position_mm(&flange(&c));
    // Braked to a stop shortly after the signal, far from the destination.
    assert!(rest[1] - at_signal[1] < 20.0, "{at_signal:?} → {rest:?}");
    assert!(rest[1] < 100.0, "{rest:?}");
    assert!(c.error().is_none());
}

#[test]
fn xmove_without_the_input_reaches_the_destination() {
    let mut c = controller(
        "  SPEED 200 MM/S ALWAYS\n  LMOVE TRANS(900, -200, 600, 0, 180, 0)\n  BREAK\n  XMOVE TRANS(900, 200, 600, 0, 180, 0) TILL 1001\n  SIGNAL 2",
    );
    c.advance_by(ms(15_000));
    assert_eq!(c.program().signal(2), Some(true));
    let p = position_mm(&flange(&c));
    assert!(distance_mm(p, [900.0, 200.0, 600.0]) < 0.01, "{p:?}");
}
