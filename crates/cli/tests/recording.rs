//! `--record`, `record FILE.mcap`, `plot`, `replay` and `demo --plot` through the binary,
//! against `fs020n sim` in a child process (loopback) or the embedded emulator.
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

use std::path::Path;
use std::process::{Command as StdCommand, Stdio};
use std::time::{Duration, Instant};

use assert_cmd::Command;
use serde_json::Value;

mod common;
use common::Sim;

fn fs020n() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_fs020n"));
    c.env_remove("FS020N_ROBOT");
    c
}

fn ok(out: &std::process::Output) -> String {
    assert!(
        out.status.success(),
        "{:?}\nstdout: {}\nstderr: {}",
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// Panel captions of an SVG drawn by `fs020n plot` (plotters writes each text on its own line).
fn panels(svg: &str) -> (usize, usize, usize) {
    let count = |p: &str| svg.lines().filter(|l| l.starts_with(p)).count();
    (
        count("joint "),
        count("tracking error"),
        count("round trip (ms):"),
    )
}

fn png_size(path: &Path) -> (u32, u32, usize) {
    let bytes = std::fs::read(path).unwrap();
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
    let w = u32::from_be_bytes(bytes[16..20].try_into().unwrap());
    let h = u32::from_be_bytes(bytes[20..24].try_into().unwrap());
    (w, h, bytes.len())
}

#[test]
fn a_recorded_move_plots_and_replays() {
    let sim = Sim::start(&[]);
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("move.mcap");
    let rec_s = rec.to_str().unwrap();
    ok(&sim
        .cmd()
        .args(["--record", rec_s, "move", "10", "0", "-80", "0", "-90", "0"])
        .args(["--speed", "100", "--wait"])
        .output()
        .unwrap());
    assert_eq!(&std::fs::read(&rec).unwrap()[..8], b"\x89MCAP0\r\n");

    let svg = dir.path().join("move.svg");
    let out = ok(&fs020n()
        .args(["--json", "plot", rec_s, "-o", svg.to_str().unwrap()])
        .output()
        .unwrap());
    let v: Value = serde_json::from_str(&out).unwrap();
    assert_eq!(v["summary"]["panels"], 8);
    let text = std::fs::read_to_string(&svg).unwrap();
    assert_eq!(panels(&text), (6, 1, 1));
    assert!(text.contains(&sim.addr), "the title names the robot");

    let png = dir.path().join("zoom.png");
    ok(&fs020n()
        .args(["plot", rec_s, "-o", png.to_str().unwrap()])
        .args(["--joints", "1,3", "--from", "0.2", "--width", "900"])
        .output()
        .unwrap());
    let (w, h, len) = png_size(&png);
    assert_eq!((w, h), (900, 64 + 280 + 320));
    assert!(len > 10_000, "a picture, not a blank page: {len} bytes");

    // Replay on the embedded emulator, which starts where the recording starts.
    let out = ok(&fs020n()
        .args(["replay", rec_s, "--monitor-speed", "10"])
        .output()
        .unwrap());
    assert!(out.contains("no divergence"), "{out}");
}

#[test]
fn replay_finds_an_injected_divergence() {
    let sim = Sim::start(&[]);
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("idle.jsonl");
    let rec_s = rec.to_str().unwrap();
    let out = ok(&sim
        .cmd()
        .args(["--json", "record", rec_s, "--rate", "20", "--duration", "1"])
        .output()
        .unwrap());
    let v: Value = serde_json::from_str(&out).unwrap();
    assert!(v["polls"].as_u64().unwrap() >= 10, "{v}");

    let clean = ok(&fs020n().args(["--json", "replay", rec_s]).output().unwrap());
    let report: Value = serde_json::from_str(&clean).unwrap();
    assert_eq!(report["report"]["divergent"], 0, "{report}");
    assert!(report["report"]["compared"].as_u64().unwrap() >= 10);

    // One recorded reply now says the controller had E1088 and the arm was elsewhere.
    let text = std::fs::read_to_string(&rec).unwrap();
    let mut lines: Vec<Value> = text
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    let rx: Vec<usize> = (0..lines.len())
        .filter(|&i| lines[i]["dir"] == "rx")
        .collect();
    let i = rx[rx.len() / 2];
    let reply = lines[i]["text"].as_str().unwrap().to_owned();
    let mut fields: Vec<String> = reply.split_whitespace().map(str::to_owned).collect();
    fields[1] = "-31088".into();
    fields[9] = "12.000".into();
    lines[i]["text"] = Value::String(format!(" {} ", fields.join(" ")));
    let edited: String = lines.iter().map(|l| format!("{l}\n")).collect();
    std::fs::write(&rec, edited).unwrap();

    let out = fs020n().args(["replay", rec_s]).output().unwrap();
    assert_eq!(out.status.code(), Some(1), "divergences fail the command");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("1 of "), "{stdout}");
    assert!(
        stdout.contains("error recorded E1088 replayed none"),
        "{stdout}"
    );
    assert!(stdout.contains("joint 2 recorded 12.000"), "{stdout}");
    assert!(String::from_utf8_lossy(&out.stderr).contains("replies differ"));
}

/// A recorder killed with SIGKILL leaves an MCAP file that reads whole up to its last second.
#[cfg(unix)]
#[test]
fn a_killed_recorder_leaves_a_file_that_opens() {
    let sim = Sim::start(&[]);
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("killed.mcap");
    let mut child = StdCommand::new(env!("CARGO_BIN_EXE_fs020n"))
        .args(["--robot", &sim.addr, "record"])
        .arg(&rec)
        .args(["--rate", "50"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    // Wait until a few chunks are on disk (one closes every second).
    let started = Instant::now();
    let mut sizes = Vec::new();
    while started.elapsed() < Duration::from_secs(60) {
        std::thread::sleep(Duration::from_millis(200));
        let size = std::fs::metadata(&rec).map(|m| m.len()).unwrap_or(0);
        if sizes.last() != Some(&size) {
            sizes.push(size);
        }
        if sizes.len() >= 4 {
            break;
        }
    }
    child.kill().unwrap();
    child.wait().unwrap();
    assert!(sizes.len() >= 4, "the file grew chunk by chunk: {sizes:?}");

    let bytes = std::fs::read(&rec).unwrap();
    assert_eq!(
        &bytes[bytes.len() - 8..],
        b"\x89MCAP0\r\n",
        "ends like an MCAP file"
    );
    // `fs020n plot` reads it, and says nothing is cut short.
    let svg = dir.path().join("killed.svg");
    let out = ok(&fs020n()
        .args(["--json", "plot"])
        .arg(&rec)
        .arg("-o")
        .arg(&svg)
        .output()
        .unwrap());
    let v: Value = serde_json::from_str(&out).unwrap();
    assert!(v["summary"]["states"].as_u64().unwrap() >= 50, "{v}");
    assert!(!std::fs::read_to_string(&svg)
        .unwrap()
        .contains("file cut short"));
}

#[test]
fn demo_plots_its_own_run() {
    let dir = tempfile::tempdir().unwrap();
    let svg = dir.path().join("demo.svg");
    let out = ok(&fs020n()
        .args(["demo", "--plot", svg.to_str().unwrap()])
        .output()
        .unwrap());
    assert!(out.contains("plot: "), "{out}");
    let text = std::fs::read_to_string(&svg).unwrap();
    assert_eq!(panels(&text), (6, 1, 1));
    // The stream's tracking error is drawn (the panel has data, not its "no samples" note).
    assert!(!text.contains("no streamed samples"));
    assert!(text.contains("embedded") || text.contains("127.0.0.1"));
}

#[test]
fn recording_options_are_checked_before_connecting() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("run.txt");
    let out = fs020n()
        .args(["--robot", "127.0.0.1:9", "--record"])
        .arg(&bad)
        .arg("status")
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains(".mcap, .csv or .jsonl"));
    assert!(!bad.exists());

    let out = fs020n().args(["demo", "--plot", "x.jpg"]).output().unwrap();
    assert_eq!(out.status.code(), Some(2));

    let rec = dir.path().join("r.jsonl");
    std::fs::write(&rec, "").unwrap();
    let out = fs020n()
        .args(["--robot", "127.0.0.1:9", "replay"])
        .arg(&rec)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2), "replay on a robot needs --yes");
    assert!(String::from_utf8_lossy(&out.stderr).contains("--yes"));

    let out = fs020n()
        .args(["plot"])
        .arg(&rec)
        .args(["-o", "x.svg"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2), "an empty recording");
    let out = fs020n()
        .args(["plot", "missing.mcap", "-o", "x.svg", "--joints", "7"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
}

#[test]
fn the_status_csv_of_record_plots_without_round_trips() {
    let sim = Sim::start(&[]);
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("status.csv");
    ok(&sim
        .cmd()
        .args(["record"])
        .arg(&rec)
        .args(["--rate", "20", "--duration", "1"])
        .output()
        .unwrap());
    let svg = dir.path().join("status.svg");
    ok(&fs020n()
        .arg("plot")
        .arg(&rec)
        .arg("-o")
        .arg(&svg)
        .output()
        .unwrap());
    let text = std::fs::read_to_string(&svg).unwrap();
    assert_eq!(panels(&text), (6, 1, 1));
    assert!(text.contains("round trip (ms): none recorded"));
}
