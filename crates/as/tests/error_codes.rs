//! Every runtime error stops its task with the number of the AS manual's error list (E series,
//! Appendix 4), so that a PC program that reads `ERROR` (or the reply's field 2) sees what a
//! real controller reports; the message printed names the remedy where there is one, and
//! `$ERROR` knows the code.
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

mod common;

use std::time::Duration;

use common::{pc, start};
use fs020n_as::error::{error_message, NOT_EMULATED};
use fs020n_as::testing::VirtualSystem;
use fs020n_as::Interpreter;
use fs020n_proto::ErrorCode;

/// Runs `src` for `secs` seconds of virtual time.
fn run(src: &str, secs: u64) -> (Interpreter, VirtualSystem) {
    let (mut i, mut s) = start(src);
    i.run_until(&mut s, Duration::from_secs(secs));
    (i, s)
}

/// `body` as the robot program `rob`, started by the PC program.
fn robot(body: &str) -> String {
    format!("{}.PROGRAM rob()\n{body}\n.END\n", pc("  MC EXECUTE rob"))
}

/// Asserts that `src` stops with `code` (named `name`) alone, that the line printed for it
/// begins with the code's name and contains `remedy`, and that `$ERROR` has a text for it.
fn stops_with(src: &str, secs: u64, name: &str, remedy: &str) {
    let code: ErrorCode = name.parse().expect("a code name");
    let (_, s) = run(src, secs);
    assert_eq!(s.raised, vec![code], "{src}\n{:?}", s.terminal);
    assert_eq!(s.error, code, "{src}");
    let line = s
        .terminal
        .iter()
        .map(|(_, l)| l.as_str())
        .find(|l| l.starts_with(&format!("({name})")))
        .unwrap_or_else(|| panic!("no ({name}) line: {:?}", s.terminal));
    assert!(line.contains(remedy), "{name}: {line:?} lacks {remedy:?}");
    assert!(error_message(code.raw()).is_some(), "$ERROR({name})");
}

#[test]
fn a_real_variable_never_assigned_is_e0102() {
    stops_with(
        &pc("  a = b + 1"),
        1,
        "E0102",
        "b (assign it before reading it)",
    );
}

#[test]
fn a_location_never_assigned_is_e0103_for_transformations_and_joints() {
    stops_with(
        &pc("  POINT p = q"),
        1,
        "E0103",
        "teach it with HERE or assign it with POINT",
    );
    stops_with(
        &pc("  a = DEXT(#q, 1)"),
        1,
        "E0103",
        "#q (teach it with HERE",
    );
}

#[test]
fn a_string_never_assigned_is_e0104() {
    stops_with(
        &pc("  $s = $t + \"x\""),
        1,
        "E0104",
        "$t (assign it before reading it)",
    );
}

#[test]
fn an_undefined_variable_of_any_type_may_still_be_given_to_call_to_receive_a_result() {
    let src = ".PROGRAM autostart.pc()\n  CALL fill(r, $s, &p, #j)\n  done = 1\n.END\n\
               .PROGRAM fill(.r, .$s, .&p, .#j)\n  .r = 1\n  .$s = \"x\"\n  POINT .p = TRANS(1, 2, 3, 0, 0, 0)\n  POINT .#j = #PPOINT(1, 2, 3, 4, 5, 6)\n.END\n";
    let (i, s) = run(src, 1);
    assert!(s.raised.is_empty(), "{:?}", s.terminal);
    assert_eq!(i.real("done"), Some(1.0));
    assert_eq!(i.real("r"), Some(1.0));
    assert_eq!(i.string("s"), Some(b"x".to_vec()));
}

#[test]
fn an_argument_out_of_range_is_e0106() {
    stops_with(&pc("  TCP_LISTEN .r, 80"), 1, "E0106", "8192 to 65535");
}

#[test]
fn division_by_zero_is_e0108() {
    stops_with(&pc("  a = 1 / 0"), 1, "E0108", "check the divisor");
    stops_with(&pc("  a = 5 MOD 0"), 1, "E0108", "check the divisor");
}

#[test]
fn a_result_too_large_for_a_real_is_e0109() {
    stops_with(
        &pc("  a = 1E30 * 1E30"),
        1,
        "E0109",
        "floating point overflow",
    );
}

#[test]
fn a_string_longer_than_255_characters_is_e0110() {
    stops_with(
        &pc("  $s = $CHR(65)\n  FOR .i = 1 TO 8\n    $s = $s + $s\n  END"),
        1,
        "E0110",
        "at most 255",
    );
}

