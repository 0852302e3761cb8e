//! The communication task (spec §2.3, §3, §4) on the deterministic core, virtual time.

mod common;

use std::time::Duration;

use common::*;
use fs020n_proto::{Command, ErrorCode, Status};
use fs020n_sim::{MotionTaskState, Refused, SessionEnd, SIGNAL_EDGE};

#[test]
fn five_seconds_of_silence_end_the_session_and_stop_the_robot() {
    let (mut c, id) = running();
    jmove(&mut c, id, [60.0, 0.0, -90.0, 0.0, -90.0, 0.0]);
    c.advance_by(ms(1000));
    raw(&mut c, id, "0 0 0"); // keep-alive at 1 s: deadline moves to 6 s
    assert!(c.velocity()[0] != 0.0, "moving");
    c.advance_to(Duration::from_millis(5999));
    assert!(
        c.native().is_session_open(id),
        "open until 5 s after the last request"
    );
    c.advance_to(Duration::from_millis(6000));
    assert!(!c.native().is_session_open(id));
    assert_eq!(
        c.native().last_session_end(),
        Some((id, SessionEnd::ReceiveTimeout))
    );
    assert_eq!(c.counters().receive_timeouts, 1);
    // the communication task raises signal 2007; the program's ONI fires after the edge
    assert!(c.native().stop_signal());
    c.advance_by(SIGNAL_EDGE);
    assert_eq!(c.task(), MotionTaskState::NotRunning);
    // the robot stops at once (braking), then stands
    until(&mut c, ms(2000), is_still);
    let here = c.joints();
    c.advance_by(ms(500));
    assert_eq!(c.joints(), here);
    // requests on the dead session are refused
    assert!(c.handle_request(id, b"0 0 0").is_err());
}

#[test]
fn a_second_client_is_refused_while_a_session_is_open() {
    let mut c = ctl();
    let id = c.try_accept().unwrap();
    assert_eq!(c.try_accept(), Err(Refused::SessionOpen));
    c.advance_by(ms(4000)); // a session never closes the port "by window"
    raw(&mut c, id, "0 0 0");
    assert_eq!(c.try_accept(), Err(Refused::SessionOpen));
    assert!(!c.native().is_listening());
    raw(&mut c, id, "1040 255 0");
    assert!(
        c.native().is_listening(),
        "listening again right after the session"
    );
    assert!(c.try_accept().is_ok());
    assert_eq!(c.counters().refused, 2);
}

#[test]
fn listen_gap_refuses_then_a_later_connect_succeeds() {
    let mut c = ctl();
    let gap = c.timing().listen_gap;
    assert_eq!(gap, ms(100));
    c.advance_to(Duration::from_millis(2999));
    assert!(c.native().is_listening());
    c.advance_to(Duration::from_secs(3));
    assert!(!c.native().is_listening());
    assert_eq!(
        c.native().next_listen_change(),
        Some(Duration::from_secs(3) + gap)
    );
    assert_eq!(c.try_accept(), Err(Refused::ListenGap));
    c.advance_to(Duration::from_millis(3050));
    assert_eq!(c.try_accept(), Err(Refused::ListenGap));
    c.advance_to(Duration::from_secs(3) + gap);
    let id = c.try_accept().expect("next window");
    assert_eq!(c.native().session(), Some(id));
    // windows are counted from the end of the last session
    raw(&mut c, id, "1040 255 0");
    let ended = c.now();
    c.advance_to(ended + ms(2999));
    assert!(c.native().is_listening());
    c.advance_to(ended + ms(3000));
    assert!(!c.native().is_listening());
}

#[test]
fn timer_and_ring_reset_on_accept() {
    let mut c = ctl();
    let a = c.try_accept().unwrap();
    c.advance_by(ms(2500));
    let s = raw(&mut c, a, "1040 4 0");
    assert_eq!(s.timer.seconds(), Some(2.5));
    assert_eq!(c.native().newest_index(), Some(1));
    assert_eq!(c.native().newest_command(), Some(Command::Reserved));
    raw(&mut c, a, "1040 255 0");
    c.advance_by(ms(700));
    let b = c.try_accept().unwrap();
    assert_ne!(a, b);
    assert_eq!(c.native().newest_index(), Some(0), "ring cleared");
    assert_eq!(
        c.native().newest_command().unwrap().number(),
        0.0,
        "slot 0 holds command 0"
    );
    assert_eq!(c.native().timer1_s(), 0.0);
    c.advance_by(ms(1234));
    let s = raw(&mut c, b, "0 0 0");
    assert_eq!(s.timer.seconds(), Some(1.234), "TIMER(1) since this accept");
}

