use std::time::Duration;

use fs020n_proto::{Command, JointsDeg, Request, Status};
use fs020n_sim::{Controller, ControllerConfig, MotionTaskState};

fn send(c: &mut Controller, id: fs020n_sim::SessionId, cmd: Command) -> Status {
    let text = Request::new(cmd).encode().unwrap();
    let h = c.handle_request(id, text.as_bytes()).unwrap();
    Status::decode(std::str::from_utf8(&h.reply).unwrap()).unwrap()
}

#[test]
fn joint_move_reaches_target() {
    let mut c = Controller::new(ControllerConfig::default());
    let id = c.try_accept().unwrap();
    send(&mut c, id, Command::StartProgram);
    assert_eq!(c.task(), MotionTaskState::Running);
    let target = JointsDeg::new([30.0, 10.0, -80.0, 10.0, -60.0, 20.0]);
    send(&mut c, id, Command::JointMove { target });
    for _ in 0..40 {
        c.advance_by(Duration::from_millis(500));
        let s = send(&mut c, id, Command::JointMove { target });
        assert!(s.task_running);
    }
    assert!(c.joints().max_abs_diff(&target) < 1e-6, "{}", c.joints());
    // Stream
    send(&mut c, id, Command::SetSpeed { percent: 100.0 });
    let mut t = 20.0;
    for k in 0..300 {
        c.advance_by(Duration::from_millis(10));
        t += 0.01;
        let mut p = target;
        p[0] += 10.0 * (k as f64 * 0.01);
        let s = fs020n_proto::StreamSample {
            t0_s: c.native().timer1_s(),
            lookahead_passes: 1.0,
            position: p,
            velocity: JointsDeg::new([10.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
            acceleration: JointsDeg::ZERO,
        };
        send(&mut c, id, Command::StreamedMove(s));
    }
    let _ = t;
    println!("after stream {} step {}", c.joints(), c.native().step_s());
    assert!((c.joints()[0] - 60.0).abs() < 1.0, "{}", c.joints());
    assert!(c.error().is_none());
}
