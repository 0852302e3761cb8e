//! Tasks on virtual time: the cost model, interleaving, waits, the robot task and its
//! look-ahead, interrupts, monitor commands, the panel, motion parameters and locations.
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

mod common;

use std::time::Duration;

use common::*;
use fs020n_as::{Config, CostModel, MotionKind, Speed, Target, TaskId, TaskState};
use fs020n_proto::ErrorCode;

fn secs(i: &fs020n_as::Interpreter, name: &str) -> f32 {
    i.real(name).unwrap_or_else(|| panic!("{name} not set"))
}

#[test]
fn statements_take_time_and_busy_loops_advance_the_clock() {
    let cfg = Config::default();
    let step = cfg.cost.statement;
    let (i, _) = run_pc("  n = 0\n  WHILE TRUE DO\n    n = n + 1\n  END", 0.010);
    // Each pass: the WHILE test, the assignment, the jump back at END: three steps.
    let passes = (Duration::from_millis(10) - step).as_nanos() / (3 * step).as_nanos();
    let n = secs(&i, "n") as u128;
    assert!(n.abs_diff(passes) <= 1, "n = {n}, expected about {passes}");
}

#[test]
fn a_custom_cost_model_changes_the_pace() {
    let cfg = Config {
        cost: CostModel {
            statement: Duration::from_micros(100),
            ..CostModel::default()
        },
        ..Config::default()
    };
    let (mut i, mut s) = start_with(&pc("  n = 0\n  WHILE TRUE DO\n    n = n + 1\n  END"), cfg);
    i.run_until(&mut s, ms(30));
    assert_eq!(secs(&i, "n"), 100.0);
}

#[test]
fn tasks_run_concurrently_and_share_globals() {
    let src = ".PROGRAM autostart.pc()\n  a = 0\n  WHILE TRUE DO\n    a = a + 1\n  END\n.END\n\
               .PROGRAM autostart2.pc()\n  b = 0\n  WHILE TRUE DO\n    b = b + 1\n  END\n.END\n\
               .PROGRAM autostart3.pc()\n  WAIT a >= 100\n  seen = b\n  at = TIMER(0)\n.END\n";
    let (mut i, mut s) = start(src);
    i.run_until(&mut s, ms(50));
    let (a, b) = (secs(&i, "a"), secs(&i, "b"));
    assert_eq!(a, b, "two busy tasks progress at the same pace");
    // a reaches 100 at 5.98 ms; task 3 sees it at the next 2 ms poll.
    assert_eq!(secs(&i, "at"), 0.006);
    assert!((99.0..=140.0).contains(&secs(&i, "seen")));
    let info = i.tasks(&s);
    assert_eq!(info[1].program.as_deref(), Some("autostart.pc"));
    assert_eq!(info[3].state, TaskState::Idle);
    assert_eq!(i.task_state(TaskId::Pc(1), &s), TaskState::Running);
}

const ROBOT: &str = ".PROGRAM rob()\n\
  ACCURACY 10 ALWAYS\n\
  t0 = TIMER(0)\n\
  JMOVE #PPOINT(30,0,-90,0,-90,0)\n\
  t1 = TIMER(0)\n\
  JMOVE #PPOINT(60,0,-90,0,-90,0)\n\
  t2 = TIMER(0)\n\
  JMOVE #PPOINT(90,0,-90,0,-90,0)\n\
  t3 = TIMER(0)\n\
.END\n";

