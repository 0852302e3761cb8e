//! `XMOVE location TILL signal` on virtual time: a straight line that stops when the signal
//! comes (scripted as an input from outside); the program goes on from where the arm stands.
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

mod common;

use common::{ms, pc, start};
use fs020n_as::system::{MotionKind, System};
use fs020n_as::testing::VirtualSystem;
use fs020n_as::Interpreter;
use fs020n_proto::ErrorCode;

fn robot(body: &str) -> (Interpreter, VirtualSystem) {
    let src = format!("{}.PROGRAM rob()\n{body}\n.END\n", pc("  MC EXECUTE rob"));
    start(&src)
}

/// From HOME, an XMOVE to a point 200 mm away (about 1.3 s on the test system at 10 %); output
/// 1 set after it.
const BODY: &str = "  SPEED 10 ALWAYS\n  XMOVE SHIFT(HERE BY 0, 200, 0) TILL 1001\n  SIGNAL 1\n  HERE p\n  DECOMPOSE p[0] = p";

fn y_of(s: &VirtualSystem) -> f64 {
    s.pose().expect("kinematics")[1]
}

#[test]
fn xmove_stops_where_the_arm_is_when_the_input_turns_on() {
    let (mut i, mut s) = robot(BODY);
    let y0 = y_of(&s);
    i.run_until(&mut s, ms(300));
    assert!(
        !i.signal(1),
        "the program waits at XMOVE while the arm moves"
    );
    let moving_y = y_of(&s);
    assert!(moving_y > y0 + 1.0, "moving: {moving_y} from {y0}");
    i.set_signal(1001, true);
    i.run_until(&mut s, ms(310));
    assert!(i.signal(1), "the program went on past XMOVE");
    assert!(!s.motion_in_progress(), "the motion was cut");
    let stopped = y_of(&s);
    i.run_until(&mut s, ms(5_000));
    assert_eq!(y_of(&s), stopped, "the arm stays where it stopped");
    assert!(stopped < y0 + 199.0, "stopped short: {stopped}");
    // Stopped within a poll period (2 ms) of the signal.
    assert!((stopped - moving_y).abs() < 5.0, "{stopped} vs {moving_y}");
    let p_y = i.real_at("p", &[1]).expect("HERE after XMOVE");
    assert!((f64::from(p_y) - stopped).abs() < 0.01);
    assert!(s.raised.is_empty(), "{:?}", s.raised);
    assert_eq!(s.motions[0].1.kind, MotionKind::Linear);
}

#[test]
fn xmove_without_the_signal_reaches_its_destination_and_then_goes_on() {
    let (mut i, mut s) = robot(BODY);
    let y0 = y_of(&s);
    i.run_until(&mut s, ms(500));
    assert!(!i.signal(1), "waits until the motion ends");
    i.run_until(&mut s, ms(20_000));
    assert!(i.signal(1));
    assert!((y_of(&s) - (y0 + 200.0)).abs() < 0.01);
}

#[test]
fn xmove_till_a_negative_number_stops_when_the_input_turns_off() {
    let (mut i, mut s) = robot(&BODY.replace("TILL 1001", "TILL -1001"));
    i.set_signal(1001, true);
    let y0 = y_of(&s);
    i.run_until(&mut s, ms(300));
    assert!(!i.signal(1));
    i.set_signal(1001, false);
    i.run_until(&mut s, ms(320));
    assert!(i.signal(1));
    assert!(y_of(&s) < y0 + 199.0);
}

#[test]
fn xmove_with_the_signal_already_on_does_not_move() {
    let (mut i, mut s) = robot(BODY);
    i.set_signal(1001, true);
    let before = s.pose().expect("kinematics");
    i.run_until(&mut s, ms(2_000));
    assert!(i.signal(1));
    let after = s.pose().expect("kinematics");
    assert!((after[1] - before[1]).abs() < 0.5, "{before:?} → {after:?}");
}

#[test]
fn xmove_till_an_illegal_signal_number_is_e0106_before_anything_moves() {
    let (mut i, mut s) = robot("  XMOVE SHIFT(HERE BY 0, 200, 0) TILL 5000");
    i.run_until(&mut s, ms(100));
    assert_eq!(s.raised, vec![ErrorCode(-30106)]);
    assert!(s.motions.is_empty());
}

#[test]
fn xmove_without_till_does_not_load() {
    let e = common::load_error(".PROGRAM rob()\n  XMOVE p\n.END\n");
    assert!(e.contains("expected TILL"), "{e}");
}
