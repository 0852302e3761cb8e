//! The client against the in-memory emulator on virtual time: every test runs in milliseconds
//! of real time, with the controller's timeouts behaving as on the real one.

mod common;

use std::time::Duration;

use common::*;
use fs020n_client::{
    Blocker, Cancellation, ClientConfig, ClientError, Completion, LinkError, RecordFormat,
    Recording, Robot, StreamMode, StreamOptions, StreamOutcome, TrajectoryError, ESTOP_REMEDY,
};
use fs020n_kin::RobotModel;
use fs020n_proto::{Command, ErrorCode, JointsDeg};
use fs020n_sim::{Fault, MotionTaskState, SessionEnd};

// ------------------------------------------------------------------ connection and session

#[tokio::test(start_paused = true)]
async fn connects_across_a_listen_gap() {
    let emu = emulator();
    // The first accept window is 3 s, then a 100 ms gap: be in the gap.
    sleep_ms(3050).await;
    assert!(
        !emu.with(|c| c.native().is_listening()),
        "the emulator should be in its listen gap"
    );
    let robot = connect(&emu).await;
    assert!(
        emu.elapsed() >= Duration::from_millis(3100),
        "{:?}",
        emu.elapsed()
    );
    assert!(emu.with(|c| c.counters().refused) >= 1);
    assert_eq!(emu.with(|c| c.counters().sessions), 1);
    let s = robot.status();
    assert_eq!(s.status.joints, home());
    assert!(robot.is_connected());
}

#[tokio::test(start_paused = true)]
async fn a_second_client_is_refused_with_a_remedy() {
    let emu = emulator();
    let first = connect(&emu).await;
    let cfg = ClientConfig {
        connect_timeout: Duration::from_secs(1),
        ..ClientConfig::default()
    };
    let err = Robot::connect_with(EmuConnector::new(&emu), cfg)
        .await
        .expect_err("the session is taken");
    match &err {
        ClientError::Connect {
            attempts, waited, ..
        } => {
            assert!(*attempts > 5, "{attempts}");
            assert!(*waited <= Duration::from_secs(1));
        }
        other => panic!("expected Connect, got {other:?}"),
    }
    assert!(err
        .to_string()
        .contains("no other client holds the session"));
    // The first client is unaffected.
    assert!(first.poll().await.is_ok());
}

#[tokio::test(start_paused = true)]
async fn a_slow_reply_below_the_deadline_is_late_but_fine() {
    let emu = emulator();
    let robot = connect(&emu).await;
    emu.with(|c| {
        c.inject(Fault::DelayReplies {
            count: 1,
            delay_ms: 600,
        })
    });
    let status = robot
        .poll()
        .await
        .expect("600 ms is below the 1 s deadline");
    assert_eq!(status.joints, home());
    let st = robot.stats();
    assert!(st.late_replies >= 1, "{st:?}");
    assert!(st.rtt.max >= Duration::from_millis(600), "{st:?}");
    assert!(robot.is_connected());
}

#[tokio::test(start_paused = true)]
async fn a_slow_reply_above_the_deadline_kills_the_handle() {
    let emu = emulator();
    let robot = connect(&emu).await;
    let mut sub = robot.subscribe();
    emu.with(|c| {
        c.inject(Fault::DelayReplies {
            count: 1,
            delay_ms: 1500,
        })
    });
    let err = robot
        .poll()
        .await
        .expect_err("1.5 s is beyond the 1 s deadline");
    assert!(
        matches!(err, ClientError::LinkLost(LinkError::ReplyTimeout { .. })),
        "{err:?}"
    );
    assert!(!robot.is_connected());
    assert_eq!(robot.link_error(), Some(err.clone()));
    // Every later call fails with the same cause; subscribers see the end.
    assert_eq!(robot.poll().await.unwrap_err(), err);
    while sub.changed().await.is_ok() {}
    assert!(robot.stats().links_lost == 1);
}

#[tokio::test(start_paused = true)]
async fn a_withheld_reply_is_a_typed_timeout_and_the_session_ends() {
    let emu = emulator();
    let robot = ready(&emu, 10.0).await;
    emu.with(|c| c.inject(Fault::WithholdReplies { count: 1 }));
    let err = robot.poll().await.unwrap_err();
    match &err {
        ClientError::LinkLost(LinkError::ReplyTimeout { request, deadline }) => {
            assert_eq!(request, "0 0 0");
            assert_eq!(*deadline, Duration::from_secs(1));
        }
        other => panic!("{other:?}"),
    }
    assert!(err.to_string().contains("reconnect"), "{err}");
    let moved = robot.move_joints(with_jt1(5.0)).await.unwrap_err();
    assert_eq!(moved, err, "a dead handle sends nothing");
    // The client dropped the connection: the controller ended the session, and the program
    // once signal 2007 has been stable for 50 ms.
    sleep_ms(10).await;
    assert_eq!(emu.with(|c| c.native().session()), None);
    sleep_ms(60).await;
    assert_eq!(emu.with(|c| c.task()), MotionTaskState::NotRunning);
}

#[tokio::test(start_paused = true)]
async fn a_garbage_reply_kills_the_handle() {
    let emu = emulator();
    let robot = connect(&emu).await;
    emu.with(|c| {
        c.inject(Fault::GarbageReply {
            text: "HELLO WORLD".into(),
        })
    });
    let err = robot.poll().await.unwrap_err();
    assert!(
        matches!(err, ClientError::LinkLost(LinkError::Undecodable(_))),
        "{err:?}"
    );
    assert!(!robot.is_connected());
}

