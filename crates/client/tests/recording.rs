//! Recordings of real sessions with the emulator, read back with the `mcap` crate's reader; a
//! stalled disk (a FIFO nobody reads) that must not delay any request.
// Without the `mcap` feature only the CSV tests run.
#![cfg_attr(not(feature = "mcap"), allow(unused_imports, dead_code))]
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

mod common;

use std::collections::{BTreeMap, HashMap};
use std::sync::mpsc;
use std::time::Duration;

use common::{emulator, home, jt1_ramp, sleep_ms, with_jt1, EmuConnector};
use fs020n_client::record_format::{
    EventMessage, ExchangeMessage, JointStateMessage, RecordingInfo, StatusMessage, JOINT_NAMES,
    TOPIC_COMMANDED, TOPIC_EVENT, TOPIC_EXCHANGE, TOPIC_JOINT_STATES, TOPIC_STATUS,
};
use fs020n_client::{
    ClientConfig, Completion, RecordFormat, Recording, Robot, StreamOptions, RECORD_QUEUE_LINES,
};

/// Every message of a file, by topic: (log time, data).
fn messages(bytes: &[u8]) -> BTreeMap<String, Vec<(u64, Vec<u8>)>> {
    let mut out: BTreeMap<String, Vec<(u64, Vec<u8>)>> = BTreeMap::new();
    for m in mcap::MessageStream::new(bytes).expect("an MCAP file") {
        let m = m.expect("a complete message");
        out.entry(m.channel.topic.clone())
            .or_default()
            .push((m.log_time, m.data.into_owned()));
    }
    out
}

async fn record_a_run(path: &std::path::Path) -> (Robot, fs020n_sim::Emulator) {
    let emu = emulator();
    let cfg = ClientConfig {
        record: Some(Recording::new(path)),
        ..ClientConfig::default()
    };
    let robot = Robot::connect_with(EmuConnector::new(&emu), cfg)
        .await
        .unwrap();
    robot.set_speed(100.0).await.unwrap();
    robot.start().await.unwrap();
    let h = robot.move_joints(with_jt1(10.0)).await.unwrap();
    h.wait(Completion::default()).await.unwrap();
    let s = robot
        .stream(jt1_ramp(10.0, 0.0, 1.0), StreamOptions::default())
        .await
        .unwrap();
    s.wait().await.unwrap();
    sleep_ms(500).await;
    (robot, emu)
}

