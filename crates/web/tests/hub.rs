//! The hub on virtual time: an in-memory emulator behind it, raw protocol-1040 clients in
//! front of it.
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

mod common;

use std::time::Duration;

use common::*;
use fs020n_kin::RobotModel;
use fs020n_proto::Command;
use fs020n_sim::{Fault, MotionTaskState};
use fs020n_web::hub::{Fence, Refusal};
use fs020n_web::HubConfig;
use tokio::time::Instant;

fn newest(emu: &fs020n_sim::Emulator) -> Option<Command> {
    emu.with(|c| c.native().newest_command())
}

#[tokio::test(start_paused = true)]
async fn a_raw_client_moves_the_arm_through_the_hub() {
    let emu = emulator();
    let hub = hub(&emu, HubConfig::default()).await;
    let mut a = Raw::connect(&hub, "a");
    let before = emu.with(|c| c.counters().effective_requests);
    let r = a.request("1040 3 1 100").await;
    assert_eq!(r.status.version, 1040);
    assert!(
        r.text.starts_with(" 1040 0 -1 -1 0 -1 "),
        "the controller's own reply: {:?}",
        r.text
    );
    let r = a.request("1040 1 0").await;
    assert!(
        r.status.task_running,
        "the reply is the controller's, after command 1"
    );
    a.request(&joint_move([30.0, 0.0, -90.0, 0.0, -90.0, 0.0]))
        .await;
    assert_eq!(hub.controller(), Some(1));
    let t0 = Instant::now();
    loop {
        let r = a.request("0 0 0").await;
        if (r.status.joints[0] - 30.0).abs() < 1e-6 {
            break;
        }
        assert!(
            t0.elapsed() < Duration::from_secs(5),
            "did not arrive: {}",
            r.status.joints
        );
        sleep_ms(50).await;
    }
    assert_eq!(emu.with(|c| c.joints())[0], 30.0);
    // 3, 1, 6 reached the controller, and nothing else acted on it.
    assert_eq!(emu.with(|c| c.counters().effective_requests), before + 3);
    let k = hub.counters();
    assert_eq!(
        k.answered_locally, 0,
        "the controlling client's polls are forwarded"
    );
    assert!(k.forwarded >= 4);
    assert_eq!(emu.with(|c| c.monitor_speed()), 100.0);
}

#[tokio::test(start_paused = true)]
async fn a_second_clients_motion_is_refused_and_its_polls_answered_locally() {
    let emu = emulator();
    let hub = hub(&emu, HubConfig::default()).await;
    let mut a = Raw::connect(&hub, "a");
    let mut b = Raw::connect(&hub, "b");
    a.request("1040 1 0").await;
    assert_eq!(hub.controller(), Some(1));
    let effective = emu.with(|c| c.counters().effective_requests);
    let r = b
        .request(&joint_move([40.0, 0.0, -90.0, 0.0, -90.0, 0.0]))
        .await;
    assert!(r.status.task_running, "answered with the current status");
    assert_eq!(
        newest(&emu),
        Some(Command::StartProgram),
        "the 6 never reached the robot"
    );
    assert_eq!(emu.with(|c| c.counters().effective_requests), effective);
    for _ in 0..5 {
        // A keeps its control alive with polls (1 s of silence would end it).
        sleep_ms(200).await;
        a.request("0 0 0").await;
    }
    assert_eq!(emu.with(|c| c.joints())[0], 0.0, "the arm did not move");
    // Polls from B: from the latest status, not the controller.
    let requests = emu.with(|c| c.counters().requests);
    let keepalives = hub.state().link.keepalive_polls;
    let polls_before = hub.counters().answered_locally;
    for _ in 0..5 {
        let r = b.request("0 0 0").await;
        assert_eq!(r.status.joints, home());
    }
    assert_eq!(hub.counters().answered_locally, polls_before + 5);
    // Only the hub's own keep-alive polls reached the controller meanwhile (one may still be
    // on its way back).
    let reached = emu.with(|c| c.counters().requests) - requests;
    let keepalive = hub.state().link.keepalive_polls - keepalives;
    assert!(
        reached <= keepalive + 1,
        "{reached} requests for {keepalive} keep-alives"
    );
    let k = hub.counters();
    assert_eq!(k.refused_no_control, 1);
    let ev = hub.events();
    let refusal = ev
        .iter()
        .find(|e| e.refusal == Some(Refusal::NoControl))
        .expect("the refusal is logged");
    assert_eq!(refusal.client, Some(2));
    assert!(
        refusal.message.contains("client 1 holds control"),
        "{}",
        refusal.message
    );
    assert!(refusal.request.as_deref().unwrap().starts_with("1040 6 9"));
    // A's motion goes through.
    a.request(&joint_move([10.0, 0.0, -90.0, 0.0, -90.0, 0.0]))
        .await;
    assert!(matches!(newest(&emu), Some(Command::JointMove { .. })));
}

