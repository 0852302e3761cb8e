//! The motion program `ros_move`, the panel and the controller's motion behaviour (spec §2.1,
//! §2.2, §2.4, §4) on the deterministic core, virtual time.

#![allow(clippy::field_reassign_with_default)]

mod common;

use std::time::Duration;

use common::*;
use fs020n_kin::RobotModel;
use fs020n_proto::{Command, ErrorCode, JointsDeg};
use fs020n_sim::{
    Behaviour, Controller, ControllerConfig, MotionPhase, MotionTaskState, MoveKind, Panel,
    PlannedAfterBrake,
};

// ------------------------------------------------------------------ command 1 conditions

fn start_refused_with(setup: impl FnOnce(&mut Controller), blocker: &str) {
    let mut c = ctl();
    setup(&mut c);
    let id = c.try_accept().unwrap();
    let s = raw(&mut c, id, "1040 1 0");
    assert!(!s.task_running, "{blocker}: started anyway");
    assert_eq!(c.task(), MotionTaskState::NotRunning);
    assert!(
        s.error.is_none() || blocker.contains("error"),
        "no error raised by 1"
    );
    assert!(
        c.start_blockers().iter().any(|b| b.contains(blocker)),
        "{:?} lacks {blocker}",
        c.start_blockers()
    );
    assert_eq!(
        c.native().newest_command(),
        Some(Command::StartProgram),
        "still recorded"
    );
    // and a motion command does nothing
    jmove(&mut c, id, [30.0, 0.0, -90.0, 0.0, -90.0, 0.0]);
    c.advance_by(ms(500));
    assert_eq!(c.joints(), HOME);
}

#[test]
fn command_1_is_ignored_in_teach() {
    start_refused_with(|c| c.set_repeat(false), "TEACH");
}

#[test]
fn command_1_is_ignored_with_the_teach_lock_on() {
    start_refused_with(|c| c.set_teach_lock(true), "TEACH LOCK");
}

#[test]
fn command_1_is_ignored_in_hold() {
    start_refused_with(|c| c.set_run(false), "HOLD");
}

#[test]
fn command_1_is_ignored_with_power_off() {
    start_refused_with(|c| c.set_power(false).unwrap(), "power");
}

#[test]
fn command_1_is_ignored_in_error() {
    start_refused_with(
        |c| {
            c.inject(fs020n_sim::Fault::RaiseError {
                code: ErrorCode(-31130),
            })
        },
        "error",
    );
}

#[test]
fn command_1_while_running_is_recorded_and_pauses_the_motion_commands() {
    let (mut c, id) = running();
    raw(&mut c, id, "1040 3 1 100");
    jmove(&mut c, id, [90.0, 0.0, -90.0, 0.0, -90.0, 0.0]);
    c.advance_by(ms(100));
    let s = raw(&mut c, id, "1040 1 0");
    assert!(s.task_running);
    assert!(c.start_blockers().iter().any(|b| b.contains("P1009")));
    // the motion in progress completes, then the robot waits
    until(&mut c, ms(5000), is_still);
    assert_eq!(c.joints()[0], 90.0);
}

#[test]
fn initial_panel_error_and_speed_are_settable() {
    let mut cfg = ControllerConfig::default();
    cfg.panel = Panel {
        power: false,
        run: false,
        repeat: false,
        teach_lock: true,
        estop: false,
    };
    cfg.monitor_speed_percent = 35.0;
    cfg.joints = JointsDeg::new([1.0, 2.0, -3.0, 4.0, -5.0, 6.0]);
    cfg.error = ErrorCode(-31130);
    let mut c = Controller::new(cfg);
    let id = c.try_accept().unwrap();
    let s = raw(&mut c, id, "0 0 0");
    assert!(!s.power && !s.run && !s.repeat && s.teach_lock);
    assert_eq!(s.error.raw(), -31130);
    assert_eq!(s.joints, JointsDeg::new([1.0, 2.0, -3.0, 4.0, -5.0, 6.0]));
    assert_eq!(c.monitor_speed(), 35.0);
    // e-stop pressed at start: power off and E3808
    let mut cfg = ControllerConfig::default();
    cfg.panel.estop = true;
    let c = Controller::new(cfg);
    assert!(!c.panel().power);
    assert_eq!(c.error(), ErrorCode::EMERGENCY_STOP);
    // defaults: ready to run at 10 %
    let c = ctl();
    assert_eq!(c.panel(), Panel::default());
    assert!(c.panel().power && c.panel().run && c.panel().repeat && !c.panel().teach_lock);
    assert_eq!(c.monitor_speed(), 10.0);
}

// ------------------------------------------------------------------ joint move, E1088

#[test]
fn joint_move_takes_the_planned_time_at_the_monitor_speed() {
    let model = RobotModel::fs020n();
    let (mut c, id) = running();
    let target = JointsDeg::new([90.0, 0.0, -90.0, 0.0, -90.0, 0.0]);
    jmove(&mut c, id, target.values());
    let expected = fs020n_kin::JointMove::plan(&model, HOME, target, 0.10).duration_s();
    let took = until(&mut c, Duration::from_secs(20), |c| c.joints() == target);
    // the pass starts at the next tick; arrival is quantized to the 2 ms tick
    assert!(
        (took.as_secs_f64() - expected).abs() <= 0.006,
        "took {took:?}, JMOVE at 10 % takes {expected} s"
    );
    assert_eq!(
        c.native().last_pass().unwrap().motion.unwrap().kind,
        MoveKind::Joint
    );
    assert_eq!(c.native().last_pass().unwrap().motion.unwrap().speed, 10.0);
}