#[cfg(feature = "mcap")]
#[tokio::test(start_paused = true)]
async fn an_mcap_recording_has_ros2_joint_states_and_json_topics() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("run.mcap");
    let (robot, emu) = record_a_run(&path).await;
    robot.close().await.unwrap();
    let stats = robot.stats();
    drop(robot);
    drop(emu);
    // The session task ends after the close; the last owner of the recording finishes the file.
    sleep_ms(10).await;
    let bytes = std::fs::read(&path).unwrap();

    // A clean end writes the summary: schemas, channels, statistics.
    let summary = mcap::Summary::read(&bytes).unwrap().expect("a summary");
    let topics: HashMap<&str, (&str, &str, &str)> = summary
        .channels
        .values()
        .map(|c| {
            let s = c.schema.as_ref().expect("every channel has a schema");
            (
                c.topic.as_str(),
                (
                    s.name.as_str(),
                    s.encoding.as_str(),
                    c.message_encoding.as_str(),
                ),
            )
        })
        .collect();
    let ros = ("sensor_msgs/msg/JointState", "ros2msg", "cdr");
    assert_eq!(topics[TOPIC_JOINT_STATES], ros);
    assert_eq!(topics[TOPIC_COMMANDED], ros);
    assert_eq!(
        topics[TOPIC_STATUS],
        ("fs020n/Status", "jsonschema", "json")
    );
    assert_eq!(topics[TOPIC_EXCHANGE].1, "jsonschema");
    assert_eq!(topics[TOPIC_EVENT].1, "jsonschema");
    let stat = summary.stats.as_ref().expect("statistics");
    assert!(stat.chunk_count >= 1);

    let all = messages(&bytes);
    let states = &all[TOPIC_JOINT_STATES];
    // One joint state per reply.
    assert_eq!(states.len() as u64, stats.replies, "{stats:?}");
    let mut last = 0;
    let mut max_jt1 = f64::MIN;
    for (log_time, data) in states {
        let m = JointStateMessage::decode_cdr(data).unwrap();
        assert_eq!(m.stamp_ns, *log_time, "stamped with the receive time");
        assert!(*log_time >= last);
        last = *log_time;
        assert_eq!(m.name, JOINT_NAMES);
        assert_eq!(m.position.len(), 6);
        max_jt1 = max_jt1.max(m.position[0]);
        // Radians: JT3 stays near -90 degrees (the streamed moves are straight lines of the
        // flange, so the other joints move a little).
        assert!(
            (m.position[2] + std::f64::consts::FRAC_PI_2).abs() < 1f64.to_radians(),
            "{:?}",
            m.position
        );
    }
    assert!((max_jt1 - 10f64.to_radians()).abs() < 1e-3, "{max_jt1}");

    // Commanded: the command-6 target first, then command-7 samples with velocities.
    let commanded: Vec<JointStateMessage> = all[TOPIC_COMMANDED]
        .iter()
        .map(|(_, d)| JointStateMessage::decode_cdr(d).unwrap())
        .collect();
    assert!((commanded[0].position[0] - 10f64.to_radians()).abs() < 1e-9);
    assert!(commanded[0].velocity.is_empty());
    assert!(commanded.len() > 10);
    assert!(commanded[1..].iter().all(|m| m.velocity.len() == 6));

    let status: Vec<StatusMessage> = all[TOPIC_STATUS]
        .iter()
        .map(|(_, d)| serde_json::from_slice(d).unwrap())
        .collect();
    assert_eq!(status.len(), states.len());
    assert!(status.iter().all(|s| s.session == 1 && s.power && s.run));
    assert!(status.iter().any(|s| s.program_running));
    assert!(status.iter().all(|s| s.timer_s.is_some()));

    let exchanges: Vec<ExchangeMessage> = all[TOPIC_EXCHANGE]
        .iter()
        .map(|(_, d)| serde_json::from_slice(d).unwrap())
        .collect();
    assert_eq!(exchanges.len() as u64, stats.requests);
    assert!(exchanges
        .iter()
        .all(|e| e.reply.is_some() && e.rtt_ms.is_some()));
    assert!(exchanges.iter().any(|e| e.request == "1040 3 1 100"));
    assert!(exchanges.iter().any(|e| e.kind == "keepalive"));
    assert_eq!(exchanges.last().unwrap().request, "1040 255 0");

    let events: Vec<EventMessage> = all[TOPIC_EVENT]
        .iter()
        .map(|(_, d)| serde_json::from_slice(d).unwrap())
        .collect();
    let names: Vec<&str> = events.iter().map(|e| e.event.as_str()).collect();
    assert_eq!(names, ["start", "connect", "end"]);
    let info: RecordingInfo = serde_json::from_str(&events[0].text).unwrap();
    assert_eq!(info.late_reply_after_ms, 100.0);
    assert!(info.started_utc.ends_with('Z'));
}

/// What is on disk while the recorder runs is what a killed process leaves: it must be a
/// complete MCAP file (end magic included) with every chunk closed so far.
#[cfg(feature = "mcap")]
#[tokio::test(start_paused = true)]
async fn the_file_on_disk_is_a_complete_mcap_file_at_every_flush() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("run.mcap");
    let (robot, _emu) = record_a_run(&path).await;
    // (Keep-alive polls may add replies while the flush is awaited on virtual time.)
    let replies = robot.stats().replies;
    robot.flush_recording().await.unwrap();
    let snapshot = std::fs::read(&path).unwrap();
    assert_eq!(&snapshot[snapshot.len() - 8..], b"\x89MCAP0\r\n");
    // No summary yet: readers read it from the start.
    assert!(mcap::Summary::read(&snapshot).unwrap().is_none());
    let first = messages(&snapshot);
    let states_then = first[TOPIC_JOINT_STATES].len();
    assert!(states_then as u64 >= replies, "{states_then} {replies}");

    // More traffic, another flush: the provisional end is overwritten, nothing is lost.
    for _ in 0..20 {
        robot.poll().await.unwrap();
    }
    robot.flush_recording().await.unwrap();
    let later = messages(&std::fs::read(&path).unwrap());
    assert!(later[TOPIC_JOINT_STATES].len() >= states_then + 20);
    assert_eq!(
        later[TOPIC_JOINT_STATES][..states_then],
        first[TOPIC_JOINT_STATES][..]
    );
    drop(robot);
}

#[cfg(feature = "mcap")]
#[tokio::test(start_paused = true)]
async fn the_format_follows_the_extension() {
    let dir = tempfile::tempdir().unwrap();
    for (name, check) in [
        ("a.csv", "t_s,session,dir,kind,rtt_ms,text\n"),
        ("a.jsonl", "{\"dir\":\"event\""),
        ("a.mcap", "\u{89}MCAP0\r\n"),
    ] {
        let path = dir.path().join(name);
        let emu = emulator();
        let cfg = ClientConfig {
            record: Some(Recording::new(&path)),
            ..ClientConfig::default()
        };
        let robot = Robot::connect_with(EmuConnector::new(&emu), cfg)
            .await
            .unwrap();
        robot.poll().await.unwrap();
        robot.close().await.unwrap();
        robot.flush_recording().await.unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let start = String::from_utf8_lossy(&bytes[..check.len().min(bytes.len())]).into_owned();
        if name.ends_with(".mcap") {
            assert_eq!(&bytes[..8], b"\x89MCAP0\r\n");
            assert_eq!(Recording::new(&path).format, RecordFormat::Mcap);
        } else {
            assert_eq!(start, check, "{name}");
        }
    }
}

