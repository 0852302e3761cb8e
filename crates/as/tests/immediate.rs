//! A statement typed at the terminal (`Interpreter::immediate`): compiled against the loaded
//! programs, run at once to its end, its printed lines given back; tasks undisturbed.
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

mod common;

use common::{ms, start};
use fs020n_as::{ImmediateError, TaskId, TaskState};
use fs020n_proto::ErrorCode;

const LOADED: &str = ".PROGRAM typer()\n  TYPE x * 2 + 1, DX(a), $name\n.END\n\
                      .PROGRAM setter()\n  x = 7\n  $name = \"cell\"\n.END\n\
                      .PROGRAM counter()\n  n = 0\n  WHILE TRUE DO\n    n = n + 1\n    TWAIT 0.01\n  END\n.END\n\
                      .TRANS\na 100.0 200.0 300.0 0.0 90.0 0.0\n.END\n";

#[test]
fn type_evaluates_any_expression_and_its_lines_come_back_not_as_program_output() {
    let (mut i, mut s) = start(LOADED);
    i.pc_execute(1, "setter").expect("setter starts");
    i.run_until(&mut s, ms(10));
    let lines = i
        .immediate("TYPE x * 2 + 1, DX(a), $name", &mut s)
        .expect("TYPE runs");
    assert!(
        i.terminal().all(|l| !l.text.contains("cell")),
        "a typed statement's output is its reply, not a program's line"
    );
    // The line a program's TYPE prints, to the byte.
    i.pc_execute(2, "typer").expect("typer starts");
    i.run_until(&mut s, ms(20));
    assert_eq!(
        lines,
        s.lines_of(TaskId::Pc(2)),
        "typed and in a program alike"
    );
    assert_eq!(lines, [" 15 100cell"]);
}

#[test]
fn an_assignment_or_point_makes_a_new_global_that_programs_then_read() {
    let (mut i, mut s) = start(LOADED);
    assert!(i
        .immediate("speed_mm = 250", &mut s)
        .expect("runs")
        .is_empty());
    assert_eq!(i.real("speed_mm"), Some(250.0));
    i.immediate("POINT b = a", &mut s).expect("POINT runs");
    assert_eq!(i.trans("b"), Some([100.0, 200.0, 300.0, 0.0, 90.0, 0.0]));
    // A later statement sees both.
    let lines = i.immediate("TYPE speed_mm + DZ(b)", &mut s).expect("runs");
    assert_eq!(lines[0].trim(), "550");
}

#[test]
fn a_call_runs_the_subroutine_to_its_end() {
    let (mut i, mut s) = start(LOADED);
    i.immediate("CALL setter", &mut s).expect("CALL runs");
    assert_eq!(i.real("x"), Some(7.0));
    assert_eq!(i.string("name").as_deref(), Some(&b"cell"[..]));
}

#[test]
fn running_tasks_are_not_disturbed_even_when_every_pc_task_runs() {
    let mut src = String::from(LOADED);
    for n in 2..=5 {
        src.push_str(&format!(
            ".PROGRAM busy{n}()\n  c{n} = 0\n  WHILE TRUE DO\n    c{n} = c{n} + 1\n    TWAIT 0.01\n  END\n.END\n"
        ));
    }
    let (mut i, mut s) = start(&src);
    i.pc_execute(1, "counter").expect("starts");
    for n in 2..=5u8 {
        i.pc_execute(n, &format!("busy{n}")).expect("starts");
    }
    i.run_until(&mut s, ms(100));
    let before = (i.real("n").expect("n"), i.real("c5").expect("c5"));
    i.immediate("n = -1000", &mut s).expect("runs");
    i.immediate("TYPE c5", &mut s).expect("runs");
    i.run_until(&mut s, ms(200));
    for n in 1..=5u8 {
        assert_eq!(
            i.task_state(TaskId::Pc(n), &s),
            TaskState::Running,
            "PC task {n}"
        );
    }
    // The counter went on from the value typed; PC task 5's loop went on counting.
    let n = i.real("n").expect("n");
    assert!(
        (-995.0..-985.0).contains(&n),
        "n = {n} (before: {before:?})"
    );
    assert!(i.real("c5").expect("c5") >= before.1 + 9.0);
}

#[test]
fn a_motion_is_refused_as_in_a_pc_program_and_a_wait_is_not_run() {
    let (mut i, mut s) = start(LOADED);
    match i.immediate("JMOVE a", &mut s) {
        Err(ImmediateError::Runtime { code, .. }) => {
            assert_eq!(code, ErrorCode::MOTION_IN_PC_PROGRAM)
        }
        other => panic!("JMOVE at the terminal: {other:?}"),
    }
    assert!(s.motions.is_empty(), "no motion was sent");
    match i.immediate("TWAIT 5", &mut s) {
        Err(ImmediateError::Waits(text)) => assert_eq!(text, "TWAIT 5"),
        other => panic!("TWAIT at the terminal: {other:?}"),
    }
}

#[test]
fn errors_are_the_programs_errors_and_bad_text_is_a_syntax_error() {
    let (mut i, mut s) = start(LOADED);
    match i.immediate("TYPE nothing_here", &mut s) {
        Err(ImmediateError::Runtime { code, text }) => {
            assert_eq!(code, ErrorCode::VARIABLE_NOT_DEFINED);
            assert!(text.starts_with("(E0102)"), "{text}");
        }
        other => panic!("{other:?}"),
    }
    assert!(matches!(
        i.immediate("x = = 3", &mut s),
        Err(ImmediateError::Syntax(_))
    ));
    assert!(matches!(
        i.immediate("CALL no_such_program", &mut s),
        Err(ImmediateError::Syntax(m)) if m.contains("no_such_program")
    ));
    // Nothing of the failed statements stays: the programs are the loaded ones.
    assert_eq!(i.programs(), ["typer", "setter", "counter"]);
}
