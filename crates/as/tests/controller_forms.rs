//! The forms real controllers accept and save, one test per form, and the load policy: names
//! resolve when a task reaches them, instructions the emulator does not run load as not
//! emulated. Every program here is written for these tests.

mod common;

use common::{load_error, ms, pc, printed, run_pc, start};
use fs020n_as::{Target, TaskId};
use fs020n_proto::ErrorCode;

fn warnings(src: &str) -> Vec<String> {
    match fs020n_as::Interpreter::from_source("test.as", src, fs020n_as::Config::default()) {
        Ok(i) => i.warnings().iter().map(|w| w.to_string()).collect(),
        Err(e) => panic!("load failed:\n{e}"),
    }
}

#[test]
fn a_call_to_a_program_of_another_file_loads_and_stops_the_task_with_e0119_when_reached() {
    let (i, s) = run_pc("  a = 1\n  CALL elsewhere\n  a = 2", 0.05);
    assert_eq!(i.real("a"), Some(1.0));
    assert_eq!(s.raised, vec![ErrorCode(-30119)]);
    let lines = s.lines_of(TaskId::Pc(1)).join("\n");
    assert!(
        lines.contains("nonexistent subroutine: program elsewhere"),
        "{lines}"
    );
}

#[test]
fn pcexecute_of_a_dotted_program_name_of_another_file_loads() {
    let (_, s) = run_pc("  PCEXECUTE 2: posedata.pc, -1", 0.05);
    assert_eq!(s.raised, vec![ErrorCode(-30119)]);
}

#[test]
fn a_jump_to_a_missing_label_loads_with_a_warning_and_stops_with_e0101() {
    let src = pc("  a = 1\n  GOTO nowhere\n  a = 2");
    assert!(warnings(&src)
        .iter()
        .any(|w| w.contains("label nowhere is not defined in program autostart.pc")));
    let (i, s) = run_pc("  a = 1\n  GOTO nowhere\n  a = 2", 0.05);
    assert_eq!(i.real("a"), Some(1.0));
    assert_eq!(s.raised, vec![ErrorCode(-30101)]);
}

#[test]
fn an_instruction_the_emulator_does_not_run_loads_and_stops_with_e0199_when_reached() {
    for line in ["STABLE 0.2", "COLRON", "GETULIMIT #lim", "LSQ STR,&V0000"] {
        let src = pc(&format!("  a = 1\n  {line}\n  a = 2"));
        let w = warnings(&src);
        assert!(
            w.iter().any(|w| w.contains("loads but is not emulated")),
            "{line}: {w:?}"
        );
        let (i, s) = run_pc(&format!("  a = 1\n  {line}\n  a = 2"), 0.05);
        assert_eq!(i.real("a"), Some(1.0), "{line}");
        assert_eq!(s.raised, vec![ErrorCode(-30199)], "{line}");
    }
}

#[test]
fn a_monitor_command_after_mc_that_the_emulator_does_not_run_loads() {
    let w = warnings(&pc("  MC PRIME a.main\n  MC ZPOWER ON"));
    assert!(w
        .iter()
        .any(|w| w.contains("MC PRIME loads but is not emulated")));
    assert!(
        !w.iter().any(|w| w.contains("ZPOWER")),
        "MC ZPOWER runs: {w:?}"
    );
}

#[test]
fn mc_zpower_switches_the_motor_power_as_the_monitor_command() {
    // Later controllers' monitor command; real autostart programs turn the motors on with it.
    let src = pc("  MC ZPOWER OFF\n  a = SWITCH(POWER)\n  MC ZPOW ON\n  b = SWITCH(POWER)");
    let (mut i, mut s) = start(&src);
    i.run_until(&mut s, ms(50));
    assert!(s.raised.is_empty(), "{:?}", s.raised);
    assert_eq!(i.real("a"), Some(0.0));
    assert_eq!(i.real("b"), Some(-1.0));
    assert!(s.panel.power);
}

#[test]
fn a_line_with_unbalanced_brackets_is_refused_as_a_controller_would() {
    assert_eq!(
        load_error(&pc("  COLRON (1, 2")),
        "test.as:2:10: this bracket is not closed: a controller refuses this line too"
    );
    assert_eq!(
        load_error(&pc("  COLRON \"open")),
        "test.as:2:10: this string is not closed (a \" is missing): a controller refuses this line too"
    );
}

