//! `ONE program`: a task whose statement fails runs its error program (with `ERROR` giving the
//! code); `RETURN` runs the failed step again, `RETURNE` goes on after it, an error program
//! that ends without either stops the task (AS-E p.6-45); without `ONE`, or after `ONE OFF`,
//! the task stops at once; an error inside the error program stops the task.
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

mod common;

use common::{ms, start};
use fs020n_as::{TaskId, TaskState};
use fs020n_proto::ErrorCode;

const HANDLER: &str = ".PROGRAM recover.pc()\n\
  code = ERROR\n\
  handled = handled + 1\n\
.END\n";

fn program(body: &str) -> String {
    format!(".PROGRAM autostart.pc()\n  handled = 0\n{body}\n.END\n{HANDLER}")
}

#[test]
fn a_failed_statement_runs_the_error_program_with_error_giving_its_code() {
    let (mut i, mut s) = start(&program("  ONE recover.pc\n  x = SQRT(-1)\n  after = 1"));
    i.run_until(&mut s, ms(50));
    assert_eq!(i.real("handled"), Some(1.0), "the error program ran once");
    let code = i.real("code").expect("ERROR read");
    assert!(code < 0.0, "ERROR gives the code, got {code}");
    assert_eq!(s.raised.len(), 1);
    assert_eq!(code, s.raised[0].raw() as f32);
    // Fail closed: the failed step is not resumed, the task stops.
    assert_eq!(i.real("after"), None);
    assert!(
        i.task_state(TaskId::Pc(1), &s) == TaskState::Idle,
        "the task stopped"
    );
    let lines = s.lines_of(TaskId::Pc(1)).join("\n");
    assert!(
        lines.contains("error program recover.pc runs (ONE)"),
        "{lines}"
    );
    assert!(
        lines.contains("program stopped at the end of its error program"),
        "{lines}"
    );
}

#[test]
fn without_one_the_task_stops_at_once() {
    let (mut i, mut s) = start(&program("  x = SQRT(-1)\n  after = 1"));
    i.run_until(&mut s, ms(50));
    assert_eq!(i.real("handled"), Some(0.0));
    assert_eq!(i.real("after"), None);
    assert_eq!(s.raised.len(), 1);
}

#[test]
fn one_off_disarms_the_error_program() {
    let (mut i, mut s) = start(&program("  ONE recover.pc\n  ONE OFF\n  x = SQRT(-1)"));
    i.run_until(&mut s, ms(50));
    assert_eq!(i.real("handled"), Some(0.0));
    assert_eq!(s.raised.len(), 1);
}

#[test]
fn an_error_inside_the_error_program_stops_the_task() {
    let src = ".PROGRAM autostart.pc()\n  ONE bad.pc\n  x = SQRT(-1)\n.END\n\
.PROGRAM bad.pc()\n  entered = 1\n  y = SQRT(-4)\n  survived = 1\n.END\n";
    let (mut i, mut s) = start(src);
    i.run_until(&mut s, ms(50));
    assert_eq!(i.real("entered"), Some(1.0));
    assert_eq!(i.real("survived"), None);
    assert_eq!(s.raised.len(), 2, "{:?}", s.raised);
    assert!(i.task_state(TaskId::Pc(1), &s) == TaskState::Idle);
}

#[test]
fn the_robot_tasks_error_program_runs_but_cannot_move_the_arm() {
    let src = ".PROGRAM main()\n  ONE rescue\n  JMOVE #PPOINT(0, 0, 0, 0, 0, 9999)\n.END\n\
.PROGRAM rescue()\n  code = ERROR\n  SIGNAL 1\n  JMOVE #PPOINT(10, 0, -90, 0, -90, 0)\n  moved = 1\n.END\n";
    let (mut i, mut s) = start(src);
    i.execute("main", &mut s).expect("starts");
    i.run_until(&mut s, ms(200));
    assert_eq!(
        i.real("code"),
        Some(ErrorCode::DESTINATION_OUT_OF_RANGE.raw() as f32)
    );
    assert!(i.signal(1), "the error program ran its steps");
    assert_eq!(i.real("moved"), None, "the motion in error was refused");
    // Only the failed motion was asked for; the arm stands where it was.
    assert_eq!(s.motions.len(), 1, "{:?}", s.motions);
    assert_eq!(s.joints_now(), s.model.home.0);
    assert!(
        i.task_state(TaskId::Robot, &s) == TaskState::Idle,
        "stopped"
    );
}

#[test]
fn one_naming_a_program_not_loaded_loads_with_a_warning_and_the_task_stops_as_without_it() {
    let src = ".PROGRAM autostart.pc()\n  ONE elsewhere\n  x = SQRT(-1)\n  after = 1\n.END\n";
    let (mut i, mut s) = start(src);
    assert!(
        i.warnings().iter().any(|w| w
            .message
            .contains("ONE elsewhere: program elsewhere is not defined")),
        "{:?}",
        i.warnings()
    );
    i.run_until(&mut s, ms(50));
    assert_eq!(i.real("after"), None);
    assert_eq!(s.raised.len(), 1);
}

#[test]
fn returne_resumes_the_task_at_the_step_after_the_one_that_failed() {
    // AS-E p.6-45: RETURNE returns to the step after the error.
    let src = ".PROGRAM autostart.pc()\n  handled = 0\n  ONE skip.pc\n  x = SQRT(-1)\n  after = 1\n.END\n\
.PROGRAM skip.pc()\n  handled = handled + 1\n  RETURNE\n.END\n";
    let (mut i, mut s) = start(src);
    i.run_until(&mut s, ms(50));
    assert_eq!(i.real("handled"), Some(1.0));
    assert_eq!(i.real("x"), None, "the failed step did not complete");
    assert_eq!(i.real("after"), Some(1.0), "the task went on after it");
    assert_eq!(
        s.raised.len(),
        1,
        "the error was raised once: {:?}",
        s.raised
    );
}

#[test]
fn return_runs_the_step_that_failed_again() {
    // AS-E p.6-45: RETURN returns to the step where the error occurred. The error program
    // repairs the divisor; the division runs again and succeeds.
    let src =
        ".PROGRAM autostart.pc()\n  d = 0\n  ONE repair.pc\n  x = 10 / d\n  after = x\n.END\n\
.PROGRAM repair.pc()\n  d = 2\n  RETURN\n.END\n";
    let (mut i, mut s) = start(src);
    i.run_until(&mut s, ms(50));
    assert_eq!(i.real("x"), Some(5.0));
    assert_eq!(i.real("after"), Some(5.0));
    assert_eq!(s.raised, vec![ErrorCode(-30108)]);
}

#[test]
fn an_error_program_ending_without_return_stops_the_task_and_says_so() {
    let (mut i, mut s) = start(&program("  ONE recover.pc\n  x = SQRT(-1)\n  after = 1"));
    i.run_until(&mut s, ms(50));
    assert_eq!(i.real("after"), None);
    let lines = s.lines_of(TaskId::Pc(1)).join("\n");
    assert!(lines.contains("no RETURN or RETURNE resumed it"), "{lines}");
}