#[test]
fn timer_has_a_1_ms_resolution() {
    let mut c = ctl();
    let id = c.try_accept().unwrap();
    c.advance_by(Duration::from_micros(1_999_900));
    let s = raw(&mut c, id, "0 0 0");
    assert_eq!(
        s.timer.seconds(),
        Some(1.999),
        "truncated to the millisecond"
    );
}

#[test]
fn ring_has_16_entries_and_publishes_the_newest_index() {
    let mut c = ctl();
    let id = c.try_accept().unwrap();
    for k in 1..=17 {
        raw(&mut c, id, "1040 4 0");
        assert_eq!(c.native().newest_index(), Some(k % 16));
    }
    // mismatched versions are not stored
    raw(&mut c, id, "1041 4 0");
    raw(&mut c, id, "0 0 0");
    assert_eq!(c.native().newest_index(), Some(1));
    assert_eq!(c.counters().requests, 19);
    assert_eq!(c.counters().effective_requests, 17);
}

#[test]
fn version_mismatch_and_leading_blank_move_nothing() {
    let mut c = ctl();
    let id = c.try_accept().unwrap();
    for req in [" 1040 1 0", "1041 1 0", "0 1 0", "abc 1 0"] {
        let s = raw(&mut c, id, req);
        assert!(!s.task_running, "{req:?} started the program");
        assert_eq!(
            s.version, 1040,
            "the reply carries the server's own version"
        );
    }
    assert_eq!(c.task(), MotionTaskState::NotRunning);
    assert_eq!(c.native().newest_index(), Some(0));
    // a run of blanks between tokens is one separator ($DECODE mode 1 cuts the whole run):
    // the double blank after the version acts
    let s = raw(&mut c, id, "1040  1 0");
    assert!(s.task_running, "\"1040  1 0\" starts the program");
    assert_eq!(c.native().newest_index(), Some(1));
    assert_eq!(c.native().newest_command().unwrap().number(), 1.0);
    for req in [
        " 1040 6 9 0 0 0 45 0 -90 0 -90 0",
        "1039 6 9 0 0 0 45 0 -90 0 -90 0",
    ] {
        raw(&mut c, id, req);
        c.advance_by(ms(500));
        assert_eq!(c.joints(), HOME, "{req:?} moved the robot");
    }
    // the real thing moves
    raw(&mut c, id, "1040 6 9 0 0 0 45 0 -90 0 -90 0");
    c.advance_by(ms(500));
    assert!(c.joints()[0] > 0.0);
}

#[test]
fn only_the_first_255_bytes_of_one_read_count() {
    let mut c = ctl();
    let id = c.try_accept().unwrap();
    raw(&mut c, id, "1040 1 0");
    // Two requests in one read are one request: the second is trailing tokens, ignored.
    raw(&mut c, id, "1040 4 01040 6 9 0 0 0 45 0 -90 0 -90 0");
    assert_eq!(c.native().newest_command(), Some(Command::Reserved));
    // A target beyond byte 255 is lost: JT1 reads from the first 255 bytes only.
    let mut req = String::from("1040 6 9 0 0 0 ");
    while req.len() < 254 {
        req.push('0');
    }
    req.push_str(" 45 0 -90 0 -90 0");
    raw(&mut c, id, &req);
    match c.native().newest_command() {
        Some(Command::JointMove { target }) => assert_eq!(target[1], 0.0),
        other => panic!("{other:?}"),
    }
}

#[test]
fn reply_bytes_match_the_controller_format_exactly() {
    let mut c = ctl();
    let id = c.try_accept().unwrap();
    c.advance_by(ms(1234));
    let h = c.handle_request(id, b"0 0 0").unwrap();
    assert_eq!(
        std::str::from_utf8(&h.reply).unwrap(),
        " 1040 0 -1 -1 0 -1 0     1.234     0.000     0.000   -90.000     0.000   -90.000     0.000 "
    );
    // program running, HOLD, TEACH LOCK ON, an error: every field in place
    raw(&mut c, id, "1040 1 0");
    c.set_teach_lock(true);
    c.inject(fs020n_sim::Fault::RaiseError {
        code: ErrorCode(-31130),
    });
    c.set_run(false);
    c.advance_by(ms(10));
    let h = c.handle_request(id, b"0 0 0").unwrap();
    assert_eq!(
        std::str::from_utf8(&h.reply).unwrap(),
        " 1040 -31130 0 -1 -1 -1 0     1.244     0.000     0.000   -90.000     0.000   -90.000     0.000 "
    );
    // the reply of a running program, at the joints of that instant
    let mut c = ctl();
    let id = c.try_accept().unwrap();
    raw(&mut c, id, "1040 1 0");
    raw(&mut c, id, "1040 6 9 0 0 0 10 30 -60 0 -45 12.5");
    c.advance_by(ms(3000));
    let h = c.handle_request(id, b"1040 0 0").unwrap();
    assert_eq!(
        std::str::from_utf8(&h.reply).unwrap(),
        " 1040 0 -1 -1 0 -1 -1     3.000    10.000    30.000   -60.000     0.000   -45.000    12.500 "
    );
    let s = Status::decode(std::str::from_utf8(&h.reply).unwrap()).unwrap();
    assert_eq!(s.joints, c.joints());
}

