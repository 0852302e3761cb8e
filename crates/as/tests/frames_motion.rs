//! Frames and the motions they define, on virtual time: `TOOL`, `BASE`, `HERE` as a
//! transformation, `POINT` between joint points and transformations, `APPRO`/`LAPPRO`/`JAPPRO`,
//! `DEPART`/`LDEPART`, `DRAW`/`TDRAW` (with rotations), `ALIGN`.
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

mod common;

use common::{ms, pc, start};
use fs020n_as::system::{MotionKind, Speed, System, Target};
use fs020n_as::Interpreter;
use fs020n_kin::{Pose, Xyzoat};
use fs020n_proto::ErrorCode;

/// The six values a program DECOMPOSEd into the real array `name`.
fn arr(i: &Interpreter, name: &str) -> [f32; 6] {
    std::array::from_fn(|k| {
        i.real_at(name, &[k as i32])
            .unwrap_or_else(|| panic!("{name}[{k}] was not set"))
    })
}

fn close(a: &[f32; 6], b: &[f32; 6], mm: f32, what: &str) {
    for k in 0..6 {
        assert!((a[k] - b[k]).abs() <= mm, "{what}: {a:?} vs {b:?}");
    }
}

/// Runs `body` as the robot program `rob` for `secs` seconds.
fn robot(body: &str, secs: u64) -> (Interpreter, fs020n_as::testing::VirtualSystem) {
    let src = format!("{}.PROGRAM rob()\n{body}\n.END\n", pc("  MC EXECUTE rob"));
    let (mut i, mut s) = start(&src);
    i.run_until(&mut s, ms(secs * 1000));
    assert!(s.raised.is_empty(), "{:?} {:?}", s.raised, s.terminal);
    (i, s)
}

/// A pose of the tool pointing down, reachable from HOME.
const PICK: &str = "TRANS(900, 100, 600, 0, 180, 0)";

#[test]
fn point_converts_between_joint_points_and_transformations() {
    let (i, s) = robot(
        "  POINT .t = #PPOINT(10, 20, -80, 5, -60, 15)\n  DECOMPOSE t[0] = .t\n  POINT #j = .t\n  DECOMPOSE j[0] = #j\n  HERE h\n  DECOMPOSE h[0] = h",
        1,
    );
    close(
        &arr(&i, "j"),
        &[10.0, 20.0, -80.0, 5.0, -60.0, 15.0],
        0.01,
        "IK of the FK",
    );
    let fk = s
        .forward(&[10.0, 20.0, -80.0, 5.0, -60.0, 15.0])
        .expect("kinematics");
    close(
        &arr(&i, "t"),
        &fk.map(|v| v as f32),
        0.01,
        "POINT t = #j is the FK",
    );
    let here = s.pose().expect("kinematics").map(|v| v as f32);
    close(
        &arr(&i, "h"),
        &here,
        0.01,
        "HERE without TOOL or BASE is the flange",
    );
}

#[test]
fn a_compound_here_defines_the_rightmost_variable_so_that_the_sum_is_the_current_pose() {
    // AS-E p.6-108: `HERE a+b` defines b; a must exist. Touch-up of a pick relative to a
    // camera frame, as cells do.
    let (i, s) = robot(
        "  POINT c_cam = TRANS(200, -100, 50, 0, 0, 90)\n  POINT c_tool = TRANS(0, 0, 10)\n  HERE c_cam+pick\n  HERE c_cam+c_tool+pick2\n  DECOMPOSE p[0] = pick\n  DECOMPOSE q[0] = pick2\n  DECOMPOSE w[0] = c_cam+pick\n  DECOMPOSE w2[0] = c_cam+c_tool+pick2",
        1,
    );
    let here = s.pose().expect("kinematics").map(|v| v as f32);
    close(&arr(&i, "w"), &here, 0.01, "c_cam+pick is HERE");
    close(&arr(&i, "w2"), &here, 0.01, "c_cam+c_tool+pick2 is HERE");
    let (p, q) = (arr(&i, "p"), arr(&i, "q"));
    assert!((p[2] - q[2] - 10.0).abs() < 0.01, "{p:?} {q:?}");
    assert!((p[2] - (here[2] - 50.0)).abs() < 0.01, "{p:?} vs {here:?}");
}