#[test]
fn out_of_range_target_raises_e1088_stops_the_program_and_stays_until_reset() {
    let (mut c, id) = running();
    jmove(&mut c, id, [30.0, 0.0, -90.0, 0.0, -90.0, 0.0]);
    until(&mut c, Duration::from_secs(5), is_still);
    let s = jmove(&mut c, id, [30.0, 0.0, -90.0, 0.0, -150.0, 0.0]); // JT5 range ±145
    assert!(
        s.error.is_none(),
        "raised by the program's pass, not by the request"
    );
    c.advance_by(ms(20));
    assert_eq!(c.error(), ErrorCode::DESTINATION_OUT_OF_RANGE);
    assert_eq!(c.error().raw(), -31088);
    assert_eq!(c.task(), MotionTaskState::NotRunning);
    until(&mut c, ms(2000), is_still);
    let s = raw(&mut c, id, "1040 1 0");
    assert_eq!(s.error.raw(), -31088);
    assert!(!s.task_running);
    c.advance_by(ms(3000));
    assert_eq!(c.error().raw(), -31088, "an error stays");
    c.reset_error().unwrap();
    assert!(raw(&mut c, id, "1040 1 0").task_running);
}

#[test]
fn a_straight_line_with_no_ik_path_raises_e1088() {
    let (mut c, id) = running();
    raw(&mut c, id, "1040 3 1 100");
    // from elbow-down at home to an elbow-up configuration: no continuous IK path on a line
    let s = sample(
        c.native().timer1_s(),
        0.0,
        [0.0, 0.0, 60.0, 0.0, -60.0, 0.0],
        [0.0; 6],
        [0.0; 6],
    );
    cmd(&mut c, id, Command::StreamedMove(s));
    c.advance_by(ms(20));
    assert_eq!(
        c.native().last_pass().unwrap().motion.unwrap().kind,
        MoveKind::Linear
    );
    assert_eq!(c.error(), ErrorCode::DESTINATION_OUT_OF_RANGE);
    assert_eq!(c.task(), MotionTaskState::NotRunning);
}

// ------------------------------------------------------------------ BRAKE

fn moving_fast() -> (Controller, fs020n_sim::SessionId) {
    moving_fast_with(Behaviour::default())
}

fn moving_fast_with(behaviour: Behaviour) -> (Controller, fs020n_sim::SessionId) {
    let mut cfg = ControllerConfig::default();
    cfg.behaviour = behaviour;
    let mut c = Controller::new(cfg);
    let id = c.try_accept().unwrap();
    assert!(raw(&mut c, id, "1040 1 0").task_running);
    raw(&mut c, id, "1040 3 1 100");
    jmove(&mut c, id, [120.0, 40.0, -60.0, 90.0, -30.0, 180.0]);
    c.advance_by(ms(400));
    assert!(c.velocity().iter().any(|v| v.abs() > 50.0));
    (c, id)
}

const DROP_PLANNED: Behaviour = Behaviour {
    planned_after_brake: PlannedAfterBrake::Drop,
    locals_survive_restart: false,
};

#[test]
fn command_5_stops_within_the_braking_distance_and_the_program_goes_on() {
    let model = RobotModel::fs020n();
    // With the planned motion dropped, the arm stays where the brake stops it (the default,
    // `Execute`, then runs the re-issued JMOVE the look-ahead holds: see below).
    let (mut c, id) = moving_fast_with(DROP_PLANNED);
    let q0 = c.joints();
    let v0 = c.velocity();
    let s = raw(&mut c, id, "1040 5 0");
    assert!(s.task_running, "the program keeps running");
    assert_eq!(c.motion_phase(), MotionPhase::Braking);
    let took = until(&mut c, ms(3000), is_still);
    let q1 = c.joints();
    let accel = model.max_accels_deg_s2();
    let speed = model.max_speeds_deg_s();
    let mut longest = 0.0_f64;
    for j in 0..6 {
        let v = v0[j].abs();
        let allowed = v * v / (2.0 * accel[j]) + speed[j] * 0.002; // + one tick
        let travel = (q1[j] - q0[j]).abs();
        assert!(
            travel <= allowed,
            "JT{} travelled {travel} > {allowed}",
            j + 1
        );
        // it stops in the direction it was going
        assert!((q1[j] - q0[j]) * v0[j] >= 0.0);
        longest = longest.max(v / accel[j]);
    }
    assert!(
        took.as_secs_f64() <= longest + 0.01,
        "{took:?} vs {longest}"
    );
    // it stays there (no drift back to the point where the brake began)
    c.advance_by(ms(1000));
    assert_eq!(c.joints(), q1);
    // the program waits for the next 6/7
    assert_eq!(c.task(), MotionTaskState::Running);
    jmove(&mut c, id, [0.0, 0.0, -90.0, 0.0, -90.0, 0.0]);
    until(&mut c, Duration::from_secs(10), |c| c.joints() == HOME);
}

