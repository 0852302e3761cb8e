//! Every syntax form controllers and their editors save loads: step markers after the
//! `.PROGRAM` line, a blank before `()`, lower-case directives, `.END` with blanks around it,
//! numbered steps, block-teaching steps, `^H`/`^B` literals, `!=` and `|`, whole arrays as
//! arguments, bodies that are not indented, SCASE/SVALUE.
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

mod common;

use common::{ms, printed, start};
use fs020n_as::ast::{BlockSpeed, BlockTarget, StmtKind};
use fs020n_as::{parse, parse_bytes, LoadOptions};

fn loads(text: &str) -> fs020n_as::ast::Module {
    match parse("form.as", text) {
        Ok(m) => m,
        Err(e) => panic!("{e}"),
    }
}

#[test]
fn a_step_number_marker_after_the_program_line_is_accepted() {
    for header in [
        ".PROGRAM main() #0",
        ".PROGRAM main() #9744",
        ".PROGRAM main() #0; #0; #0; comment",
        ".PROGRAM main(.a, .$b) #12 ;comment",
        ".PROGRAM main()@25/10/31 16:24 #0",
        ".PROGRAM main () @24/01/02 08:00 #281; the edit time and step, as saved",
    ] {
        let m = loads(&format!("{header}\r\n  x = 1\r\n.END\r\n"));
        assert_eq!(m.programs[0].name, "main", "{header}");
        assert_eq!(m.programs[0].body.len(), 1, "{header}");
    }
}

#[test]
fn a_blank_before_the_parameters_and_lower_case_directives_load() {
    let m = loads(".program  pick.part (.a)\n  x = .a\n.end\n");
    assert_eq!(m.programs[0].name, "pick.part");
    assert_eq!(m.programs[0].params.len(), 1);
}

#[test]
fn end_with_blanks_around_it_or_indented_closes_the_program() {
    let m = loads(".PROGRAM a()\n  x = 1\n.END \n.PROGRAM b()\n  x = 2\n   .END\t \n.PROGRAM c()\n.End ; last\n");
    let names: Vec<&str> = m.programs.iter().map(|p| p.name.as_str()).collect();
    assert_eq!(names, ["a", "b", "c"]);
}

#[test]
fn numbered_steps_are_labels_a_goto_can_reach() {
    let (mut i, mut s) = start(
        ".PROGRAM autostart.pc()\n1 n = 0\n2 n = n + 1\n3 IF n < 3 GOTO 2\n4 PRINT n\n.END\n",
    );
    i.run_until(&mut s, ms(100));
    assert_eq!(printed(&s), vec![" 3"]);
}

#[test]
fn block_teaching_steps_load_as_steps_and_a_form_the_emulator_does_not_model_as_not_emulated() {
    let m = loads(concat!(
        ".PROGRAM weld1() #0\n",
        "JOINT SPEED9 ACCU1 TIMER0 TOOL1 WORK0 CLAMP1 (OFF,0,0,O) 2 (0,0,0) 0 #[0,-50,-60,0,-80,0,40] ;home\n",
        "  5 LINEAR SPEED3 ACCU0 TIMER1 TOOL1 WORK0 CLAMP1 (ON,0,0,O) 2 (0,0,0) 0 #[10,-40,-60,0,-80,0,40]\n",
        "\tLINEAR 30.0 ACCU1 TIMER0 TOOL1 WORK0 CLAMP OX= WX= #[-1.5,9.6,-122.9,38.1,56.5,-11.7] ;\n",
        "JOINT SPEED9 ACCU1 TIMER0 TOOL1 WORK3 CLAMP OX= WX= #[0,-50,-60,0,-80,0] ;\n",
        ".END\n"
    ));
    let body = &m.programs[0].body;
    assert_eq!(body.len(), 4);
    assert!(matches!(
        &body[0].kind,
        StmtKind::BlockStep(s) if !s.linear && s.speed == BlockSpeed::Number(9)
            && s.target == BlockTarget::Joints([0.0, -50.0, -60.0, 0.0, -80.0, 0.0])
    ));
    assert_eq!(body[1].label.as_ref().map(|l| l.name.as_str()), Some("5"));
    assert!(matches!(
        &body[2].kind,
        StmtKind::BlockStep(s) if s.linear && s.speed == BlockSpeed::MmPerS(30.0)
    ));
    // Work compensation is not modelled: that step loads as not emulated.
    assert!(matches!(
        &body[3].kind,
        StmtKind::NotEmulated { instruction, stubbed: false } if instruction == "JOINT (block-teaching step)"
    ));
    assert_eq!(m.warnings.len(), 1, "{:?}", m.warnings);
    assert!(m.warnings[0]
        .message
        .starts_with("JOINT (block-teaching step) loads but is not emulated"));
}

