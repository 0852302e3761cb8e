//! The protocol-1040 server text (programs/server1040.as) on the test system: every rule of
//! the specification that does not need the emulator's motion planner (that part is the
//! differential test in fs020n-sim).
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

mod common;

use std::time::Duration;

use common::ms;
use fs020n_as::testing::VirtualSystem;
use fs020n_as::{Config, Interpreter, MotionKind, Speed, TaskId, TaskState, SERVER_1040};
use fs020n_proto::{ErrorCode, JointsDeg, Status};

struct Rig {
    i: Interpreter,
    s: VirtualSystem,
    c: i32,
}

impl Rig {
    fn new() -> Rig {
        Rig::of(SERVER_1040)
    }

    /// The server with its per-pass PRINT on (it ships off: PRINT reaches every terminal).
    fn printing() -> Rig {
        Rig::of(&SERVER_1040.replace("ros_print = 0", "ros_print = 1"))
    }

    fn of(source: &str) -> Rig {
        let mut i = Interpreter::from_source("server1040.as", source, Config::default()).unwrap();
        let mut s = VirtualSystem::new();
        i.start(&mut s);
        i.run_until(&mut s, ms(10));
        let c = s.connect(10050).expect("listening");
        let mut r = Rig { i, s, c };
        r.wait(ms(10));
        r
    }

    fn wait(&mut self, d: Duration) {
        let t = self.i.now() + d;
        self.i.run_until(&mut self.s, t);
    }

    /// Sends one request and waits (1 ms steps, at most 100 ms) for its reply.
    fn req(&mut self, text: &str) -> String {
        assert!(self.s.send(self.c, text.as_bytes()), "connection gone");
        for _ in 0..100 {
            self.wait(ms(1));
            let got = self.s.recv(self.c);
            if !got.is_empty() {
                return String::from_utf8(got).unwrap();
            }
        }
        panic!("no reply to {text:?}; terminal: {:?}", self.s.terminal);
    }

    fn status(&mut self, text: &str) -> Status {
        let r = self.req(text);
        Status::decode(&r).unwrap_or_else(|e| panic!("{r:?}: {e}"))
    }

    fn joints(&mut self) -> JointsDeg {
        self.status("0 0 0").joints
    }
}

#[test]
fn the_reply_is_byte_exact() {
    let mut r = Rig::new();
    let reply = r.req("0 0 0");
    // TIMER(1) restarted at the accept (10 ms) and the reply was built ~11 ms later.
    assert_eq!(
        reply,
        " 1040 0 -1 -1 0 -1 0     0.010     0.000     0.000   -90.000     0.000   -90.000     0.000 "
    );
    r.s.panel.run = false;
    r.s.panel.teach_lock = true;
    r.s.error = ErrorCode(-31088);
    let st = r.status("0 0 0");
    assert_eq!(
        (st.error, st.run, st.teach_lock),
        (ErrorCode(-31088), false, true)
    );
}

#[test]
fn command_1_starts_ros_move_only_when_the_controller_allows() {
    let mut r = Rig::new();
    assert!(!r.status("1041 1 0").task_running, "version mismatch");
    assert!(
        !r.status(" 1040 1 0").task_running,
        "a leading blank is a mismatch"
    );
    r.s.panel.teach_lock = true;
    assert!(!r.status("1040 1 0").task_running);
    r.s.panel.teach_lock = false;
    let st = r.status("1040  1   0");
    assert!(st.task_running, "runs of blanks between tokens are fine");
    assert_eq!(r.i.task_state(TaskId::Robot, &r.s), TaskState::Running);
}