#[test]
fn five_five_brakes_once() {
    let (mut c, id) = moving_fast_with(DROP_PLANNED);
    raw(&mut c, id, "1040 5 0");
    let mut once = c.clone();
    c.advance_by(ms(50));
    once.advance_by(ms(50));
    raw(&mut c, id, "1040 5 0");
    assert_eq!(c.motion_phase(), MotionPhase::Braking);
    until(&mut c, ms(3000), is_still);
    until(&mut once, ms(3000), is_still);
    assert_eq!(c.joints(), once.joints(), "the second 5 changed nothing");
    // 5, then a motion, then 5 again brakes again
    jmove(&mut c, id, [120.0, 40.0, -60.0, 90.0, -30.0, 180.0]);
    c.advance_by(ms(200));
    assert_eq!(c.motion_phase(), MotionPhase::Moving);
    raw(&mut c, id, "1040 5 0");
    assert_eq!(c.motion_phase(), MotionPhase::Braking);
}

/// A planned motion when the brake comes, under `behaviour`: returns the controller after
/// the brake. The program re-issues the newest 6 every pass, so while the arm moves to A
/// (JT1 90°) the look-ahead holds a re-issued JMOVE A; a newer 6 (B: JT2 30°) waits unread
/// behind it, and the 5 replaces it as newest before any pass reads it.
fn brake_with_a_planned_motion(behaviour: Behaviour) -> (Controller, fs020n_sim::SessionId) {
    let mut cfg = ControllerConfig::default();
    cfg.behaviour = behaviour;
    let mut c = Controller::new(cfg);
    let id = c.try_accept().unwrap();
    raw(&mut c, id, "1040 1 0");
    raw(&mut c, id, "1040 3 1 100");
    jmove(&mut c, id, [90.0, 0.0, -90.0, 0.0, -90.0, 0.0]);
    c.advance_by(ms(50));
    jmove(&mut c, id, [90.0, 30.0, -90.0, 0.0, -90.0, 0.0]);
    c.advance_by(ms(20));
    assert!(c.arm().has_planned(), "the look-ahead holds one motion");
    assert_eq!(c.arm().target()[1], 0.0, "B is not read yet");
    let s = raw(&mut c, id, "1040 5 0");
    assert_eq!(c.motion_phase(), MotionPhase::Braking);
    assert!(s.task_running);
    (c, id)
}

#[test]
fn brake_drops_the_planned_motion_when_so_configured() {
    let (mut c, _) = brake_with_a_planned_motion(DROP_PLANNED);
    assert!(!c.arm().has_planned());
    until(&mut c, ms(3000), is_still);
    c.advance_by(ms(500));
    assert!(
        c.joints()[0] < 90.0,
        "braked short of A; the re-issued A never ran"
    );
    assert!(c.joints()[1].abs() < 1e-9, "B never ran");
}

#[test]
fn by_default_the_planned_motion_runs_after_the_brake() {
    // Spec §4, medium confidence: a motion planned by look-ahead is executed after BRAKE. For
    // a 6 that motion is the program's re-issue of the same target: the arm brakes, then goes
    // on to A anyway. B, never read, never runs. (Why a client that must stop sends 2.)
    let (mut c, _) = brake_with_a_planned_motion(Behaviour::default());
    assert!(
        c.arm().has_planned(),
        "kept, re-planned from where the brake stops"
    );
    let rest = c.arm().target();
    assert!(rest[0] < 90.0 && rest[1] == 0.0);
    // it starts only once the arm has stopped, then goes to the planned target
    until(&mut c, ms(3000), |c| {
        c.motion_phase() != MotionPhase::Braking
    });
    let planned = JointsDeg::new([90.0, 0.0, -90.0, 0.0, -90.0, 0.0]);
    until(&mut c, ms(10_000), |c| c.joints() == planned);
    // the program then goes on with the next step: the newest is the 5, passes do nothing
    until(&mut c, ms(3000), is_still);
    let q = c.joints();
    c.advance_by(ms(1000));
    assert_eq!(c.joints(), q);
}

// ------------------------------------------------------------------ look-ahead and blending

#[test]
fn exactly_one_motion_is_planned_and_blends_within_accuracy() {
    let model = RobotModel::fs020n();
    let (mut c, id) = running();
    raw(&mut c, id, "1040 3 1 100");
    let a = JointsDeg::new([40.0, 0.0, -90.0, 0.0, -90.0, 0.0]);
    let b = JointsDeg::new([40.0, 20.0, -90.0, 0.0, -90.0, 0.0]);
    let d = JointsDeg::new([0.0, 20.0, -90.0, 0.0, -90.0, 0.0]);
    let tool_mm = |q: &JointsDeg, r: &JointsDeg| {
        model
            .forward(&q.to_rad())
            .distance_m(&model.forward(&r.to_rad()))
            * 1000.0
    };
    jmove(&mut c, id, a.values());
    c.advance_by(ms(100));
    // The program re-issues A every pass: the pass after the one that started A has planned a
    // (zero-length) JMOVE A and waits there until the tool is within ACCURACY of A. That is the
    // one motion of look-ahead; nothing else is queued.
    assert!(c.arm().has_planned());
    assert_eq!(c.native().last_pass().unwrap().motion.unwrap().target, a);
    assert_eq!(c.arm().target(), a);
    let passes = c.counters().passes;
    jmove(&mut c, id, b.values());
    // B is read only when the blocked pass ends, i.e. within ACCURACY of A; it blends in
    let mut switch = None;
    while c.arm().target() == a {
        let before = c.joints();
        c.advance_by(ms(2));
        if c.arm().target() == b {
            switch = Some((tool_mm(&before, &a), c.velocity()));
        }
        assert!(c.now() < Duration::from_secs(5));
    }
    assert_eq!(
        c.counters().passes,
        passes + 1,
        "the blocked pass ended, the next one read B"
    );
    let (dist, v) = switch.expect("B started after A");
    assert!(
        dist <= 10.0 && dist > 0.5,
        "B blends in within ACCURACY: {dist} mm"
    );
    assert!(
        v[0].abs() > 1.0,
        "A was still moving when B started (continuous path)"
    );
    // continuous path: the speed never drops to zero between A and B
    let mut min_speed = f64::INFINITY;
    for _ in 0..20 {
        c.advance_by(ms(2));
        min_speed = min_speed.min(c.velocity().iter().map(|v| v.abs()).fold(0.0, f64::max));
    }
    assert!(min_speed > 1.0, "stopped in between: {min_speed}");
    // a newer target waits behind the blocked pass, then wins over B's re-issue
    jmove(&mut c, id, d.values());
    assert_eq!(c.arm().target(), b);
    until(&mut c, Duration::from_secs(5), |c| c.arm().target() == d);
    assert!(tool_mm(&c.joints(), &b) <= 10.0);
    until(&mut c, Duration::from_secs(5), |c| c.joints() == d);
}

