//! Circular motion on the test system: `C1MOVE via` then `C2MOVE end` issue one circular
//! motion through the via point (converted by TOOL and BASE like any target), and every way of
//! leaving the pair incomplete, or giving three points that define no circle, stops the
//! program before anything moves: E1098 for a `C2MOVE` without its `C1MOVE`, E1097 for a
//! `C1MOVE` without its `C2MOVE`, E1099 for three points that define no circle. (The arc itself is drawn by the emulator's
//! planner: `fs020n-sim`'s tests measure it.)
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

mod common;

use common::{ms, pc, start};
use fs020n_as::system::{MotionKind, System, Target};
use fs020n_as::testing::VirtualSystem;
use fs020n_as::{Interpreter, TaskId, TaskState};
use fs020n_proto::ErrorCode;

const E1097: ErrorCode = ErrorCode(-31097);
const E1098: ErrorCode = ErrorCode(-31098);
const E1099: ErrorCode = ErrorCode(-31099);

/// Runs `body` as the robot program `rob` for `secs` seconds.
fn robot(body: &str, secs: u64) -> (Interpreter, VirtualSystem) {
    let src = format!("{}.PROGRAM rob()\n{body}\n.END\n", pc("  MC EXECUTE rob"));
    let (mut i, mut s) = start(&src);
    i.run_until(&mut s, ms(secs * 1000));
    (i, s)
}

const START: &str = "TRANS(900, 0, 600, 0, 180, 0)";
const VIA: &str = "TRANS(1000, 100, 600, 0, 180, 0)";
const END: &str = "TRANS(1100, 0, 600, 0, 180, 0)";

fn close(a: &[f64], b: &[f64], tolerance: f64, what: &str) {
    for k in 0..a.len() {
        assert!((a[k] - b[k]).abs() <= tolerance, "{what}: {a:?} vs {b:?}");
    }
}

#[test]
fn c1move_then_c2move_issue_one_circular_motion_through_the_via_point() {
    let (_, s) = robot(
        &format!("  LMOVE {START}\n  BREAK\n  C1MOVE {VIA}\n  C2MOVE {END}\n  BREAK"),
        20,
    );
    assert!(s.raised.is_empty(), "{:?} {:?}", s.raised, s.terminal);
    assert_eq!(s.motions.len(), 2, "C1MOVE issues no motion of its own");
    let (_, m) = &s.motions[1];
    assert_eq!(m.kind, MotionKind::Circular);
    close(
        &m.via.expect("a via point"),
        &[1000.0, 100.0, 600.0, 0.0, 180.0, 0.0],
        1e-3,
        "via",
    );
    match m.target {
        Target::Pose(p) => close(&p, &[1100.0, 0.0, 600.0, 0.0, 180.0, 0.0], 1e-3, "end"),
        other => panic!("{other:?}"),
    }
    let here = s.pose().expect("kinematics");
    close(
        &here[..3],
        &[1100.0, 0.0, 600.0],
        0.01,
        "the arm ends at the end point",
    );
}

#[test]
fn the_circle_points_are_the_tool_tip_in_the_world_and_the_system_gets_the_flange() {
    let (_, s) = robot(
        &format!("  TOOL TRANS(0, 0, 150)\n  BASE TRANS(0, 0, -100)\n  LMOVE {START}\n  BREAK\n  C1MOVE {VIA}\n  C2MOVE {END}\n  BREAK"),
        20,
    );
    assert!(s.raised.is_empty(), "{:?}", s.raised);
    let (_, m) = s.motions.last().expect("motions");
    // The tool points down: the flange is 150 mm above the tip, and the robot's base 100 mm
    // below the world's origin.
    close(
        &m.via.expect("a via point")[..3],
        &[1000.0, 100.0, 850.0],
        1e-3,
        "via as the flange in the robot's frame",
    );
}

#[test]
fn c2move_without_c1move_stops_with_e1098_and_does_not_move() {
    let (i, s) = robot(&format!("  C2MOVE {END}"), 2);
    assert_eq!(s.raised, vec![E1098]);
    assert!(s.motions.is_empty());
    assert_eq!(i.task_state(TaskId::Robot, &s), TaskState::Idle);
}

#[test]
fn another_motion_between_c1move_and_c2move_stops_with_e1097() {
    let (_, s) = robot(
        &format!("  C1MOVE {VIA}\n  LMOVE {START}\n  C2MOVE {END}"),
        2,
    );
    assert_eq!(s.raised, vec![E1097]);
    assert!(s.motions.is_empty(), "{:?}", s.motions);
}

#[test]
fn two_c1moves_in_a_row_stop_with_e1097() {
    let (_, s) = robot(
        &format!("  C1MOVE {VIA}\n  C1MOVE {START}\n  C2MOVE {END}"),
        2,
    );
    assert_eq!(s.raised, vec![E1097]);
    assert!(s.motions.is_empty());
}

#[test]
fn a_program_ending_after_c1move_stops_with_e1097() {
    let (_, s) = robot(&format!("  C1MOVE {VIA}"), 2);
    assert_eq!(s.raised, vec![E1097]);
    assert!(s.motions.is_empty());
}

#[test]
fn c1move_then_c2move_in_a_called_program_and_back_is_one_circle() {
    let src = format!(
        "{}.PROGRAM rob()\n  LMOVE {START}\n  BREAK\n  C1MOVE {VIA}\n  CALL half\n  BREAK\n.END\n.PROGRAM half()\n  C2MOVE {END}\n.END\n",
        pc("  MC EXECUTE rob")
    );
    let (mut i, mut s) = start(&src);
    i.run_until(&mut s, ms(20_000));
    assert!(s.raised.is_empty(), "{:?}", s.raised);
    assert_eq!(
        s.motions.last().map(|(_, m)| m.kind),
        Some(MotionKind::Circular)
    );
}

#[test]
fn collinear_points_stop_with_e1099_before_anything_moves() {
    let (_, s) = robot(
        &format!(
            "  LMOVE {START}\n  BREAK\n  C1MOVE TRANS(1000, 0, 600, 0, 180, 0)\n  C2MOVE {END}"
        ),
        20,
    );
    assert_eq!(s.raised, vec![E1099]);
    assert_eq!(s.motions.len(), 1, "only the LMOVE");
    assert!(
        s.lines_of(TaskId::Robot)
            .iter()
            .chain(s.lines_of(TaskId::Pc(1)).iter())
            .any(|l| l.contains("E1099") && l.contains("one straight line")),
        "{:?}",
        s.terminal
    );
}

#[test]
fn a_via_point_on_the_start_stops_with_e1099() {
    let (_, s) = robot(
        &format!("  LMOVE {START}\n  BREAK\n  C1MOVE {START}\n  C2MOVE {END}"),
        20,
    );
    assert_eq!(s.raised, vec![E1099]);
    assert_eq!(s.motions.len(), 1);
}

#[test]
fn c1move_in_a_pc_program_is_e1095() {
    let (mut i, mut s) = start(&pc(&format!("  C1MOVE {VIA}")));
    i.run_until(&mut s, ms(10));
    assert_eq!(s.raised, vec![ErrorCode(-31095)]);
}

#[test]
fn error_names_the_circular_motion_codes() {
    assert_eq!(
        fs020n_as::error::error_message(-31097),
        Some("C1MOVE or C2MOVE instruction missing")
    );
    assert_eq!(
        fs020n_as::error::error_message(-31098),
        Some("C2MOVE needs a C1MOVE before it")
    );
    assert_eq!(
        fs020n_as::error::error_message(-31099),
        Some("Cannot create the arc: check the positions of the three points")
    );
}
