//! Operator precedence as AS-E p.3-22 lists it, one test per level: each pairs an operator
//! with the next lower level and shows which binds first. Highest first: functions and array
//! references; `^`; unary `-`, `NOT`, `COM`; `*` `/`; `MOD`; `+` `-`; relational operators;
//! `BAND`; `BOR`; `BXOR`; `AND`; `OR`; `XOR`.

mod common;

use common::run_pc;

/// The value of `expr` computed by a PC program.
fn value(expr: &str) -> f32 {
    let (i, s) = run_pc(&format!("  v = {expr}"), 0.05);
    assert!(s.raised.is_empty(), "{expr}: {:?}", s.terminal);
    i.real("v").unwrap_or(f32::NAN)
}

#[test]
fn a_function_binds_before_the_power() {
    assert_eq!(value("ABS(-2) ^ 2"), 4.0);
}

#[test]
fn the_power_binds_before_unary_minus() {
    assert_eq!(value("-2 ^ 2"), -4.0);
    assert_eq!(value("2 ^ -1"), 0.5);
}

#[test]
fn unary_not_and_com_bind_before_multiplication_and_comparison() {
    // (NOT 0) * 2 = -2, not NOT (0 * 2) = -1.
    assert_eq!(value("NOT 0 * 2"), -2.0);
    // (NOT a) == b: a program's history records the controller doing this.
    assert_eq!(value("NOT 1 == 0"), -1.0);
    assert_eq!(value("COM 0 * 2"), -2.0);
}

#[test]
fn multiplication_binds_before_mod() {
    // 7 MOD (3 * 2) = 1; (7 MOD 3) * 2 would be 2.
    assert_eq!(value("7 MOD 3 * 2"), 1.0);
}

#[test]
fn mod_binds_before_addition() {
    assert_eq!(value("1 + 7 MOD 4"), 4.0);
}

#[test]
fn addition_binds_before_comparison() {
    assert_eq!(value("1 + 1 == 2"), -1.0);
}

#[test]
fn comparison_binds_before_band() {
    // (1 == 1) BAND 3 = -1 BAND 3 = 3; 1 == (1 BAND 3) would be -1.
    assert_eq!(value("1 == 1 BAND 3"), 3.0);
}

#[test]
fn band_binds_before_bor() {
    // 4 BOR (6 BAND 3) = 6; (4 BOR 6) BAND 3 would be 2.
    assert_eq!(value("4 BOR 6 BAND 3"), 6.0);
}

#[test]
fn bor_binds_before_bxor() {
    // 3 BXOR (1 BOR 2) = 0; (3 BXOR 1) BOR 2 would be 2.
    assert_eq!(value("3 BXOR 1 BOR 2"), 0.0);
}

#[test]
fn bxor_binds_before_and() {
    // 1 AND (1 BXOR 1) = 0; (1 AND 1) BXOR 1 would be -1 BXOR 1 = -2.
    assert_eq!(value("1 AND 1 BXOR 1"), 0.0);
}

#[test]
fn and_binds_before_or() {
    // 1 OR (0 AND 0) = -1; (1 OR 0) AND 0 would be 0.
    assert_eq!(value("1 OR 0 AND 0"), -1.0);
}

#[test]
fn or_binds_before_xor() {
    // 1 XOR (0 OR 1) = 0; (1 XOR 0) OR 1 would be -1.
    assert_eq!(value("1 XOR 0 OR 1"), 0.0);
}

#[test]
fn parentheses_override() {
    assert_eq!(value("(1 + 2) * 3"), 9.0);
    assert_eq!(value("NOT (1 == 0)"), -1.0);
}
