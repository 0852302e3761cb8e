//! CLI tests against the emulator (`fs020n sim` in a child process, on loopback).
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

use std::io::{BufRead, BufReader, Write};
use std::process::{Command as StdCommand, Stdio};

use assert_cmd::Command;
use predicates::prelude::*;
use serde_json::Value;

mod common;
use common::*;

#[test]
fn status_json_reads_the_emulator() {
    let sim = Sim::start(&[]);
    let out = sim.cmd().args(["--json", "status"]).output().unwrap();
    assert!(out.status.success());
    let v = json_of(&out.stdout);
    assert_eq!(v["version"], 1040);
    assert_eq!(v["power"], true);
    assert_eq!(
        v["joints_deg"],
        serde_json::json!([0.0, 0.0, -90.0, 0.0, -90.0, 0.0])
    );
}

#[test]
fn move_waits_and_reaches_the_target() {
    let sim = Sim::start(&[]);
    let out = sim
        .cmd()
        .args([
            "--json",
            "move",
            "5",
            "0",
            "-85",
            "0",
            "-90",
            "0",
            "--speed",
            "100",
            "--wait",
            "--tolerance",
            "0.01",
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v = json_of(&out.stdout);
    assert!(v["error_deg"].as_f64().unwrap() <= 0.01);
    // The robot stays there after the session (the status of a new session shows it).
    let out = sim.cmd().args(["--json", "status"]).output().unwrap();
    let j = json_of(&out.stdout)["joints_deg"].clone();
    assert!((j[0].as_f64().unwrap() - 5.0).abs() < 0.01, "{j}");
    // The session end stopped the program (signal 2007 acts after 50 ms; a status taken at
    // once may still see it).
    let mut running = json_of(&out.stdout)["task_running"].clone();
    for _ in 0..20 {
        if running == false {
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
        let out = sim.cmd().args(["--json", "status"]).output().unwrap();
        running = json_of(&out.stdout)["task_running"].clone();
    }
    assert_eq!(running, false, "the session end stopped the program");
}

#[test]
fn out_of_range_target_is_refused_before_connecting() {
    // Nothing listens on this address: the refusal must come before any connection attempt.
    Command::cargo_bin("fs020n")
        .unwrap()
        .args([
            "--robot",
            "127.0.0.1:9",
            "move",
            "0",
            "0",
            "130",
            "0",
            "-90",
            "0",
        ])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("JT3").and(predicate::str::contains("before connecting")));
}

#[test]
fn unreachable_robot_exits_3() {
    Command::cargo_bin("fs020n")
        .unwrap()
        .args([
            "--robot",
            "127.0.0.1:9",
            "--connect-timeout",
            "0.3",
            "status",
        ])
        .assert()
        .code(3)
        .stderr(predicate::str::contains("could not connect"));
}

#[test]
fn teach_mode_blocks_motion_with_a_remedy() {
    let sim = Sim::start(&["--mode", "teach"]);
    sim.cmd()
        .args(["move", "5", "0", "-85", "0", "-90", "0"])
        .assert()
        .code(4)
        .stderr(predicate::str::contains("switch TEACH/REPEAT to REPEAT"));
    let sim = Sim::start(&["--teach-lock", "on", "--error", "E1088"]);
    sim.cmd()
        .args(["move", "5", "0", "-85", "0", "-90", "0"])
        .assert()
        .code(4)
        .stderr(
            predicate::str::contains("turn TEACH LOCK off").and(predicate::str::contains("E1088")),
        );
}

#[test]
fn speed_validates_and_sets() {
    let sim = Sim::start(&[]);
    sim.cmd().args(["speed", "0"]).assert().code(2);
    sim.cmd().args(["speed", "150"]).assert().code(2);
    sim.cmd()
        .args(["speed", "35"])
        .assert()
        .success()
        .stdout(predicate::str::contains("35 %"));
}

#[test]
fn play_validates_the_whole_file_first() {
    let sim = Sim::start(&[]);
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.csv");
    std::fs::write(
        &bad,
        "time_s,j1,j2,j3,j4,j5,j6\n0,0,0,-90,0,-90,0\n0.5,0,0,-90,zz,-90,0\n",
    )
    .unwrap();
    sim.cmd()
        .args(["play", bad.to_str().unwrap()])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("line 3, column 5"));
    let out_of_range = dir.path().join("range.csv");
    std::fs::write(&out_of_range, "0,0,0,-90,0,-90,0\n1,0,0,-90,0,-150,0\n").unwrap();
    sim.cmd()
        .args(["play", out_of_range.to_str().unwrap()])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("line 2").and(predicate::str::contains("JT5")));
    let good = dir.path().join("good.csv");
    let mut text = String::from("time_s,j1,j2,j3,j4,j5,j6\n");
    for k in 0..=50 {
        let t = k as f64 * 0.02;
        text.push_str(&format!("{t},{},0,-90,0,-90,0\n", 5.0 * t));
    }
    std::fs::write(&good, text).unwrap();
    let out = sim
        .cmd()
        .args(["--json", "play", good.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v = json_of(&out.stdout);
    assert_eq!(v["outcome"], "completed");
    assert!(v["samples_sent"].as_u64().unwrap() > 10);
    // A file that starts away from the robot needs --approach.
    let away = dir.path().join("away.csv");
    std::fs::write(&away, "0,20,0,-90,0,-90,0\n1,21,0,-90,0,-90,0\n").unwrap();
    sim.cmd()
        .args(["play", away.to_str().unwrap()])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("--approach"));
    sim.cmd()
        .args([
            "play",
            away.to_str().unwrap(),
            "--approach",
            "--mode",
            "waypoints",
        ])
        .assert()
        .success();
}

#[test]
fn record_writes_rows() {
    let sim = Sim::start(&[]);
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("rec.csv");
    sim.cmd()
        .args([
            "record",
            file.to_str().unwrap(),
            "--rate",
            "50",
            "--duration",
            "0.3",
        ])
        .assert()
        .success();
    let text = std::fs::read_to_string(&file).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert!(lines[0].starts_with("time_s,timer_s,error_code"));
    assert!(lines.len() >= 5, "{text}");
    assert_eq!(lines[1].split(',').count(), 15);
}

#[test]
fn raw_prints_the_reply_and_guards_motion() {
    let sim = Sim::start(&[]);
    let out = sim.cmd().args(["--json", "raw", "0 0 0"]).output().unwrap();
    assert!(out.status.success());
    let v = json_of(&out.stdout);
    assert!(v["reply"]
        .as_str()
        .unwrap()
        .starts_with(" 1040 0 -1 -1 0 -1 0"));
    assert_eq!(v["decoded"]["version"], 1040);
    sim.cmd()
        .args(["raw", "1040 6 9 0 0 0 0 0 -90 0 -90 0"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("--yes"));
    // With --yes it is still refused while the program is not running (it could not move).
    sim.cmd()
        .args(["raw", "1040 6 9 0 0 0 0 0 -90 0 -90 0", "--yes"])
        .assert()
        .code(4)
        .stderr(predicate::str::contains("start the motion program"));
    // Non-motion commands with version 1040 go through.
    let out = sim
        .cmd()
        .args(["--json", "raw", "1040 3 1 25"])
        .output()
        .unwrap();
    assert!(out.status.success());
}

#[test]
fn bench_json_keys() {
    let sim = Sim::start(&[]);
    let out = sim
        .cmd()
        .args(["--json", "bench", "--count", "50"])
        .output()
        .unwrap();
    assert!(out.status.success());
    let v = json_of(&out.stdout);
    assert_eq!(v["count"], 50);
    assert!(v["rate_hz"].as_f64().unwrap() > 0.0);
    let rtt = &v["rtt_us"];
    let (min, mean, p99, max) = (
        rtt["min"].as_f64().unwrap(),
        rtt["mean"].as_f64().unwrap(),
        rtt["p99"].as_f64().unwrap(),
        rtt["max"].as_f64().unwrap(),
    );
    assert!(min <= mean && mean <= max && p99 <= max && min > 0.0);
}

#[test]
fn bench_without_robot_uses_the_embedded_emulator() {
    let out = Command::cargo_bin("fs020n")
        .unwrap()
        .env_remove("FS020N_ROBOT")
        .args(["--json", "bench", "--count", "20"])
        .output()
        .unwrap();
    assert!(out.status.success());
    assert_eq!(json_of(&out.stdout)["count"], 20);
}

#[test]
fn shell_runs_commands_in_one_session() {
    let sim = Sim::start(&[]);
    let mut child = StdCommand::new(assert_cmd::cargo::cargo_bin("fs020n"))
        .args(["--robot", &sim.addr, "shell"])
        .env("HOME", tempfile::tempdir().unwrap().path())
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    child
        .stdin
        .take()
        .unwrap()
        .write_all(b"help\nspeed 100\nstart\nmove 3 0 -88 0 -90 0 wait\nstatus\nbogus\nquit\n")
        .unwrap();
    let out = child.wait_with_output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stdout}\n{stderr}");
    assert!(stdout.contains("program running"), "{stdout}");
    assert!(
        stdout.contains("reached [3.000, 0.000, -88.000"),
        "{stdout}"
    );
    assert!(
        stdout.contains("program        running"),
        "the program ran until quit: {stdout}"
    );
    assert!(stderr.contains("unknown command"), "{stderr}");
    assert!(stdout.contains("session closed"));
}

#[test]
fn sim_rejects_bad_flags() {
    Command::cargo_bin("fs020n")
        .unwrap()
        .args([
            "sim",
            "--listen",
            "127.0.0.1:0",
            "--joints",
            "0",
            "0",
            "130",
            "0",
            "0",
            "0",
        ])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("JT3"));
    Command::cargo_bin("fs020n")
        .unwrap()
        .args(["sim", "--listen", "127.0.0.1:0", "--pendant", "0.0.0.0:0"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("token"));
}

#[test]
fn demo_runs_on_the_embedded_emulator() {
    let out = Command::cargo_bin("fs020n")
        .unwrap()
        .env_remove("FS020N_ROBOT")
        .args(["--json", "demo"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v = json_of(&out.stdout);
    assert_eq!(v["moves"].as_array().unwrap().len(), 4);
    for m in v["moves"].as_array().unwrap() {
        assert!(m["error_deg"].as_f64().unwrap() <= 0.05);
    }
    assert_eq!(v["stream"]["outcome"], "completed");
    assert!(v["stream"]["tracking_error_max_deg"].as_f64().unwrap() < 5.0);
}

#[test]
fn demo_on_a_real_robot_needs_yes() {
    Command::cargo_bin("fs020n")
        .unwrap()
        .args(["--robot", "127.0.0.1:9", "demo"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("--yes"));
}

#[test]
fn status_watch_streams_json_lines_until_interrupted() {
    let sim = Sim::start(&[]);
    let mut child = StdCommand::new(assert_cmd::cargo::cargo_bin("fs020n"))
        .args([
            "--robot", &sim.addr, "--json", "status", "--watch", "--rate", "50",
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut reader = BufReader::new(child.stdout.take().unwrap());
    let mut timers = Vec::new();
    for _ in 0..4 {
        let mut line = String::new();
        reader.read_line(&mut line).unwrap();
        let v: Value = serde_json::from_str(&line).unwrap();
        timers.push(v["timer_s"].as_f64().unwrap());
    }
    assert!(timers.windows(2).all(|w| w[1] >= w[0]), "{timers:?}");
    interrupt(&child);
    let status = child.wait().unwrap();
    assert_eq!(
        status.code(),
        Some(130),
        "Ctrl-C ends --watch as it ends every command: {status:?}"
    );
}

#[test]
fn ctrl_c_during_play_cancels_and_closes() {
    let sim = Sim::start(&[]);
    let dir = tempfile::tempdir().unwrap();
    let slow = dir.path().join("slow.csv");
    let mut text = String::from("time_s,j1,j2,j3,j4,j5,j6\n");
    for k in 0..=500 {
        let t = k as f64 * 0.02;
        text.push_str(&format!("{t},{},0,-90,0,-90,0\n", 2.0 * t));
    }
    std::fs::write(&slow, text).unwrap();
    let child = StdCommand::new(assert_cmd::cargo::cargo_bin("fs020n"))
        .args(["--robot", &sim.addr, "play", slow.to_str().unwrap()])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Let the stream run (the file lasts 10 s), then interrupt it.
    std::thread::sleep(std::time::Duration::from_millis(1500));
    interrupt(&child);
    let out = child.wait_with_output().unwrap();
    assert_eq!(
        out.status.code(),
        Some(130),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(String::from_utf8_lossy(&out.stderr).contains("interrupted"));
    // The session was closed: a new one is accepted and the robot stands still, part way.
    std::thread::sleep(std::time::Duration::from_millis(300));
    let first = sim.cmd().args(["--json", "status"]).output().unwrap();
    let j1 = json_of(&first.stdout)["joints_deg"][0].as_f64().unwrap();
    assert!(j1 > 0.5 && j1 < 15.0, "stopped part way: {j1}");
    std::thread::sleep(std::time::Duration::from_millis(300));
    let second = sim.cmd().args(["--json", "status"]).output().unwrap();
    assert_eq!(
        json_of(&second.stdout)["joints_deg"][0].as_f64().unwrap(),
        j1,
        "standing still"
    );
}

#[test]
fn play_refuses_before_acting() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("p.csv");
    std::fs::write(&file, "0,20,0,-90,0,-90,0\n1,21,0,-90,0,-90,0\n").unwrap();
    // Options that cannot work are refused before any connection (nothing listens here).
    Command::cargo_bin("fs020n")
        .unwrap()
        .args([
            "--robot",
            "127.0.0.1:9",
            "play",
            file.to_str().unwrap(),
            "--rate",
            "2",
        ])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("--rate"));
    // A start away from the robot is refused before the speed is changed or the program started.
    let sim = Sim::with_pendant();
    let pendant = sim.pendant.clone().expect("pendant");
    sim.cmd()
        .args(["play", file.to_str().unwrap(), "--speed", "23"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("--approach"));
    let state = pendant_get(&pendant, "/state");
    assert_eq!(state["monitor_speed_percent"], 10.0, "speed untouched");
    assert_eq!(
        state["counters"]["effective_requests"], 1,
        "only the closing 255 acted: {state}"
    );
}

#[test]
fn move_options_are_bounded() {
    let c = |args: &[&str]| {
        let mut c = Command::cargo_bin("fs020n").unwrap();
        c.args([
            "--robot",
            "127.0.0.1:9",
            "move",
            "1",
            "0",
            "-90",
            "0",
            "-90",
            "0",
        ])
        .args(args);
        c
    };
    c(&["--tolerance", "50"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("--tolerance"));
    c(&["--timeout", "1e19"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("--timeout"));
    c(&["--tolerance", "NaN"]).assert().code(2);
}

#[test]
fn raw_refusals_say_why() {
    let sim = Sim::start(&[]);
    sim.cmd()
        .args(["raw", ""])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("empty").and(predicate::str::contains("--yes").not()));
}

#[test]
fn ctrl_c_during_the_demo_cancels_and_exits_130() {
    let child = StdCommand::new(assert_cmd::cargo::cargo_bin("fs020n"))
        .env_remove("FS020N_ROBOT")
        .arg("demo")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(1500));
    interrupt(&child);
    let out = child.wait_with_output().unwrap();
    assert_eq!(
        out.status.code(),
        Some(130),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn sampling_options_are_bounded_before_connecting() {
    let c = |args: &[&str]| {
        let mut c = Command::cargo_bin("fs020n").unwrap();
        c.args(["--robot", "127.0.0.1:9"]).args(args);
        c
    };
    c(&["record", "/tmp/never.csv", "--duration", "1e30"])
        .assert()
        .code(2);
    c(&["record", "/tmp/never.csv", "--rate", "1e-300"])
        .assert()
        .code(2);
    c(&["status", "--watch", "--rate", "1e-300"])
        .assert()
        .code(2);
}