#[test]
fn command_255_replies_then_ends_the_session_and_the_program() {
    let (mut c, id) = running();
    jmove(&mut c, id, [60.0, 0.0, -90.0, 0.0, -90.0, 0.0]);
    c.advance_by(ms(500));
    let h = c.handle_request(id, b"1040 255 0").unwrap();
    assert!(h.close);
    let s = Status::decode(std::str::from_utf8(&h.reply).unwrap()).unwrap();
    assert!(s.task_running, "the reply is built before the session ends");
    assert_eq!(
        c.native().last_session_end(),
        Some((id, SessionEnd::EndCommand))
    );
    // then `SIGNAL 2007`: the program ends once the signal has been stable for 50 ms; the arm
    // brakes, and until it stands the brake is the program's last motion (TASK(1) = 3)
    assert_eq!(c.task(), MotionTaskState::Running);
    c.advance_by(SIGNAL_EDGE);
    assert_eq!(c.task(), MotionTaskState::Finishing);
    assert_eq!(c.motion_phase(), fs020n_sim::MotionPhase::Braking);
    until(&mut c, ms(2000), |c| {
        c.task() == MotionTaskState::NotRunning
    });
    assert!(is_still(&c));
    assert!(
        c.joints()[0] < 59.0,
        "stopped where it was, not at the target"
    );
}

#[test]
fn command_2_stops_after_the_signal_edge_and_the_session_stays() {
    let (mut c, id) = running();
    jmove(&mut c, id, [60.0, 0.0, -90.0, 0.0, -90.0, 0.0]);
    c.advance_by(ms(500));
    // `SIGNAL 2007` + `ros_move_run = 0`: the reply is built at once, TASK(1) still 1
    let s = raw(&mut c, id, "1040 2 0");
    assert!(s.task_running, "the ONI needs the signal stable for 50 ms");
    assert!(c.native().is_session_open(id));
    let q = c.joints();
    c.advance_by(SIGNAL_EDGE - ms(2));
    assert!(c.joints()[0] > q[0], "still moving during the edge");
    assert!(c.task() != MotionTaskState::NotRunning);
    c.advance_by(ms(2));
    assert_eq!(
        c.task(),
        MotionTaskState::Finishing,
        "the ONI fired: the program ended, its last motion (the brake) runs"
    );
    assert_eq!(c.motion_phase(), fs020n_sim::MotionPhase::Braking);
    until(&mut c, ms(2000), |c| {
        c.task() == MotionTaskState::NotRunning
    });
    assert!(is_still(&c));
    let stop = c.joints();
    assert!(stop[0] < 59.0);
    // 6 alone does nothing now: command 1 is needed
    jmove(&mut c, id, [60.0, 0.0, -90.0, 0.0, -90.0, 0.0]);
    c.advance_by(ms(1000));
    assert_eq!(c.joints(), stop);
    raw(&mut c, id, "1040 1 0");
    jmove(&mut c, id, [60.0, 0.0, -90.0, 0.0, -90.0, 0.0]);
    c.advance_by(ms(1000));
    assert!(c.joints()[0] > stop[0]);
}

#[test]
fn a_1_sent_right_after_a_2_is_lost() {
    // Spec §4: the server tests `TASK(1) <> 1`; within the signal edge the program still runs
    // (here it waits at its look-ahead motion, so its loop does not see the cleared flag), so
    // the 1 is ignored, and then the ONI ends the program.
    let (mut c, id) = running();
    jmove(&mut c, id, [60.0, 0.0, -90.0, 0.0, -90.0, 0.0]);
    c.advance_by(ms(100));
    raw(&mut c, id, "1040 2 0");
    c.advance_by(ms(10));
    let ignored = c.counters().starts_ignored;
    let s = raw(&mut c, id, "1040 1 0");
    assert!(s.task_running);
    assert_eq!(c.counters().starts_ignored, ignored + 1);
    c.advance_by(SIGNAL_EDGE);
    assert_eq!(
        c.task(),
        MotionTaskState::Finishing,
        "the ONI fired, the arm brakes"
    );
    assert!(!raw(&mut c, id, "0 0 0").task_running);
    // once the arm stands (TASK(1) = 0), a 1 starts it again
    until(&mut c, ms(2000), |c| {
        c.task() == MotionTaskState::NotRunning
    });
    assert!(raw(&mut c, id, "1040 1 0").task_running);
    assert!(
        !c.native().stop_signal(),
        "the program clears signal 2007 when it starts"
    );
}

