//! The sections of a controller backup: programs and data are read, `.SYSDATA`'s switches
//! are read, every other section is kept opaque and reported with its line range — and no
//! section swallows its neighbours.
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

use fs020n_as::ast::{DataValue, Module};
use fs020n_as::sections::SectionUse;
use fs020n_as::{parse_bytes, LoadOptions};

fn loads(text: &str) -> Module {
    parse_bytes("backup.as", text.as_bytes(), &LoadOptions::new()).unwrap_or_else(|e| panic!("{e}"))
}

/// A backup written here in the shape of a controller save: header lines, one-line
/// directives, a program, data, the system data and the opaque sections.
const BACKUP: &str = concat!(
    ".**************************************************\r\n", // 1
    ".** backup.as  saved by the controller\r\n",              // 2
    ".**************************************************\r\n", // 3
    ".NETCONF 192.168.0.2,\"robot1\",255.255.255.0,0.0.0.0\r\n", // 4
    ".NETCONF2 10.0.0.2,\"robot1\"\r\n",                       // 5
    ".SAVETIME 2024/05/01 12:00\r\n",                          // 6
    ".LANGUAGE ENGLISH\r\n",                                   // 7
    ".PROGRAM autostart.pc() #0\r\n",                          // 8
    "  PRINT \"up\"\r\n",                                      // 9
    ".END\r\n",                                                // 10
    ".AUXDATA\r\n",                                            // 11
    "N_INT1    \"ready    \"\r\n",                             // 12
    ".END\r\n",                                                // 13
    ".ROBOTDATA2\r\n",                                         // 14
    "ZROB.TYPE 1 2 3\r\n",                                     // 15
    ".END\r\n",                                                // 16
    ".INTER_PANEL_D\r\n",                                      // 17
    "0,1,\"A\",\"B\"\r\n",                                     // 18
    ".END\r\n",                                                // 19
    ".SIG_COMMENT\r\n",                                        // 20
    "2001 \"gripper closed\"\r\n",                             // 21
    ".KLOGIC_DATA\r\n",                                        // 22
    "K 1 2\r\n",                                               // 23
    ".END\r\n",                                                // 24
    ".OPELOG\r\n",                                             // 25
    "2024/05/01 power on\r\n",                                 // 26
    ".END\r\n",                                                // 27
    ".ERRLOG\r\n",                                             // 28
    "E1088 2024/05/01\r\n",                                    // 29
    ".END\r\n",                                                // 30
    ".SYSDATA\r\n",                                            // 31
    "  SWITCH AUTOSTART.PC    ON\r\n",                         // 32
    "  SWITCH AUTOSTART2.PC   OFF\r\n",                        // 33
    "  ZSWITCH ZKILL_LOAD OFF\r\n",                            // 34
    ".END\r\n",                                                // 35
    ".REALS\r\n",                                              // 36
    "speed = 30\r\n",                                          // 37
    ".END\r\n",                                                // 38
    ".STRINGS\r\n",                                            // 39
    "$name = \"cell 1\"\r\n",                                  // 40
    ".END\r\n",                                                // 41
    ".JOINTS\r\n",                                             // 42
    "#home 0 0 -90 0 -90 0\r\n",                               // 43
    ".END\r\n",                                                // 44
    ".TRANS\r\n",                                              // 45
    "pick 850 0 1153.5 0 180 0\r\n",                           // 46
    ".END\r\n",                                                // 47
);

#[test]
fn every_section_of_a_backup_is_read_or_reported_with_its_lines() {
    let m = loads(BACKUP);
    let got: Vec<(&str, u32, u32, SectionUse)> = m
        .sections
        .iter()
        .map(|s| (s.name.as_str(), s.first_line, s.last_line, s.reads))
        .collect();
    use SectionUse::*;
    assert_eq!(
        got,
        vec![
            ("NETCONF", 4, 4, Opaque),
            ("NETCONF2", 5, 5, Opaque),
            ("SAVETIME", 6, 6, Opaque),
            ("LANGUAGE", 7, 7, Opaque),
            ("PROGRAM", 8, 10, Program),
            ("AUXDATA", 11, 13, Opaque),
            ("ROBOTDATA2", 14, 16, Opaque),
            ("INTER_PANEL_D", 17, 19, Opaque),
            ("SIG_COMMENT", 20, 21, Opaque),
            ("KLOGIC_DATA", 22, 24, Opaque),
            ("OPELOG", 25, 27, Opaque),
            ("ERRLOG", 28, 30, Opaque),
            ("SYSDATA", 31, 35, SysData),
            ("REALS", 36, 38, Data),
            ("STRINGS", 39, 41, Data),
            ("JOINTS", 42, 44, Data),
            ("TRANS", 45, 47, Data),
        ]
    );
    assert_eq!(m.programs.len(), 1);
    assert_eq!(m.data.len(), 4);
    assert_eq!(m.data[1].value, DataValue::Str(b"cell 1".to_vec()));
}