#[test]
fn omitted_shift_values_are_zero() {
    let (i, _) = run_pc(
        "  POINT p = TRANS(100, 200, 300, 0, 180, 0)\n  POINT q = SHIFT(p BY , , 50)\n  DECOMPOSE v[0] = q",
        0.05,
    );
    assert_eq!(i.real_at("v", &[0]), Some(100.0));
    assert_eq!(i.real_at("v", &[1]), Some(200.0));
    assert_eq!(i.real_at("v", &[2]), Some(350.0));
}

#[test]
fn omitted_trans_components_are_zero() {
    let (i, _) = run_pc("  POINT q = TRANS(, -100)\n  DECOMPOSE v[0] = q", 0.05);
    assert_eq!(i.real_at("v", &[0]), Some(0.0));
    assert_eq!(i.real_at("v", &[1]), Some(-100.0));
    assert_eq!(i.real_at("v", &[2]), Some(0.0));
}

#[test]
fn inline_joint_values_are_a_joint_point() {
    let src = ".PROGRAM autostart.pc()\n  MC EXECUTE rob\n.END\n.PROGRAM rob()\n  JMOVE #[0, 0, -15, 0, -30, 0]\n.END\n";
    let (mut i, mut s) = start(src);
    i.run_until(&mut s, ms(50));
    assert!(s.raised.is_empty(), "{:?}", s.raised);
    match s.motions.first().map(|m| &m.1.target) {
        Some(Target::Joints(j)) => assert_eq!(j[2], -15.0),
        other => panic!("expected a joint target, got {other:?}"),
    }
}

#[test]
fn the_robot_number_before_a_colon_is_read_for_robot_1_and_not_emulated_for_another() {
    let src = ".PROGRAM autostart.pc()\n  MC SPEED 1: 40\n  MC EXECUTE 1: rob\n.END\n.PROGRAM rob()\n  HOME\n.END\n";
    let (mut i, mut s) = start(src);
    i.run_until(&mut s, ms(50));
    assert_eq!(s.monitor_speed, 40.0);
    assert_eq!(s.motions.len(), 1);
    let w = warnings(&pc("  MC EXECUTE 2: prog\n  MC SPEED 2: 100"));
    assert!(w
        .iter()
        .any(|w| w.contains("EXECUTE for another robot loads but is not emulated")));
    assert!(w
        .iter()
        .any(|w| w.contains("SPEED for another robot loads but is not emulated")));
}

#[test]
fn sysdata_takes_a_keyword_argument() {
    // SYSDATA is parsed with its keyword; the function itself is evaluated where emulated.
    let w = warnings(&pc("  IF SYSDATA(STEP) == 1 THEN\n    a = 1\n  END"));
    assert!(w.iter().all(|w| !w.contains("error")), "{w:?}");
}

#[test]
fn rx_ry_rz_are_rotations_about_one_axis() {
    let (i, _) = run_pc(
        "  POINT q = TRANS(10, 0, 0) + RZ(90)\n  POINT r = q + TRANS(10, 0, 0)\n  DECOMPOSE v[0] = r",
        0.05,
    );
    let x = i.real_at("v", &[0]).unwrap_or(f32::NAN);
    let y = i.real_at("v", &[1]).unwrap_or(f32::NAN);
    assert!(
        (x - 10.0).abs() < 1e-3 && (y - 10.0).abs() < 1e-3,
        "{x} {y}"
    );
}

#[test]
fn a_transformation_minus_another_composes_with_its_inverse() {
    let (i, _) = run_pc(
        "  POINT a = TRANS(100, 50, 20, 0, 90, 0)\n  POINT b = a - a\n  DECOMPOSE v[0] = b",
        0.05,
    );
    for k in 0..3 {
        let v = i.real_at("v", &[k]).unwrap_or(f32::NAN);
        assert!(v.abs() < 1e-3, "component {k}: {v}");
    }
}

#[test]
fn point_with_a_component_qualifier_loads_as_not_emulated() {
    let w = warnings(&pc("  POINT/OAT baza = NULL"));
    assert!(w
        .iter()
        .any(|w| w.contains("POINT with a component qualifier loads but is not emulated")));
}

#[test]
fn block_teaching_function_steps_load() {
    let w = warnings(&pc("  FN99[ \"a note\" ]\n  FN20[ 17 ]"));
    assert!(w
        .iter()
        .any(|w| w.contains("FN99 (block-teaching step) loads but is not emulated")));
}

#[test]
fn while_without_do_and_if_without_then_open_blocks() {
    let (i, _) = run_pc(
        "  n = 0\n  WHILE n < 3\n    n = n + 1\n  END\n  IF n == 3\n    ok = 1\n  ELSE\n    ok = 0\n  END",
        0.05,
    );
    assert_eq!(i.real("n"), Some(3.0));
    assert_eq!(i.real("ok"), Some(1.0));
}

