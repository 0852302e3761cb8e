//! One machine, two servers: the controller runs either the native protocol-1040 server or an
//! AS program, never both. Each server answers only its own clients; the panel, the error and
//! the fault queue belong to the machine under either.
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

use std::time::Duration;

use fs020n_proto::ErrorCode;
use fs020n_sim::{
    Controller, ControllerConfig, Fault, MotionTaskState, PanelError, Refused, ServerProgram,
    SessionGone, SessionId,
};

fn native() -> Controller {
    Controller::new(ControllerConfig::default())
}

fn program() -> Controller {
    let program = ServerProgram::server_1040().expect("the project's server text loads");
    let mut c = Controller::with_program(ControllerConfig::default(), program);
    c.advance_by(Duration::from_millis(10));
    c
}

#[test]
fn a_controller_running_a_program_refuses_native_sessions_and_counts_the_refusal() {
    let mut c = program();
    assert!(c.program().runs());
    assert_eq!(c.try_accept(), Err(Refused::ListenGap));
    assert_eq!(c.counters().refused, 1);
    assert!(!c.native().is_listening());
    assert_eq!(c.native().next_listen_change(), None);
    assert_eq!(c.native().session(), None);
    assert_eq!(
        c.handle_request(SessionId(1), b"1040 1 0"),
        Err(SessionGone)
    );
    // Its own clients connect to the port the program listens on.
    assert!(c.program().listening(None));
    assert!(c.program_mut().connect(None, [127, 0, 0, 1]).is_ok());
}

#[test]
fn a_native_controller_has_no_program_clients() {
    let mut c = native();
    assert!(!c.program().runs());
    assert_eq!(
        c.program_mut().connect(None, [127, 0, 0, 1]),
        Err(Refused::ListenGap)
    );
    assert_eq!(c.counters().refused, 1);
    assert_eq!(c.program().tasks(), None);
    assert_eq!(c.program().next_event(), None);
    assert!(c.snapshot().program.is_none());
    // Its own clients are accepted in a listen window.
    assert!(c.native().is_listening());
    assert!(c.try_accept().is_ok());
}

#[test]
fn the_emergency_stop_acts_on_the_machine_under_either_server() {
    for mut c in [native(), program()] {
        c.set_estop(true);
        assert_eq!(c.error(), ErrorCode::EMERGENCY_STOP);
        assert!(!c.panel().power);
        assert_eq!(c.reset_error(), Err(PanelError::EstopPressed));
        assert_eq!(c.set_power(true), Err(PanelError::EstopPressed));
        c.set_estop(false);
        assert_eq!(c.reset_error(), Ok(()));
        assert!(c.error().is_none());
        let s = c.snapshot();
        assert_eq!(s.counters.errors, 1, "runs_program: {}", c.program().runs());
        assert_eq!(s.task, MotionTaskState::NotRunning);
    }
}

#[test]
fn reply_faults_wait_in_the_machine_under_either_server() {
    for mut c in [native(), program()] {
        c.inject(Fault::WithholdReplies { count: 2 });
        assert_eq!(
            c.pending_faults(),
            2,
            "runs_program: {}",
            c.program().runs()
        );
        c.clear_faults();
        assert_eq!(c.pending_faults(), 0);
    }
}

#[test]
fn the_pendant_switches_abs_speed_as_the_server_sees_it() {
    for mut c in [native(), program()] {
        assert!(!c.abs_speed());
        c.set_abs_speed(true);
        assert!(c.abs_speed(), "runs_program: {}", c.program().runs());
        assert!(c.snapshot().abs_speed);
        c.set_abs_speed(false);
        assert!(!c.abs_speed());
    }
}