#[test]
fn a_segment_without_a_planned_successor_stops() {
    let (mut c, id) = running();
    jmove(&mut c, id, [10.0, 0.0, -90.0, 0.0, -90.0, 0.0]);
    c.advance_by(ms(20)); // a pass has read the 6
    raw(&mut c, id, "1040 4 0"); // newest is 4: passes do nothing
    until(&mut c, Duration::from_secs(5), is_still);
    assert_eq!(c.joints()[0], 10.0);
}

// ------------------------------------------------------------------ command 7

fn streaming_at(joints: [f64; 6], speed: f64) -> (Controller, fs020n_sim::SessionId) {
    let mut cfg = ControllerConfig::default();
    cfg.joints = JointsDeg::new(joints);
    let mut c = Controller::new(cfg);
    let id = c.try_accept().unwrap();
    raw(&mut c, id, "1040 1 0");
    if speed > 0.0 {
        raw(&mut c, id, &format!("1040 3 1 {speed}"));
    }
    (c, id)
}

#[test]
fn command_7_extrapolates_exactly_as_the_formula_says() {
    let (mut c, id) = streaming_at([0.0, 10.0, -80.0, 0.0, -80.0, 0.0], 100.0);
    let mut checked = 0;
    let mut steps = Vec::new();
    for k in 0..100 {
        let t = c.native().timer1_s();
        // a stamp that is sometimes late, sometimes early, sometimes off by more than 0.5 s
        let t0 = match k % 4 {
            0 => t - 0.03,
            1 => t + 0.02,
            2 => t - 0.9,
            _ => t + 0.7,
        };
        let p = [0.01 * k as f64, 10.0, -80.0, 0.0, -80.0, 0.0];
        let s = sample(
            t0,
            2.0,
            p,
            [5.0, -1.0, 2.0, 0.0, 3.0, 1.0],
            [1.0, 0.0, -2.0, 0.0, 0.5, 0.0],
        );
        cmd(&mut c, id, Command::StreamedMove(s));
        let before = c.counters().passes;
        c.advance_by(ms(10));
        if c.counters().passes > before {
            let pass = c.native().last_pass().unwrap();
            assert_eq!(pass.command, 7.0);
            let ms_count = pass.tm_s * 1000.0;
            assert!(
                (ms_count - ms_count.round()).abs() < 1e-6,
                "TIMER: 1 ms resolution"
            );
            // the sample as the controller parsed it (3 decimals on the wire, AS reals)
            let Some(Command::StreamedMove(parsed)) = c.native().newest_command() else {
                panic!("newest is not a 7")
            };
            assert!((parsed.t0_s - s.t0_s).abs() < 1e-3);
            let expected = parsed.extrapolate(pass.tm_s, pass.step_s);
            if let Some(m) = pass.motion {
                assert_eq!(
                    m.target, expected,
                    "pass at tm={} step={}",
                    pass.tm_s, pass.step_s
                );
                checked += 1;
            }
            steps.push(pass.step_s);
        }
    }
    assert!(checked > 20, "checked {checked} passes");
    // step follows 0.9 step + 0.1 (tm − last_tm): the loop overhead (4 ms), never the motion
    // wait — though these passes waited for their LMOVEs to blend in
    let overhead = fs020n_sim::PASS_TIME.as_secs_f64();
    assert!(steps.iter().all(|&s| s <= overhead + 0.001), "{steps:?}");
    assert!(
        c.native().step_s() >= overhead * 0.5,
        "{}",
        c.native().step_s()
    );
    assert!(c.error().is_none());
}

#[test]
fn step_is_the_running_average_of_the_loop_overhead() {
    let (mut c, id) = running();
    raw(&mut c, id, "1040 4 0"); // passes that do nothing: one every PASS_TIME = 4 ms
    assert_eq!(c.native().step_s(), 0.0, "step starts at 0");
    // the first pass runs at the next tick, 2 ms after `last_tm` was set at program start
    c.advance_by(ms(2));
    let mut expected = 0.1 * 0.002;
    assert!((c.native().step_s() - expected).abs() < 1e-12);
    for _ in 0..30 {
        c.advance_by(fs020n_sim::PASS_TIME);
        expected = 0.9 * expected + 0.1 * fs020n_sim::PASS_TIME.as_secs_f64();
        assert!(
            (c.native().step_s() - expected).abs() < 1e-12,
            "{} vs {expected}",
            c.native().step_s()
        );
    }
}