#[test]
fn a_one_line_directive_does_not_swallow_the_sections_after_it() {
    let m = loads(".NETCONF 192.168.0.2\n.PROGRAM a()\n  x = 1\n.END\n.REALS\nx = 2\n.END\n");
    assert_eq!(m.programs.len(), 1);
    assert_eq!(m.data.len(), 1);
}

#[test]
fn a_section_without_its_end_stops_where_the_next_known_section_begins() {
    let m = loads(BACKUP);
    let w = m
        .warnings
        .iter()
        .find(|w| w.message.contains("SIG_COMMENT"))
        .expect("a warning");
    assert_eq!(
        w.to_string(),
        "backup.as:20:1: section .SIG_COMMENT (lines 20–21) is kept as it is: the emulator does not use it; it has no .END and ends before line 22, where the next section begins"
    );
}

#[test]
fn an_unknown_section_ends_at_its_end_or_at_the_next_known_section() {
    let m = loads(".VENDOR_THING\na b c\n.END\n.OTHER_THING 1 2\n.PROGRAM a()\n.END\n");
    let names: Vec<(&str, u32, u32, bool)> = m
        .sections
        .iter()
        .map(|s| (s.name.as_str(), s.first_line, s.last_line, s.known))
        .collect();
    assert_eq!(
        names,
        vec![
            ("VENDOR_THING", 1, 3, false),
            ("OTHER_THING", 4, 4, false),
            ("PROGRAM", 5, 6, true)
        ]
    );
    assert!(m.warnings[0]
        .message
        .starts_with("unknown section .VENDOR_THING (lines 1–3) is kept as it is"));
    assert_eq!(m.programs.len(), 1);
}

#[test]
fn the_autostart_switches_of_sysdata_are_read() {
    let m = loads(BACKUP);
    assert_eq!(m.switch("AUTOSTART.PC"), Some(true));
    assert_eq!(m.switch("autostart2.pc"), Some(false));
    assert_eq!(m.switch("autostart3.pc"), None);
    assert_eq!(m.autostart(), vec![(1, true), (2, false)]);
    // `SWITCH name = ON`, as the manual writes the command, also reads.
    let m = loads(".SYSDATA\nSWITCH AUTOSTART3.PC = ON\n.END\n");
    assert_eq!(m.autostart(), vec![(3, true)]);
}

#[test]
fn a_save_with_no_program_loads() {
    let m = loads(".** header only\n.NETCONF 1.2.3.4\n.REALS\na = 1\n.END\n");
    assert!(m.programs.is_empty());
    assert_eq!(m.data.len(), 1);
    let i = fs020n_as::Loaded::from_bytes(
        "data.as",
        b".REALS\na = 1\n.END\n",
        &LoadOptions::new(),
        fs020n_as::Config::default(),
    )
    .expect("loads");
    assert_eq!(i.interpreter.real("a"), Some(1.0));
    assert!(i.interpreter.programs().is_empty());
}

#[test]
fn a_program_without_end_is_still_an_error() {
    let e = parse_bytes("p.as", b".PROGRAM a()\n  x = 1\n", &LoadOptions::new()).unwrap_err();
    assert_eq!(
        e.to_string(),
        "p.as:1:1: expected .END to close this .PROGRAM (the file ends at line 3)"
    );
    let e = parse_bytes(
        "p.as",
        b".REALS\nx = 1\n.PROGRAM a()\n.END\n",
        &LoadOptions::new(),
    )
    .unwrap_err();
    assert_eq!(
        e.to_string(),
        "p.as:1:1: expected .END to close this .REALS section"
    );
}