#[test]
fn a_compound_here_on_an_undefined_frame_stops_with_e0103() {
    let src = format!(
        "{}.PROGRAM rob()\n  HERE nowhere+pick\n.END\n",
        pc("  MC EXECUTE rob")
    );
    let (mut i, mut s) = start(&src);
    i.run_until(&mut s, ms(100));
    assert_eq!(s.raised, vec![ErrorCode(-30103)]);
}

#[test]
fn point_to_a_joint_point_out_of_reach_stops_with_e1088() {
    let src = format!(
        "{}.PROGRAM rob()\n  POINT #j = TRANS(5000, 0, 0, 0, 0, 0)\n.END\n",
        pc("  MC EXECUTE rob")
    );
    let (mut i, mut s) = start(&src);
    i.run_until(&mut s, ms(100));
    assert_eq!(s.raised, vec![ErrorCode(-31088)]);
}

#[test]
fn tool_makes_here_the_tool_tip_and_moves_put_the_tip_on_the_target() {
    let (i, s) = robot(
        &format!("  HERE f\n  DECOMPOSE f[0] = f\n  TOOL TRANS(0, 0, 150)\n  HERE h\n  DECOMPOSE h[0] = h\n  LMOVE {PICK}\n  BREAK\n  HERE at\n  DECOMPOSE at[0] = at"),
        10,
    );
    let f = arr(&i, "f");
    let h = arr(&i, "h");
    // At HOME the flange points down (A = 180): the tip is 150 mm below it.
    assert!((f[4] - 180.0).abs() < 0.01, "{f:?}");
    close(
        &h,
        &[f[0], f[1], f[2] - 150.0, f[3], f[4], f[5]],
        0.05,
        "TOOL 150 mm along Z",
    );
    close(
        &arr(&i, "at"),
        &[900.0, 100.0, 600.0, 0.0, 180.0, 0.0],
        0.05,
        "tip on the target",
    );
    // The system moved the flange: 150 mm above the target.
    let flange = s.pose().expect("kinematics");
    assert!((flange[2] - 750.0).abs() < 0.05, "{flange:?}");
    match s.motions.last().map(|(_, m)| (m.kind, m.target)) {
        Some((MotionKind::Linear, Target::Pose(p))) => assert!((p[2] - 750.0).abs() < 0.05),
        other => panic!("{other:?}"),
    }
}

#[test]
fn base_moves_the_world_frame() {
    let (i, s) = robot(
        &format!("  BASE TRANS(100, -50, 20, 0, 0, 0)\n  JMOVE {PICK}\n  BREAK\n  HERE at\n  DECOMPOSE at[0] = at\n  BASE NULL\n  HERE raw\n  DECOMPOSE raw[0] = raw"),
        10,
    );
    close(
        &arr(&i, "at"),
        &[900.0, 100.0, 600.0, 0.0, 180.0, 0.0],
        0.05,
        "in the world",
    );
    close(
        &arr(&i, "raw"),
        &[800.0, 150.0, 580.0, 0.0, 180.0, 0.0],
        0.05,
        "in the robot's frame",
    );
    let flange = s.pose().expect("kinematics");
    assert!((flange[0] - 800.0).abs() < 0.05 && (flange[1] - 150.0).abs() < 0.05);
}

#[test]
fn tool_waits_for_the_motion_to_end() {
    let (i, _) = robot(
        "  JMOVE #PPOINT(30, 0, -90, 0, -90, 0)\n  TOOL TRANS(0, 0, 100)\n  t = TIMER(0)",
        2,
    );
    let t = i.real("t").expect("TOOL went on");
    assert!(
        (0.3..0.32).contains(&t),
        "{t}: after the 30° move at 100 °/s"
    );
}