/// Spec §2.4 "Careful with step": `tm` is read at the start of a pass and `last_tm` after the
/// previous pass's motion instruction was accepted, so `step` holds the loop overhead and
/// `ARG2 × step` is a small look-ahead — here 40 passes × 4 ms = 0.16 s, where the old reading
/// (step ≈ a whole 0.1 s pass with its motion wait) extrapolated about 4 s.
#[test]
fn a_large_lookahead_extrapolates_by_the_loop_overhead_not_the_motion_wait() {
    let start = [0.0, 10.0, -80.0, 0.0, -80.0, 0.0];
    let (mut c, id) = streaming_at(start, 100.0);
    let v = 30.0; // deg/s on JT1: the tool moves ≈ 47 mm per 0.1 s LMOVE, beyond ACCURACY
    let lookahead = 40.0;
    let mut distances = Vec::new();
    // a steady stream at 100 Hz: every sample stamped with the controller's own clock, so the
    // clamp term is ≈ 0 and only ARG2 × step moves the point beyond the sample
    for k in 0..300 {
        let t = c.native().timer1_s();
        let p = [start[0] + v * 0.01 * k as f64, 10.0, -80.0, 0.0, -80.0, 0.0];
        let s = sample(t, lookahead, p, [v, 0.0, 0.0, 0.0, 0.0, 0.0], [0.0; 6]);
        cmd(&mut c, id, Command::StreamedMove(s));
        let before = c.counters().passes;
        c.advance_by(ms(10));
        if k > 100 && c.counters().passes > before {
            let pass = c.native().last_pass().unwrap();
            if let Some(m) = pass.motion {
                // how far beyond the sample (in time) the controller aimed
                let Some(Command::StreamedMove(parsed)) = c.native().newest_command() else {
                    panic!("newest is not a 7")
                };
                let dt_clamp = (pass.tm_s - parsed.t0_s).clamp(-0.5, 0.5);
                distances.push((
                    (m.target[0] - parsed.position[0]) / v - dt_clamp,
                    pass.step_s,
                ));
            }
        }
    }
    assert!(distances.len() > 20, "{}", distances.len());
    let overhead = fs020n_sim::PASS_TIME.as_secs_f64();
    for (ahead_s, step) in &distances {
        assert!(
            (ahead_s - lookahead * step).abs() < 1e-3,
            "{ahead_s} vs {lookahead} × {step}"
        );
        assert!(
            (step - overhead).abs() < 0.0015,
            "step {step} is the loop overhead, not the motion wait"
        );
        assert!(*ahead_s < 0.25, "extrapolated {ahead_s} s ahead");
    }
    // the passes did wait for motion (≈ 0.1 s LMOVEs blending in within 10 mm), yet step
    // ignores it: without waits there would be a pass every 4 ms, 750 in these 3 s
    assert!(c.counters().passes < 500, "{}", c.counters().passes);
}

#[test]
fn same_extrapolated_point_is_not_reissued() {
    let (mut c, id) = streaming_at([0.0, 10.0, -80.0, 0.0, -80.0, 0.0], 100.0);
    // zero velocity and acceleration: pt is the same every pass, one motion only
    let s = sample(
        0.0,
        1.0,
        [5.0, 10.0, -80.0, 0.0, -80.0, 0.0],
        [0.0; 6],
        [0.0; 6],
    );
    cmd(&mut c, id, Command::StreamedMove(s));
    c.advance_by(ms(1000));
    assert_eq!(c.counters().motions, 1);
    assert!(c.counters().passes > 50);
}

#[test]
fn near_singularities_the_30_percent_joint_move_is_used() {
    // |JT3| < 5: arm stretched
    for (p, what) in [
        ([0.0, 10.0, -4.9, 0.0, -80.0, 0.0], "JT3"),
        ([0.0, 10.0, -80.0, 0.0, 4.9, 0.0], "JT5"),
        ([0.0, 10.0, 4.0, 0.0, -4.0, 0.0], "both"),
    ] {
        let (mut c, id) = streaming_at([0.0, 10.0, -80.0, 0.0, -80.0, 0.0], 0.0);
        stream_to(&mut c, id, p);
        // the first pass (at the next tick) reads the 7
        c.advance_by(ms(3));
        let m = c.native().last_pass().unwrap().motion.unwrap();
        assert_eq!(m.kind, MoveKind::Joint, "{what}");
        // SPEED 30 with the monitor at 10 %: product, 3 %
        assert!((m.speed - 3.0).abs() < 1e-9, "{what}: {}", m.speed);
    }
    // just outside the zone: LMOVE taking 0.1 s at 100 %, scaled by 100/monitor at 10 %
    let (mut c, id) = streaming_at([0.0, 10.0, -80.0, 0.0, -80.0, 0.0], 0.0);
    let p = [1.0, 10.0, -5.0, 0.0, -5.0, 0.0];
    stream_to(&mut c, id, p);
    c.advance_by(ms(3));
    let m = c.native().last_pass().unwrap().motion.unwrap();
    assert_eq!(m.kind, MoveKind::Linear);
    assert!((m.speed - 1.0).abs() < 1e-9, "{}", m.speed);
}