#[test]
fn command_6_moves_and_arguments_beyond_count_are_stale() {
    let mut r = Rig::new();
    r.req("1040 1 0");
    r.req("1040 6 9 0 0 0 10 20 -80 5 -70 15");
    r.wait(ms(500));
    assert_eq!(
        r.joints(),
        JointsDeg::new([10.0, 20.0, -80.0, 5.0, -70.0, 15.0])
    );
    // COUNT 6: JT1..JT3 from this request, JT4..JT6 left by the previous one.
    r.req("1040 6 6 0 0 0 30 0 -90");
    r.wait(ms(500));
    assert_eq!(
        r.joints(),
        JointsDeg::new([30.0, 0.0, -90.0, 5.0, -70.0, 15.0])
    );
    // The newest command is 0 (a poll with version 1040): the robot stays.
    r.req("1040 0 0");
    r.wait(ms(200));
    assert!(r.status("0 0 0").task_running);
}

#[test]
fn an_argument_never_assigned_stops_ros_move_with_e0102() {
    let mut r = Rig::new();
    r.req("1040 1 0");
    r.req("1040 6 3 0 0 0");
    r.wait(ms(20));
    let st = r.status("0 0 0");
    assert_eq!(st.error, ErrorCode(-30102));
    assert!(!st.task_running);
    let info = &r.i.tasks(&r.s)[0];
    let line = SERVER_1040
        .lines()
        .position(|l| l.contains("JMOVE #PPOINT(.arg[4]"))
        .unwrap()
        + 1;
    assert_eq!(
        info.last_error.as_deref(),
        Some(
            format!(
                "(E0102) variable not defined: .arg[4] (assign it before reading it) (ros_move line {line})"
            )
            .as_str()
        )
    );
    // In error, command 1 does nothing; the communication task keeps serving.
    assert!(!r.status("1040 1 0").task_running);
}

#[test]
fn command_3_sets_the_monitor_speed_and_abs_speed() {
    let mut r = Rig::new();
    assert_eq!(r.i.system_switch("abs.speed"), Some(false));
    r.req("1040 3 1 50");
    assert_eq!(r.s.monitor_speed, 50.0);
    assert_eq!(r.i.system_switch("abs.speed"), Some(true));
    // Speed 0 is refused by MC SPEED (the server goes on), over 100 is 100.
    r.req("1040 3 1 0");
    assert_eq!(r.s.monitor_speed, 50.0);
    assert!(r
        .s
        .lines_of(TaskId::Pc(1))
        .iter()
        .any(|l| l.starts_with("MC SPEED 0:")));
    r.req("1040 3 1 150");
    assert_eq!(r.s.monitor_speed, 100.0);
    // A 3 without its argument reads it as 0.
    r.req("1040 3 0");
    assert_eq!(r.s.monitor_speed, 100.0);
}

#[test]
fn commands_2_and_5_stop_the_robot() {
    let mut r = Rig::new();
    r.req("1040 1 0");
    r.req("1040 6 9 0 0 0 90 0 -90 0 -90 0");
    r.wait(ms(200));
    // 5: BRAKE; the program keeps running.
    let st = r.status("1040 5 0");
    let at = st.joints[0];
    assert!(at > 10.0 && at < 40.0, "{at}");
    r.wait(ms(300));
    let st = r.status("0 0 0");
    assert_eq!(st.joints[0], at, "braked");
    assert!(st.task_running);
    // A 5 after a 5 does nothing more.
    r.status("1040 5 0");
    // A new 6 moves again; 2 stops the robot and ends the program within the 50 ms the
    // interrupt needs.
    r.req("1040 6 9 0 0 0 90 0 -90 0 -90 0");
    r.wait(ms(200));
    r.req("1040 2 0");
    r.wait(ms(60));
    let st = r.status("0 0 0");
    assert!(!st.task_running);
    let j = st.joints[0];
    r.wait(ms(300));
    assert_eq!(r.joints()[0], j);
    assert!(j < 89.0);
}

