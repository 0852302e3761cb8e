//! A running interpreter takes a new set of programs (`Interpreter::adopt`, a `LOAD` while
//! tasks run), on virtual time: what runs goes on untouched, mapped onto the new code by name;
//! what cannot be mapped is refused and nothing changes.
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

mod common;

use common::*;
use fs020n_as::{Config, Interpreter, ReloadError, TaskId, TaskState};

fn load(src: &str) -> Interpreter {
    match Interpreter::from_source("new.as", src, Config::default()) {
        Ok(i) => i,
        Err(e) => panic!("load failed:\n{e}"),
    }
}

fn data(src: &str) -> Vec<fs020n_as::ast::DataItem> {
    fs020n_as::parse("new.as", src).expect("parses").data
}

/// Counts in PC task 1, one step every 0.1 s.
const COUNTER: &str = ".PROGRAM autostart.pc()\n  n = 0\n  WHILE TRUE DO\n    n = n + 1\n    TWAIT 0.1\n  END\n.END\n";

/// A program placed first, so that the globals and programs after it get other slots and
/// indices in the new set than in the old.
const SHIFT: &str = ".PROGRAM aaa()\n  z1 = 1\n  z2 = 2\n  z3 = 3\n.END\n";

#[test]
fn a_global_of_a_running_task_keeps_its_value_and_its_pace_across_a_reload() {
    let (mut plain, mut ps) = start(COUNTER);
    let (mut i, mut s) = start(COUNTER);
    i.run_until(&mut s, ms(450));
    let more = format!("{SHIFT}{COUNTER}.PROGRAM other()\n  m = n\n.END\n");
    i.adopt(load(&more), &[]).expect("the counter is unchanged");
    assert_eq!(i.real("n"), Some(5.0), "kept at once");
    // Differential: the counter's values at every 10 ms are those of an interpreter never
    // reloaded.
    for k in 46..=200u64 {
        i.run_until(&mut s, ms(10 * k));
        plain.run_until(&mut ps, ms(10 * k));
        assert_eq!(i.real("n"), plain.real("n"), "at {} ms", 10 * k);
    }
    assert_eq!(i.tasks(&s)[1].steps, plain.tasks(&ps)[1].steps);
    // And the new program runs beside it, reading the shared global.
    i.run_until(&mut s, ms(2050));
    i.pc_execute(2, "other").expect("starts");
    i.run_until(&mut s, ms(2060));
    assert_eq!(i.real("m"), Some(21.0));
    assert_eq!(i.real("z1"), None, "aaa never ran");
}

#[test]
fn a_frame_in_a_called_program_keeps_its_step_and_its_locals() {
    let old = ".PROGRAM autostart.pc()\n  CALL sub(7)\n  after = TIMER(0)\n.END\n\
               .PROGRAM sub(.k)\n  .x = .k * 2\n  TWAIT 0.5\n  got = .x + .k\n.END\n";
    let (mut i, mut s) = start(old);
    i.run_until(&mut s, ms(250));
    let before = i.tasks(&s)[1].clone();
    assert_eq!(before.program.as_deref(), Some("sub"));
    i.adopt(load(&format!("{SHIFT}{old}")), &[])
        .expect("both programs are unchanged");
    let after = i.tasks(&s)[1].clone();
    // The same step (its line in the file moved by the program placed first).
    assert_eq!((after.program, after.text), (before.program, before.text));
    assert_eq!(after.line, before.line.map(|l| l + 5));
    i.run_until(&mut s, ms(1000));
    assert_eq!(i.real("got"), Some(21.0), "the local .x and .k survived");
    assert_eq!(i.real("after"), Some(0.5), "the TWAIT ended on time");
}

#[test]
fn a_by_reference_argument_naming_a_global_goes_back_to_that_global() {
    let old = ".PROGRAM autostart.pc()\n  g = 1\n  CALL bump(g)\n  done = 1\n.END\n\
               .PROGRAM bump(.v)\n  .v = .v + 1\n  TWAIT 0.5\n  .v = .v + 10\n.END\n";
    let (mut i, mut s) = start(old);
    i.run_until(&mut s, ms(250));
    i.adopt(load(&format!("{SHIFT}{old}")), &[])
        .expect("unchanged");
    i.run_until(&mut s, ms(1000));
    assert_eq!(i.real("done"), Some(1.0));
    assert_eq!(i.real("g"), Some(12.0));
    for z in ["z1", "z2", "z3"] {
        assert_eq!(i.real(z), None, "{z} was not written by the RETURN");
    }
}

#[test]
fn an_interrupt_armed_before_the_reload_calls_its_program_after_it() {
    let waiter =
        ".PROGRAM autostart.pc()\n  ON 2011 CALL handler\n  TWAIT 1\n  after = TIMER(0)\n.END\n";
    let old = format!("{waiter}.PROGRAM handler()\n  handled = 1\n.END\n");
    let (mut i, mut s) = start(&old);
    i.run_until(&mut s, ms(100));
    // The handler moves to another index and its text changes: the new text runs.
    let new = format!("{SHIFT}{waiter}.PROGRAM handler()\n  handled = 2\n  at = TIMER(0)\n.END\n");
    i.adopt(load(&new), &[]).expect("the waiter is unchanged");
    i.set_signal(2011, true);
    i.run_until(&mut s, ms(2000));
    assert_eq!(i.real("handled"), Some(2.0));
    assert_eq!(i.real("at"), Some(1.0), "called when the TWAIT ended");
    assert_eq!(i.real("after"), Some(1.0));
    assert_eq!(i.real("z1"), None, "the interrupt did not call aaa");
}