#[test]
fn hex_and_binary_literals_not_equal_and_bar_as_or() {
    let (mut i, mut s) = start(concat!(
        ".PROGRAM autostart.pc()\n",
        "a = ^H1000\n",
        "b = ^B101\n",
        "IF a != 4096 | b <> 5 THEN\n",
        "  PRINT \"wrong\"\n",
        "ELSE\n",
        "  PRINT a, b\n",
        "END\n",
        "IF a == 1 | b == 5 THEN\n",
        "  PRINT \"or\"\n",
        "END\n",
        ".END\n"
    ));
    i.run_until(&mut s, ms(100));
    assert_eq!(printed(&s), vec![" 4096 5", "or"]);
}

#[test]
fn a_whole_array_argument_gives_the_subroutine_every_element_and_takes_them_back() {
    // Saved programs pass buffers whole: `CALL tcp.send.pc(.$data[], 1)` to
    // `.PROGRAM tcp.send.pc(.$buf[], .n)`. The parameter holds every element; what the
    // subroutine leaves in it is the caller's on RETURN (as for a variable argument, AS-E
    // p.4-12), new elements too.
    let src = ".PROGRAM autostart.pc()\n  .$data[1] = \"AB\"\n  .$data[2] = \"CD\"\n  CALL tcp.send.pc (.$data[], 2)\n  PRINT .$data[1], .$data[2], .$data[3]\n  CALL sum(v[])\n  PRINT v[0]\n.END\n\
.PROGRAM tcp.send.pc(.$buf[], .n)\n  PRINT .$buf[1] + .$buf[.n]\n  .$buf[1] = \"ab\"\n  .$buf[3] = \"new\"\n.END\n\
.PROGRAM sum(.a[])\n  .a[0] = 0\n  FOR .k = 1 TO 3\n    .a[.k] = .k\n    .a[0] = .a[0] + .k\n  END\n.END\n";
    let m = loads(src);
    assert!(m.programs[1].params[0].array);
    let (mut i, mut s) = start(src);
    i.run_until(&mut s, ms(100));
    assert!(
        i.tasks(&s)[1].last_error.is_none(),
        "{:?}",
        i.tasks(&s)[1].last_error
    );
    assert_eq!(printed(&s), vec!["ABCD", "abCDnew", " 6"]);
    assert_eq!(i.real_at("v", &[2]), Some(2.0));
}

#[test]
fn a_whole_two_dimensional_array_by_reference_is_passed_whole() {
    let src = ".PROGRAM autostart.pc()\n  POINT p.rel[1,2] = TRANS(10, 20, 30)\n  CALL trace.part(&p.rel[,])\n  DECOMPOSE d[0] = p.rel[1,2]\n  DECOMPOSE e[0] = p.rel[2,1]\n.END\n\
.PROGRAM trace.part(.&p[,])\n  POINT .p[2,1] = .p[1,2] + TRANS(1)\n.END\n";
    let m = loads(src);
    assert!(m.programs[1].params[0].array && m.programs[1].params[0].by_ref);
    let (mut i, mut s) = start(src);
    i.run_until(&mut s, ms(100));
    assert!(
        i.tasks(&s)[1].last_error.is_none(),
        "{:?}",
        i.tasks(&s)[1].last_error
    );
    assert_eq!(i.real_at("d", &[2]), Some(30.0));
    assert_eq!(i.real_at("e", &[0]), Some(11.0));
}

#[test]
fn unindented_bodies_and_local_variables_at_the_start_of_a_line_load() {
    let (mut i, mut s) =
        start(".PROGRAM autostart.pc()\n.n = 2\n.$s = \"ok\"\nPRINT .$s, .n\n.END\n");
    i.run_until(&mut s, ms(100));
    assert_eq!(printed(&s), vec!["ok 2"]);
}

#[test]
fn scase_and_svalue_choose_by_string() {
    let (mut i, mut s) = start(concat!(
        ".PROGRAM autostart.pc()\n",
        "$c = \"stop\"\n",
        "SCASE $c OF\n",
        "  SVALUE \"go\", \"run\":\n",
        "    PRINT 1\n",
        "  SVALUE \"stop\":\n",
        "    PRINT 2\n",
        "  ANY :\n",
        "    PRINT 3\n",
        "END\n",
        ".END\n"
    ));
    i.run_until(&mut s, ms(100));
    assert_eq!(printed(&s), vec![" 2"]);
}

#[test]
fn lines_may_end_with_cr_alone() {
    let m = parse_bytes(
        "cr.as",
        b".PROGRAM a()\r  x = 1\r.END\r",
        &LoadOptions::new(),
    )
    .expect("loads");
    assert_eq!(m.programs[0].body.len(), 1);
}

#[test]
fn an_assignment_to_a_name_like_an_instruction_word_is_still_an_assignment() {
    // `fine` starts block-teaching steps, but `fine = 1` assigns.
    let (mut i, mut s) = start(".PROGRAM autostart.pc()\n  fine = 1\n  PRINT fine\n.END\n");
    i.run_until(&mut s, ms(100));
    assert_eq!(printed(&s), vec![" 1"]);
}