#[test]
fn linear_moves_follow_a_straight_tool_line_and_take_their_time() {
    let model = RobotModel::fs020n();
    let start = [0.0, 10.0, -80.0, 0.0, -80.0, 0.0];
    let (mut c, id) = streaming_at(start, 100.0);
    let p = [3.0, 12.0, -78.0, 2.0, -81.0, 1.0];
    stream_to(&mut c, id, p);
    let a = model.forward(&JointsDeg::new(start).to_rad()).position_m();
    let b = model.forward(&JointsDeg::new(p).to_rad()).position_m();
    let dir = (b - a).normalize();
    let mut worst = 0.0_f64;
    let t = until(&mut c, ms(2000), |c| {
        let q = model.forward(&c.joints().to_rad()).position_m() - a;
        let off = (q - dir * q.dot(&dir)).norm();
        worst = worst.max(off);
        c.joints() == JointsDeg::new(p)
    });
    assert!(
        worst * 1000.0 < 0.5,
        "left the line by {} mm",
        worst * 1000.0
    );
    assert!(t >= ms(100) && t <= ms(130), "LMOVE SPEED 0.1 S took {t:?}");
}

// ------------------------------------------------------------------ speed rules

#[test]
fn speed_is_a_product_before_command_3_and_a_minimum_after() {
    let p = [0.0, 10.0, -3.0, 0.0, -80.0, 0.0]; // 30 % JMOVE branch
    let (mut c, id) = streaming_at([0.0, 10.0, -80.0, 0.0, -80.0, 0.0], 0.0);
    c.set_monitor_speed(50.0).unwrap();
    assert!(!c.abs_speed());
    stream_to(&mut c, id, p);
    c.advance_by(ms(3));
    assert!(
        (c.native().last_pass().unwrap().motion.unwrap().speed - 15.0).abs() < 1e-9,
        "30 % x 50 %"
    );
    raw(&mut c, id, "1040 2 0");
    raw(&mut c, id, "1040 3 1 50");
    assert!(c.abs_speed());
    // the stop by signal 2007 takes its 50 ms edge; the program has ended but the arm brakes
    // (TASK(1) = 3) until it stands
    c.advance_by(ms(60));
    assert_eq!(c.task(), MotionTaskState::Finishing);
    until(&mut c, ms(2000), |c| {
        c.task() == MotionTaskState::NotRunning
    });
    assert!(c.arm().is_still());
    raw(&mut c, id, "1040 1 0");
    let p2 = [1.0, 10.0, -3.0, 0.0, -80.0, 0.0];
    stream_to(&mut c, id, p2);
    c.advance_by(ms(3));
    assert!(
        (c.native().last_pass().unwrap().motion.unwrap().speed - 30.0).abs() < 1e-9,
        "min(30, 50)"
    );
    // command 3: > 100 clamps, <= 0 is ignored (but ABS.SPEED still switches on)
    raw(&mut c, id, "1040 3 1 250");
    assert_eq!(c.monitor_speed(), 100.0);
    raw(&mut c, id, "1040 3 1 0");
    assert_eq!(c.monitor_speed(), 100.0);
    raw(&mut c, id, "1040 3 1 -5");
    assert_eq!(c.monitor_speed(), 100.0);
    raw(&mut c, id, "1040 3 1 7.5");
    assert_eq!(c.monitor_speed(), 7.5);
    // ABS.SPEED stays on for the controller's life (a new session does not reset it)
    raw(&mut c, id, "1040 255 0");
    c.try_accept().unwrap();
    assert!(c.abs_speed());
}

#[test]
fn a_monitor_speed_change_does_not_alter_the_motion_in_progress() {
    let (mut c, id) = running();
    let target = JointsDeg::new([60.0, 0.0, -90.0, 0.0, -90.0, 0.0]);
    jmove(&mut c, id, target.values());
    c.advance_by(ms(500));
    let mut faster = c.clone();
    faster.set_monitor_speed(100.0).unwrap();
    let mut via_3 = c.clone();
    raw(&mut via_3, id, "1040 3 1 100");
    let t_plain = until(&mut c, Duration::from_secs(10), |c| c.joints() == target);
    let t_fast = until(&mut faster, Duration::from_secs(10), |c| {
        c.joints() == target
    });
    let t_3 = until(&mut via_3, Duration::from_secs(10), |c| {
        c.joints() == target
    });
    assert_eq!(t_plain, t_fast, "same arrival time");
    assert_eq!(t_plain, t_3, "same arrival time with command 3");
    // the next planned motion uses the new speed
    let back = HOME;
    let t_slow_back = {
        jmove(&mut c, id, back.values());
        until(&mut c, Duration::from_secs(20), |c| c.joints() == back)
    };
    let t_fast_back = {
        jmove(&mut faster, id, back.values());
        until(&mut faster, Duration::from_secs(20), |c| c.joints() == back)
    };
    assert!(t_fast_back.as_secs_f64() < t_slow_back.as_secs_f64() / 2.0);
}

// ------------------------------------------------------------------ HOLD, power, E-stop, TEACH

