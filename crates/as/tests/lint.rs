//! The lint against the real controller's limits: each rule of `lint::RULES` finds what it
//! says, where it is, and only for the generations it names.
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

use fs020n_as::lint::{Generation, Severity, RULES};
use fs020n_as::{check, LoadOptions};

/// (rule, line, column) of the findings for `text` on `controller`.
fn findings(text: &str, controller: Option<Generation>) -> Vec<(&'static str, u32, u32)> {
    let r = check("l.as", text.as_bytes(), &LoadOptions::new(), controller);
    assert!(r.loaded, "{:?}", r.errors);
    r.lint.iter().map(|f| (f.rule, f.line, f.column)).collect()
}

/// (rule, message) of the findings for `text`.
fn lint_messages(text: &str, generation: Option<Generation>) -> Vec<(&'static str, String)> {
    let r = check("l.as", text.as_bytes(), &LoadOptions::new(), generation);
    assert!(r.loaded, "{:?}", r.errors);
    r.lint.iter().map(|f| (f.rule, f.message.clone())).collect()
}

fn pc(body: &str) -> String {
    format!(".PROGRAM autostart.pc()\n{body}\n.END\n")
}

#[test]
fn every_rule_names_its_source() {
    for r in RULES {
        assert!(!r.source.is_empty() && !r.checks.is_empty(), "{}", r.id);
    }
    let mut ids: Vec<&str> = RULES.iter().map(|r| r.id).collect();
    ids.sort_unstable();
    ids.dedup();
    assert_eq!(ids.len(), RULES.len(), "rule ids are unique");
}

#[test]
fn a_name_longer_than_15_characters_is_flagged() {
    assert_eq!(
        findings(&pc("  conveyor_speed_mm = 1"), None),
        vec![("name-length", 2, 3)]
    );
    assert!(findings(&pc("  conveyor_speed1 = 1"), None).is_empty());
}

#[test]
fn two_names_sharing_their_first_15_characters_are_one_variable_on_the_controller() {
    let f = findings(
        &pc("  part_counter_left = 1\n  part_counter_lefx = 2"),
        None,
    );
    assert_eq!(
        f,
        vec![
            ("name-length", 2, 3),
            ("name-length", 3, 3),
            ("name-collision", 3, 3)
        ]
    );
    let r = check(
        "l.as",
        pc("  part_counter_left = 1\n  part_counter_lefx = 2").as_bytes(),
        &LoadOptions::new(),
        None,
    );
    assert!(!r.passes(), "a collision is an error");
    // The same long name twice is one variable everywhere: no collision.
    let f = findings(
        &pc("  part_counter_left = 1\n  part_counter_left = 2"),
        None,
    );
    assert!(!f.iter().any(|x| x.0 == "name-collision"));
    // Locals of different programs do not collide.
    let two = ".PROGRAM a()\n  .part_counter_left = 1\n.END\n.PROGRAM b()\n  .part_counter_lefx = 1\n.END\n";
    assert!(!findings(two, None).iter().any(|x| x.0 == "name-collision"));
}

#[test]
fn a_non_ascii_byte_outside_comments_and_strings_is_flagged() {
    let text = ".PROGRAM p()\n  a\u{a0}= 1 ; ünïcode is fine here\n  $s = \"and here: ü\"\n.END\n";
    assert_eq!(findings(text, None), vec![("non-ascii-code", 2, 4)]);
}

#[test]
fn a_line_longer_than_the_limit_is_flagged() {
    let long = format!("  a = 1 ;{}", "x".repeat(140));
    assert_eq!(findings(&pc(&long), None), vec![("line-length", 2, 129)]);
}

#[test]
fn tcp_timeouts_outside_1_to_60_seconds_are_flagged_and_e_allows_0() {
    let body = "  TCP_ACCEPT .s, 10050, 0\n  TCP_SEND .r, .s, .$b[1], 1, 61\n  TCP_RECV .r, .s, .$b[1], .n, 5";
    assert_eq!(
        findings(&pc(body), None),
        vec![("tcp-timeout-range", 2, 25), ("tcp-timeout-range", 3, 31)]
    );
    assert_eq!(
        findings(&pc(body), Some(Generation::E)),
        vec![("tcp-timeout-range", 3, 31)]
    );
}

#[test]
fn listen_ports_outside_8192_to_65535_are_errors() {
    let r = check(
        "l.as",
        pc("  TCP_LISTEN .r, 80\n  TCP_LISTEN .r, 10050\n  TCP_END_LISTEN .r, 70000").as_bytes(),
        &LoadOptions::new(),
        None,
    );
    let f: Vec<(&str, u32, Severity)> = r
        .lint
        .iter()
        .map(|f| (f.rule, f.line, f.severity))
        .collect();
    assert_eq!(
        f,
        vec![
            ("tcp-port-range", 2, Severity::Error),
            ("tcp-port-range", 4, Severity::Error)
        ]
    );
    assert!(!r.passes());
}

