//! Functions of the controller's state, on virtual time: `$TIME`, `$DATE`, `SYSDATA`,
//! `$SYSDATA`, `SWITCH` of the panel, `TASK`.

mod common;

use common::{ms, pc, start_with};
use fs020n_as::Config;

/// 2026-11-28 23:59:58 UTC, shown at UTC+1: 2026-11-29 00:59:58.
const CLOCK: (i64, i32) = (1_795_910_398, 3600);

fn config() -> Config {
    Config {
        clock_at_start: Some(CLOCK),
        ..Config::default()
    }
}

#[test]
fn time_and_date_follow_the_controller_clock_on_virtual_time() {
    let src = pc("  $t0 = $TIME\n  $d1 = $DATE(1)\n  $d2 = $DATE(2)\n  $d3 = $DATE(3)\n  TWAIT 3\n  $t1 = $TIME");
    let (mut i, mut s) = start_with(&src, config());
    i.run_until(&mut s, ms(4000));
    let text = |n: &str| String::from_utf8(i.string(n).unwrap_or_default()).unwrap_or_default();
    assert_eq!(text("t0"), "00:59:58");
    assert_eq!(text("d1"), "11/29/2026");
    assert_eq!(text("d2"), "29/NOV/2026");
    assert_eq!(text("d3"), "2026/11/29");
    assert_eq!(
        text("t1"),
        "01:00:01",
        "three seconds of virtual time later"
    );
}

#[test]
fn an_unknown_date_form_stops_the_task_with_an_illegal_value() {
    let (mut i, mut s) = start_with(&pc("  $d = $DATE(7)"), config());
    i.run_until(&mut s, ms(10));
    assert_eq!(s.raised, vec![fs020n_proto::ErrorCode(-30106)]);
}

#[test]
fn sysdata_answers_the_keywords_of_the_emulated_controller() {
    let src = pc("  a = SYSDATA(NUMROBOT)\n  b = SYSDATA(ZROB.NOWAXIS)\n  c = SYSDATA(M.SPEED)\n  d = SYSDATA(STEP)\n  $n = $SYSDATA(ZROB.NAME, 1)");
    let (mut i, mut s) = start_with(&src, config());
    s.monitor_speed = 35.0;
    i.run_until(&mut s, ms(10));
    assert_eq!(i.real("a"), Some(1.0));
    assert_eq!(i.real("b"), Some(6.0));
    assert_eq!(i.real("c"), Some(35.0));
    assert_eq!(i.real("d"), Some(4.0), "SYSDATA(STEP) on the fourth step");
    assert_eq!(i.string("n"), Some(b"FS020N".to_vec()));
}

#[test]
fn sysdata_of_another_robot_or_an_unknown_keyword_loads_as_not_emulated() {
    let w: Vec<String> = fs020n_as::Interpreter::from_source(
        "t.as",
        &pc("  a = SYSDATA(MTR.RPM)\n  b = SYSDATA(M.SPEED, 2)"),
        config(),
    )
    .map(|i| i.warnings().iter().map(|w| w.to_string()).collect())
    .unwrap_or_default();
    assert!(w.iter().any(|w| w.contains("SYSDATA(MTR.RPM)")), "{w:?}");
    assert!(w.iter().any(|w| w.contains("SYSDATA(M.SPEED)")), "{w:?}");
}

#[test]
fn the_panel_switches_read_the_panel_and_no_emergency_stop_is_pressed() {
    let src = pc(
        "  p = SWITCH(POWER)\n  r = SWITCH(REPEAT)\n  e = SWITCH(EMERGENCY)\n  t = SWITCH(TP_EMG)",
    );
    let (mut i, mut s) = start_with(&src, config());
    i.run_until(&mut s, ms(10));
    assert_eq!(i.real("p"), Some(-1.0));
    assert_eq!(i.real("r"), Some(-1.0));
    assert_eq!(i.real("e"), Some(0.0));
    assert_eq!(i.real("t"), Some(0.0));
}

#[test]
fn task_reports_whether_a_task_runs() {
    let src = pc("  a = TASK(1001)\n  b = TASK(1002)");
    let (mut i, mut s) = start_with(&src, config());
    i.run_until(&mut s, ms(10));
    assert_ne!(i.real("a"), Some(0.0), "PC task 1 runs this program");
    assert_eq!(i.real("b"), Some(0.0));
}
