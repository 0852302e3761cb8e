//! Move and stream handles behave alike (wait and cancel by reference, cancel only while
//! current, dropping the last handle cancels), the one-call move, and waiting out HOLD. On the
//! in-memory emulator, on virtual time.
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

mod common;

use std::time::Duration;

use common::*;
use fs020n_client::{Blocker, Cancellation, ClientError, Completion, StreamOptions, StreamOutcome};
use fs020n_proto::Command;

fn newest(emu: &fs020n_sim::Emulator) -> Option<Command> {
    emu.with(|c| c.native().newest_command())
}

fn jt1(emu: &fs020n_sim::Emulator) -> f64 {
    emu.with(|c| c.joints())[0]
}

/// A hold policy for the tests.
fn waits_out_hold(limit_s: u64) -> Completion {
    Completion {
        hold_timeout: Some(Duration::from_secs(limit_s)),
        ..Completion::default()
    }
}

// ------------------------------------------------------------------ one call

#[tokio::test(start_paused = true)]
async fn move_joints_and_wait_is_one_call() {
    let emu = emulator();
    let robot = ready(&emu, 100.0).await;
    let report = robot
        .move_joints_and_wait(with_jt1(12.0), Completion::default())
        .await
        .expect("the move completes");
    assert!(report.error_deg <= 0.1, "{report:?}");
    assert!((jt1(&emu) - 12.0).abs() < 0.1);
    // A refused target comes back from the same call, with nothing sent.
    let before = effective(&emu);
    let err = robot
        .move_joints_and_wait(with_jt1(500.0), Completion::default())
        .await
        .unwrap_err();
    assert!(matches!(err, ClientError::Limit(_)), "{err:?}");
    assert!(err.refused_before_sending());
    assert_eq!(effective(&emu), before);
}

// ------------------------------------------------------------------ handles alike

#[tokio::test(start_paused = true)]
async fn dropping_the_last_move_handle_cancels_the_move() {
    let emu = emulator();
    let robot = ready(&emu, 10.0).await;
    let mv = robot.move_joints(with_jt1(60.0)).await.unwrap();
    let watcher = mv.clone();
    drop(mv);
    sleep_ms(300).await;
    assert!(
        matches!(newest(&emu), Some(Command::JointMove { .. })),
        "a clone is still held: the move goes on"
    );
    drop(watcher);
    sleep_ms(100).await;
    assert_eq!(
        newest(&emu),
        Some(Command::StopProgram),
        "5, then 2: a sure stop"
    );
    sleep_ms(3000).await;
    let j = jt1(&emu);
    assert!(j > 0.0 && j < 20.0, "stopped part-way: {j}");
}

#[tokio::test(start_paused = true)]
async fn a_finished_or_superseded_move_handle_does_not_cancel_on_drop() {
    let emu = emulator();
    let robot = ready(&emu, 100.0).await;
    let first = robot.move_joints(with_jt1(5.0)).await.unwrap();
    first.wait(Completion::default()).await.unwrap();
    drop(first);
    sleep_ms(100).await;
    assert!(matches!(newest(&emu), Some(Command::JointMove { .. })));
    // Superseded: neither its drop nor its cancel stops the newer move.
    let old = robot.move_joints(with_jt1(-5.0)).await.unwrap();
    let new = robot.move_joints(with_jt1(20.0)).await.unwrap();
    old.cancel().await.expect("a no-op");
    drop(old);
    assert!(matches!(
        wait_default(&new).await,
        Ok(r) if r.error_deg <= 0.1
    ));
    assert!((jt1(&emu) - 20.0).abs() < 0.1);
}

async fn wait_default(
    h: &fs020n_client::MoveHandle,
) -> Result<fs020n_client::MoveReport, ClientError> {
    h.wait(Completion::default()).await
}

#[tokio::test(start_paused = true)]
async fn stream_handles_wait_by_reference_and_share_the_report() {
    let emu = emulator();
    let robot = ready(&emu, 100.0).await;
    let handle = robot
        .stream(jt1_ramp(0.0, 8.0, 1.0), StreamOptions::default())
        .await
        .unwrap();
    let other = handle.clone();
    let (a, b) = tokio::join!(handle.wait(), other.wait());
    let (a, b) = (a.unwrap(), b.unwrap());
    assert_eq!(a, b);
    assert_eq!(a.outcome, StreamOutcome::Completed);
    assert!(handle.is_finished());
    // Cancelling a finished stream does nothing.
    handle.cancel().await.unwrap();
    assert!(matches!(newest(&emu), Some(Command::StreamedMove(_))));
}

#[tokio::test(start_paused = true)]
async fn dropping_the_last_stream_handle_cancels_the_stream() {
    let emu = emulator();
    let robot = ready(&emu, 100.0).await;
    let handle = robot
        .stream(jt1_ramp(0.0, 20.0, 4.0), StreamOptions::default())
        .await
        .unwrap();
    let clone = handle.clone();
    drop(handle);
    sleep_ms(500).await;
    assert!(matches!(newest(&emu), Some(Command::StreamedMove(_))));
    drop(clone);
    sleep_ms(200).await;
    assert_eq!(
        newest(&emu),
        Some(Command::StopProgram),
        "5, then 2: a sure stop"
    );
    let at = jt1(&emu);
    sleep_ms(2000).await;
    assert!((jt1(&emu) - at).abs() < 0.5, "stopped near {at}");
    assert!(jt1(&emu) < 10.0);
}

