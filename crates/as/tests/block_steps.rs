//! Block-teaching steps on virtual time: each step's motion (joint or linear interpolation,
//! the speed, accuracy and tool of its numbers), its `OX` outputs, its `WX` wait and its timer,
//! the motion errors of a target out of range, and the values of axes this arm does not have.
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

mod common;

use std::time::Duration;

use common::{ms, pc, start, start_with};
use fs020n_as::system::{MotionKind, Speed, System, Target};
use fs020n_as::testing::VirtualSystem;
use fs020n_as::{Config, Interpreter};
use fs020n_proto::ErrorCode;

/// A program source whose robot program `rob` is `body` (started by the PC program).
fn robot_src(body: &str) -> String {
    format!("{}.PROGRAM rob()\n{body}\n.END\n", pc("  MC EXECUTE rob"))
}

/// Runs `body` as the robot program for `millis` of virtual time.
fn robot(body: &str, millis: u64) -> (Interpreter, VirtualSystem) {
    let (mut i, mut s) = start(&robot_src(body));
    i.run_until(&mut s, ms(millis));
    (i, s)
}

fn close(a: &[f64; 6], b: &[f64; 6], tol: f64, what: &str) {
    for k in 0..6 {
        assert!((a[k] - b[k]).abs() <= tol, "{what}: {a:?} vs {b:?}");
    }
}

/// The joint targets and kinds of the motions issued, in order.
fn moves(s: &VirtualSystem) -> Vec<(MotionKind, Target)> {
    s.motions.iter().map(|(_, m)| (m.kind, m.target)).collect()
}

/// When the motion to `target` was issued.
fn issued_at(s: &VirtualSystem, target: [f64; 6]) -> Duration {
    s.motions
        .iter()
        .find(|(_, m)| m.target == Target::Joints(target))
        .map(|(t, _)| *t)
        .expect("the motion was issued")
}

const A: [f64; 6] = [10.0, 20.0, -80.0, 5.0, -60.0, 15.0];
const B: [f64; 6] = [20.0, 10.0, -70.0, 0.0, -50.0, 10.0];
const C: [f64; 6] = [0.0, 0.0, -90.0, 0.0, -90.0, 0.0];

#[test]
fn a_block_program_moves_to_each_target_in_order_with_its_interpolation() {
    let (i, s) = robot(
        concat!(
            "  JOINT SPEED9 ACCU1 TIMER0 TOOL1 WORK0 CLAMP1 (OFF,0,0,O) OX= WX= #[10,20,-80,5,-60,15] ;\n",
            "  LINEAR SPEED9 ACCU2 TIMER0 TOOL1 WORK0 CLAMP OX= WX= #[20,10,-70,0,-50,10] ;\n",
            "  7 JOINT SPEED9 ACCU4 TIMER0 TOOL1 WORK0 GROUP0 CLAMP OX= WX= YO=^H0,^H0 #[0,0,-90,0,-90,0] ;\n",
        ),
        5000,
    );
    assert!(i.warnings().is_empty(), "{:?}", i.warnings());
    assert!(s.raised.is_empty(), "{:?} {:?}", s.raised, s.terminal);
    assert_eq!(
        moves(&s),
        vec![
            (MotionKind::Joint, Target::Joints(A)),
            (MotionKind::Linear, Target::Joints(B)),
            (MotionKind::Joint, Target::Joints(C)),
        ]
    );
    let accuracy: Vec<f64> = s.motions.iter().map(|(_, m)| m.accuracy_mm).collect();
    assert_eq!(accuracy, vec![1.0, 10.0, 100.0], "ACCU1, ACCU2, ACCU4");
    assert!(s
        .motions
        .iter()
        .all(|(_, m)| m.speed == Speed::Percent(100.0)));
    close(
        &s.joints_now(),
        &C,
        1e-9,
        "the robot stands at the last step",
    );
}