#[tokio::test(start_paused = true)]
async fn a_reply_split_across_segments_is_reassembled() {
    let emu = emulator();
    let robot = connect(&emu).await;
    emu.with(|c| {
        c.inject(Fault::SplitReply {
            parts: 7,
            gap_ms: 30,
        })
    });
    let status = robot.poll().await.expect("a split reply is one reply");
    assert_eq!(status.joints, home());
    assert!(status.power && status.run && status.repeat);
    assert!(robot.poll().await.is_ok());
    assert!(robot.is_connected());
}

#[tokio::test(start_paused = true)]
async fn keep_alive_holds_an_idle_session_for_30_s() {
    let emu = emulator();
    let robot = connect(&emu).await;
    sleep_ms(30_000).await;
    assert_eq!(emu.with(|c| c.counters().receive_timeouts), 0);
    assert!(emu.with(|c| c.native().session()).is_some());
    assert!(robot.is_connected());
    let snap = robot.status();
    assert!(snap.age() <= Duration::from_millis(100), "{:?}", snap.age());
    let st = robot.stats();
    assert!(st.keepalive_polls >= 290, "{st:?}");
    // Keep-alives are polls with a mismatched version: the controller acted on none of them.
    assert_eq!(effective(&emu), 0);
    assert!(robot.poll().await.is_ok());
}

#[tokio::test(start_paused = true)]
async fn close_sends_255_and_waits_for_the_server() {
    let emu = emulator();
    let robot = ready(&emu, 10.0).await;
    robot.close().await.expect("close");
    let end = emu.with(|c| c.native().last_session_end());
    assert_eq!(end.map(|e| e.1), Some(SessionEnd::EndCommand));
    sleep_ms(60).await; // signal 2007's edge
    assert_eq!(emu.with(|c| c.task()), MotionTaskState::NotRunning);
    assert_eq!(robot.poll().await.unwrap_err(), ClientError::Closed);
    assert!(robot.close().await.is_ok(), "closing twice is harmless");
}

#[tokio::test(start_paused = true)]
async fn dropping_the_robot_ends_the_session() {
    let emu = emulator();
    let robot = connect(&emu).await;
    drop(robot);
    sleep_ms(50).await;
    assert_eq!(
        emu.with(|c| c.native().last_session_end()).map(|e| e.1),
        Some(SessionEnd::EndCommand)
    );
}

#[tokio::test(start_paused = true)]
async fn a_peer_that_is_not_a_controller_is_rejected() {
    use fs020n_client::{BoxedStream, ConnectFuture, Connector};
    use tokio::io::{AsyncReadExt, AsyncWriteExt};
    struct Impostor;
    impl Connector for Impostor {
        fn connect(&self) -> ConnectFuture<'_> {
            Box::pin(async {
                let (client, mut server) = tokio::io::duplex(1024);
                tokio::spawn(async move {
                    let mut buf = [0u8; 256];
                    while let Ok(n) = server.read(&mut buf).await {
                        if n == 0 {
                            break;
                        }
                        let reply = " 2000 0 -1 -1 0 -1 0     0.001     0.000     0.000     0.000     0.000     0.000     0.000 ";
                        if server.write_all(reply.as_bytes()).await.is_err() {
                            break;
                        }
                    }
                });
                Ok(Box::new(client) as BoxedStream)
            })
        }
        fn describe(&self) -> String {
            "impostor".into()
        }
    }
    let err = Robot::connect_with(Impostor, ClientConfig::default())
        .await
        .unwrap_err();
    assert_eq!(
        err,
        ClientError::NotAController {
            target: "impostor".into(),
            cause: LinkError::NotAController { version: 2000 }
        }
    );
}

#[tokio::test(start_paused = true)]
async fn an_http_server_is_rejected_at_once_without_retries() {
    use fs020n_client::{BoxedStream, ConnectFuture, Connector};
    use std::sync::atomic::{AtomicU32, Ordering};
    use std::sync::Arc;
    use tokio::io::{AsyncReadExt, AsyncWriteExt};
    struct Http(Arc<AtomicU32>);
    impl Connector for Http {
        fn connect(&self) -> ConnectFuture<'_> {
            self.0.fetch_add(1, Ordering::SeqCst);
            Box::pin(async {
                let (client, mut server) = tokio::io::duplex(1024);
                tokio::spawn(async move {
                    let mut buf = [0u8; 256];
                    if server.read(&mut buf).await.is_ok() {
                        let _ = server
                            .write_all(b"HTTP/1.1 400 Bad Request\r\ncontent-length: 0\r\n\r\n")
                            .await;
                    }
                    // Keep the connection open, as a keep-alive HTTP server would.
                    tokio::time::sleep(Duration::from_secs(60)).await;
                });
                Ok(Box::new(client) as BoxedStream)
            })
        }
        fn describe(&self) -> String {
            "web server".into()
        }
    }
    let attempts = Arc::new(AtomicU32::new(0));
    let started = tokio::time::Instant::now();
    let err = Robot::connect_with(Http(attempts.clone()), ClientConfig::default())
        .await
        .unwrap_err();
    assert!(
        matches!(
            &err,
            ClientError::NotAController {
                cause: LinkError::Undecodable(_),
                ..
            }
        ),
        "{err:?}"
    );
    assert!(
        err.to_string().contains("not a protocol-1040 server"),
        "{err}"
    );
    assert_eq!(attempts.load(Ordering::SeqCst), 1, "no retries");
    assert!(
        started.elapsed() < Duration::from_secs(1),
        "{:?}",
        started.elapsed()
    );
}