#[test]
fn look_ahead_runs_on_to_the_next_motion_and_waits_there() {
    let src = format!("{}{ROBOT}", pc("  MC EXECUTE rob"));
    let (mut i, mut s) = start(&src);
    i.run_until(&mut s, ms(100));
    // The statement after the first JMOVE runs at once; the second JMOVE waits.
    assert_eq!(secs(&i, "t1"), 0.0);
    assert_eq!(i.real("t2"), None);
    assert_eq!(
        s.motions.len(),
        2,
        "the second motion is planned (look-ahead of one)"
    );
    assert_eq!(i.task_state(TaskId::Robot, &s), TaskState::Running);
    let info = &i.tasks(&s)[0];
    assert!(
        info.waiting.as_deref().unwrap().contains("ACCURACY"),
        "{info:?}"
    );
    // 30° at 100 °/s: within the 10° toy accuracy at 0.2 s; seen at the next 2 ms poll.
    i.run_until(&mut s, ms(400));
    assert_eq!(secs(&i, "t2"), 0.202);
    i.run_until(&mut s, ms(600));
    assert_eq!(secs(&i, "t3"), 0.502);
    // Every step done, the last motion still running: TASK(1) = 3, then 0.
    assert_eq!(i.task_state(TaskId::Robot, &s), TaskState::WaitingMotion);
    i.run_until(&mut s, ms(1000));
    assert_eq!(i.task_state(TaskId::Robot, &s), TaskState::Idle);
    assert_eq!(s.joints_now()[0], 90.0);
}

#[test]
fn hold_pauses_the_robot_task_only() {
    let src = format!(
        "{}{ROBOT}",
        pc("  MC EXECUTE rob\n  n = 0\n  WHILE TRUE DO\n    n = n + 1\n    TWAIT 0.01\n  END")
    );
    let (mut i, mut s) = start(&src);
    i.run_until(&mut s, ms(100));
    s.panel.run = false;
    i.run_until(&mut s, ms(1100));
    assert_eq!(i.task_state(TaskId::Robot, &s), TaskState::Paused);
    assert_eq!(
        i.real("t2"),
        None,
        "held for a second: the robot program did not go on"
    );
    assert!(secs(&i, "n") > 100.0, "the PC task kept running");
    s.panel.run = true;
    i.run_until(&mut s, ms(1400));
    assert_eq!(i.task_state(TaskId::Robot, &s), TaskState::Running);
    assert!(i.real("t2").is_some());
}

#[test]
fn power_off_teach_and_errors_stop_the_robot_task() {
    for what in ["power", "teach", "lock", "error"] {
        let src = format!("{}{ROBOT}", pc("  MC EXECUTE rob"));
        let (mut i, mut s) = start(&src);
        i.run_until(&mut s, ms(100));
        match what {
            "power" => s.panel.power = false,
            "teach" => s.panel.repeat = false,
            "lock" => s.panel.teach_lock = true,
            _ => s.error = ErrorCode(-31130),
        }
        i.run_until(&mut s, ms(110));
        assert_eq!(i.task_state(TaskId::Robot, &s), TaskState::Idle, "{what}");
        assert!(
            s.lines_of(TaskId::Robot)
                .iter()
                .any(|l| l.starts_with("program stopped")),
            "{what}: {:?}",
            s.terminal
        );
    }
}

#[test]
fn mc_execute_is_refused_with_p_codes() {
    let src = format!(
        "{}{ROBOT}",
        pc("  MC EXECUTE rob\n  MC EXECUTE rob\n  running = TASK(1)")
    );
    let (mut i, mut s) = start(&src);
    i.run_until(&mut s, ms(10));
    assert_eq!(secs(&i, "running"), 1.0);
    assert!(printed(&s).contains(&"EXECUTE rob: (P1009) Program is already running.".to_string()));
    for (setup, code) in [
        ("power", "P1000"),
        ("teach", "P1001"),
        ("lock", "P1002"),
        ("error", "P1013"),
    ] {
        let (mut i, mut s) = start(&format!("{}{ROBOT}", pc("  TWAIT 0.01\n  MC EXECUTE rob")));
        match setup {
            "power" => s.panel.power = false,
            "teach" => s.panel.repeat = false,
            "lock" => s.panel.teach_lock = true,
            _ => s.error = ErrorCode(-31088),
        }
        i.run_until(&mut s, ms(50));
        assert_eq!(i.task_state(TaskId::Robot, &s), TaskState::Idle);
        assert!(
            printed(&s).iter().any(|l| l.contains(code)),
            "{setup}: {:?}",
            printed(&s)
        );
        assert_eq!(
            i.execute("rob", &mut s).unwrap_err().to_string().get(1..6),
            Some(code)
        );
    }
}