#[test]
fn hold_pauses_and_run_resumes_to_the_target() {
    let (mut c, id) = running();
    let target = JointsDeg::new([60.0, 0.0, -90.0, 0.0, -90.0, 0.0]);
    jmove(&mut c, id, target.values());
    c.advance_by(ms(1000));
    c.set_run(false);
    let s = raw(&mut c, id, "0 0 0");
    assert!(
        !s.run && !s.task_running,
        "field 3 and field 7 read 0 in HOLD"
    );
    assert_eq!(c.task(), MotionTaskState::Paused);
    c.advance_by(ms(250)); // the HOLD ramp (0.2 s) has brought it to a pause
    let held = c.joints();
    assert!(c.velocity().iter().all(|v| v == 0.0));
    assert_eq!(c.motion_phase(), MotionPhase::Held);
    wait_polling(&mut c, id, Duration::from_secs(3));
    assert_eq!(c.joints(), held, "no motion while held");
    assert!(held[0] < 60.0);
    c.set_run(true);
    let s = raw(&mut c, id, "0 0 0");
    assert!(s.run && s.task_running);
    until(&mut c, Duration::from_secs(10), |c| c.joints() == target);
}

#[test]
fn power_off_mid_move_stops_dead_and_ends_the_program() {
    let (mut c, id) = moving_fast();
    let q = c.joints();
    c.set_power(false).unwrap();
    assert_eq!(c.joints(), q);
    c.advance_by(ms(2));
    assert_eq!(c.joints(), q, "no deceleration: stopped dead");
    assert!(c.velocity().iter().all(|v| v == 0.0));
    let s = raw(&mut c, id, "0 0 0");
    assert!(!s.power && !s.task_running);
    assert!(s.error.is_none());
    c.set_power(true).unwrap();
    jmove(&mut c, id, HOME.values());
    c.advance_by(ms(500));
    assert_eq!(c.joints(), q, "the program must be started again");
}

#[test]
fn estop_mid_move_cuts_power_raises_e3808_and_needs_release_and_reset() {
    let (mut c, id) = moving_fast();
    let q = c.joints();
    c.set_estop(true);
    c.advance_by(ms(100));
    assert_eq!(c.joints(), q);
    let s = raw(&mut c, id, "1040 1 0");
    assert!(!s.power && !s.task_running);
    assert_eq!(s.error.raw(), -33808);
    assert!(c.set_power(true).is_err(), "power stays off while pressed");
    assert!(c.reset_error().is_err(), "cannot reset while pressed");
    c.set_estop(false);
    assert_eq!(c.error().raw(), -33808, "the error stays after release");
    c.reset_error().unwrap();
    c.set_power(true).unwrap();
    assert!(raw(&mut c, id, "1040 1 0").task_running);
}

#[test]
fn switching_to_teach_stops_the_program() {
    let (mut c, id) = moving_fast();
    c.set_repeat(false);
    assert_eq!(c.task(), MotionTaskState::NotRunning);
    until(&mut c, ms(3000), is_still);
    let s = raw(&mut c, id, "1040 1 0");
    assert!(!s.repeat && !s.task_running);
}

#[test]
fn an_injected_error_stops_the_program_and_brakes() {
    let (mut c, id) = moving_fast();
    c.inject(fs020n_sim::Fault::RaiseError {
        code: "E1130".parse().unwrap(),
    });
    assert_eq!(c.task(), MotionTaskState::NotRunning);
    assert_eq!(c.motion_phase(), MotionPhase::Braking);
    let s = raw(&mut c, id, "0 0 0");
    assert_eq!(s.error.raw(), -31130);
}

#[test]
fn long_straight_lines_stay_on_the_line_with_adaptive_sampling() {
    use fs020n_sim::LinearPath;
    let model = RobotModel::fs020n();
    let from = JointsDeg::new([-20.0, 10.0, -80.0, 30.0, -60.0, 0.0]);
    let to = JointsDeg::new([25.0, 30.0, -70.0, -20.0, -40.0, 45.0]);
    let path = LinearPath::plan(&model, from, to, 0.1, 0.002).expect("reachable");
    let a = model.forward(&from.to_rad());
    let b = model.forward(&to.to_rad());
    let len_mm = a.distance_m(&b) * 1000.0;
    assert!(len_mm > 300.0, "{len_mm}");
    assert!(path.sample_count() >= (len_mm / 5.0) as usize);
    // follow it through the robot at fine time steps
    let mut cfg = ControllerConfig::default();
    cfg.joints = from;
    let mut c = Controller::new(cfg);
    let id = c.try_accept().unwrap();
    raw(&mut c, id, "1040 1 0");
    raw(&mut c, id, "1040 3 1 100");
    stream_to(&mut c, id, to.values());
    let (pa, pb) = (a.position_m(), b.position_m());
    let dir = (pb - pa).normalize();
    let mut worst = 0.0_f64;
    let took = until(&mut c, Duration::from_secs(10), |c| {
        let q = model.forward(&c.joints().to_rad()).position_m() - pa;
        worst = worst.max((q - dir * q.dot(&dir)).norm());
        c.joints() == to
    });
    assert!(
        worst * 1000.0 < 0.1,
        "left the line by {} mm",
        worst * 1000.0
    );
    // stretched beyond 0.1 s so that no joint exceeds its maximum speed
    assert!(
        (took.as_secs_f64() - path.duration_s()).abs() < 0.02,
        "{took:?} vs {}",
        path.duration_s()
    );
    assert!(path.duration_s() > 0.1);
}

