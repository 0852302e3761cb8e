//! Instructions the emulator does not model load, are listed as warnings, stop a task that
//! reaches them with E0199 naming the instruction, program and line — and do nothing when the
//! user stubs them.
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

mod common;

use common::{ms, printed};
use fs020n_as::testing::VirtualSystem;
use fs020n_as::{Config, LoadOptions, Loaded, TaskState};
use fs020n_proto::ErrorCode;

const ISSUE_LIST: &str = concat!(
    ".PROGRAM pick()\n",
    "  TOOL gripper\n",
    "  BASE frame\n",
    "  APPRO p, 100\n",
    "  LAPPRO p, 100\n",
    "  JAPPRO p, 100\n",
    "  DEPART 50\n",
    "  LDEPART 50\n",
    "  DRAW 10, 0, 0\n",
    "  TDRAW 0, 0, 10\n",
    "  C1MOVE p\n",
    "  C2MOVE q\n",
    "  SWAIT 1001, -1002\n",
    "  PULSE 2, 0.5\n",
    "  DLYSIG 3, 1\n",
    "  BITS 1, 8 = 255\n",
    "  a = BITS(1001, 8)\n",
    "  OPEN\n",
    "  OPENI 1\n",
    "  CLOSE\n",
    "  CLOSEI 1\n",
    "  RELAX\n",
    "  RELAXI\n",
    "  LEFTY\n",
    "  RIGHTY\n",
    "  ABOVE\n",
    "  BELOW\n",
    "  UWRIST\n",
    "  DWRIST\n",
    "  RUNMASK 1, 8\n",
    "  ONE err.prog\n",
    "  TCP_STATUS .n, .port[1], .sock[1], .err[1], .sub[1], .$ip[1]\n",
    "  UDP_SENDTO .r, .ip[1], 49152, .$d[1], 1, 1\n",
    "  UDP_RECVFROM .r, 49152, .$d[1], .n, 1, .ip[1]\n",
    "  INTFCHK 1\n",
    "  L3JMOVE #a, #b\n",
    "  RTC_SW 1: ON\n",
    ".END\n"
);