#[test]
fn command_255_replies_then_closes_and_the_server_listens_again() {
    let mut r = Rig::new();
    r.req("1040 1 0");
    let reply = r.req("1040 255 0");
    assert!(reply.starts_with(" 1040 0 -1 -1 0 -1"), "{reply:?}");
    r.wait(ms(5));
    assert!(r.s.peer_closed(r.c));
    // Signal 2007 must be on for 50 ms before ros_move's ONI stops it.
    assert_eq!(r.i.task_state(TaskId::Robot, &r.s), TaskState::Running);
    r.wait(ms(50));
    assert_eq!(r.i.task_state(TaskId::Robot, &r.s), TaskState::Idle);
    r.wait(ms(10));
    let c2 = r.s.connect(10050).expect("listening again");
    r.c = c2;
    r.wait(ms(10));
    assert!(r.req("0 0 0").starts_with(" 1040 0 -1 -1 0 -1 0     0.0"));
}

#[test]
fn receive_and_send_timeouts_end_the_session() {
    let mut r = Rig::new();
    r.req("1040 1 0");
    r.wait(ms(4900));
    assert!(!r.s.peer_closed(r.c));
    r.wait(ms(200));
    assert!(r.s.peer_closed(r.c), "no request for 5 s");
    assert_eq!(r.i.task_state(TaskId::Robot, &r.s), TaskState::Idle);

    // A client that does not read: the reply waits, 2 s later the session ends.
    let mut r = Rig::new();
    r.s.socket_capacity = 100;
    r.req("0 0 0");
    assert!(r.s.send(r.c, b"0 0 0"));
    r.wait(ms(50));
    assert!(r.s.send(r.c, b"0 0 0"));
    r.wait(ms(1900));
    assert!(!r.s.peer_closed(r.c));
    r.wait(ms(200));
    assert!(r.s.peer_closed(r.c), "send timeout");
}

#[test]
fn only_the_first_255_bytes_count() {
    let mut r = Rig::new();
    let mut text = String::from("1040 3 1 ");
    text.push_str(&" ".repeat(255 - text.len()));
    text.push_str("50");
    r.req(&text);
    assert_eq!(
        r.s.monitor_speed, 100.0,
        "the argument was beyond byte 255 (read as 0, refused)"
    );
    assert_eq!(
        r.i.system_switch("abs.speed"),
        Some(true),
        "the command itself acted"
    );
}

#[test]
fn command_7_extrapolates_and_chooses_the_move() {
    let mut r = Rig::new();
    r.req("1040 1 0");
    // A sample at the current position with a velocity on JT1: straight-line moves of 0.1 s.
    let t = r.status("0 0 0").timer.seconds().unwrap();
    r.req(&format!(
        "1040 7 21 {t} 0 0 0 0 -90 0 -90 0 10 0 0 0 0 0 0 0 0 0 0 0"
    ));
    r.wait(ms(50));
    let last = *r.s.motions.last().map(|(_, m)| m).expect("a motion");
    assert_eq!(last.kind, MotionKind::Linear);
    assert_eq!(last.speed, Speed::Seconds(f64::from(0.1f32)));
    // Near the elbow singularity (|JT3| < 5): a joint move at 30 %.
    r.req(&format!(
        "1040 7 21 {t} 0 0 0 0 -3 0 -90 0 0 0 0 0 0 0 0 0 0 0 0 0"
    ));
    r.wait(ms(50));
    let last = *r.s.motions.last().map(|(_, m)| m).unwrap();
    assert_eq!(last.kind, MotionKind::Joint);
    assert_eq!(last.speed, Speed::Percent(30.0));
    assert!(last.accuracy_mm == 10.0 && last.cp);
}

#[test]
fn step_converges_to_the_loop_overhead() {
    let mut r = Rig::printing();
    r.req("1040 1 0");
    for _ in 0..50 {
        r.req("1040 4 0");
        r.wait(ms(10));
    }
    let line =
        r.s.lines_of(TaskId::Robot)
            .last()
            .map(|s| s.to_string())
            .unwrap();
    let step: f64 = line.rsplit(' ').next().unwrap().parse().unwrap();
    // From the end of one pass (last_tm) to the start of the next (tm): the PRINT of the
    // pass (1 ms + 29 bytes at 100 µs) and the loop test, about 4 ms with the default cost
    // model, measured with the 1 ms TIMER resolution.
    assert!((0.0035..0.0045).contains(&step), "{line}");
}