#[test]
fn oni_cuts_the_motion_after_the_signal_is_stable_for_50_ms() {
    let robot = ".PROGRAM rob()\n\
                   SIGNAL -2010\n\
                   ONI 2010 GOTO cut\n\
                   JMOVE #PPOINT(90,0,-90,0,-90,0)\n\
                   JMOVE #PPOINT(0,0,-90,0,-90,0)\n\
                   reached = 1\n\
                   HALT\n\
                 cut:\n\
                   cut_at = TIMER(0)\n\
                   j1 = DEXT(#HERE, 1)\n\
                 .END\n";
    // A pulse shorter than 50 ms does nothing.
    let src = format!("{}{robot}", pc("  MC EXECUTE rob\n  TWAIT 0.1\n  SIGNAL 2010\n  TWAIT 0.02\n  SIGNAL -2010\n  TWAIT 0.2\n  SIGNAL 2010"));
    let (mut i, mut s) = start(&src);
    i.run_until(&mut s, ms(2000));
    assert_eq!(i.real("reached"), None);
    // The stable edge came at ~0.32 s: cut at +50 ms, the arm stops where it is.
    let cut_at = secs(&i, "cut_at");
    assert!((0.370..=0.372).contains(&cut_at), "{cut_at}");
    let j1 = secs(&i, "j1");
    assert!((36.0..38.0).contains(&j1), "{j1}");
    assert_eq!(s.joints_now()[0] as f32, j1, "nothing moved after the cut");
    assert_eq!(i.task_state(TaskId::Robot, &s), TaskState::Idle);
}

#[test]
fn on_call_branches_at_a_step_boundary_and_returns() {
    let src = ".PROGRAM autostart.pc()\n  TWAIT 0.1\n  SIGNAL 2011\n.END\n\
               .PROGRAM autostart2.pc()\n  n = 0\n  ON 2011 CALL handler\n  TWAIT 0.5\n  after = TIMER(0)\n.END\n\
               .PROGRAM handler()\n  handled = TIMER(0)\n.END\n";
    let (mut i, mut s) = start(src);
    i.run_until(&mut s, ms(1000));
    // The interrupt comes during the TWAIT: the handler runs when it ends, then the task goes
    // on where it was.
    assert_eq!(secs(&i, "handled"), 0.5);
    assert_eq!(secs(&i, "after"), 0.5);
}

#[test]
fn oni_in_a_pc_program_is_an_error() {
    let (_, s) = run_pc("  ONI 2001 GOTO x\nx:", 0.1);
    assert_eq!(s.raised, vec![ErrorCode(-31095)]);
}

#[test]
fn brake_from_a_pc_task_stops_the_motion_and_the_program_goes_on() {
    let robot = ".PROGRAM rob()\n  JMOVE #PPOINT(90,0,-90,0,-90,0)\n  BREAK\n  after = TIMER(0)\n  j1 = DEXT(#HERE, 1)\n.END\n";
    let src = format!("{}{robot}", pc("  MC EXECUTE rob\n  TWAIT 0.25\n  BRAKE"));
    let (mut i, mut s) = start(&src);
    i.run_until(&mut s, ms(1000));
    // BREAK waited for the motion; BRAKE ended it at ~0.25 s.
    assert_eq!(secs(&i, "after"), 0.252);
    assert!((24.0..26.0).contains(&secs(&i, "j1")));
}

