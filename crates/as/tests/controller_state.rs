//! Functions of the controller's state, on virtual time: `$TIME`, `$DATE`, `SYSDATA`,
//! `$SYSDATA`, `SWITCH` of the panel, `TASK`; the payload `WEIGHT` sets.

mod common;

use common::{ms, pc, run_pc, start_with};
use fs020n_as::Config;
use fs020n_proto::ErrorCode;

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
fn sysdata_reads_a_robot_number_given_as_a_variable_when_it_is_read() {
    // Cells loop over their robots: `SYSDATA(ZROB.NOWAXIS, .rno)`. Robot 1 is this robot;
    // another has no value (−1, the manual's "no value").
    // P.SPEED is the robot program's speed, read from a PC program.
    let src = format!(
        "{}.PROGRAM rob()\n  SPEED 40 ALWAYS\n  TWAIT 1\n  SPEED 100 MM/S ALWAYS\n  TWAIT 1\n.END\n",
        pc("  .rno = 1\n  a = SYSDATA(ZROB.NOWAXIS, .rno)\n  .rno = 2\n  b = SYSDATA(ZROB.NOWAXIS, .rno)\n  MC EXECUTE rob\n  TWAIT 0.5\n  c = SYSDATA(P.SPEED, 1)\n  TWAIT 1\n  d = SYSDATA(P.SPEED)")
    );
    let (mut i, mut s) = start_with(&src, config());
    i.run_until(&mut s, ms(2000));
    assert!(s.raised.is_empty(), "{:?}", s.raised);
    assert_eq!(i.real("a"), Some(6.0));
    assert_eq!(i.real("b"), Some(-1.0));
    assert_eq!(i.real("c"), Some(40.0), "the program speed, percent");
    assert_eq!(i.real("d"), Some(-1.0), "a speed in mm/s is no percentage");
}

#[test]
fn a_user_timer_counts_seconds_from_its_preset_on_virtual_time() {
    // AS-E p.6-118, p.9-22: `UTIMER @t = value`, `UTIMER(@t)`; local timers too.
    let src = pc("  UTIMER .@now = 0\n  UTIMER @lamp = 10\n  TWAIT 1.5\n  a = UTIMER(.@now)\n  b = UTIMER(@lamp)\n  UTIMER @lamp = 0\n  c = UTIMER(@lamp)\n  TWAIT 0.25\n  d = UTIMER(.@now)");
    let (mut i, mut s) = start_with(&src, config());
    i.run_until(&mut s, ms(3000));
    assert!(s.raised.is_empty(), "{:?}", s.raised);
    let near = |n: &str, v: f32| {
        let got = i.real(n).unwrap_or(f32::NAN);
        assert!((got - v).abs() <= 0.002, "{n}: {got}, expected {v}");
    };
    near("a", 1.5);
    near("b", 11.5);
    near("c", 0.0);
    near("d", 1.75);
}

#[test]
fn a_user_timer_preset_out_of_its_range_stops_with_an_illegal_value() {
    let (mut i, mut s) = start_with(&pc("  UTIMER @t = -1"), config());
    i.run_until(&mut s, ms(10));
    assert_eq!(s.raised, vec![fs020n_proto::ErrorCode(-30106)]);
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

#[test]
fn weight_sets_the_payload_without_values_the_rated_one_and_refuses_more() {
    let (i, s) = run_pc("  WEIGHT 7.5, 10, 0, 80, 0.1\n  done = 1", 0.1);
    assert_eq!(i.real("done"), Some(1.0));
    let p = i.payload();
    assert_eq!(
        (p.mass_kg, p.cog_mm, p.inertia_kg_m2),
        (7.5, [10.0, 0.0, 80.0], [0.1, 0.0, 0.0])
    );
    assert!(s.raised.is_empty());
    let (i, _) = run_pc("  WEIGHT 3\n  WEIGHT", 0.1);
    assert_eq!(i.payload().mass_kg, 20.0, "no values: the rated payload");
    for body in ["  WEIGHT 20.5", "  WEIGHT -1", "  WEIGHT 1, 0, 0, 0, -0.1"] {
        let (_, s) = run_pc(body, 0.1);
        assert_eq!(s.raised, [ErrorCode::VALUE_OUT_OF_RANGE], "{body}");
    }
}