#[test]
fn a_first_7_at_the_current_joints_issues_no_motion() {
    let (mut c, id) = running();
    let here = c.joints().values();
    let before = c.counters().motions;
    let t0 = c.native().timer1_s();
    cmd(
        &mut c,
        id,
        Command::StreamedMove(sample(t0, 1.0, here, [0.0; 6], [0.0; 6])),
    );
    c.advance_by(ms(200));
    assert_eq!(
        c.counters().motions,
        before,
        "the program remembers the joints it started at"
    );
    assert!(c.counters().passes > 0);
}

// ------------------------------------------------------------------ stale arguments (spec §2)

#[test]
fn arguments_beyond_count_are_stale_not_zero() {
    let (mut c, id) = running();
    raw(&mut c, id, "1040 3 1 100");
    jmove(&mut c, id, [10.0, 5.0, -80.0, 4.0, -70.0, 3.0]);
    until(&mut c, ms(5000), |c| {
        c.joints() == JointsDeg::new([10.0, 5.0, -80.0, 4.0, -70.0, 3.0])
    });
    // COUNT 6: ARG4–ARG6 (JT1–JT3) come from this request, JT4–JT6 keep the local array's
    // values from the previous 6: the robot goes to (20, 15, -60, 4, -70, 3), not to zeros.
    raw(&mut c, id, "1040 6 6 0 0 0 20 15 -60");
    let expected = JointsDeg::new([20.0, 15.0, -60.0, 4.0, -70.0, 3.0]);
    until(&mut c, ms(5000), |c| c.joints() == expected);
    assert!(c.error().is_none());
}

#[test]
fn a_short_command_7_extrapolates_with_old_velocities() {
    let start = [0.0, 10.0, -80.0, 0.0, -80.0, 0.0];
    let (mut c, id) = streaming_at(start, 100.0);
    let t = c.native().timer1_s();
    let full = sample(t, 0.0, start, [10.0, 0.0, 0.0, 0.0, 0.0, 0.0], [0.0; 6]);
    cmd(&mut c, id, Command::StreamedMove(full));
    c.advance_by(ms(3));
    // now a 7 with COUNT 9 (positions only): the velocities are the previous pass's 10 deg/s
    let t = c.native().timer1_s();
    raw(
        &mut c,
        id,
        &format!("1040 7 9 {:.3} 0 0 1 10 -80 0 -80 0", t - 0.2),
    );
    c.advance_by(ms(4));
    let pass = c.native().last_pass().unwrap();
    let m = pass.motion.expect("a motion");
    // dt = clamp(tm − t0) + 0 ≈ 0.2 s (+ the ms since): JT1 = 1 + 10 × dt, not 1
    let dt = (pass.tm_s - (t - 0.2)).clamp(-0.5, 0.5);
    assert!(
        (m.target[0] - (1.0 + 10.0 * dt)).abs() < 1e-3,
        "{:?}",
        m.target
    );
    assert!(c.error().is_none());
}

#[test]
fn an_argument_never_assigned_stops_the_program_with_e0102() {
    // A fresh controller: the motion program's local array holds nothing yet.
    let (mut c, id) = running();
    let s = raw(&mut c, id, "1040 6 3 0 0 0");
    assert!(
        s.error.is_none(),
        "the communication task stores it without complaint"
    );
    c.advance_by(ms(10));
    assert_eq!(c.error(), ErrorCode::VARIABLE_NOT_DEFINED);
    assert_eq!(c.error().to_string(), "E0102");
    assert_eq!(c.task(), MotionTaskState::NotRunning);
    assert_eq!(c.counters().undefined_arguments, 1);
    let s = raw(&mut c, id, "0 0 0");
    assert_eq!(s.error.raw(), -30102);
    assert_eq!(c.joints(), HOME, "nothing moved");
}

#[test]
fn the_full_count_never_reads_stale_values() {
    // What the client always sends: 9 arguments for 6, 21 for 7.
    let (mut c, id) = running();
    raw(&mut c, id, "1040 3 1 100");
    jmove(&mut c, id, [10.0, 5.0, -80.0, 4.0, -70.0, 3.0]);
    c.advance_by(ms(20));
    jmove(&mut c, id, [0.0, 0.0, -90.0, 0.0, -90.0, 0.0]);
    until(&mut c, ms(10_000), |c| c.joints() == HOME);
}

#[test]
fn locals_start_undefined_after_a_restart_unless_configured_to_survive() {
    for survive in [false, true] {
        let mut cfg = ControllerConfig::default();
        cfg.behaviour.locals_survive_restart = survive;
        let mut c = Controller::new(cfg);
        let id = c.try_accept().unwrap();
        raw(&mut c, id, "1040 1 0");
        jmove(&mut c, id, [1.0, 0.0, -90.0, 0.0, -90.0, 0.0]);
        c.advance_by(ms(20));
        raw(&mut c, id, "1040 2 0");
        // the ONI after 50 ms, then the brake (TASK(1) = 3 until the arm stands)
        c.advance_by(ms(60));
        until(&mut c, ms(2000), |c| {
            c.task() == MotionTaskState::NotRunning
        });
        raw(&mut c, id, "1040 1 0");
        raw(&mut c, id, "1040 6 6 0 0 0 2 0 -90");
        c.advance_by(ms(10));
        if survive {
            assert!(c.error().is_none(), "JT4–JT6 from the earlier execution");
        } else {
            assert_eq!(c.error(), ErrorCode::VARIABLE_NOT_DEFINED);
        }
    }
}