#[test]
fn mc_hold_continue_and_pause() {
    let robot = ".PROGRAM rob()\n  PAUSE\n  WHILE TRUE DO\n    b = TIMER(0)\n  END\n.END\n";
    let src = format!(
        "{}{robot}",
        pc("  MC EXECUTE rob\n  TWAIT 0.1\n  st = TASK(1)\n  MC CONTINUE\n  TWAIT 0.1\n  MC HOLD\n  TWAIT 0.1\n  held = TASK(1)\n  b_held = b\n  TWAIT 0.1\n  b_still = b\n  MC CONTINUE\n  TWAIT 0.1\n  b_after = b")
    );
    let (mut i, mut s) = start(&src);
    i.run_until(&mut s, ms(600));
    assert_eq!(secs(&i, "st"), 2.0, "PAUSE: TASK(1) = 2");
    assert_eq!(secs(&i, "held"), 2.0, "MC HOLD: TASK(1) = 2");
    assert_eq!(
        secs(&i, "b_held"),
        secs(&i, "b_still"),
        "nothing ran while held"
    );
    assert!((0.19..0.21).contains(&secs(&i, "b_held")));
    assert!((0.49..0.51).contains(&secs(&i, "b_after")));
    assert!(!s.held);
}

#[test]
fn pcexecute_pcabort_and_cycles() {
    let src = ".PROGRAM autostart.pc()\n  PCEXECUTE 2: counter, 3\n  TWAIT 0.1\n  PCEXECUTE 3: forever\n  TWAIT 0.1\n  PCABORT 3:\n  st = TASK(1003)\n.END\n\
               .PROGRAM counter()\n  IF cycles_seen == 0 THEN\n  END\n.END\n\
               .PROGRAM forever()\n  WHILE TRUE DO\n    ticks = TIMER(0)\n  END\n.END\n\
               .REALS\ncycles_seen = 0\n.END\n";
    let src = src.replace(
        "  IF cycles_seen == 0 THEN\n  END\n",
        "  cycles_seen = cycles_seen + 1\n",
    );
    let (mut i, mut s) = start(&src);
    i.run_until(&mut s, ms(500));
    assert_eq!(secs(&i, "cycles_seen"), 3.0);
    assert_eq!(secs(&i, "st"), 0.0);
    assert!((0.19..0.21).contains(&secs(&i, "ticks")));
    assert_eq!(i.task_state(TaskId::Pc(3), &s), TaskState::Idle);
}

#[test]
fn motion_parameters_reach_the_system() {
    let robot = ".PROGRAM rob()\n\
                   SPEED 50 ALWAYS\n\
                   ACCURACY 5 ALWAYS\n\
                   ACCEL 80 ALWAYS\n\
                   DECEL 70\n\
                   JMOVE #PPOINT(1,0,-90,0,-90,0)\n\
                   SPEED 0.1 S\n\
                   ACCURACY 1 FINE\n\
                   CP OFF\n\
                   LMOVE #PPOINT(2,0,-90,0,-90,0)\n\
                   SPEED 250 MM/S\n\
                   JMOVE #PPOINT(3,0,-90,0,-90,0)\n\
                   DELAY 0.5\n\
                   HOME\n\
                 .END\n";
    let src = format!(
        "{}{robot}",
        pc("  ABS.SPEED ON\n  a = SWITCH(ABS.SPEED)\n  MC EXECUTE rob")
    );
    let (mut i, mut s) = start(&src);
    i.run_until(&mut s, ms(3000));
    assert_eq!(secs(&i, "a"), -1.0);
    let m: Vec<_> = s.motions.iter().map(|(_, m)| *m).collect();
    assert_eq!(m.len(), 5);
    assert_eq!(m[0].speed, Speed::Percent(50.0));
    assert_eq!(
        (
            m[0].accuracy_mm,
            m[0].fine,
            m[0].accel_percent,
            m[0].decel_percent
        ),
        (5.0, false, 80.0, 70.0)
    );
    assert!(m[0].cp && m[0].abs_speed);
    assert_eq!(m[1].kind, MotionKind::Linear);
    assert_eq!(m[1].speed, Speed::Seconds(f64::from(0.1f32)));
    assert_eq!(
        (m[1].accuracy_mm, m[1].fine, m[1].decel_percent),
        (1.0, true, 100.0)
    );
    assert!(!m[1].cp);
    assert_eq!(m[2].speed, Speed::MmPerS(250.0));
    assert_eq!(
        (m[2].accuracy_mm, m[2].fine),
        (5.0, false),
        "one-shot ACCURACY used up"
    );
    assert_eq!(m[3].kind, MotionKind::Delay);
    assert_eq!(m[3].delay_s, 0.5);
    assert_eq!(
        m[4].target,
        Target::Joints([0.0, 0.0, -90.0, 0.0, -90.0, 0.0])
    );
    assert_eq!(m[4].speed, Speed::Percent(50.0));
}