#[tokio::test]
async fn a_name_that_does_not_resolve_fails_at_once() {
    let err = Robot::connect("no-such-host.invalid:10050", ClientConfig::default())
        .await
        .unwrap_err();
    assert!(matches!(&err, ClientError::Address { .. }), "{err:?}");
    assert!(err.to_string().contains("check the host name"), "{err}");
}

// ------------------------------------------------------------------ preflight and start

#[tokio::test(start_paused = true)]
async fn preflight_names_every_blocker_with_its_remedy() {
    let emu = emulator();
    let robot = connect(&emu).await;
    assert!(robot.preflight().await.is_ok());

    type Flip = fn(&mut fs020n_sim::Controller, bool);
    let cases: [(Flip, Blocker, &str); 4] = [
        (
            |c, on| c.set_repeat(!on),
            Blocker::Teach,
            "switch TEACH/REPEAT to REPEAT",
        ),
        (
            |c, on| c.set_teach_lock(on),
            Blocker::TeachLock,
            "turn TEACH LOCK off",
        ),
        (
            |c, on| c.set_run(!on),
            Blocker::Hold,
            "switch RUN/HOLD to RUN",
        ),
        (
            |c, on| c.set_power(!on).unwrap(),
            Blocker::PowerOff,
            "turn motor power on",
        ),
    ];
    for (flip, blocker, remedy) in cases {
        emu.with(|c| flip(c, true));
        let err = robot.preflight().await.unwrap_err();
        assert_eq!(err, ClientError::Blocked(vec![blocker]));
        assert!(err.to_string().contains(remedy), "{err}");
        // start() refuses too, without sending command 1.
        let before = effective(&emu);
        assert_eq!(robot.start().await.unwrap_err(), err);
        assert_eq!(effective(&emu), before);
        emu.with(|c| flip(c, false));
    }
    // All at once: every one listed.
    emu.with(|c| {
        c.set_repeat(false);
        c.set_teach_lock(true);
        c.set_run(false);
    });
    let err = robot.preflight().await.unwrap_err();
    assert_eq!(
        err.blockers(),
        &[Blocker::Teach, Blocker::TeachLock, Blocker::Hold]
    );
    emu.with(|c| {
        c.set_repeat(true);
        c.set_teach_lock(false);
        c.set_run(true);
    });

    emu.with(|c| {
        c.inject(Fault::RaiseError {
            code: ErrorCode::DESTINATION_OUT_OF_RANGE,
        })
    });
    let err = robot.preflight().await.unwrap_err();
    assert!(
        err.to_string()
            .contains("reset error E1088 (Destination is out of motion range) at the pendant"),
        "{err}"
    );
    emu.with(|c| c.reset_error().unwrap());

    emu.with(|c| c.set_estop(true));
    let err = robot.preflight().await.unwrap_err();
    assert_eq!(
        err.blockers(),
        &[
            Blocker::ControllerError(ErrorCode::EMERGENCY_STOP),
            Blocker::PowerOff
        ]
    );
    assert!(err.to_string().contains(ESTOP_REMEDY), "{err}");
    assert!(err.to_string().contains("E3808"), "{err}");
    emu.with(|c| {
        c.set_estop(false);
        c.reset_error().unwrap();
        c.set_power(true).unwrap();
    });
    assert!(robot.preflight().await.is_ok());
    assert_eq!(emu.with(|c| c.counters().starts_ignored), 0);
}

#[tokio::test(start_paused = true)]
async fn start_confirms_the_program_runs() {
    let emu = emulator();
    let robot = connect(&emu).await;
    robot.start().await.expect("start");
    assert_eq!(emu.with(|c| c.task()), MotionTaskState::Running);
    assert!(robot.status().status.task_running);
    // Already running: no second command 1 (it would make the robot pause).
    let before = effective(&emu);
    robot.start().await.expect("start again");
    assert_eq!(effective(&emu), before);
    robot.stop_program().await.expect("stop");
    sleep_ms(60).await; // signal 2007's edge
    assert_eq!(emu.with(|c| c.task()), MotionTaskState::NotRunning);
    // A start right after a stop waits for the old program to end, then starts anew.
    robot.start().await.expect("start after stop");
    robot.stop_program().await.expect("stop");
    robot.start().await.expect("start at once after a stop");
    sleep_ms(200).await;
    assert_eq!(
        emu.with(|c| c.task()),
        MotionTaskState::Running,
        "not ended by the old signal"
    );
}

#[tokio::test(start_paused = true)]
async fn start_in_a_new_session_does_not_trust_the_old_sessions_program() {
    // The previous session's program is still running for 50 ms after it ended (signal 2007's
    // edge); a start in the next session must not take it for its own.
    let emu = emulator();
    let robot = connect(&emu).await;
    robot.start().await.expect("start");
    robot.close().await.expect("close");
    let robot = connect(&emu).await;
    assert!(
        emu.with(|c| c.task()) == MotionTaskState::Running,
        "still on its way out"
    );
    robot.start().await.expect("start");
    sleep_ms(500).await;
    assert_eq!(emu.with(|c| c.task()), MotionTaskState::Running);
    assert!(robot.poll().await.unwrap().task_running);
}

// ------------------------------------------------------------------ checks before sending