#[test]
fn appro_and_depart_move_along_the_tool_z_axis() {
    let (i, s) = robot(
        &format!("  TOOL TRANS(0, 0, 100)\n  JAPPRO {PICK}, 80\n  BREAK\n  HERE a\n  DECOMPOSE a[0] = a\n  LMOVE {PICK}\n  BREAK\n  LDEPART 120\n  BREAK\n  HERE d\n  DECOMPOSE d[0] = d\n  APPRO {PICK}, 10\n  LAPPRO {PICK}, 20\n  DEPART 30"),
        20,
    );
    // The tool points down: "back along its Z axis" is up.
    close(
        &arr(&i, "a"),
        &[900.0, 100.0, 680.0, 0.0, 180.0, 0.0],
        0.05,
        "JAPPRO 80 mm short",
    );
    close(
        &arr(&i, "d"),
        &[900.0, 100.0, 720.0, 0.0, 180.0, 0.0],
        0.05,
        "LDEPART 120 mm",
    );
    let kinds: Vec<MotionKind> = s.motions.iter().map(|(_, m)| m.kind).collect();
    assert_eq!(
        kinds,
        [
            MotionKind::Joint,
            MotionKind::Linear,
            MotionKind::Linear,
            MotionKind::Joint,
            MotionKind::Linear,
            MotionKind::Joint
        ]
    );
}

#[test]
fn draw_moves_along_the_base_axes_and_tdraw_along_the_tool_axes() {
    let (i, s) = robot(
        &format!("  LMOVE {PICK}\n  BREAK\n  DRAW 10, , -20\n  BREAK\n  HERE a\n  DECOMPOSE a[0] = a\n  TDRAW 0, 5, 30\n  BREAK\n  HERE b\n  DECOMPOSE b[0] = b"),
        10,
    );
    close(
        &arr(&i, "a"),
        &[910.0, 100.0, 580.0, 0.0, 180.0, 0.0],
        0.05,
        "DRAW",
    );
    // Tool pointing down (O 0, A 180, T 0: a half turn about Y): tool Y is world Y, tool Z
    // is world −Z.
    close(
        &arr(&i, "b"),
        &[910.0, 105.0, 550.0, 0.0, 180.0, 0.0],
        0.05,
        "TDRAW",
    );
    assert!(s
        .motions
        .iter()
        .skip(1)
        .all(|(_, m)| m.kind == MotionKind::Linear));
}

/// The kinematics' pose of six values a program DECOMPOSEd.
fn pose(v: &[f32; 6]) -> Pose {
    Pose::from_xyzoat(Xyzoat {
        x_mm: f64::from(v[0]),
        y_mm: f64::from(v[1]),
        z_mm: f64::from(v[2]),
        o_deg: f64::from(v[3]),
        a_deg: f64::from(v[4]),
        t_deg: f64::from(v[5]),
    })
}

/// Column `k` of the pose's rotation (0: the tool's X axis, 2: its Z axis) in the world.
fn axis(p: &Pose, k: usize) -> [f64; 3] {
    let m = p.rotation_matrix();
    [m[(0, k)], m[(1, k)], m[(2, k)]]
}

fn position_mm(p: &Pose) -> [f64; 3] {
    let v = p.position_m();
    [v[0] * 1000.0, v[1] * 1000.0, v[2] * 1000.0]
}

fn axis_close(got: [f64; 3], want: [f64; 3], tolerance: f64, what: &str) {
    let d = (0..3).map(|k| (got[k] - want[k]).abs()).fold(0.0, f64::max);
    assert!(d < tolerance, "{what}: {got:?} vs {want:?}");
}

#[test]
fn draw_turns_the_tool_about_the_base_axes_and_tdraw_about_its_own() {
    // From the tool pointing down (tool X = world −X), O = 30 turns about Z: about the world's
    // Z the tool X goes to (−cos 30, −sin 30, 0); about the tool's own Z (pointing down) to
    // (−cos 30, +sin 30, 0).
    let (i, s) = robot(
        &format!("  LMOVE {PICK}\n  BREAK\n  DRAW 10, 0, -20, 30, 0, 0\n  BREAK\n  HERE a\n  DECOMPOSE a[0] = a\n  LMOVE {PICK}\n  BREAK\n  TDRAW 0, 0, 0, 30\n  BREAK\n  HERE b\n  DECOMPOSE b[0] = b"),
        20,
    );
    let (c, sn) = (30f64.to_radians().cos(), 30f64.to_radians().sin());
    let a = pose(&arr(&i, "a"));
    axis_close(
        position_mm(&a),
        [910.0, 100.0, 580.0],
        0.05,
        "DRAW position",
    );
    axis_close(axis(&a, 0), [-c, -sn, 0.0], 1e-4, "DRAW: tool X");
    axis_close(axis(&a, 2), [0.0, 0.0, -1.0], 1e-4, "DRAW: tool Z");
    let b = pose(&arr(&i, "b"));
    axis_close(
        position_mm(&b),
        [900.0, 100.0, 600.0],
        0.05,
        "TDRAW position",
    );
    axis_close(axis(&b, 0), [-c, sn, 0.0], 1e-4, "TDRAW: tool X");
    assert!(s.motions.iter().all(|(_, m)| m.kind == MotionKind::Linear));
}