const FENCE: &str = r#"
speed_cap_percent = 50
[joints]
min_deg = [-45, -30, -150, -180, -120, -360]
max_deg = [ 45,  80,  -10,  180,  -10,  360]
[workspace]
min_mm = [ 300, -900,  300]
max_mm = [1500,  900, 1900]
"#;

#[tokio::test(start_paused = true)]
async fn fence_violations_are_refused_with_the_current_status() {
    let emu = emulator();
    let config = HubConfig {
        fence: Some(Fence::from_toml_str(FENCE, &RobotModel::fs020n()).unwrap()),
        ..HubConfig::default()
    };
    let hub = hub(&emu, config).await;
    assert_eq!(
        emu.with(|c| c.monitor_speed()),
        50.0,
        "the cap is set on connect"
    );
    let mut a = Raw::connect(&hub, "a");
    a.request("1040 1 0").await;
    let cases = [
        ("1040 3 1 80".to_owned(), "above the fence's cap of 50 %"),
        (
            joint_move([60.0, 0.0, -90.0, 0.0, -90.0, 0.0]),
            "JT1 target 60.000 deg is outside the fence's range [-45, 45]",
        ),
        (
            joint_move([0.0, 80.0, -150.0, 0.0, -90.0, 0.0]),
            "workspace box",
        ),
        (
            // 100 deg/s on JT1: under the robot's 190, over the cap's 95.
            "1040 7 21 1 2 0 0 0 -90 0 -90 0 100 0 0 0 0 0 0 0 0 0 0 0".to_owned(),
            "velocity",
        ),
    ];
    for (text, why) in &cases {
        let effective = emu.with(|c| c.counters().effective_requests);
        let r = a.request(text).await;
        assert_eq!(r.status.joints, home(), "answered with the status");
        assert_eq!(
            emu.with(|c| c.counters().effective_requests),
            effective,
            "{text} was not forwarded"
        );
        let ev = hub.events();
        let last = ev.last().unwrap();
        assert_eq!(last.refusal, Some(Refusal::Fence), "{last:?}");
        assert!(last.message.contains(why), "{text}: {}", last.message);
    }
    assert_eq!(hub.counters().refused_fence, 4);
    assert_eq!(emu.with(|c| c.monitor_speed()), 50.0);
    // Inside the fence: forwarded, and the arm moves.
    a.request(&joint_move([20.0, 0.0, -90.0, 0.0, -90.0, 0.0]))
        .await;
    sleep_ms(3000).await;
    assert!((emu.with(|c| c.joints())[0] - 20.0).abs() < 1e-9);
}