#[tokio::test(start_paused = true)]
async fn a_cancel_before_sending_is_a_typed_cause() {
    let emu = emulator();
    let robot = ready(&emu, 100.0).await;
    let (mv, _) = tokio::join!(robot.move_joints(with_jt1(10.0)), robot.cancel());
    // Either the move left before the cancel (then it is cancelled), or it was not sent.
    match mv {
        Err(ClientError::Cancelled(Cancellation::NotSent)) => {}
        Ok(h) => assert!(matches!(
            h.wait(Completion::default()).await,
            Err(ClientError::Cancelled(Cancellation::Cancelled))
        )),
        other => panic!("{other:?}"),
    }
}

// ------------------------------------------------------------------ HOLD

#[tokio::test(start_paused = true)]
async fn with_a_hold_timeout_a_move_waits_out_hold_and_completes_on_run() {
    let emu = emulator();
    let robot = ready(&emu, 20.0).await;
    let target = with_jt1(40.0);
    let mv = robot.move_joints(target).await.unwrap();
    let waiting = tokio::spawn({
        let mv = mv.clone();
        async move { mv.wait(waits_out_hold(60)).await }
    });
    sleep_ms(500).await;
    emu.with(|c| c.set_run(false));
    sleep_ms(1500).await;
    assert!(mv.progress().unwrap().held, "{:?}", mv.progress());
    let paused_at = jt1(&emu);
    sleep_ms(2000).await;
    assert!((jt1(&emu) - paused_at).abs() < 1e-6, "paused in HOLD");
    assert!(!waiting.is_finished(), "the wait follows the hold");
    assert!(matches!(newest(&emu), Some(Command::JointMove { .. })));
    emu.with(|c| c.set_run(true));
    let report = waiting.await.unwrap().expect("completes after RUN");
    assert!(report.error_deg <= 0.1);
    assert!(!mv.progress().unwrap().held);
    assert!((jt1(&emu) - 40.0).abs() < 0.1);
}

#[tokio::test(start_paused = true)]
async fn a_hold_longer_than_the_hold_timeout_cancels_the_move() {
    let emu = emulator();
    let robot = ready(&emu, 20.0).await;
    let mv = robot.move_joints(with_jt1(40.0)).await.unwrap();
    sleep_ms(300).await;
    emu.with(|c| c.set_run(false));
    let err = mv.wait(waits_out_hold(2)).await.unwrap_err();
    match &err {
        ClientError::HoldTimeout { during, waited } => {
            assert_eq!(*during, "joint move");
            assert!(*waited >= Duration::from_secs(2), "{waited:?}");
        }
        other => panic!("{other:?}"),
    }
    assert!(err.to_string().contains("switch RUN/HOLD to RUN"), "{err}");
    assert_eq!(
        newest(&emu),
        Some(Command::StopProgram),
        "5, then 2: a sure stop"
    );
    emu.with(|c| c.set_run(true));
    let at = jt1(&emu);
    sleep_ms(3000).await;
    assert!(
        (jt1(&emu) - at).abs() < 0.5,
        "cancelled: it does not resume"
    );
}

#[tokio::test(start_paused = true)]
async fn hold_with_another_blocker_still_aborts() {
    let emu = emulator();
    let robot = ready(&emu, 20.0).await;
    let mv = robot.move_joints(with_jt1(40.0)).await.unwrap();
    sleep_ms(300).await;
    emu.with(|c| {
        c.set_run(false);
        c.set_teach_lock(true);
    });
    let err = mv.wait(waits_out_hold(60)).await.unwrap_err();
    assert!(
        matches!(&err, ClientError::Aborted { blockers, .. } if blockers.contains(&Blocker::TeachLock)),
        "{err:?}"
    );
}

#[tokio::test(start_paused = true)]
async fn with_a_hold_timeout_a_stream_pauses_and_resumes_on_run() {
    let emu = emulator();
    let robot = ready(&emu, 100.0).await;
    let opts = StreamOptions {
        hold_timeout: Some(Duration::from_secs(30)),
        ..StreamOptions::default()
    };
    let handle = robot.stream(jt1_ramp(0.0, 20.0, 4.0), opts).await.unwrap();
    sleep_ms(1500).await;
    emu.with(|c| c.set_run(false));
    sleep_ms(1000).await;
    assert!(handle.progress().held, "{:?}", handle.progress());
    assert_eq!(
        newest(&emu),
        Some(Command::CancelMotion),
        "the stream braked, so RUN does not replay a stale sample"
    );
    let sent = handle.progress().index;
    let paused_at = jt1(&emu);
    sleep_ms(2000).await;
    assert_eq!(handle.progress().index, sent, "no samples while held");
    assert!((jt1(&emu) - paused_at).abs() < 1e-6);
    emu.with(|c| c.set_run(true));
    let report = handle.wait().await.expect("the stream completes");
    assert_eq!(report.outcome, StreamOutcome::Completed);
    assert!(report.settled, "{report:?}");
    assert!((jt1(&emu) - 20.0).abs() < 0.5);
    // Resumed from the trajectory time it paused at: nothing was skipped.
    assert!(report.samples_sent >= 190, "{report:?}");
}

#[tokio::test(start_paused = true)]
async fn without_a_hold_timeout_a_stream_aborts_on_hold() {
    let emu = emulator();
    let robot = ready(&emu, 100.0).await;
    let handle = robot
        .stream(jt1_ramp(0.0, 20.0, 4.0), StreamOptions::default())
        .await
        .unwrap();
    sleep_ms(1000).await;
    emu.with(|c| c.set_run(false));
    let err = handle.wait().await.unwrap_err();
    assert_eq!(
        err,
        ClientError::Aborted {
            during: "stream",
            blockers: vec![Blocker::Hold]
        }
    );
}
