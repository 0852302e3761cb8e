//! Real loopback TCP against the emulator's TCP server (real time, kept short), for the async
//! and the blocking API.

use std::time::Duration;

use fs020n_client::{blocking, ClientConfig, ClientError, Completion, Robot, StreamOptions};
use fs020n_client::{Trajectory, TrajectoryPoint};
use fs020n_proto::JointsDeg;
use fs020n_sim::{ControllerConfig, Emulator, MotionTaskState, SessionEnd};

fn home() -> JointsDeg {
    JointsDeg::new([0.0, 0.0, -90.0, 0.0, -90.0, 0.0])
}

fn with_jt1(d: f64) -> JointsDeg {
    let mut j = home();
    j[0] = d;
    j
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn loopback_round_trips_and_a_move() {
    let emu = Emulator::new(ControllerConfig::default());
    let server = emu.serve_tcp("127.0.0.1:0".parse().unwrap()).await.unwrap();
    let addr = server.local_addr().to_string();
    let robot = Robot::connect(&addr, ClientConfig::default())
        .await
        .unwrap();
    for _ in 0..200 {
        let s = robot.poll().await.unwrap();
        assert_eq!(s.joints, home());
    }
    let st = robot.stats();
    assert!(st.rtt.count >= 201, "{st:?}");
    assert!(st.rtt.p99 < Duration::from_millis(50), "{st:?}");
    // A second client is refused while this one holds the session.
    let cfg = ClientConfig {
        connect_timeout: Duration::from_millis(300),
        ..ClientConfig::default()
    };
    assert!(matches!(
        Robot::connect(&addr, cfg).await,
        Err(ClientError::Connect { .. })
    ));
    robot.set_speed(100.0).await.unwrap();
    robot.start().await.unwrap();
    let target = with_jt1(2.0);
    robot
        .move_joints(target)
        .await
        .unwrap()
        .wait(Completion::default())
        .await
        .unwrap();
    assert!(emu.with(|c| c.joints()).max_abs_diff(&target) < 0.01);
    robot.close().await.unwrap();
    assert_eq!(
        emu.with(|c| c.native().last_session_end()).map(|e| e.1),
        Some(SessionEnd::EndCommand)
    );
    server.stop();
}

/// An emulator served over TCP from its own thread and runtime (real time).
struct Served {
    emu: Emulator,
    addr: String,
    stop: Option<tokio::sync::oneshot::Sender<()>>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Served {
    fn start() -> Served {
        let (tx, rx) = std::sync::mpsc::channel();
        let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
        let thread = std::thread::spawn(move || {
            let rt = tokio::runtime::Runtime::new().unwrap();
            rt.block_on(async move {
                let emu = Emulator::new(ControllerConfig::default());
                let server = emu.serve_tcp("127.0.0.1:0".parse().unwrap()).await.unwrap();
                tx.send((emu.clone(), server.local_addr().to_string()))
                    .unwrap();
                let _ = stopped.await;
                server.stop();
            });
        });
        let (emu, addr) = rx.recv().unwrap();
        Served {
            emu,
            addr,
            stop: Some(stop),
            thread: Some(thread),
        }
    }
}

impl Drop for Served {
    fn drop(&mut self) {
        if let Some(s) = self.stop.take() {
            let _ = s.send(());
        }
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

#[test]
fn the_blocking_api_over_loopback() {
    let served = Served::start();
    let robot = blocking::Robot::connect(&served.addr, ClientConfig::default()).unwrap();
    assert_eq!(robot.poll().unwrap().joints, home());
    robot.preflight().unwrap();
    robot.set_speed(100.0).unwrap();
    robot.start().unwrap();
    assert_eq!(served.emu.with(|c| c.task()), MotionTaskState::Running);
    let mv = robot.move_joints(with_jt1(-2.0)).unwrap();
    let report = mv.wait(Completion::default()).unwrap();
    assert!(report.error_deg <= 0.1);
    let points = (0..=10)
        .map(|k| TrajectoryPoint::new(k as f64 * 0.05, with_jt1(-2.0 + 0.2 * k as f64)))
        .collect();
    let report = robot
        .stream(Trajectory::new(points).unwrap(), StreamOptions::default())
        .unwrap()
        .wait()
        .unwrap();
    assert!(report.samples_sent >= 10, "{report:?}");
    assert!(report.settled, "{report:?}");
    // The session stays alive while the caller does something else.
    std::thread::sleep(Duration::from_millis(300));
    let age = robot.status().age();
    assert!(age < Duration::from_millis(250), "{age:?}");
    assert!(robot.stats().keepalive_polls >= 1);
    let err = robot.move_joints(with_jt1(500.0)).unwrap_err();
    assert!(matches!(err, ClientError::Limit(_)));
    // Dropping the blocking handle ends the session with 255 at once.
    drop(robot);
    assert_eq!(
        served
            .emu
            .with(|c| c.native().last_session_end())
            .map(|e| e.1),
        Some(SessionEnd::EndCommand)
    );
}

#[test]
fn the_blocking_robot_inside_an_async_runtime_refuses_and_still_closes_on_drop() {
    let served = Served::start();
    let robot = blocking::Robot::connect(&served.addr, ClientConfig::default()).unwrap();
    robot.set_speed(100.0).unwrap();
    robot.start().unwrap();
    let mv = robot.move_joints(with_jt1(1.0)).unwrap();
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap();
    let addr = served.addr.clone();
    rt.block_on(async move {
        // Blocking calls inside a runtime are refused with a typed error instead of panicking.
        let err = blocking::Robot::connect(&addr, ClientConfig::default()).unwrap_err();
        assert!(matches!(err, ClientError::InsideAsyncRuntime), "{err:?}");
        assert!(err.to_string().contains("async"), "{err}");
        assert!(matches!(robot.poll(), Err(ClientError::InsideAsyncRuntime)));
        assert!(matches!(
            mv.wait(Completion::default()),
            Err(ClientError::InsideAsyncRuntime)
        ));
        // Dropping the robot here neither panics nor leaves the session open: 255 is sent.
        drop(robot);
        // The last handle on the client's runtime goes too, still without a panic.
        drop(mv);
    });
    assert_eq!(
        served
            .emu
            .with(|c| c.native().last_session_end())
            .map(|e| e.1),
        Some(SessionEnd::EndCommand)
    );
    // The program ends once signal 2007 has been stable for 50 ms.
    let mut waited = 0;
    while served.emu.with(|c| c.task()) != MotionTaskState::NotRunning {
        assert!(waited < 200, "the program did not end");
        std::thread::sleep(std::time::Duration::from_millis(10));
        waited += 1;
    }
}