#[tokio::test(start_paused = true)]
async fn invalid_requests_are_refused_before_sending() {
    let emu = emulator();
    let robot = ready(&emu, 10.0).await;
    let before = effective(&emu);
    let newest = emu.with(|c| c.native().newest_command());

    let err = robot.move_joints(with_jt1(200.0)).await.unwrap_err();
    assert!(
        matches!(&err, ClientError::Limit(l) if l.joint == 1),
        "{err:?}"
    );
    assert!(err.to_string().contains("JT1"), "{err}");
    let mut t = home();
    t[4] = f64::NAN;
    assert!(matches!(
        robot.move_joints(t).await,
        Err(ClientError::NonFinite { .. })
    ));
    t[4] = f64::INFINITY;
    assert!(matches!(
        robot.move_joints(t).await,
        Err(ClientError::NonFinite { .. })
    ));
    for bad in [0.0, 0.5, 101.0, f64::NAN] {
        assert!(matches!(
            robot.set_speed(bad).await,
            Err(ClientError::Speed { .. })
        ));
    }
    let oversize = format!("1040 3 1 {}", "1".repeat(250));
    assert!(matches!(
        robot.send_raw(&oversize, true).await,
        Err(ClientError::RawRefused { .. })
    ));
    let err = robot
        .send_raw("1040 6 9 0 0 0 10 0 -90 0 -90 0", false)
        .await
        .unwrap_err();
    assert!(err.to_string().contains("allow_motion"), "{err}");
    assert!(matches!(
        robot
            .send_raw("1040 7 21 0 0 0 0 0 -90 0 -90 0", false)
            .await,
        Err(ClientError::RawRefused { .. })
    ));
    assert!(matches!(
        robot
            .send_raw("1040 6 9 0 0 0 300 0 -90 0 -90 0", true)
            .await,
        Err(ClientError::Limit(_))
    ));
    assert!(matches!(
        robot.send_raw("1040 5 0\n", false).await,
        Err(ClientError::RawRefused { .. })
    ));
    // A trajectory leaving the ranges, one too fast, one starting away from the robot.
    let opts = StreamOptions::default();
    assert!(matches!(
        robot.stream(jt1_ramp(0.0, 170.0, 20.0), opts).await,
        Err(ClientError::Trajectory(TrajectoryError::OutOfRange { .. }))
    ));
    assert!(matches!(
        robot.stream(jt1_ramp(0.0, 90.0, 0.5), opts).await,
        Err(ClientError::Trajectory(TrajectoryError::TooFast { .. }))
    ));
    assert!(matches!(
        robot.stream(jt1_ramp(20.0, 30.0, 2.0), opts).await,
        Err(ClientError::Trajectory(TrajectoryError::StartTooFar { .. }))
    ));
    assert!(matches!(
        robot
            .move_pose(fs020n_client::Xyzoat::new(
                5000.0, 0.0, 0.0, 0.0, 180.0, 0.0
            ))
            .await,
        Err(ClientError::Ik(_))
    ));

    assert_eq!(effective(&emu), before, "nothing reached the controller");
    assert_eq!(emu.with(|c| c.native().newest_command()), newest);
    assert_eq!(emu.with(|c| c.joints()), home());
    assert!(robot.stats().refused_before_sending >= 13);
}

#[tokio::test(start_paused = true)]
async fn motion_is_refused_while_the_status_blocks_it() {
    let emu = emulator();
    let robot = connect(&emu).await;
    // Program not running.
    let err = robot.move_joints(with_jt1(5.0)).await.unwrap_err();
    assert_eq!(err, ClientError::Blocked(vec![Blocker::ProgramNotRunning]));
    robot.start().await.unwrap();
    emu.with(|c| c.set_teach_lock(true));
    robot.poll().await.unwrap();
    let err = robot.move_joints(with_jt1(5.0)).await.unwrap_err();
    assert_eq!(err.blockers(), &[Blocker::TeachLock]);
    assert!(!emu.with(|c| c.native().newest_command().is_some_and(|n| n.is_motion())));
}

// ------------------------------------------------------------------ joint moves

#[tokio::test(start_paused = true)]
async fn a_joint_move_completes_with_progress() {
    let emu = emulator();
    let robot = ready(&emu, 50.0).await;
    let target = JointsDeg::new([20.0, 10.0, -80.0, 5.0, -70.0, 15.0]);
    let mv = robot.move_joints(target).await.unwrap();
    assert!(mv.planned_duration() > Duration::ZERO);
    sleep_ms(150).await;
    let p = mv.progress().unwrap();
    assert!(p.fraction > 0.0 && p.fraction < 1.0, "{p:?}");
    assert!((p.total_deg - 20.0).abs() < 1e-9, "{p:?}");
    let report = mv
        .wait(Completion::default())
        .await
        .expect("the move completes");
    assert!(report.error_deg <= 0.1);
    assert!(emu.with(|c| c.joints()).max_abs_diff(&target) < 0.01);
    assert_eq!(mv.progress().unwrap().fraction, 1.0);
}

#[tokio::test(start_paused = true)]
async fn move_pose_goes_through_ik_nearest_to_the_current_joints() {
    let emu = emulator();
    let robot = ready(&emu, 100.0).await;
    let model = RobotModel::fs020n();
    let want = JointsDeg::new([10.0, 5.0, -85.0, 3.0, -80.0, 2.0]);
    let pose = model.forward(&want.to_rad()).to_xyzoat();
    let mv = robot.move_pose(pose).await.unwrap();
    assert!(mv.target().max_abs_diff(&want) < 1e-6, "{}", mv.target());
    mv.wait(Completion::default()).await.unwrap();
    assert!(emu.with(|c| c.joints()).max_abs_diff(&want) < 0.01);
}