#[test]
fn any_without_a_colon_is_the_default_arm() {
    let (i, _) = run_pc(
        "  CASE 7 OF\n    VALUE 1:\n      r = 1\n    ANY\n      r = 2\n  END",
        0.05,
    );
    assert_eq!(i.real("r"), Some(2.0));
}

#[test]
fn goto_with_a_condition_jumps_only_when_it_holds() {
    let (i, _) = run_pc(
        "  n = 0\nagain:\n  n = n + 1\n  GOTO again IF n < 5\n  done = n",
        0.05,
    );
    assert_eq!(i.real("done"), Some(5.0));
}

#[test]
fn a_stray_second_end_line_is_ignored_with_a_warning() {
    let src = ".PROGRAM autostart.pc()\n  PRINT \"ran\"\n.END\n.END\n";
    let w = warnings(src);
    assert!(w
        .iter()
        .any(|w| w.contains(".END without a .PROGRAM or a data section to close: ignored")));
    let (mut i, mut s) = start(src);
    i.run_until(&mut s, ms(10));
    assert_eq!(printed(&s), vec!["ran"]);
}

#[test]
fn integer_variables_read_as_whole_reals() {
    let (i, _) = run_pc("  @count = 3\n  a = @count * 2", 0.05);
    assert_eq!(i.real("a"), Some(6.0));
}

#[test]
fn a_transformation_argument_may_carry_its_ampersand() {
    let src = ".PROGRAM autostart.pc()\n  POINT p = TRANS(1, 2, 3)\n  CALL show(&p)\n.END\n.PROGRAM show(.&t)\n  DECOMPOSE v[0] = .t\n.END\n";
    let (mut i, mut s) = start(src);
    i.run_until(&mut s, ms(10));
    assert!(s.raised.is_empty(), "{:?}", s.raised);
    assert_eq!(i.real_at("v", &[2]), Some(3.0));
}

#[test]
fn a_data_line_that_cannot_be_read_is_left_out_with_a_warning() {
    let src = ".PROGRAM autostart.pc()\n.END\n.TRANS\np1 1 2 3 0 0 0\n1 4 5 6 0 0 0\n.END\n";
    let w = warnings(src);
    assert!(
        w.iter().any(|w| w.contains("this data line is not loaded")),
        "{w:?}"
    );
}

#[test]
fn abbreviations_follow_the_manual_and_ambiguous_ones_are_refused() {
    // EX is EXTCALL or EXECUTE in a program: P0110.
    assert!(load_error(&pc("  EX prog")).contains("spell it out (P0110"));
    let (_, s) = run_pc("  PRIN \"p\"\n  TY \"t\"", 0.05);
    assert_eq!(printed(&s), vec!["p", "t"]);
}

#[test]
fn a_switch_may_name_its_robot_before_a_colon() {
    let w = warnings(&pc("  ABS.SPEED 1: ON\n  ABS.SPEED 2: OFF"));
    assert!(w
        .iter()
        .any(|w| w.contains("ABS.SPEED of another robot loads but is not emulated")));
}

#[test]
fn an_instruction_may_name_its_robot_before_a_colon() {
    let (i, _) = run_pc(
        "  POINT 1: #p = #PPOINT(1, 2, 3, 4, 5, 6)\n  DECOMPOSE 1: v[0] = #p",
        0.05,
    );
    assert_eq!(i.real_at("v", &[2]), Some(3.0));
    let w = warnings(&pc("  POINT .rno: .#pos = #PPOINT(0)\n  a = INRANGE:2(#p)"));
    assert!(
        w.iter()
            .any(|w| w.contains("POINT for another robot loads but is not emulated")),
        "{w:?}"
    );
}

#[test]
fn double_ampersand_and_double_bar_are_and_and_or() {
    let (i, _) = run_pc("  r = 2\n  IF r != 1 && r != 3 THEN\n    a = 1\n  END\n  IF r == 5 || r == 2 THEN\n    b = 1\n  END", 0.05);
    assert_eq!(i.real("a"), Some(1.0));
    assert_eq!(i.real("b"), Some(1.0));
}

#[test]
fn a_block_step_with_an_application_prefix_loads() {
    let w = warnings(&pc(
        "  AC JOINT SPEED2 ACCU4 TIMER0 OX= WX= #[1, 2, 3, 4, 5, 6]",
    ));
    assert!(
        w.iter()
            .any(|w| w.contains("AC (block-teaching step) loads but is not emulated")),
        "{w:?}"
    );
}