#[test]
fn sqrt_of_a_negative_number_is_e0114() {
    stops_with(&pc("  a = SQRT(-4)"), 1, "E0114", "SQRT(-4)");
}

#[test]
fn an_array_index_outside_0_to_9999_is_e0115() {
    stops_with(
        &pc("  a[10000] = 1"),
        1,
        "E0115",
        "indices go from 0 to 9999",
    );
    stops_with(&pc("  a[-1] = 1"), 1, "E0115", "indices go from 0 to 9999");
}

#[test]
fn runaway_recursion_is_e0118() {
    stops_with(
        ".PROGRAM autostart.pc()\n  CALL deeper\n.END\n.PROGRAM deeper()\n  CALL deeper\n.END\n",
        1,
        "E0118",
        "needs a condition that ends it",
    );
}

#[test]
fn a_program_not_loaded_is_e0119() {
    stops_with(
        &pc("  CALL nowhere"),
        1,
        "E0119",
        "load the file that holds it",
    );
}

#[test]
fn a_jump_to_a_missing_label_is_e0101() {
    stops_with(&pc("  GOTO 100"), 1, "E0101", "100");
}

#[test]
fn a_motion_in_a_pc_program_is_e1095() {
    stops_with(
        &pc("  LMOVE TRANS(900, 0, 600, 0, 180, 0)"),
        1,
        "E1095",
        "move it to the robot program",
    );
    stops_with(
        &pc("  ONI 2001 GOTO x\nx:"),
        1,
        "E1095",
        "move it to the robot program",
    );
}

#[test]
fn execute_or_mc_in_the_robot_program_is_p1023() {
    stops_with(&robot("  MC ABORT"), 1, "P1023", "move it to a PC program");
}

#[test]
fn c2move_without_its_c1move_is_e1098() {
    stops_with(
        &robot("  C2MOVE TRANS(900, 100, 600, 0, 180, 0)"),
        2,
        "E1098",
        "write C1MOVE via-point, then C2MOVE",
    );
}

#[test]
fn c1move_followed_by_another_motion_or_the_end_is_e1097() {
    stops_with(
        &robot("  C1MOVE TRANS(900, 100, 600, 0, 180, 0)\n  LMOVE TRANS(900, 0, 600, 0, 180, 0)"),
        2,
        "E1097",
        "a C2MOVE must come next",
    );
    stops_with(
        &robot("  C1MOVE TRANS(900, 100, 600, 0, 180, 0)"),
        2,
        "E1097",
        "a C2MOVE must follow it",
    );
}

#[test]
fn three_points_on_one_line_are_e1099() {
    stops_with(
        &robot(
            "  LMOVE TRANS(900, 0, 600, 0, 180, 0)\n  BREAK\n  C1MOVE TRANS(1000, 0, 600, 0, 180, 0)\n  C2MOVE TRANS(1100, 0, 600, 0, 180, 0)",
        ),
        20,
        "E1099",
        "check the three points",
    );
}

#[test]
fn filling_the_variable_memory_is_p1031() {
    stops_with(
        &pc("  FOR .j = 0 TO 20\n    FOR .i = 0 TO 9999\n      a[.j, .i] = 1\n    END\n  END"),
        100_000,
        "P1031",
        "variable memory is full",
    );
}

#[test]
fn an_instruction_not_emulated_is_the_emulators_own_e0199() {
    assert_eq!(NOT_EMULATED.to_string(), "E0199");
    stops_with(
        &pc("  INTFCHK 1001"),
        1,
        "E0199",
        "--stub makes one a no-op",
    );
    // E0111 is the manual's "operation with a negative exponent", not this.
    assert_ne!(error_message(-30111), error_message(NOT_EMULATED.raw()));
}

#[test]
fn error_reads_the_code_a_pc_program_stopped_with() {
    let src = ".PROGRAM autostart.pc()\n  PCEXECUTE 2: fail\n  TWAIT 0.5\n  e = ERROR\n  $m = $ERROR(ERROR)\n.END\n\
               .PROGRAM fail()\n  a = 1 / 0\n.END\n";
    let (i, s) = run(src, 2);
    assert_eq!(s.raised, vec![ErrorCode::DIVIDED_BY_ZERO]);
    assert_eq!(i.real("e"), Some(-30108.0));
    assert_eq!(i.string("m"), Some(b"Division by zero".to_vec()));
}