#[tokio::test(start_paused = true)]
async fn incomplete_and_unchecked_requests_are_refused() {
    let emu = emulator();
    let hub = hub(&emu, HubConfig::default()).await;
    let mut a = Raw::connect(&hub, "a");
    a.request("1040 1 0").await;
    // COUNT 6: the controller would move JT4..JT6 to stale arguments.
    a.request("1040 6 6 0 0 0 10 0 -90").await;
    assert_eq!(
        hub.events().last().unwrap().refusal,
        Some(Refusal::Incomplete)
    );
    a.request("1040 7 9 0 0 0 0 0 -90 0 -90 0").await;
    assert_eq!(
        hub.events().last().unwrap().refusal,
        Some(Refusal::Incomplete)
    );
    // Outside the robot's own range: the client library's check.
    a.request(&joint_move([170.0, 0.0, -90.0, 0.0, -90.0, 0.0]))
        .await;
    let last = hub.events().last().cloned().unwrap();
    assert_eq!(last.refusal, Some(Refusal::Checks));
    assert!(last.message.contains("JT1"), "{}", last.message);
    a.request("1040 3 1 0").await;
    assert_eq!(hub.events().last().unwrap().refusal, Some(Refusal::Checks));
    assert_eq!(newest(&emu), Some(Command::StartProgram));
    let k = hub.counters();
    assert_eq!((k.refused_incomplete, k.refused_checks), (2, 2));
    // A trailing line end changes nothing: forwarded.
    a.request("1040 5 0\r\n").await;
    assert_eq!(newest(&emu), Some(Command::CancelMotion));
}

/// Starts a long JT1 move at 30 % through client `a` and lets it run half a second.
async fn moving(hub: &fs020n_web::Hub, emu: &fs020n_sim::Emulator) -> Raw {
    let mut a = Raw::connect(hub, "a");
    a.request("1040 3 1 30").await;
    a.request("1040 1 0").await;
    a.request(&joint_move([150.0, 0.0, -90.0, 0.0, -90.0, 0.0]))
        .await;
    for _ in 0..5 {
        sleep_ms(100).await;
        a.request("0 0 0").await;
    }
    assert!(speed_norm(&emu.with(|c| c.velocity())) > 40.0, "moving");
    a
}

/// Virtual time from now until the arm stands still.
async fn time_to_standstill(emu: &fs020n_sim::Emulator) -> Duration {
    let t0 = Instant::now();
    loop {
        if speed_norm(&emu.with(|c| c.velocity())) == 0.0 {
            return t0.elapsed();
        }
        assert!(
            t0.elapsed() < Duration::from_secs(5),
            "the arm never stopped"
        );
        sleep_ms(2).await;
    }
}

#[tokio::test(start_paused = true)]
async fn a_killed_controlling_client_stops_the_arm_within_half_a_second() {
    let emu = emulator();
    let hub = hub(&emu, HubConfig::default()).await;
    let a = moving(&hub, &emu).await;
    let session = emu.with(|c| c.native().session());
    drop(a); // the process dies: its connection closes
    let t = time_to_standstill(&emu).await;
    assert!(t <= Duration::from_millis(500), "stopped after {t:?}");
    assert_eq!(newest(&emu), Some(Command::StopProgram), "by command 2");
    assert_eq!(emu.with(|c| c.task()), MotionTaskState::NotRunning);
    assert_eq!(
        emu.with(|c| c.native().session()),
        session,
        "the hub's session goes on"
    );
    assert!(emu.with(|c| c.joints())[0] < 100.0);
    assert_eq!(hub.controller(), None);
    assert_eq!(hub.counters().stops_on_client_end, 1);
    let stop = hub.events().into_iter().find(|e| e.kind == "stop").unwrap();
    assert!(stop.message.contains("disconnected"), "{}", stop.message);
}

#[tokio::test(start_paused = true)]
async fn a_silent_controlling_client_is_stopped_after_the_silence_limit() {
    let emu = emulator();
    let hub = hub(&emu, HubConfig::default()).await;
    let mut a = moving(&hub, &emu).await;
    let t0 = Instant::now();
    // The client hangs: it sends nothing more (its connection stays open).
    let t = time_to_standstill(&emu).await;
    assert!(
        t >= Duration::from_millis(1000),
        "not before the 1 s limit: {t:?}"
    );
    assert!(
        t <= Duration::from_millis(1500),
        "stopped {t:?} after the last request"
    );
    assert_eq!(newest(&emu), Some(Command::StopProgram));
    assert!(a.closed().await, "its connection is closed");
    assert!(
        t0.elapsed() < Duration::from_secs(5),
        "long before the controller's 5 s"
    );
    let stop = hub.events().into_iter().find(|e| e.kind == "stop").unwrap();
    assert!(stop.message.contains("sent nothing"), "{}", stop.message);
}