#[tokio::test(start_paused = true)]
async fn estop_mid_move_fails_the_wait_with_e3808_and_its_remedy() {
    let emu = emulator();
    let robot = ready(&emu, 10.0).await;
    let mv = robot.move_joints(with_jt1(60.0)).await.unwrap();
    sleep_ms(500).await;
    emu.with(|c| c.set_estop(true));
    let err = mv.wait(Completion::default()).await.unwrap_err();
    assert!(
        matches!(
            err,
            ClientError::Aborted {
                during: "joint move",
                ..
            }
        ),
        "{err:?}"
    );
    assert!(err
        .blockers()
        .contains(&Blocker::ControllerError(ErrorCode::EMERGENCY_STOP)));
    let text = err.to_string();
    assert!(
        text.contains("E3808") && text.contains(ESTOP_REMEDY),
        "{text}"
    );
    let j = emu.with(|c| c.joints());
    assert!(j[0] > 0.0 && j[0] < 60.0, "stopped on the way: {j}");
}

#[tokio::test(start_paused = true)]
async fn hold_mid_move_fails_the_wait_and_the_move_does_not_resume() {
    let emu = emulator();
    let robot = ready(&emu, 10.0).await;
    let target = with_jt1(60.0);
    let mv = robot.move_joints(target).await.unwrap();
    sleep_ms(500).await;
    emu.with(|c| c.set_run(false));
    let err = mv.wait(Completion::default()).await.unwrap_err();
    assert_eq!(
        err,
        ClientError::Aborted {
            during: "joint move",
            blockers: vec![Blocker::Hold]
        }
    );
    assert!(err.to_string().contains("switch RUN/HOLD to RUN"), "{err}");
    // The wait cancelled the move (command 5): back on RUN, the robot stays where it is.
    assert_eq!(
        emu.with(|c| c.native().newest_command()),
        Some(Command::StopProgram)
    );
    sleep_ms(1000).await;
    emu.with(|c| c.set_run(true));
    sleep_ms(5000).await;
    let j = emu.with(|c| c.joints());
    assert!(j.max_abs_diff(&target) > 30.0, "the move resumed: {j}");
}

#[tokio::test(start_paused = true)]
async fn a_move_that_cannot_finish_in_time_is_cancelled() {
    let emu = emulator();
    let robot = ready(&emu, 1.0).await;
    let mv = robot.move_joints(with_jt1(90.0)).await.unwrap();
    let err = mv
        .wait(Completion {
            timeout: Some(Duration::from_secs(2)),
            ..Completion::default()
        })
        .await
        .unwrap_err();
    assert!(matches!(err, ClientError::MoveTimeout { .. }), "{err:?}");
    assert_eq!(
        emu.with(|c| c.native().newest_command()),
        Some(Command::StopProgram)
    );
}

#[tokio::test(start_paused = true)]
async fn cancel_and_supersede_end_a_wait_without_sending() {
    let emu = emulator();
    let robot = ready(&emu, 10.0).await;
    let first = robot.move_joints(with_jt1(30.0)).await.unwrap();
    let second = robot.move_joints(with_jt1(-30.0)).await.unwrap();
    assert!(matches!(
        first.wait(Completion::default()).await,
        Err(ClientError::Cancelled(Cancellation::Superseded))
    ));
    robot.cancel().await.unwrap();
    assert!(matches!(
        second.wait(Completion::default()).await,
        Err(ClientError::Cancelled(Cancellation::Cancelled))
    ));
}

// ------------------------------------------------------------------ streaming

#[tokio::test(start_paused = true)]
async fn a_command_7_stream_tracks_the_trajectory() {
    let emu = emulator();
    let robot = ready(&emu, 100.0).await;
    let traj = jt1_ramp(0.0, 20.0, 2.0);
    let handle = robot.stream(traj, StreamOptions::default()).await.unwrap();
    let report = handle.wait().await.expect("the stream completes");
    println!("{report:#?}");
    assert_eq!(report.outcome, StreamOutcome::Completed);
    assert!((90..=110).contains(&report.samples_sent), "{report:?}");
    assert!(report.settled, "{report:?}");
    assert!(report.tracking_samples > 50);
    assert!(report.tracking_error_max_deg < 1.5, "{report:?}");
    assert_eq!(report.underruns, 0);
    assert!((emu.with(|c| c.joints())[0] - 20.0).abs() < 0.5);
    assert_eq!(robot.stats().stream_samples, report.samples_sent);
    assert!(matches!(
        emu.with(|c| c.native().newest_command()),
        Some(Command::StreamedMove(_))
    ));
}

#[tokio::test(start_paused = true)]
async fn a_command_6_waypoint_stream_reaches_the_end() {
    let emu = emulator();
    let robot = ready(&emu, 100.0).await;
    let opts = StreamOptions {
        mode: StreamMode::Waypoints,
        period: Duration::from_millis(50),
        ..StreamOptions::default()
    };
    let report = robot
        .stream(jt1_ramp(0.0, -15.0, 1.5), opts)
        .await
        .unwrap()
        .wait()
        .await
        .unwrap();
    assert_eq!(report.outcome, StreamOutcome::Completed);
    assert!(report.settled, "{report:?}");
    assert!((emu.with(|c| c.joints())[0] + 15.0).abs() < 0.5);
}