#[test]
fn command_1_during_task_state_3_reaches_mc_execute_which_is_refused() {
    // After a 2, the program's loop ends at its next pass (`ros_move_run = 0`): TASK(1) = 3
    // while its last motion finishes, until the ONI fires. A 1 then passes the server's test
    // (TASK(1) <> 1) but MC EXECUTE is refused (P1009).
    let (mut c, id) = running();
    jmove(&mut c, id, [60.0, 0.0, -90.0, 0.0, -90.0, 0.0]);
    // the first pass (at 2 ms) starts the JMOVE; a 4 before the next pass (at 6 ms) means no
    // pass re-issues it, so the loop runs freely while the arm moves
    c.advance_by(ms(3));
    raw(&mut c, id, "1040 4 0");
    c.advance_by(ms(300));
    raw(&mut c, id, "1040 2 0");
    c.advance_by(ms(10));
    assert_eq!(c.task(), MotionTaskState::Finishing);
    assert_eq!(c.task().as_task_value(), 3);
    let s = raw(&mut c, id, "1040 1 0");
    assert!(!s.task_running, "field 7 is TASK(1) == 1: 0 in state 3");
    assert_eq!(c.counters().starts_refused, 1);
    // the ONI stops the arm; TASK(1) stays 3 while it brakes, so a 1 is still refused
    c.advance_by(SIGNAL_EDGE);
    assert_eq!(c.motion_phase(), fs020n_sim::MotionPhase::Braking);
    assert_eq!(c.task(), MotionTaskState::Finishing);
    assert!(!raw(&mut c, id, "1040 1 0").task_running);
    assert_eq!(c.counters().starts_refused, 2);
    until(&mut c, ms(2000), |c| {
        c.task() == MotionTaskState::NotRunning
    });
    assert!(is_still(&c));
    assert!(
        raw(&mut c, id, "1040 1 0").task_running,
        "a 1 now starts it"
    );
}

#[test]
fn a_1040_poll_stops_a_stream_after_its_current_motion_a_0_poll_does_not() {
    let (mut c, id) = running();
    raw(&mut c, id, "1040 3 1 100");
    let start = [0.0, 10.0, -80.0, 0.0, -80.0, 0.0];
    jmove(&mut c, id, start);
    until(&mut c, ms(5000), |c| {
        c.joints() == fs020n_proto::JointsDeg::new(start)
    });
    // Stream a trajectory JT1 = 20 deg/s * (t - t_start) that keeps going.
    let t_start = c.native().timer1_s();
    for _ in 0..50 {
        let t = c.native().timer1_s();
        let p = [20.0 * (t - t_start), 10.0, -80.0, 0.0, -80.0, 0.0];
        cmd(
            &mut c,
            id,
            Command::StreamedMove(sample(t, 1.0, p, [20.0, 0.0, 0.0, 0.0, 0.0, 0.0], [0.0; 6])),
        );
        c.advance_by(ms(20));
    }
    assert!(c.velocity()[0] > 0.0, "streaming");
    // a 0 0 0 poll changes nothing: the newest command is still the 7, the robot keeps going
    let mut d = c.clone();
    raw(&mut d, id, "0 0 0");
    let before = d.joints()[0];
    d.advance_by(ms(300));
    assert!(d.joints()[0] > before + 2.0, "kept extrapolating");
    assert_eq!(d.native().newest_command().unwrap().number(), 7.0);
    // a 1040 0 0 poll becomes the newest command: the robot finishes its motion and stands
    raw(&mut c, id, "1040 0 0");
    assert_eq!(c.native().newest_command().unwrap().number(), 0.0);
    until(&mut c, ms(3000), is_still);
    let stop = c.joints();
    c.advance_by(ms(1000));
    assert_eq!(c.joints(), stop);
    assert_eq!(c.task(), MotionTaskState::Running, "the program still runs");
}

#[test]
fn session_end_on_a_new_connection_keeps_the_error_but_not_the_program() {
    let (mut c, id) = running();
    jmove(&mut c, id, [200.0, 0.0, -90.0, 0.0, -90.0, 0.0]);
    c.advance_by(ms(20));
    assert_eq!(c.error(), ErrorCode::DESTINATION_OUT_OF_RANGE);
    raw(&mut c, id, "1040 255 0");
    let id2 = c.try_accept().unwrap();
    let s = raw(&mut c, id2, "1040 1 0");
    assert_eq!(s.error.raw(), -31088, "E1088 survives a new session");
    assert!(!s.task_running, "command 1 ignored in error");
    c.reset_error().unwrap();
    let s = raw(&mut c, id2, "1040 1 0");
    assert!(s.error.is_none() && s.task_running);
}