#[test]
fn the_speed_number_scales_the_motion_time() {
    // From HOME to A and back at SPEED9 (100 %), then the same at SPEED4 (50 %): twice as long.
    let body = |n: u8| {
        format!("  JOINT SPEED{n} ACCU1 TIMER0 TOOL1 WORK0 CLAMP OX= WX= #[10,20,-80,5,-60,15] ;")
    };
    let reach = |n: u8| -> (Speed, Duration) {
        let (mut i, mut s) = start(&robot_src(&body(n)));
        let mut t = Duration::ZERO;
        while t < Duration::from_secs(10) {
            t += ms(10);
            i.run_until(&mut s, t);
            if s.joints_now() == A {
                return (s.motions[0].1.speed, t);
            }
        }
        panic!("never reached A: {:?}", s.joints_now());
    };
    let (fast_speed, fast) = reach(9);
    let (slow_speed, slow) = reach(4);
    assert_eq!(fast_speed, Speed::Percent(100.0));
    assert_eq!(slow_speed, Speed::Percent(50.0));
    let ratio = slow.as_secs_f64() / fast.as_secs_f64();
    assert!((1.8..=2.2).contains(&ratio), "{fast:?} vs {slow:?}");
}

#[test]
fn the_speed_table_and_monitor_speed_multiply() {
    let mut cfg = Config::default();
    cfg.block.speed_percent[3] = 40.0;
    let (mut i, mut s) = start_with(
        &robot_src("  JOINT SPEED3 ACCU1 TIMER0 TOOL1 WORK0 CLAMP OX= WX= #[10,20,-80,5,-60,15] ;"),
        cfg,
    );
    s.monitor_speed = 50.0;
    i.run_until(&mut s, ms(100));
    assert_eq!(s.motions[0].1.speed, Speed::Percent(40.0));
    // At 40 % × 50 % of 100 °/s the joints move at 20 °/s.
    let largest = A
        .iter()
        .zip(s.model.home.0)
        .map(|(a, h)| (a - h).abs())
        .fold(0.0, f64::max);
    let takes = Duration::from_secs_f64(largest / 20.0);
    i.run_until(&mut s, takes - ms(20));
    assert_ne!(s.joints_now(), A);
    i.run_until(&mut s, takes + ms(20));
    assert_eq!(s.joints_now(), A);
}

#[test]
fn a_linear_step_with_a_number_moves_at_that_many_mm_per_s() {
    let (_, s) = robot(
        "  LINEAR 80.0 ACCU1 TIMER0 TOOL1 WORK0 GROUP0 CLAMP OX= WX= #[10,20,-80,5,-60,15] ;",
        5000,
    );
    assert_eq!(s.motions[0].1.kind, MotionKind::Linear);
    assert_eq!(s.motions[0].1.speed, Speed::MmPerS(80.0));
}

#[test]
fn ox_sets_its_outputs_as_the_motion_starts() {
    let (mut i, mut s) = start(&robot_src(
        "  SIGNAL 4\n  JOINT SPEED0 ACCU1 TIMER0 TOOL1 WORK0 CLAMP OX=3,-4 WX= #[10,20,-80,5,-60,15] ;",
    ));
    i.run_until(&mut s, ms(50));
    assert!(s.motions.len() == 1 && s.joints_now() != A, "still moving");
    assert!(i.signal(3) && !i.signal(4), "OX.PREOUT is ON by default");
}

#[test]
fn with_ox_preout_off_the_outputs_wait_for_the_pose() {
    let (mut i, mut s) = start(&robot_src(
        "  OX.PREOUT OFF\n  JOINT SPEED9 ACCU1 TIMER0 TOOL1 WORK0 CLAMP OX=3 WX= #[10,20,-80,5,-60,15] ;",
    ));
    i.run_until(&mut s, ms(50));
    assert!(s.joints_now() != A && !i.signal(3), "not yet at the pose");
    i.run_until(&mut s, ms(5000));
    assert!(s.joints_now() == A && i.signal(3), "set at the pose");
}