#[test]
fn locations_here_point_decompose_and_transformations() {
    let robot = ".PROGRAM rob()\n\
                   HERE #start\n\
                   POINT #copy = #start\n\
                   DECOMPOSE j[0] = #copy\n\
                   HERE tool\n\
                   DECOMPOSE x[1] = tool\n\
                   POINT above = tool + TRANS(0, 0, -100)\n\
                   DECOMPOSE y[1] = above\n\
                   LMOVE above\n\
                   BREAK\n\
                   DECOMPOSE z[1] = HERE\n\
                 .END\n";
    let src = format!("{}{robot}", pc("  MC EXECUTE rob"));
    let (mut i, mut s) = start(&src);
    i.run_until(&mut s, ms(3000));
    assert!(s.raised.is_empty(), "{:?}", s.terminal);
    assert_eq!(i.real_at("j", &[2]), Some(-90.0));
    assert_eq!(i.real_at("j", &[5]), Some(0.0));
    assert_eq!(i.real_at("x", &[1]), Some(850.0));
    assert_eq!(i.real_at("x", &[3]), Some(1153.5));
    assert_eq!(i.real_at("x", &[5]), Some(180.0));
    // 100 mm along the tool's approach axis (pointing down): 100 mm lower.
    let z = i.real_at("y", &[3]).unwrap();
    assert!(
        (z - 1253.5).abs() < 1e-2 || (z - 1053.5).abs() < 1e-2,
        "{z}"
    );
    let reached = i.real_at("z", &[3]).unwrap();
    assert!(
        (reached - z).abs() < 0.05,
        "the LMOVE reached the transformation: {reached} vs {z}"
    );
}

#[test]
fn a_motion_out_of_range_raises_e1088_and_stops_the_program() {
    let robot = ".PROGRAM rob()\n  JMOVE #PPOINT(170,0,-90,0,-90,0)\n  after = 1\n.END\n";
    let (mut i, mut s) = start(&format!("{}{robot}", pc("  MC EXECUTE rob")));
    i.run_until(&mut s, ms(100));
    assert_eq!(s.raised, vec![ErrorCode(-31088)]);
    assert_eq!(i.real("after"), None);
    assert_eq!(i.task_state(TaskId::Robot, &s), TaskState::Idle);
    assert!(s.lines_of(TaskId::Robot)[0].starts_with("(E1088) Destination is out of motion range"));
}

#[test]
fn trace_records_executed_lines() {
    let (mut i, mut s) = start(&pc("  a = 1\n  b = 2"));
    i.set_trace(true);
    i.run_until(&mut s, ms(10));
    let t = i.take_trace();
    let lines: Vec<(u32, &str)> = t.iter().map(|l| (l.line, l.text.trim())).collect();
    assert_eq!(lines, vec![(2, "a = 1"), (3, "b = 2"), (4, ".END")]);
    assert_eq!(t[1].at, Duration::from_micros(20));
    assert_eq!(t[1].to_string(), "    0.0000 pc1   autostart.pc:3 b = 2");
    assert!(i.take_trace().is_empty());
}