/// A FIFO that nobody reads stands for a disk that stopped answering: the writer thread blocks
/// on it, the session does not. Run on its own thread so that a blocked session fails the test
/// instead of hanging it.
#[cfg(unix)]
#[test]
fn a_stalled_disk_delays_no_request_and_loses_nothing_it_can_queue() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("stalled.csv");
    let made = std::process::Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .expect("mkfifo");
    assert!(made.success());

    // The reader opens the FIFO (so that the recorder's open succeeds), then reads nothing
    // until told to.
    let (go, go_rx) = mpsc::channel::<()>();
    let (text_tx, text_rx) = mpsc::channel::<String>();
    let reader_path = fifo.clone();
    std::thread::spawn(move || {
        use std::io::Read;
        let mut f = std::fs::File::open(&reader_path).expect("open the FIFO");
        let _ = go_rx.recv();
        let mut text = String::new();
        let _ = f.read_to_string(&mut text);
        let _ = text_tx.send(text);
    });

    const POLLS: usize = 3000;
    let (result_tx, result_rx) = mpsc::channel();
    let session_path = fifo.clone();
    std::thread::spawn(move || {
        let rt = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .start_paused(true)
            .build()
            .unwrap();
        rt.block_on(async move {
            let emu = emulator();
            let cfg = ClientConfig {
                record: Some(Recording {
                    path: session_path,
                    format: RecordFormat::Csv,
                }),
                ..ClientConfig::default()
            };
            let robot = Robot::connect_with(EmuConnector::new(&emu), cfg)
                .await
                .unwrap();
            let mut slowest = Duration::ZERO;
            for _ in 0..POLLS {
                let t = tokio::time::Instant::now();
                robot.poll().await.unwrap();
                slowest = slowest.max(t.elapsed());
            }
            let stats = robot.stats();
            // Everything done: now the disk answers again.
            let _ = result_tx.send((slowest, stats));
            let _ = go.send(());
            robot.close().await.unwrap();
            robot.flush_recording().await.unwrap();
        });
    });

    let (slowest, stats) = result_rx
        .recv_timeout(Duration::from_secs(120))
        .expect("the session went on while the disk was stalled");
    assert!(slowest < Duration::from_millis(10), "{slowest:?}");
    assert_eq!(stats.record_errors, 0, "{stats:?}");
    const { assert!(POLLS * 2 < RECORD_QUEUE_LINES) };
    let text = text_rx
        .recv_timeout(Duration::from_secs(120))
        .expect("the recording was written once the disk answered");
    // More than a pipe's buffer was queued while the disk was stalled, and all of it arrived.
    assert!(text.len() > 64 * 1024, "{}", text.len());
    let polls = text
        .lines()
        .filter(|l| l.ends_with(",tx,poll,,\"0 0 0\""))
        .count();
    assert_eq!(polls, POLLS + 1, "the connect poll and every poll");
    assert!(text.contains("\"1040 255 0\""));
}

#[cfg(feature = "mcap")]
#[tokio::test(start_paused = true)]
async fn recording_continues_across_a_reconnect_with_a_new_session_number() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("two.mcap");
    let emu = emulator();
    let cfg = ClientConfig {
        record: Some(Recording::new(&path)),
        ..ClientConfig::default()
    };
    let mut robot = Robot::connect_with(EmuConnector::new(&emu), cfg)
        .await
        .unwrap();
    robot.poll().await.unwrap();
    robot.close().await.unwrap();
    robot.reconnect().await.unwrap();
    assert_eq!(robot.poll().await.unwrap().joints, home());
    robot.close().await.unwrap();
    drop(robot);
    sleep_ms(10).await;
    let all = messages(&std::fs::read(&path).unwrap());
    let sessions: Vec<u64> = all[TOPIC_STATUS]
        .iter()
        .map(|(_, d)| serde_json::from_slice::<StatusMessage>(d).unwrap().session)
        .collect();
    assert_eq!(sessions.first(), Some(&1));
    assert_eq!(sessions.last(), Some(&2));
    let ends = all[TOPIC_EVENT]
        .iter()
        .filter(|(_, d)| serde_json::from_slice::<EventMessage>(d).unwrap().event == "end")
        .count();
    assert_eq!(ends, 2);
}