#[test]
fn wx_waits_at_the_pose_for_its_inputs() {
    let (mut i, mut s) = start(&robot_src(concat!(
        "  JOINT SPEED9 ACCU1 TIMER0 TOOL1 WORK0 CLAMP OX= WX=5,-6 #[10,20,-80,5,-60,15] ;\n",
        "  JOINT SPEED9 ACCU1 TIMER0 TOOL1 WORK0 CLAMP OX= WX= #[20,10,-70,0,-50,10] ;",
    )));
    i.set_signal(1006, true);
    i.run_until(&mut s, ms(3000));
    assert_eq!(s.joints_now(), A);
    assert_eq!(s.motions.len(), 1, "waits for input 1005 ON and 1006 OFF");
    i.set_signal(1005, true);
    i.run_until(&mut s, ms(3500));
    assert_eq!(s.motions.len(), 1, "input 1006 is still ON");
    i.set_signal(1006, false);
    i.run_until(&mut s, ms(6000));
    assert_eq!(s.motions.len(), 2);
    assert!(issued_at(&s, B) >= ms(3500));
    assert_eq!(s.joints_now(), B);
}

#[test]
fn the_timer_delays_the_next_step_after_the_pose() {
    let body = |timer: u8| {
        format!(
            "  JOINT SPEED9 ACCU1 TIMER{timer} TOOL1 WORK0 CLAMP OX= WX= #[10,20,-80,5,-60,15] ;\n  JOINT SPEED9 ACCU1 TIMER0 TOOL1 WORK0 CLAMP OX= WX= #[20,10,-70,0,-50,10] ;"
        )
    };
    let (_, plain) = robot(&body(0), 5000);
    let (_, timed) = robot(&body(5), 5000);
    // Without a timer the next motion is planned during the first (as after JMOVE); with
    // TIMER5 (0.5 s) it starts 0.5 s after the arm reached the first pose.
    let first_end = Duration::from_secs_f64(
        A.iter()
            .zip(plain.model.home.0)
            .map(|(a, h)| (a - h).abs())
            .fold(0.0, f64::max)
            / 100.0,
    );
    assert!(issued_at(&plain, B) < first_end);
    let at = issued_at(&timed, B);
    assert!(
        at >= first_end + ms(500) && at <= first_end + ms(520),
        "{at:?} vs {first_end:?}"
    );
    assert_eq!(timed.joints_now(), B);
}

#[test]
fn a_target_out_of_range_stops_with_the_motion_error_and_sets_no_output() {
    let (i, s) = robot(
        "  JOINT SPEED9 ACCU1 TIMER0 TOOL1 WORK0 CLAMP OX=7 WX= #[400,0,-90,0,-90,0] ;",
        500,
    );
    assert_eq!(s.raised, vec![ErrorCode::DESTINATION_OUT_OF_RANGE]);
    assert!(!i.signal(7));
}

#[test]
fn values_for_axes_beyond_the_sixth_are_ignored_without_a_warning() {
    let (i, s) = robot(
        "  JOINT SPEED9 ACCU1 TIMER0 TOOL1 WORK0 CLAMP OX= WX= #[10,20,-80,5,-60,15,-2000,35] ;",
        5000,
    );
    assert!(i.warnings().is_empty(), "{:?}", i.warnings());
    assert!(s.raised.is_empty(), "{:?}", s.raised);
    assert_eq!(moves(&s), vec![(MotionKind::Joint, Target::Joints(A))]);
}

#[test]
fn a_transformation_target_is_the_tool_of_the_step_in_the_world() {
    let mut cfg = Config::default();
    cfg.block.tools[2] = Some([0.0, 0.0, 150.0, 0.0, 0.0, 0.0]);
    let (mut i, mut s) = start_with(
        &robot_src(concat!(
            "  LINEAR SPEED9 ACCU1 TIMER0 TOOL2 WORK0 CLAMP OX= WX= [900,100,600,0,180,0] ;\n",
            "  BREAK\n  HERE h\n  DECOMPOSE w[0] = h\n",
        )),
        cfg,
    );
    i.run_until(&mut s, ms(10_000));
    assert!(s.raised.is_empty(), "{:?} {:?}", s.raised, s.terminal);
    let w: [f64; 6] = std::array::from_fn(|k| f64::from(i.real_at("w", &[k as i32]).expect("w")));
    close(
        &w,
        &[900.0, 100.0, 600.0, 0.0, 180.0, 0.0],
        0.05,
        "HERE with TOOL2",
    );
    // The flange stands 150 mm above the tool tip (the tool points down).
    let flange = s.pose().expect("kinematics");
    assert!((flange[2] - 750.0).abs() < 0.05, "{flange:?}");
}