#[test]
fn every_instruction_the_issue_lists_loads_as_not_emulated() {
    let loaded = Loaded::from_bytes(
        "pick.as",
        ISSUE_LIST.as_bytes(),
        &LoadOptions::new(),
        Config::default(),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let warnings: Vec<String> = loaded
        .interpreter
        .warnings()
        .iter()
        .map(|w| w.message.clone())
        .collect();
    for word in ["INTFCHK", "L3JMOVE", "RTC_SW"] {
        assert!(
            warnings
                .iter()
                .any(|w| w.starts_with(&format!("{word} loads but is not emulated"))),
            "{word}: {warnings:#?}"
        );
    }
}

fn run(src: &str, opts: &LoadOptions) -> (fs020n_as::Interpreter, VirtualSystem) {
    let mut interp = Loaded::from_bytes("t.as", src.as_bytes(), opts, Config::default())
        .unwrap_or_else(|e| panic!("{e}"))
        .interpreter;
    let mut sys = VirtualSystem::new();
    interp.start(&mut sys);
    interp.run_until(&mut sys, ms(100));
    (interp, sys)
}

#[test]
fn the_modelled_instructions_of_the_list_load_as_statements() {
    let loaded = Loaded::from_bytes(
        "pick.as",
        ISSUE_LIST.as_bytes(),
        &LoadOptions::new(),
        Config::default(),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    for w in loaded.interpreter.warnings() {
        for word in [
            "SWAIT",
            "PULSE",
            "DLYSIG",
            "BITS",
            "OPEN",
            "OPENI",
            "CLOSE",
            "CLOSEI",
            "RELAX",
            "RELAXI",
            "TOOL",
            "BASE",
            "APPRO",
            "LAPPRO",
            "JAPPRO",
            "DEPART",
            "LDEPART",
            "DRAW",
            "TDRAW",
            "RUNMASK",
            "TCP_STATUS",
            "ONE",
            "UDP_SENDTO",
            "UDP_RECVFROM",
        ] {
            assert!(
                !w.message.starts_with(&format!("{word} loads")),
                "{word} runs (see the instruction table in docs/AS.md): {}",
                w.message
            );
        }
    }
}

#[test]
fn a_task_that_reaches_one_stops_with_e0199_naming_instruction_program_and_line() {
    let src = ".PROGRAM autostart.pc()\n  PRINT 1\n  INTFCHK 1001\n  PRINT 2\n.END\n";
    let (i, s) = run(src, &LoadOptions::new());
    assert_eq!(printed(&s)[0], " 1");
    let message = "(E0199) INTFCHK is not emulated (fs020n as check lists these; --stub makes one a no-op) (autostart.pc line 3)";
    assert!(
        printed(&s).contains(&message.to_owned()),
        "{:?}",
        printed(&s)
    );
    assert_eq!(s.raised, vec![ErrorCode(-30199)]);
    let info = i.tasks(&s);
    assert_eq!(info[1].last_error.as_deref(), Some(message));
    assert_eq!(info[1].state, TaskState::Idle);
    assert_eq!(
        fs020n_as::error::error_message(-30199),
        Some("Instruction not emulated")
    );
}

#[test]
fn a_function_the_emulator_does_not_compute_stops_the_task_at_its_line() {
    let (i, s) = run(
        ".PROGRAM autostart.pc()\n  x = 1\n  IF STRTOPOS(\"p\") == 0 THEN\n    x = 2\n  END\n.END\n",
        &LoadOptions::new(),
    );
    assert_eq!(
        i.tasks(&s)[1].last_error.as_deref(),
        Some("(E0199) the function STRTOPOS is not emulated (fs020n as check lists these; --stub makes one a no-op) (autostart.pc line 3)")
    );
}

#[test]
fn a_stubbed_instruction_does_nothing_and_the_task_goes_on() {
    let src = ".PROGRAM autostart.pc()\n  TOOL gripper\n  SWAIT 1001\n  PRINT 2\n.END\n";
    let opts = LoadOptions::new().stub("swait").stub("TOOL");
    let (i, s) = run(src, &opts);
    assert_eq!(printed(&s), vec![" 2"]);
    assert!(s.raised.is_empty());
    assert!(i.tasks(&s)[1].last_error.is_none());
    let w: Vec<&str> = i.warnings().iter().map(|w| w.message.as_str()).collect();
    assert_eq!(
        w,
        [
            "TOOL is stubbed: it loads and does nothing",
            "SWAIT is stubbed: it loads and does nothing"
        ]
    );
}

#[test]
fn an_application_instruction_loads_as_not_emulated_and_can_be_stubbed() {
    let src = ".PROGRAM autostart.pc()\n  GUNON 1, 2\n  PRINT 2\n.END\n";
    let (_, s) = run(src, &LoadOptions::new());
    assert_eq!(s.raised, vec![ErrorCode(-30199)], "GUNON is not emulated");
    assert!(
        !printed(&s).iter().any(|l| l == " 2"),
        "the task stopped at GUNON"
    );
    let (_, s) = run(src, &LoadOptions::new().stub("gunon"));
    assert_eq!(printed(&s), vec![" 2"]);
}

#[test]
fn block_words_are_never_stubbed() {
    let opts = LoadOptions::new().stub("END").stub("if");
    assert!(!opts.is_stubbed("end"));
    let (_, s) = run(
        ".PROGRAM autostart.pc()\n  IF 1 THEN\n    PRINT 1\n  END\n.END\n",
        &opts,
    );
    assert_eq!(printed(&s), vec![" 1"]);
}

#[test]
fn repeated_uses_give_one_warning_with_the_count() {
    let src = ".PROGRAM p()\n  INTFCHK 2\n  INTFCHK 3\n  INTFCHK 4\n.END\n";
    let m = fs020n_as::parse("t.as", src).expect("loads");
    assert_eq!(m.warnings.len(), 1);
    assert_eq!(
        m.warnings[0].to_string(),
        "t.as:2:3: INTFCHK loads but is not emulated (3 lines, the first here): a task that reaches it stops with E0199 (--stub INTFCHK makes it a no-op)"
    );
}

#[test]
fn forms_from_pc_programs_load_as_not_emulated() {
    // INTFCHK, a monitor command the emulator does not run, functions and switches it does
    // not keep: each loads, the program around them runs (EXISTREAL, ROUND, FRAME and the
    // interface panel's IFPWPRINT/IFPWOVERWRITE now run: no warning).
    let src = concat!(
        ".PROGRAM autostart.pc()\n",
        "  IF NOT EXISTREAL (\"tyterm\") THEN\n",
        "    tyterm = 1\n",
        "  END\n",
        "  IFPWPRINT 1 = \"ready\"\n",
        "  IFPWOVERWRITE 1, 2 = \"x\"\n",
        "  INTFCHK 6\n",
        "  MC ZPOWER ON\n",
        "  IF SWITCH(EMERGENCY) THEN\n",
        "    x = 1\n",
        "  END\n",
        "  .v = ROUND(2.5)\n",
        "  POINT p = FRAME(a, b, c, d)\n",
        "  DECOMPOSE .d[0] = STRTOPOS(\"#home\")\n",
        "  $log = $TIME + \" started\"\n",
        ".END\n"
    );
    let loaded = Loaded::from_bytes(
        "t.as",
        src.as_bytes(),
        &LoadOptions::new(),
        Config::default(),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let w: Vec<String> = loaded
        .interpreter
        .warnings()
        .iter()
        .map(|w| {
            format!(
                "{}: {}",
                w.span.line,
                w.message.split(" loads").next().unwrap_or("")
            )
        })
        .collect();
    assert_eq!(w, ["7: INTFCHK"]);
}

#[test]
fn print_to_a_device_named_by_a_variable_prints_to_the_terminal() {
    let (_, s) = run(
        ".PROGRAM autostart.pc()\n  tyterm = 1\n  PRINT tyterm: \"hello\", 2\n.END\n",
        &LoadOptions::new(),
    );
    assert_eq!(printed(&s), vec!["hello 2"]);
}

#[test]
fn autostart_and_errstart_switches_are_set_by_name() {
    let (i, _) = run(
        ".PROGRAM autostart.pc()\n  errstart.pc ON\n  AUTOSTART2.PC ON\n.END\n",
        &LoadOptions::new(),
    );
    assert_eq!(i.system_switch("errstart.pc"), Some(true));
    assert_eq!(i.system_switch("autostart2.pc"), Some(true));
    assert_eq!(i.system_switch("autostart3.pc"), Some(false));
}

#[test]
fn system_switch_lines_of_an_autostart_program_load() {
    let (i, s) = run(
        concat!(
            ".PROGRAM autostart.pc()\n",
            "  CP ON\n",
            "  PREFETCH.SIGINS ON\n",
            "  QTOOL OFF\n",
            "  REP_ONCE ON\n",
            "  HOLD.STEP ON\n",
            "  DISP.EXESTEP ON\n",
            "  PROG.DATE ON\n",
            "  autostart.pc ON\n",
            "  errstart.pc ON ;\n",
            "  PRINT \"set\"\n",
            ".END\n"
        ),
        &LoadOptions::new(),
    );
    assert_eq!(printed(&s), vec!["set"]);
    assert!(i.warnings().is_empty(), "{:?}", i.warnings());
    for sw in [
        "prefetch.sigins",
        "rep_once",
        "hold.step",
        "prog.date",
        "autostart.pc",
    ] {
        assert_eq!(i.system_switch(sw), Some(true), "{sw}");
    }
    // A switch name nobody knows loads as not emulated.
    let (i, s) = run(
        ".PROGRAM autostart.pc()\n  NO.SUCH.SWITCH ON\n.END\n",
        &LoadOptions::new(),
    );
    assert!(
        i.tasks(&s)[1].last_error.as_deref().is_some_and(
            |e| e.starts_with("(E0199) NO.SUCH.SWITCH (a system switch) is not emulated")
        )
    );
}