#[test]
fn draw_tilts_the_tool_about_its_tip() {
    // A = 20 about the world's Y with a 150 mm tool: the tip stays, the tool Z tilts.
    let (i, _) = robot(
        &format!("  TOOL TRANS(0, 0, 150)\n  LMOVE {PICK}\n  BREAK\n  DRAW , , , 0, 20\n  BREAK\n  HERE a\n  DECOMPOSE a[0] = a"),
        20,
    );
    let a = pose(&arr(&i, "a"));
    axis_close(
        position_mm(&a),
        [900.0, 100.0, 600.0],
        0.05,
        "the tip stays",
    );
    let (c, sn) = (20f64.to_radians().cos(), 20f64.to_radians().sin());
    axis_close(
        axis(&a, 2),
        [-sn, 0.0, -c],
        1e-4,
        "tool Z turned about world Y",
    );
}

#[test]
fn align_turns_the_tool_z_onto_the_nearest_world_axis_by_a_joint_motion() {
    let (i, s) = robot(
        "  JMOVE TRANS(900, 100, 600, 30, 160, 10)\n  BREAK\n  ALIGN\n  BREAK\n  HERE a\n  DECOMPOSE a[0] = a",
        20,
    );
    let a = pose(&arr(&i, "a"));
    axis_close(axis(&a, 2), [0.0, 0.0, -1.0], 1e-4, "tool Z straight down");
    axis_close(
        position_mm(&a),
        [900.0, 100.0, 600.0],
        0.05,
        "the tip stays",
    );
    // The smallest turn: by the 20° between the Z axes.
    let before = pose(&[900.0, 100.0, 600.0, 30.0, 160.0, 10.0]);
    assert!((before.angle_to_rad(&a).to_degrees() - 20.0).abs() < 0.01);
    assert_eq!(
        s.motions.last().map(|(_, m)| m.kind),
        Some(MotionKind::Joint)
    );
}

#[test]
fn align_in_a_pc_program_is_e1095() {
    let (mut i, mut s) = start(&pc("  ALIGN"));
    i.run_until(&mut s, ms(10));
    assert_eq!(s.raised, vec![ErrorCode(-31095)]);
}

#[test]
fn appro_in_a_pc_program_is_e1095() {
    let (mut i, mut s) = start(&pc("  APPRO TRANS(900, 0, 600, 0, 180, 0), 10"));
    i.run_until(&mut s, ms(10));
    assert_eq!(s.raised, vec![ErrorCode(-31095)]);
}

#[test]
fn shift_moves_a_location_along_the_base_axes() {
    let (i, _) = robot(
        &format!("  POINT p = SHIFT({PICK} BY 10, -20, 30)\n  DECOMPOSE a[0] = p\n  LMOVE SHIFT(p BY 0, 0, 5)\n  BREAK\n  HERE h\n  DECOMPOSE h[0] = h\n  POINT q = SHIFT(#PPOINT(0, 0, -90, 0, -90, 0) BY 1)\n  DECOMPOSE b[0] = q\n  HERE #j\n  POINT r = #PPOINT(0, 0, -90, 0, -90, 0)\n  DECOMPOSE c[0] = r"),
        10,
    );
    close(
        &arr(&i, "a"),
        &[910.0, 80.0, 630.0, 0.0, 180.0, 0.0],
        0.01,
        "SHIFT",
    );
    close(
        &arr(&i, "h"),
        &[910.0, 80.0, 635.0, 0.0, 180.0, 0.0],
        0.05,
        "moved to a SHIFT",
    );
    let c = arr(&i, "c");
    close(
        &arr(&i, "b"),
        &[c[0] + 1.0, c[1], c[2], c[3], c[4], c[5]],
        0.01,
        "SHIFT of a joint point",
    );
}