#[test]
fn a_block_step_in_a_pc_program_is_refused_as_a_robot_only_instruction() {
    let (mut i, mut s) = start(&pc(
        "  JOINT SPEED9 ACCU1 TIMER0 TOOL1 WORK0 CLAMP OX= WX= #[10,20,-80,5,-60,15] ;",
    ));
    i.run_until(&mut s, ms(10));
    assert_eq!(s.raised, vec![ErrorCode(-31095)]);
    assert!(s.motions.is_empty());
}

#[test]
fn an_end_step_ends_the_program_after_its_motion() {
    let (i, s) = robot(
        "  JOINT SPEED9 ACCU1 TIMER0 TOOL1 WORK0 GROUP0 END CLAMP OX= WX= #[10,20,-80,5,-60,15] ;\n  SIGNAL 9",
        5000,
    );
    assert_eq!(s.joints_now(), A);
    assert!(!i.signal(9));
}

#[test]
fn the_timer_runs_during_the_wx_wait_unless_after_wait_tmr_is_on() {
    let next_after_input = |switch: &str| -> Duration {
        let (mut i, mut s) = start(&robot_src(&format!(
            "  AFTER.WAIT.TMR {switch}\n  JOINT SPEED9 ACCU1 TIMER3 TOOL1 WORK0 CLAMP OX= WX=12 #[10,20,-80,5,-60,15] ;\n  JOINT SPEED9 ACCU1 TIMER0 TOOL1 WORK0 CLAMP OX= WX= #[20,10,-70,0,-50,10] ;"
        )));
        i.run_until(&mut s, ms(3000));
        assert_eq!(s.motions.len(), 1);
        i.set_signal(1012, true);
        i.run_until(&mut s, ms(6000));
        issued_at(&s, B) - ms(3000)
    };
    // OFF (default): the 0.3 s timer ran out during the wait; the next step follows the input.
    assert!(next_after_input("OFF") <= ms(10));
    // ON: the timer starts when the input came.
    let on = next_after_input("ON");
    assert!(on >= ms(300) && on <= ms(320), "{on:?}");
}

#[test]
fn an_illegal_signal_number_stops_the_step_before_it_moves() {
    for signals in ["OX=1500 WX=", "OX= WX=3000"] {
        let (_, s) = robot(
            &format!(
                "  JOINT SPEED9 ACCU1 TIMER0 TOOL1 WORK0 CLAMP {signals} #[10,20,-80,5,-60,15] ;"
            ),
            500,
        );
        assert_eq!(s.raised, vec![ErrorCode::VALUE_OUT_OF_RANGE], "{signals}");
        assert!(s.motions.is_empty(), "{signals}");
    }
}

#[test]
fn a_joint_or_linear_line_the_emulator_does_not_read_loads_as_not_emulated() {
    let src = robot_src(concat!(
        "  JOINT\n",
        "  LINEAR SPEED9 ACCU1 TIMER0 TOOL1 WORK0 JUMP CLAMP OX= WX= #[10,20,-80,5,-60,15] ;\n",
        "  LINEAR 80.0 ACCU1 TIMER0 TOOL1 WORK0 CLAMP OX= WX= [900,100,600,0,180,0] ;",
    ));
    let m = fs020n_as::parse("t.as", &src).expect("loads");
    let body = &m.programs[1].body;
    assert!(
        matches!(&body[0].kind, fs020n_as::ast::StmtKind::NotEmulated { instruction, .. } if instruction == "JOINT (block-teaching step)")
    );
    assert!(
        matches!(&body[1].kind, fs020n_as::ast::StmtKind::NotEmulated { instruction, .. } if instruction == "LINEAR (block-teaching step)")
    );
    assert!(matches!(&body[2].kind, fs020n_as::ast::StmtKind::BlockStep(s) if s.linear));
}