#[tokio::test(start_paused = true)]
async fn cancelling_a_stream_brakes_and_reports() {
    let emu = emulator();
    let robot = ready(&emu, 100.0).await;
    let handle = robot
        .stream(jt1_ramp(0.0, 30.0, 3.0), StreamOptions::default())
        .await
        .unwrap();
    // Motion is refused while the stream runs.
    assert!(matches!(
        robot.move_joints(home()).await,
        Err(ClientError::Busy(_))
    ));
    sleep_ms(1000).await;
    let p = handle.progress();
    assert!(p.fraction > 0.2 && p.fraction < 0.5, "{p:?}");
    handle.cancel().await.unwrap();
    let report = handle.wait().await.unwrap();
    assert_eq!(report.outcome, StreamOutcome::Cancelled);
    assert_eq!(
        emu.with(|c| c.native().newest_command()),
        Some(Command::StopProgram)
    );
    sleep_ms(2000).await;
    let j = emu.with(|c| c.joints())[0];
    assert!(j > 1.0 && j < 20.0, "stopped part-way: {j}");
    // The stream is over and the program ended (5 then 2): after a start, motion is accepted
    // again.
    assert!(robot.move_joints(with_jt1(j)).await.is_err());
    robot.start().await.unwrap();
    assert!(robot.move_joints(with_jt1(j)).await.is_ok());
}

#[tokio::test(start_paused = true)]
async fn robot_cancel_stops_a_stream() {
    let emu = emulator();
    let robot = ready(&emu, 100.0).await;
    let handle = robot
        .stream(jt1_ramp(0.0, 30.0, 3.0), StreamOptions::default())
        .await
        .unwrap();
    sleep_ms(500).await;
    robot.cancel().await.unwrap();
    let report = handle.wait().await.unwrap();
    assert_eq!(report.outcome, StreamOutcome::Cancelled);
    assert_eq!(
        emu.with(|c| c.native().newest_command()),
        Some(Command::StopProgram)
    );
}

#[tokio::test(start_paused = true)]
async fn an_error_raised_mid_stream_ends_it_with_the_code() {
    let emu = emulator();
    let robot = ready(&emu, 100.0).await;
    let handle = robot
        .stream(jt1_ramp(0.0, 30.0, 3.0), StreamOptions::default())
        .await
        .unwrap();
    sleep_ms(800).await;
    emu.with(|c| {
        c.inject(Fault::RaiseError {
            code: "E1130".parse().unwrap(),
        })
    });
    let err = handle.wait().await.unwrap_err();
    assert!(
        matches!(
            err,
            ClientError::Aborted {
                during: "stream",
                ..
            }
        ),
        "{err:?}"
    );
    let text = err.to_string();
    assert!(
        text.contains("E1130") && text.contains("Collision detected"),
        "{text}"
    );
    assert!(text.contains("reset error E1130"), "{text}");
}

#[tokio::test(start_paused = true)]
async fn a_connection_reset_mid_stream_is_a_lost_link() {
    let emu = emulator();
    let robot = ready(&emu, 100.0).await;
    let handle = robot
        .stream(jt1_ramp(0.0, 30.0, 3.0), StreamOptions::default())
        .await
        .unwrap();
    sleep_ms(700).await;
    emu.with(|c| c.inject(Fault::CloseConnection));
    let err = handle.wait().await.unwrap_err();
    assert!(err.is_link_dead(), "{err:?}");
    assert!(
        matches!(
            err,
            ClientError::LinkLost(LinkError::Closed | LinkError::Io { .. })
        ),
        "{err:?}"
    );
    assert!(!robot.is_connected());
}

#[tokio::test(start_paused = true)]
async fn a_slow_controller_mid_stream_is_an_underrun() {
    let emu = emulator();
    let robot = ready(&emu, 100.0).await;
    let handle = robot
        .stream(jt1_ramp(0.0, 30.0, 3.0), StreamOptions::default())
        .await
        .unwrap();
    sleep_ms(500).await;
    emu.with(|c| {
        c.inject(Fault::DelayReplies {
            count: 1,
            delay_ms: 400,
        })
    });
    let err = handle.wait().await.unwrap_err();
    assert!(matches!(err, ClientError::StreamUnderrun { .. }), "{err:?}");
    assert!(robot.stats().stream_underruns >= 1);
    sleep_ms(10).await;
    assert_eq!(
        emu.with(|c| c.native().newest_command()),
        Some(Command::StopProgram)
    );
    assert!(robot.is_connected(), "a late reply is not a lost link");
}

// ------------------------------------------------------------------ reconnect

#[tokio::test(start_paused = true)]
async fn after_an_emulator_restart_reconnect_works_and_motion_is_not_resumed() {
    let emu = emulator();
    let connector = EmuConnector::new(&emu);
    let mut robot = Robot::connect_with(connector.clone(), ClientConfig::default())
        .await
        .unwrap();
    robot.set_speed(10.0).await.unwrap();
    robot.start().await.unwrap();
    let mv = robot.move_joints(with_jt1(60.0)).await.unwrap();
    sleep_ms(500).await;
    // The controller restarts: the connection drops, a fresh controller comes up.
    emu.with(|c| c.inject(Fault::CloseConnection));
    let fresh = emulator();
    connector.swap(&fresh);
    let err = mv.wait(Completion::default()).await.unwrap_err();
    assert!(err.is_link_dead(), "{err:?}");
    assert!(robot.poll().await.unwrap_err().is_link_dead());

    robot.reconnect().await.expect("reconnect");
    assert!(robot.is_connected());
    assert_eq!(robot.stats().reconnects, 1);
    sleep_ms(3000).await;
    // Nothing but polls reached the new controller; its program is not running, nothing moved.
    assert_eq!(effective(&fresh), 0);
    assert_eq!(fresh.with(|c| c.task()), MotionTaskState::NotRunning);
    assert_eq!(fresh.with(|c| c.joints()), home());
    let s = robot.status().status;
    assert!(!s.task_running);
    // The old handle cannot move anything on the new session.
    assert!(mv.cancel().await.unwrap_err().is_link_dead());
    // Motion needs an explicit start again.
    assert_eq!(
        robot.move_joints(with_jt1(5.0)).await.unwrap_err(),
        ClientError::Blocked(vec![Blocker::ProgramNotRunning])
    );
}