#[test]
fn shift_without_by_is_a_load_error() {
    let e = Interpreter::from_source(
        "t.as",
        ".PROGRAM rob()\n  p = SHIFT(TRANS(1, 2, 3) 1, 2)\n.END\n",
        fs020n_as::Config::default(),
    )
    .expect_err("does not load")
    .to_string();
    assert!(e.contains("t.as:2:"), "{e}");
}

#[test]
fn dest_is_the_target_of_the_latest_motion_while_it_runs() {
    let (i, _) = robot(
        &format!("  TOOL TRANS(0, 0, 100)\n  LMOVE {PICK}\n  DECOMPOSE d[0] = DEST\n  HERE h\n  DECOMPOSE h[0] = h\n  JMOVE #PPOINT(10, 0, -90, 0, -90, 0)\n  DECOMPOSE j[0] = #DEST"),
        10,
    );
    close(
        &arr(&i, "d"),
        &[900.0, 100.0, 600.0, 0.0, 180.0, 0.0],
        0.05,
        "DEST with the tool",
    );
    let h = arr(&i, "h");
    assert!(
        (h[2] - 600.0).abs() > 10.0,
        "the robot was still on its way: {h:?}"
    );
    close(
        &arr(&i, "j"),
        &[10.0, 0.0, -90.0, 0.0, -90.0, 0.0],
        0.001,
        "#DEST",
    );
}

#[test]
fn draw_takes_a_seventh_value_as_this_motions_speed() {
    let (_, s) = robot(
        &format!("  SPEED 50 ALWAYS\n  LMOVE {PICK}\n  BREAK\n  DRAW 10, , , , , , 20\n  BREAK\n  DRAW -10\n  BREAK"),
        10,
    );
    let speeds: Vec<Speed> = s.motions.iter().map(|(_, m)| m.speed).collect();
    assert_eq!(
        speeds,
        vec![
            Speed::Percent(50.0),
            Speed::Percent(20.0),
            Speed::Percent(50.0)
        ],
        "the speed holds for its DRAW only"
    );
}

#[test]
fn drive_turns_one_joint_by_an_amount_at_its_own_speed() {
    let (i, s) = robot(
        "  SPEED 80 ALWAYS\n  JMOVE #PPOINT(10, 20, -80, 5, -60, 15)\n  BREAK\n  DRIVE 2, -12.5, 30\n  BREAK\n  DRIVE 6, 90\n  BREAK\n  HERE #h\n  DECOMPOSE h[0] = #h",
        10,
    );
    close(
        &arr(&i, "h"),
        &[10.0, 7.5, -80.0, 5.0, -60.0, 105.0],
        0.01,
        "DRIVE 2 then 6",
    );
    let last: Vec<(MotionKind, Speed)> = s.motions[1..]
        .iter()
        .map(|(_, m)| (m.kind, m.speed))
        .collect();
    assert_eq!(
        last,
        vec![
            (MotionKind::Joint, Speed::Percent(30.0)),
            (MotionKind::Joint, Speed::Percent(80.0))
        ]
    );
}

#[test]
fn drive_of_a_joint_that_does_not_exist_stops_with_an_illegal_value_and_does_not_move() {
    let src = format!(
        "{}.PROGRAM rob()\n  DRIVE 7, 10\n.END\n",
        pc("  MC EXECUTE rob")
    );
    let (mut i, mut s) = start(&src);
    i.run_until(&mut s, ms(1000));
    assert!(s.motions.is_empty(), "{:?}", s.motions);
    let e = i
        .tasks(&s)
        .into_iter()
        .find_map(|t| t.last_error)
        .expect("the robot task stopped with an error");
    assert!(e.contains("DRIVE joint 7"), "{e}");
}
