//! Helpers shared by the scenario tests.
#![allow(dead_code)]

use std::time::Duration;

use fs020n_proto::{Command, JointsDeg, Request, Status, StreamSample};
use fs020n_sim::{Controller, ControllerConfig, SessionId};

pub(crate) const HOME: JointsDeg = JointsDeg::new([0.0, 0.0, -90.0, 0.0, -90.0, 0.0]);

pub(crate) fn ms(n: u64) -> Duration {
    Duration::from_millis(n)
}

pub(crate) fn ctl() -> Controller {
    Controller::new(ControllerConfig::default())
}

/// A controller with an open session and the program running.
pub(crate) fn running() -> (Controller, SessionId) {
    let mut c = ctl();
    let id = c.try_accept().unwrap();
    let s = raw(&mut c, id, "1040 1 0");
    assert!(s.task_running, "program started");
    (c, id)
}

/// Sends raw request bytes, returns the decoded reply.
pub(crate) fn raw(c: &mut Controller, id: SessionId, text: &str) -> Status {
    let h = c.handle_request(id, text.as_bytes()).unwrap();
    Status::decode(std::str::from_utf8(&h.reply).unwrap()).unwrap()
}

/// Sends a command as the client library encodes it.
pub(crate) fn cmd(c: &mut Controller, id: SessionId, command: Command) -> Status {
    let text = Request::new(command).encode().unwrap();
    raw(c, id, &text)
}

pub(crate) fn jmove(c: &mut Controller, id: SessionId, target: [f64; 6]) -> Status {
    cmd(
        c,
        id,
        Command::JointMove {
            target: JointsDeg::new(target),
        },
    )
}

pub(crate) fn sample(t0: f64, look: f64, p: [f64; 6], v: [f64; 6], a: [f64; 6]) -> StreamSample {
    StreamSample {
        t0_s: t0,
        lookahead_passes: look,
        position: JointsDeg::new(p),
        velocity: JointsDeg::new(v),
        acceleration: JointsDeg::new(a),
    }
}

/// Advances in ticks until `pred` holds; returns the time it took. Panics after `max`.
pub(crate) fn until(
    c: &mut Controller,
    max: Duration,
    mut pred: impl FnMut(&Controller) -> bool,
) -> Duration {
    let start = c.now();
    while !pred(c) {
        assert!(
            c.now() - start <= max,
            "condition not reached within {max:?}"
        );
        c.advance_by(ms(2));
    }
    c.now() - start
}

/// Advances in steps of 1 s, polling with `0 0 0` to keep the session alive.
pub(crate) fn wait_polling(c: &mut Controller, id: SessionId, d: Duration) {
    let end = c.now() + d;
    while c.now() < end {
        let step = (end - c.now()).min(Duration::from_secs(1));
        c.advance_by(step);
        if c.native().is_session_open(id) {
            raw(c, id, "0 0 0");
        }
    }
}

pub(crate) fn is_still(c: &Controller) -> bool {
    c.velocity().iter().all(|v| v == 0.0) && c.motion_phase() == fs020n_sim::MotionPhase::Idle
}

/// Sends a command 7 holding `p` (zero velocity and acceleration), stamped now.
pub(crate) fn stream_to(c: &mut Controller, id: SessionId, p: [f64; 6]) -> Status {
    let s = sample(c.native().timer1_s(), 0.0, p, [0.0; 6], [0.0; 6]);
    cmd(c, id, Command::StreamedMove(s))
}