#[test]
fn the_d_series_tcp_recv_wants_both_its_arguments_and_whole_second_timeouts() {
    let body = "  TCP_RECV .r, .s, .$b[1], .n, 5\n  TCP_SEND .r, .s, .$b[1], 1, 1.5\n  TCP_RECV .r, .s, .$b[1], .n, 5, 255";
    assert_eq!(
        findings(&pc(body), Some(Generation::D)),
        vec![("d-tcp-recv-arguments", 2, 3), ("d-integer-timeout", 3, 31)]
    );
    // Not a D controller: the rules do not apply.
    assert!(findings(&pc(body), Some(Generation::F)).is_empty());
    assert!(findings(&pc(body), None).is_empty());
}

#[test]
fn the_protocol_1040_server_passes_the_lint_for_every_generation() {
    for c in [None, Some(Generation::E), Some(Generation::F)] {
        let r = check(
            "server1040.as",
            fs020n_as::SERVER_1040.as_bytes(),
            &LoadOptions::new(),
            c,
        );
        assert!(r.passes(), "{c:?}: {:?} {:?}", r.errors, r.lint);
    }
}

#[test]
fn a_file_that_does_not_load_is_reported_with_its_errors() {
    let r = check(
        "bad.as",
        b".PROGRAM p()\n  IF a THEN\n.END\n",
        &LoadOptions::new(),
        None,
    );
    assert!(!r.loaded && !r.passes());
    assert_eq!(
        r.errors[0].to_string(),
        "bad.as:2:3: expected END to close this IF before .END"
    );
}

#[test]
fn udp_timeouts_and_receive_ports_follow_the_tcp_ranges() {
    let body = "  UDP_SENDTO .r, .ip[1], 5000, .$b[1], 1, 61\n  UDP_RECVFROM .r, 80, .$b[1], .n, 0\n  UDP_RECVFROM .r, 49152, .$b[1], .n, 2";
    assert_eq!(
        findings(&pc(body), None),
        vec![
            ("tcp-timeout-range", 2, 43),
            ("tcp-port-range", 3, 20),
            ("tcp-timeout-range", 3, 36)
        ]
    );
    // E takes a 0 s timeout.
    assert_eq!(
        findings(&pc(body), Some(Generation::E)),
        vec![("tcp-timeout-range", 2, 43), ("tcp-port-range", 3, 20)]
    );
}

#[test]
fn a_word_in_no_keyword_table_is_flagged_with_the_keyword_one_edit_away() {
    let f = lint_messages(&pc("  JAPRRO p, 100\n  FROBNICATE 3"), None);
    assert!(
        f.iter().any(|(r, m)| *r == "unknown-word"
            && m.starts_with("JAPRRO is in no AS keyword table: did you mean JAPPRO?")),
        "{f:?}"
    );
    assert!(
        f.iter().any(|(r, m)| *r == "unknown-word"
            && m.starts_with("FROBNICATE is in no AS keyword table: a controller refuses it")),
        "{f:?}"
    );
}

#[test]
fn a_monitor_command_written_as_a_step_is_flagged() {
    let f = lint_messages(&pc("  KILL"), None);
    assert!(
        f.iter()
            .any(|(r, m)| *r == "monitor-command-in-program" && m.contains("write MC KILL")),
        "{f:?}"
    );
}

#[test]
fn an_f_series_keyword_is_flagged_on_an_older_generation_only() {
    let body = pc("  COLRON");
    let on_e = lint_messages(&body, Some(Generation::E));
    assert!(
        on_e.iter().any(|(r, _)| *r == "generation-keyword"),
        "{on_e:?}"
    );
    let on_f = lint_messages(&body, Some(Generation::F));
    assert!(!on_f.iter().any(|(r, _)| *r == "generation-keyword"));
}

#[test]
fn files_checked_together_are_one_controller_memory() {
    let main = b".PROGRAM main()\n  CALL helper\n  PCEXECUTE 2: other.pc\n.END\n";
    let lib = b".PROGRAM helper()\n.END\n.PROGRAM main()\n.END\n";
    let opts = LoadOptions::new();
    let alone = fs020n_as::check_memory(&[("main.as", &main[..])], &opts, None);
    let undefined = |r: &fs020n_as::CheckReport| {
        r.lint
            .iter()
            .filter(|f| f.rule == "undefined-program")
            .map(|f| f.message.split(':').next().unwrap_or("").to_owned())
            .collect::<Vec<_>>()
    };
    assert_eq!(undefined(&alone[0]), ["CALL helper", "PCEXECUTE other.pc"]);
    let both =
        fs020n_as::check_memory(&[("main.as", &main[..]), ("lib.as", &lib[..])], &opts, None);
    assert_eq!(undefined(&both[0]), ["PCEXECUTE other.pc"]);
    // Each file loads on its own; a program defined twice is a warning on the second file.
    assert!(both.iter().all(|r| r.loaded));
    assert!(both[1].warnings.iter().any(|w| w
        .message
        .starts_with("program main is also defined in main.as")));
}