#[tokio::test(start_paused = true)]
async fn end_command_stops_releases_control_and_keeps_the_session() {
    let emu = emulator();
    let hub = hub(&emu, HubConfig::default()).await;
    let mut a = Raw::connect(&hub, "a");
    a.request("1040 1 0").await;
    let session = emu.with(|c| c.native().session());
    let r = a.request("1040 255 0").await;
    assert_eq!(
        r.status.version, 1040,
        "255 is answered, as by the controller"
    );
    assert!(a.closed().await);
    // Signal 2007 ends the program once it has been stable for 50 ms.
    sleep_ms(100).await;
    assert_eq!(emu.with(|c| c.task()), MotionTaskState::NotRunning);
    assert_eq!(
        emu.with(|c| c.native().session()),
        session,
        "255 was not forwarded"
    );
    assert_eq!(newest(&emu), Some(Command::StopProgram));
    assert_eq!(hub.controller(), None);
    // Another client may take control now.
    let mut b = Raw::connect(&hub, "b");
    let r = b.request("1040 1 0").await;
    assert!(r.status.task_running);
    assert_eq!(hub.controller(), Some(2));
}

#[tokio::test(start_paused = true)]
async fn the_page_buttons_stop_and_cancel_whoever_holds_control() {
    let emu = emulator();
    let hub = hub(&emu, HubConfig::default()).await;
    let _a = moving(&hub, &emu).await;
    hub.cancel_motion("page").await.unwrap();
    assert_eq!(newest(&emu), Some(Command::CancelMotion));
    assert!(time_to_standstill(&emu).await <= Duration::from_millis(500));
    assert_eq!(
        emu.with(|c| c.task()),
        MotionTaskState::Running,
        "5 keeps the program"
    );
    hub.stop_robot("page").await.unwrap();
    sleep_ms(100).await;
    assert_eq!(emu.with(|c| c.task()), MotionTaskState::NotRunning);
    let kinds: Vec<_> = hub.events().iter().map(|e| e.kind).collect();
    assert!(
        kinds.contains(&"cancel") && kinds.contains(&"stop"),
        "{kinds:?}"
    );
}

#[tokio::test(start_paused = true)]
async fn a_lost_controller_session_closes_the_clients_and_is_reopened() {
    let emu = emulator();
    let hub = hub(&emu, HubConfig::default()).await;
    let mut a = Raw::connect(&hub, "a");
    a.request("1040 1 0").await;
    emu.with(|c| c.inject(Fault::CloseConnection));
    assert!(a.closed().await, "clients are closed with the session");
    let t0 = Instant::now();
    while !hub.is_connected() {
        assert!(t0.elapsed() < Duration::from_secs(10), "never reconnected");
        sleep_ms(50).await;
    }
    let st = hub.state();
    assert!(st.link.connected);
    assert_eq!(st.counters.links_lost, 1);
    assert_eq!(st.controller, None);
    let mut b = Raw::connect(&hub, "b");
    let r = b.request("0 0 0").await;
    assert!(!r.status.task_running, "a new session: nothing resumed");
    assert_eq!(emu.with(|c| c.counters().sessions), 2);
}

#[tokio::test(start_paused = true)]
async fn the_state_shows_what_the_page_needs() {
    let emu = emulator();
    let hub = hub(&emu, HubConfig::default()).await;
    let mut a = Raw::connect(&hub, "a");
    a.request("1040 1 0").await;
    a.request(&joint_move([5.0, 0.0, -90.0, 0.0, -90.0, 0.0]))
        .await;
    let st = hub.state();
    let s = st.status.as_ref().unwrap();
    assert!(s.power && s.run && s.repeat && !s.teach_lock && s.task_running);
    assert_eq!(st.target_deg.unwrap()[0], 5.0);
    assert_eq!(st.controller, Some(1));
    assert_eq!(st.clients.len(), 1);
    assert!(st.clients[0].controlling);
    let tool = st.tool.unwrap();
    assert!((tool.z_mm - 1153.5).abs() < 1.0);
    let v = serde_json::to_value(&st).unwrap();
    assert!(v["events"].as_array().unwrap().len() >= 2);
    assert_eq!(v["link"]["connected"], true);
}