// ------------------------------------------------------------------ raw, recording, stats

#[tokio::test(start_paused = true)]
async fn raw_requests_are_sent_as_typed() {
    let emu = emulator();
    let robot = connect(&emu).await;
    let reply = robot.send_raw("0 0 0", false).await.unwrap();
    assert_eq!(reply.status.joints, home());
    assert!(reply.text.starts_with(" 1040 "));
    robot.send_raw("1040 3 1 25", false).await.unwrap();
    assert_eq!(emu.with(|c| c.monitor_speed()), 25.0);
    robot.send_raw("1040 1 0", false).await.unwrap();
    assert_eq!(emu.with(|c| c.task()), MotionTaskState::Running);
    robot
        .send_raw("1040 6 9 0 0 0 1 0 -90 0 -90 0", true)
        .await
        .expect("an allowed, checked motion");
    sleep_ms(3000).await;
    assert!((emu.with(|c| c.joints())[0] - 1.0).abs() < 1e-6);
    robot.send_raw("1040 255 0", false).await.unwrap();
    assert!(!robot.is_connected());
    assert_eq!(robot.link_error(), Some(ClientError::Closed));
}

#[tokio::test(start_paused = true)]
async fn every_request_and_reply_is_recorded() {
    let dir = tempfile::tempdir().unwrap();
    for format in [RecordFormat::Csv, RecordFormat::JsonLines] {
        let path = dir.path().join(format!("{format:?}"));
        let emu = emulator();
        let cfg = ClientConfig {
            record: Some(Recording {
                path: path.clone(),
                format,
            }),
            ..ClientConfig::default()
        };
        let robot = Robot::connect_with(EmuConnector::new(&emu), cfg)
            .await
            .unwrap();
        robot.set_speed(30.0).await.unwrap();
        sleep_ms(1000).await;
        let st = robot.stats();
        robot.close().await.unwrap();
        // The file is written by its own thread: wait until it has every line.
        robot.flush_recording().await.unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        let tx = text.matches("tx").count() as u64;
        let rx = text.matches("rx").count() as u64;
        assert!(
            tx >= st.requests && rx >= st.replies,
            "{tx} {rx} {st:?}\n{text}"
        );
        assert!(text.contains("1040 3 1 30"));
        assert!(text.contains("keepalive"));
        assert!(text.contains("1040 255 0"));
        if format == RecordFormat::JsonLines {
            for line in text.lines() {
                let v: serde_json::Value = serde_json::from_str(line).unwrap();
                assert!(v["t_s"].as_f64().is_some());
            }
        } else {
            assert!(text.starts_with("t_s,session,dir,kind,rtt_ms,text\n"));
        }
    }
}

#[tokio::test(start_paused = true)]
async fn stats_count_round_trips() {
    let emu = emulator();
    let robot = connect(&emu).await;
    for _ in 0..20 {
        robot.poll().await.unwrap();
    }
    let st = robot.stats();
    assert!(st.requests >= 21 && st.replies == st.requests, "{st:?}");
    assert!(st.rtt.count == st.replies);
    assert!(st.rtt.min <= st.rtt.mean && st.rtt.mean <= st.rtt.max);
    assert!(st.rtt.p99 <= st.rtt.max);
    let fit = robot.server_clock().unwrap();
    assert!((fit.rate - 1.0).abs() <= 1e-3);
}

/// A peer that answers like the controller, each reply written as given pieces with a pause
/// between them.
struct Pieces(Vec<&'static str>, Duration);

impl fs020n_client::Connector for Pieces {
    fn connect(&self) -> fs020n_client::ConnectFuture<'_> {
        use tokio::io::{AsyncReadExt, AsyncWriteExt};
        let (pieces, gap) = (self.0.clone(), self.1);
        Box::pin(async move {
            let (client, mut server) = tokio::io::duplex(1024);
            tokio::spawn(async move {
                let mut buf = [0u8; 256];
                while let Ok(n) = server.read(&mut buf).await {
                    if n == 0 {
                        break;
                    }
                    for (k, p) in pieces.iter().enumerate() {
                        if k > 0 {
                            tokio::time::sleep(gap).await;
                        }
                        if server.write_all(p.as_bytes()).await.is_err() {
                            return;
                        }
                    }
                }
            });
            Ok(Box::new(client) as fs020n_client::BoxedStream)
        })
    }
    fn describe(&self) -> String {
        "pieces".into()
    }
}

#[tokio::test(start_paused = true)]
async fn a_reply_without_its_final_blank_is_taken_once_the_peer_is_quiet() {
    let reply = " 1040 0 -1 -1 0 -1 0     1.500     0.000    30.000     0.000     0.000     0.000     0.000";
    let robot = Robot::connect_with(Pieces(vec![reply], Duration::ZERO), ClientConfig::default())
        .await
        .unwrap();
    let started = tokio::time::Instant::now();
    let status = robot.poll().await.unwrap();
    assert_eq!(status.joints[1], 30.0);
    // Taken after the short quiet period, far before the reply deadline.
    assert!(
        started.elapsed() < Duration::from_millis(500),
        "{:?}",
        started.elapsed()
    );
}