#[test]
fn next_event_tells_the_driver_when_to_come_back() {
    let (mut i, mut s) = start(&pc("  TWAIT 0.5\n  a = 1"));
    assert_eq!(i.next_event(), Some(Duration::ZERO));
    i.run_until(&mut s, ms(1));
    assert_eq!(i.next_event(), Some(Duration::from_millis(500)));
    i.run_until(&mut s, ms(600));
    assert_eq!(i.next_event(), None, "everything idle");
}

#[test]
fn whichtask_names_the_task_running_a_program_or_its_subroutine() {
    // AS-E p.9-19: 1 the robot program, 1001–1005 the PC programs, -1 none.
    let src = ".PROGRAM autostart.pc()\n  MC EXECUTE rob\n  TWAIT 0.1\n  r = WHICHTASK(\"rob\")\n  s = WHICHTASK(\"sub\")\n  p = WHICHTASK(\"AUTOSTART.PC\")\n  n = WHICHTASK(\"idle\")\n  u = WHICHTASK(\"nowhere\")\n.END\n\
.PROGRAM rob()\n  CALL sub\n.END\n.PROGRAM sub()\n  TWAIT 5\n.END\n.PROGRAM idle()\n.END\n";
    let (mut i, mut s) = start(src);
    i.run_until(&mut s, ms(500));
    assert!(s.raised.is_empty(), "{:?}", s.raised);
    let v = |n: &str| secs(&i, n);
    assert_eq!(
        [v("r"), v("s"), v("p"), v("n"), v("u")],
        [1.0, 1.0, 1001.0, -1.0, -1.0]
    );
}

#[test]
fn a_task_in_a_subroutine_reports_the_subroutine_and_the_program_it_was_started_with() {
    let src = ".PROGRAM autostart.pc()\n  CALL sub\n.END\n.PROGRAM sub()\n  TWAIT 5\n.END\n";
    let (mut i, mut s) = start(src);
    i.run_until(&mut s, ms(100));
    let pc1 = &i.tasks(&s)[1];
    assert_eq!(pc1.program.as_deref(), Some("sub"));
    assert_eq!(pc1.main.as_deref(), Some("autostart.pc"));
}

#[test]
fn pcend_ends_a_pc_task_at_the_end_of_its_cycle_and_minus_one_cancels_it() {
    let src = ".PROGRAM loop()\n  n = n + 1\n  TWAIT 0.1\n  done = n\n.END\n\
               .PROGRAM ender()\n  PCEND 2:\n.END\n\
               .PROGRAM canceller()\n  PCEND 2: -1\n.END\n\
               .REALS\nn = 0\n.END\n";
    let (mut i, mut s) = start(src);
    i.pc_execute_cycles(2, "loop", -1).expect("starts");
    i.run_until(&mut s, ms(250));
    // PCEND then its cancel: the loop goes on.
    i.pc_execute(1, "ender").expect("starts");
    i.run_until(&mut s, ms(260));
    assert!(s.raised.is_empty(), "{:?}", s.raised);
    i.pc_execute(1, "canceller").expect("starts");
    i.run_until(&mut s, ms(600));
    assert_eq!(i.task_state(TaskId::Pc(2), &s), TaskState::Running);
    // PCEND typed at the terminal: the cycle under way ends (`done` catches up), no other.
    i.immediate("PCEND 2:", &mut s).expect("runs");
    let n = i.real("n").expect("n");
    i.run_until(&mut s, ms(2000));
    assert_eq!(i.task_state(TaskId::Pc(2), &s), TaskState::Idle);
    assert_eq!(i.real("n"), Some(n), "no new cycle began");
    assert_eq!(i.real("done"), Some(n), "the cycle under way ended");
    assert!(s.raised.is_empty(), "{:?}", s.raised);
    // Out of range: E0106.
    let (_, s) = run_pc("  PCEND 7:", 0.1);
    assert_eq!(s.raised, [ErrorCode::VALUE_OUT_OF_RANGE]);
}