#[test]
fn a_running_program_whose_text_changed_is_refused_and_nothing_changes() {
    let (mut plain, mut ps) = start(COUNTER);
    let (mut i, mut s) = start(COUNTER);
    i.run_until(&mut s, ms(450));
    plain.run_until(&mut ps, ms(450));
    let changed = COUNTER.replace("n + 1", "n + 100");
    assert_eq!(
        i.adopt(load(&format!("{changed}.PROGRAM other()\n.END\n")), &[]),
        Err(ReloadError::ProgramChanged {
            task: "pc1".into(),
            program: "autostart.pc".into()
        })
    );
    assert_eq!(i.programs(), vec!["autostart.pc"]);
    assert!(
        i.pc_execute(2, "other").is_err(),
        "the new set was not taken"
    );
    i.run_until(&mut s, ms(1050));
    plain.run_until(&mut ps, ms(1050));
    assert_eq!(i.real("n"), plain.real("n"));
    assert_eq!(i.real("n"), Some(11.0));
}

#[test]
fn a_running_program_missing_from_the_new_set_is_refused() {
    let (mut i, mut s) = start(COUNTER);
    i.run_until(&mut s, ms(150));
    let err = i
        .adopt(load(".PROGRAM other()\n.END\n"), &[])
        .expect_err("refused");
    assert_eq!(
        err,
        ReloadError::ProgramMissing {
            task: "pc1".into(),
            program: "autostart.pc".into()
        }
    );
    assert!(
        err.to_string().contains("PCABORT"),
        "names the remedy: {err}"
    );
    assert_eq!(i.task_state(TaskId::Pc(1), &s), TaskState::Running);
}

#[test]
fn an_armed_interrupts_program_missing_from_the_new_set_is_refused() {
    // `arm` arms the interrupt and returns: the interrupt stays, naming `handler`.
    let main = ".PROGRAM autostart.pc()\n  CALL arm\n  TWAIT 1\n.END\n";
    let old = format!(
        "{main}.PROGRAM arm()\n  ON 2011 CALL handler\n.END\n.PROGRAM handler()\n  handled = 1\n.END\n"
    );
    let (mut i, mut s) = start(&old);
    i.run_until(&mut s, ms(100));
    let err = i
        .adopt(load(&format!("{main}.PROGRAM arm()\n.END\n")), &[])
        .expect_err("handler is gone");
    assert_eq!(
        err,
        ReloadError::HandlerMissing {
            task: "pc1".into(),
            program: "handler".into()
        }
    );
    i.set_signal(2011, true);
    i.run_until(&mut s, ms(2000));
    assert_eq!(i.real("handled"), Some(1.0), "the old handler still runs");
}

#[test]
fn globals_held_stay_the_loaded_data_overwrites_and_new_globals_take_their_data() {
    let old = ".PROGRAM autostart.pc()\n  a = 1\n  b = 2\n  c[3] = 4\n  TWAIT 10\n.END\n";
    let (mut i, mut s) = start(old);
    i.run_until(&mut s, ms(100));
    // The memory's data sections give every global a value; only those of the file just
    // loaded (`loaded`) overwrite a value held.
    let memory = format!(
        "{old}.PROGRAM other()\n  d = d + 1\n.END\n.REALS\na = 10\nb = 20\nc[3] = 40\nc[4] = 50\nd = 30\n.END\n"
    );
    let loaded = ".REALS\nb = 200\nc[4] = 500\n.END\n";
    i.adopt(load(&memory), &data(loaded)).expect("unchanged");
    assert_eq!(i.real("a"), Some(1.0), "held: stays");
    assert_eq!(i.real("b"), Some(200.0), "named by the file loaded");
    assert_eq!(i.real_at("c", &[3]), Some(4.0), "the element held stays");
    assert_eq!(i.real_at("c", &[4]), Some(500.0), "the element loaded");
    assert_eq!(i.real("d"), Some(30.0), "new: from the data section");
    i.pc_execute(2, "other").expect("starts");
    i.run_until(&mut s, ms(200));
    assert_eq!(i.real("d"), Some(31.0));
}

#[test]
fn a_global_the_new_programs_no_longer_name_is_kept() {
    let old = ".PROGRAM autostart.pc()\n  n = 3\n  TWAIT 10\n.END\n.PROGRAM gone()\n  only_here = 9\n.END\n";
    let (mut i, mut s) = start(old);
    i.pc_execute(2, "gone").expect("starts");
    i.run_until(&mut s, ms(100));
    let without = ".PROGRAM autostart.pc()\n  n = 3\n  TWAIT 10\n.END\n.PROGRAM back()\n  seen = only_here\n.END\n";
    i.adopt(load(without), &[]).expect("unchanged");
    assert_eq!(i.real("only_here"), Some(9.0));
    i.pc_execute(2, "back").expect("starts");
    i.run_until(&mut s, ms(200));
    assert_eq!(i.real("seen"), Some(9.0));
}

#[test]
fn programs_in_use_lists_the_started_and_the_called_programs() {
    let old = ".PROGRAM autostart.pc()\n  CALL sub\n.END\n.PROGRAM sub()\n  TWAIT 1\n.END\n.PROGRAM idle()\n.END\n";
    let (mut i, mut s) = start(old);
    i.run_until(&mut s, ms(100));
    assert_eq!(i.programs_in_use(), vec!["autostart.pc", "sub"]);
    i.run_until(&mut s, ms(1100));
    assert!(i.programs_in_use().is_empty());
}