#[tokio::test(start_paused = true)]
async fn a_number_that_goes_on_after_ten_characters_is_read_whole() {
    // Cut after a whole /F10.3 field, then one more digit: the value is 0.0001, not 0.000.
    let head = " 1040 0 -1 -1 0 -1 0     1.500     0.000    30.000     0.000     0.000     0.000     0.000";
    let robot = Robot::connect_with(
        Pieces(vec![head, "1 "], Duration::from_millis(5)),
        ClientConfig::default(),
    )
    .await
    .unwrap();
    assert_eq!(robot.poll().await.unwrap().joints[5], 0.0001);
    // And nothing is left over to poison the next exchange.
    assert_eq!(robot.poll().await.unwrap().joints[5], 0.0001);
}

/// The previous session ends while its program runs (mid-move or idle, then 255); a new
/// session connects at once and may find the old program still on its way out (TASK(1) = 3
/// while its last motion finishes: field 7 shows 0, and a command 1 would be refused with
/// P1009). `start` must still start the program, without sending a 1 into the old program's end.
#[tokio::test(start_paused = true)]
async fn start_right_after_a_session_ended_with_the_program_running() {
    let cases = [
        (0u64, true),
        (0, false),
        (10, true),
        (30, true),
        (45, false),
    ];
    for ((delay_ms, moving), interpreted) in cases.iter().flat_map(|&c| [(c, false), (c, true)]) {
        // The native emulator, and the AS text of the server run by the AS interpreter.
        let connector = if interpreted {
            AnyConnector::Program(ProgramConnector(interpreted_emulator()))
        } else {
            AnyConnector::Native(EmuConnector::new(&emulator()))
        };
        sleep_ms(10).await;
        let first = Robot::connect_with(connector.clone(), ClientConfig::default())
            .await
            .unwrap();
        first.set_speed(100.0).await.unwrap();
        first.start().await.unwrap();
        if moving {
            let _mv = first.move_joints(with_jt1(90.0)).await.unwrap();
            sleep_ms(100).await;
        }
        first.close().await.unwrap();
        sleep_ms(delay_ms).await;
        let second = Robot::connect_with(connector.clone(), ClientConfig::default())
            .await
            .unwrap();
        second.start().await.unwrap_or_else(|e| {
            panic!("delay {delay_ms} ms, moving {moving}, interpreted {interpreted}: {e}")
        });
        assert!(second.poll().await.unwrap().task_running);
    }
}

/// A request whose caller's future is dropped while it is on the wire is completed anyway: its
/// reply is read and published, and the next request gets its own reply (lock-step holds).
#[tokio::test(start_paused = true)]
async fn a_request_dropped_on_the_wire_completes_and_the_link_stays_in_step() {
    let emu = emulator();
    let robot = connect(&emu).await;
    let seq = robot.status().seq;
    let effective_before = effective(&emu);
    emu.with(|c| {
        c.inject(Fault::DelayReplies {
            count: 1,
            delay_ms: 300,
        })
    });
    let speed = robot.set_speed(37.0);
    assert!(
        tokio::time::timeout(Duration::from_millis(50), speed)
            .await
            .is_err(),
        "dropped while its reply is delayed"
    );
    // The next request waits for the dropped one's reply, then gets its own.
    let status = robot.poll().await.unwrap();
    assert_eq!(status.joints, home());
    assert_eq!(effective(&emu), effective_before + 1, "the 3 was sent once");
    assert_eq!(emu.with(|c| c.monitor_speed()), 37.0);
    assert!(robot.status().seq >= seq + 2, "both replies were published");
    assert!(robot.is_connected());
}

/// Requests from many tasks at once go out one at a time, each with its own reply.
#[tokio::test(start_paused = true)]
async fn concurrent_requests_stay_in_lock_step() {
    let emu = emulator();
    let robot = std::sync::Arc::new(connect(&emu).await);
    let before = robot.stats().requests;
    let mut tasks = tokio::task::JoinSet::new();
    for k in 0..16 {
        let r = robot.clone();
        tasks.spawn(async move {
            if k % 2 == 0 {
                r.poll().await.map(|_| ())
            } else {
                r.set_speed(f64::from(10 + k)).await.map(|_| ())
            }
        });
    }
    while let Some(r) = tasks.join_next().await {
        r.unwrap().unwrap();
    }
    assert!(robot.stats().requests >= before + 16);
    assert!(robot.is_connected());
    assert!(robot.poll().await.is_ok());
}

/// Samples go out on a fixed schedule: the runtime's timers fire on whole milliseconds, and a
/// period of 4.5 ms must still give 222 samples a second, not 200 (each late timer delaying
/// the ones after it).
#[tokio::test(start_paused = true)]
async fn a_stream_keeps_its_rate_when_timers_fire_late() {
    let emu = emulator();
    let robot = ready(&emu, 100.0).await;
    let period = Duration::from_micros(4500);
    let opts = StreamOptions {
        period,
        max_gap: StreamOptions::default().max_gap.max(period * 2),
        ..StreamOptions::default()
    };
    let report = robot
        .stream(jt1_ramp(0.0, 10.0, 2.0), opts)
        .await
        .unwrap()
        .wait()
        .await
        .unwrap();
    assert_eq!(report.outcome, StreamOutcome::Completed);
    let expected = 2.0 / period.as_secs_f64();
    let sent = report.samples_sent as f64;
    assert!(
        sent >= expected * 0.97 && sent <= expected * 1.03 + 2.0,
        "{sent} samples, {expected:.0} expected"
    );
}
