//! The CLI as a user meets it, through the binary: logs, errors and their remedies, colours,
//! connecting, `record` files, `--json` errors, Ctrl-C, HOLD, pose moves, help texts.
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

mod common;

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpListener;
use std::process::{Command as StdCommand, Stdio};
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::Arc;
use std::time::Duration;

use assert_cmd::Command;
use common::*;
use fs020n_kin::{Pose, RobotModel, Xyzoat};
use predicates::prelude::*;
use serde_json::Value;

fn fs020n() -> Command {
    let mut c = Command::cargo_bin("fs020n").expect("binary");
    c.env_remove("FS020N_ROBOT").env_remove("NO_COLOR");
    c
}

fn stderr_of(out: &std::process::Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Runs `cmd` under a pseudo-terminal (`script` from util-linux), returning what it printed.
fn on_a_terminal(cmd: &str, env: &[(&str, &str)]) -> String {
    let out = StdCommand::new("script")
        .args(["-qec", cmd, "/dev/null"])
        .envs(env.iter().copied())
        .env_remove("FS020N_ROBOT")
        .output()
        .expect("`script` (util-linux) runs the command on a pseudo-terminal");
    String::from_utf8_lossy(&out.stdout).into_owned()
}

// ------------------------------------------------------------------ 1. -vv and -vvv

#[test]
fn vv_logs_every_exchange_with_bytes_and_round_trip_and_vvv_adds_keepalives() {
    let sim = Sim::start(&[]);
    let out = sim
        .cmd()
        .args([
            "-vv", "move", "1", "0", "-90", "0", "-90", "0", "--speed", "100",
        ])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", stderr_of(&out));
    let log = stderr_of(&out);
    for want in [
        r#"kind="command" request="1040 3 1 100" reply=" 1040 0 -1 -1 0 -1 0"#,
        r#"kind="command" request="1040 1 0""#,
        r#"kind="motion" request="1040 6 9 0 0 0 1 0 -90 0 -90 0" reply=" 1040 "#,
        r#"kind="close" request="1040 255 0""#,
        "rtt_us=",
    ] {
        assert!(log.contains(want), "{want:?} missing from:\n{log}");
    }
    assert!(
        !log.contains("keepalive"),
        "-vv leaves the polls out:\n{log}"
    );
    // -vvv adds the keep-alive polls (recording at 1 Hz leaves gaps the keep-alive fills).
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("r.csv");
    let out = sim
        .cmd()
        .args(["-vvv", "record"])
        .arg(&file)
        .args(["--rate", "1", "--duration", "1.2"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", stderr_of(&out));
    assert!(
        stderr_of(&out).contains(r#"kind="keepalive" request="0 0 0""#),
        "{}",
        stderr_of(&out)
    );
}

// ------------------------------------------------------------------ 2. errors, remedies, colour

#[test]
fn a_lost_link_is_reported_once_without_colour_and_names_a_cli_remedy() {
    let sim = Sim::with_pendant();
    let pendant = sim.pendant.clone().expect("pendant");
    let child = StdCommand::new(assert_cmd::cargo::cargo_bin("fs020n"))
        .args(["--robot", &sim.addr, "status", "--watch", "--rate", "20"])
        .env_remove("NO_COLOR")
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    wait_for_state(&pendant, |s| s["session"]["open"] == true);
    pendant_post(&pendant, "/faults", r#"{"kind": "close_connection"}"#);
    let out = child.wait_with_output().unwrap();
    assert_eq!(out.status.code(), Some(3));
    let err = stderr_of(&out);
    assert_eq!(err.matches("link to the robot lost").count(), 1, "{err}");
    assert!(!err.contains("WARN"), "{err}");
    assert!(!err.contains('\x1b'), "no colour in a file: {err:?}");
    assert!(err.contains("run the command again"), "{err}");
    assert!(!err.contains("Robot::reconnect"), "{err}");
}

#[test]
fn colour_follows_color_and_no_color() {
    let unreachable = [
        "--robot",
        "127.0.0.1:9",
        "--connect-timeout",
        "0.2",
        "status",
    ];
    let out = fs020n()
        .args(["--color", "always"])
        .args(unreachable)
        .output()
        .unwrap();
    assert!(
        stderr_of(&out).contains("\x1b[1;31merror:"),
        "{}",
        stderr_of(&out)
    );
    let out = fs020n().args(unreachable).output().unwrap();
    assert!(!stderr_of(&out).contains('\x1b'), "auto, not a terminal");
    // On a terminal: colour by default, none with NO_COLOR or --color never.
    let bin = assert_cmd::cargo::cargo_bin("fs020n");
    let cmd = format!("{} {}", bin.display(), unreachable.join(" "));
    assert!(on_a_terminal(&cmd, &[]).contains("\x1b[1;31merror:"));
    assert!(!on_a_terminal(&cmd, &[("NO_COLOR", "1")]).contains("\x1b["));
    assert!(!on_a_terminal(&format!("{cmd} --color never"), &[]).contains("\x1b["));
}

#[test]
fn remedies_name_cli_actions() {
    let sim = Sim::start(&[]);
    // A raw motion names --yes, not the library's allow_motion.
    let out = sim
        .cmd()
        .args(["raw", "1040 6 9 0 0 0 0 0 -90 0 -90 0"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = stderr_of(&out);
    assert!(
        err.contains("--yes") && !err.contains("allow_motion"),
        "{err}"
    );
    // A move that cannot finish in time names --speed and --timeout, not set_speed.
    let out = sim
        .cmd()
        .args([
            "move",
            "60",
            "0",
            "-90",
            "0",
            "-90",
            "0",
            "--speed",
            "1",
            "--timeout",
            "0.5",
        ])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(5), "{}", stderr_of(&out));
    let err = stderr_of(&out);
    assert!(
        err.contains("--timeout") && !err.contains("set_speed"),
        "{err}"
    );
    assert!(err.contains("within 500 ms"), "rounded: {err}");
}

#[test]
fn in_the_shell_a_refused_target_says_nothing_was_sent() {
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
        .write_all(b"move 0 0 130 0 -90 0\nmove 1 0 -90 0 -90 0\nquit\n")
        .unwrap();
    let out = child.wait_with_output().unwrap();
    let err = stderr_of(&out);
    assert!(
        err.contains("JT3") && err.contains("nothing was sent"),
        "{err}"
    );
    assert!(!err.contains("before connecting"), "{err}");
    // The program is not running in the shell yet: the remedy is the shell's `start`.
    assert!(err.contains("type `start`"), "{err}");
}

#[test]
fn a_malformed_json_trajectory_names_the_point_not_the_parser() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("t.json");
    std::fs::write(
        &file,
        r#"[{"time_s": 0, "position_deg": [0, 0, -90, 0, -90, 0]}, {"time_s": 1}]"#,
    )
    .unwrap();
    let out = fs020n()
        .args(["--robot", "127.0.0.1:9", "play"])
        .arg(&file)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = stderr_of(&out);
    assert!(
        err.contains("point 2: missing field `position_deg`"),
        "{err}"
    );
    assert!(
        !err.contains("untagged") && !err.contains("JsonFile"),
        "{err}"
    );
}

// ------------------------------------------------------------------ 3. connecting

#[test]
fn connecting_is_announced_on_a_terminal_and_durations_are_rounded() {
    let bin = assert_cmd::cargo::cargo_bin("fs020n");
    let text = on_a_terminal(
        &format!(
            "{} --robot 127.0.0.1:9 --connect-timeout 1 status",
            bin.display()
        ),
        &[],
    );
    assert!(
        text.contains("connecting to 127.0.0.1:9 (the controller listens in 3 s windows"),
        "{text}"
    );
    // Not in a file or a pipe.
    let out = fs020n()
        .args(["--robot", "127.0.0.1:9", "--connect-timeout", "1", "status"])
        .output()
        .unwrap();
    let err = stderr_of(&out);
    assert!(!err.contains("connecting to"), "{err}");
    // "within 960 ms" or "within 1.0 s", never "within 983.816934ms".
    let within = err.split("within ").nth(1).expect("a duration").to_owned();
    let figure: String = within.chars().take_while(|c| *c != ' ').collect();
    assert!(
        figure.len() <= 4 && (within.contains(" ms (") || within.contains(" s (")),
        "{err}"
    );
}

#[test]
fn an_unresolvable_name_fails_without_retrying() {
    let out = fs020n()
        .args([
            "--robot",
            "no-such-host.invalid:10050",
            "--connect-timeout",
            "60",
            "status",
        ])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(3));
    let err = stderr_of(&out);
    assert!(err.contains("does not resolve"), "{err}");
    assert!(!err.contains("attempts"), "no retries: {err}");
    assert!(err.contains("check the host name in --robot"), "{err}");
}

#[test]
fn a_peer_that_answers_http_is_named_and_not_retried() {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap().to_string();
    let accepted = Arc::new(AtomicU32::new(0));
    let count = accepted.clone();
    std::thread::spawn(move || {
        for stream in listener.incoming() {
            let Ok(mut s) = stream else { break };
            count.fetch_add(1, Ordering::SeqCst);
            let mut buf = [0u8; 64];
            let _ = s.read(&mut buf);
            let _ = s.write_all(b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\n\r\n");
            // Keep it open, as an HTTP server with keep-alive does.
            std::thread::spawn(move || {
                std::thread::sleep(Duration::from_secs(30));
                drop(s);
            });
        }
    });
    let out = fs020n()
        .args(["--robot", &addr, "--connect-timeout", "30", "status"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(3));
    let err = stderr_of(&out);
    assert!(err.contains("is not a protocol-1040 server"), "{err}");
    assert!(err.contains("HTTP/1.1"), "names what it saw: {err}");
    assert_eq!(accepted.load(Ordering::SeqCst), 1, "one attempt only");
}

// ------------------------------------------------------------------ 4. record files

#[test]
fn record_refuses_an_existing_file_unless_force_or_append() {
    let sim = Sim::start(&[]);
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("rec.csv");
    std::fs::write(&file, "precious\n").unwrap();
    let record = |extra: &[&str]| {
        let mut c = sim.cmd();
        c.arg("record")
            .arg(&file)
            .args(["--rate", "20", "--duration", "0.3"])
            .args(extra);
        c
    };
    record(&[])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("--force").and(predicate::str::contains("--append")));
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "precious\n");
    // --append to something that is not a recording is refused too.
    record(&["--append"]).assert().code(2);
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "precious\n");
    record(&["--force"]).assert().success();
    let first = std::fs::read_to_string(&file).unwrap();
    assert!(first.starts_with("time_s,timer_s,"), "{first}");
    let rows = first.lines().count();
    record(&["--append"]).assert().success();
    let both = std::fs::read_to_string(&file).unwrap();
    assert!(both.starts_with(&first));
    assert_eq!(both.matches("time_s,timer_s").count(), 1, "one header");
    assert!(both.lines().count() > rows);
    record(&["--force", "--append"]).assert().code(2);
}

// ------------------------------------------------------------------ 5. --json errors

#[test]
fn with_json_an_error_is_one_json_object_on_stderr() {
    let out = fs020n()
        .args([
            "--json",
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
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let v: Value = serde_json::from_slice(&out.stderr).expect("stderr is one JSON object");
    assert_eq!(v["exit_code"], 2);
    assert!(v["error"].as_str().unwrap().contains("JT3"), "{v}");
    assert!(v.get("remedy").is_some(), "{v}");
    let out = fs020n()
        .args([
            "--json",
            "--robot",
            "127.0.0.1:9",
            "--connect-timeout",
            "0.2",
            "status",
        ])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(3));
    let v: Value = serde_json::from_slice(&out.stderr).expect("one JSON object");
    let keys: Vec<&str> = v.as_object().unwrap().keys().map(String::as_str).collect();
    assert_eq!(keys, ["error", "exit_code", "remedy"]);
    assert_eq!(v["exit_code"], 3);
    assert!(v["remedy"].as_str().unwrap().contains("--robot"), "{v}");
    assert!(out.stdout.is_empty());
}

// ------------------------------------------------------------------ 6. Ctrl-C

#[test]
fn ctrl_c_ends_record_with_130_and_a_complete_file() {
    let sim = Sim::start(&[]);
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("rec.csv");
    let child = StdCommand::new(assert_cmd::cargo::cargo_bin("fs020n"))
        .args(["--robot", &sim.addr, "record"])
        .arg(&file)
        .args(["--rate", "50"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Wait for some rows.
    for _ in 0..200 {
        if std::fs::read_to_string(&file).is_ok_and(|t| t.lines().count() > 5) {
            break;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    interrupt(&child);
    let out = child.wait_with_output().unwrap();
    assert_eq!(out.status.code(), Some(130), "{}", stderr_of(&out));
    assert!(String::from_utf8_lossy(&out.stdout).contains("recorded"));
    let text = std::fs::read_to_string(&file).unwrap();
    assert!(text.ends_with('\n'));
    assert!(
        text.lines().skip(1).all(|l| l.split(',').count() == 15),
        "{text}"
    );
}

// ------------------------------------------------------------------ 7. HOLD

#[test]
fn hold_during_a_move_waits_for_run_and_goes_on() {
    let sim = Sim::with_pendant();
    let pendant = sim.pendant.clone().expect("pendant");
    let child = StdCommand::new(assert_cmd::cargo::cargo_bin("fs020n"))
        .args([
            "--robot", &sim.addr, "move", "30", "0", "-90", "0", "-90", "0", "--speed", "10",
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    wait_for_state(&pendant, |s| jt1_of(s) > 2.0);
    pendant_post(&pendant, "/panel", r#"{"run": false}"#);
    std::thread::sleep(Duration::from_millis(1500));
    let held_at = jt1_of(&pendant_get(&pendant, "/state"));
    assert!(held_at > 2.0 && held_at < 29.0, "{held_at}");
    std::thread::sleep(Duration::from_millis(300));
    assert_eq!(jt1_of(&pendant_get(&pendant, "/state")), held_at, "paused");
    pendant_post(&pendant, "/panel", r#"{"run": true}"#);
    let out = child.wait_with_output().unwrap();
    let err = stderr_of(&out);
    assert!(out.status.success(), "{err}");
    assert!(
        err.contains("held — switch RUN/HOLD to RUN to resume"),
        "{err}"
    );
    assert!(err.contains("resumed"), "{err}");
    assert!(String::from_utf8_lossy(&out.stdout).contains("reached [30.000"));
}

#[test]
fn a_hold_beyond_hold_timeout_cancels_with_exit_5() {
    let sim = Sim::with_pendant();
    let pendant = sim.pendant.clone().expect("pendant");
    let child = StdCommand::new(assert_cmd::cargo::cargo_bin("fs020n"))
        .args([
            "--robot",
            &sim.addr,
            "move",
            "30",
            "0",
            "-90",
            "0",
            "-90",
            "0",
            "--speed",
            "10",
            "--hold-timeout",
            "1",
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    wait_for_state(&pendant, |s| jt1_of(s) > 1.0);
    pendant_post(&pendant, "/panel", r#"{"run": false}"#);
    let out = child.wait_with_output().unwrap();
    assert_eq!(out.status.code(), Some(5), "{}", stderr_of(&out));
    assert!(
        stderr_of(&out).contains("--hold-timeout"),
        "{}",
        stderr_of(&out)
    );
}

#[test]
fn hold_during_play_pauses_the_stream_and_run_resumes_it() {
    let sim = Sim::with_pendant();
    let pendant = sim.pendant.clone().expect("pendant");
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("slow.csv");
    let mut text = String::from("time_s,j1,j2,j3,j4,j5,j6\n");
    for k in 0..=150 {
        let t = f64::from(k) * 0.02;
        text.push_str(&format!("{t},{},0,-90,0,-90,0\n", 3.0 * t));
    }
    std::fs::write(&file, text).unwrap();
    let child = StdCommand::new(assert_cmd::cargo::cargo_bin("fs020n"))
        .args(["--robot", &sim.addr, "play"])
        .arg(&file)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    wait_for_state(&pendant, |s| jt1_of(s) > 2.0);
    pendant_post(&pendant, "/panel", r#"{"run": false}"#);
    std::thread::sleep(Duration::from_millis(1500));
    pendant_post(&pendant, "/panel", r#"{"run": true}"#);
    let out = child.wait_with_output().unwrap();
    let err = stderr_of(&out);
    assert!(out.status.success(), "{err}");
    assert!(
        err.contains("held — switch RUN/HOLD to RUN to resume"),
        "{err}"
    );
    let report = String::from_utf8_lossy(&out.stdout);
    assert!(report.contains("stream completed"), "{report}");
    let end = jt1_of(&pendant_get(&pendant, "/state"));
    assert!(
        (end - 9.0).abs() < 0.5,
        "the whole trajectory was played: {end}"
    );
}

// ------------------------------------------------------------------ 8. poses

fn pose_of(v: &Value) -> Xyzoat {
    let f = |k: &str| v[k].as_f64().unwrap_or_else(|| panic!("{k} in {v}"));
    Xyzoat::new(f("x"), f("y"), f("z"), f("o"), f("a"), f("t"))
}

#[test]
fn status_shows_the_flange_pose() {
    let sim = Sim::start(&["--joints", "10", "5", "-85", "0", "-80", "20"]);
    let out = sim.cmd().args(["--json", "status"]).output().unwrap();
    let v = json_of(&out.stdout);
    let want = RobotModel::fs020n()
        .forward(&fs020n_proto::JointsDeg::new([10.0, 5.0, -85.0, 0.0, -80.0, 20.0]).to_rad());
    let got = Pose::from_xyzoat(pose_of(&v["pose"]));
    assert!(
        got.distance_m(&want) < 1e-6 && got.angle_to_rad(&want) < 1e-6,
        "{v}"
    );
    sim.cmd()
        .arg("status")
        .assert()
        .success()
        .stdout(predicate::str::contains("flange pose    X="));
}

#[test]
fn move_pose_reaches_the_pose_and_refuses_unreachable_ones_before_connecting() {
    fs020n()
        .args([
            "--robot",
            "127.0.0.1:9",
            "move",
            "--pose",
            "5000",
            "0",
            "0",
            "0",
            "180",
            "0",
        ])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("before connecting"));
    let sim = Sim::start(&[]);
    let out = sim
        .cmd()
        .args([
            "--json",
            "move",
            "--pose",
            "820",
            "-60",
            "1080",
            "0",
            "180",
            "0",
            "--speed",
            "100",
            "--tolerance",
            "0.01",
        ])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", stderr_of(&out));
    let v = json_of(&out.stdout);
    let want = Pose::from_xyzoat(Xyzoat::new(820.0, -60.0, 1080.0, 0.0, 180.0, 0.0));
    let got = Pose::from_xyzoat(pose_of(&v["final_pose"]));
    assert!(got.distance_m(&want) < 1e-3, "{v}");
}

/// Largest distance (mm) of the flange from the segment `a`–`b` while a move runs, sampled
/// through the pendant API.
fn deviation_while(sim: &Sim, args: &[&str], a: &Pose, b: &Pose) -> (f64, Value) {
    let pendant = sim.pendant.clone().expect("pendant");
    let mut child = StdCommand::new(assert_cmd::cargo::cargo_bin("fs020n"))
        .args(["--robot", &sim.addr, "--json", "move"])
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let (pa, pb) = (a.position_m(), b.position_m());
    let mut worst: f64 = 0.0;
    while child.try_wait().unwrap().is_none() {
        let x = Pose::from_xyzoat(
            serde_json::from_value(pendant_get(&pendant, "/state")["tool"].clone()).unwrap(),
        )
        .position_m();
        let s = ((x - pa).dot(&(pb - pa)) / (pb - pa).norm_squared()).clamp(0.0, 1.0);
        worst = worst.max((x - (pa + (pb - pa) * s)).norm() * 1000.0);
        std::thread::sleep(Duration::from_millis(10));
    }
    let out = child.wait_with_output().unwrap();
    assert!(out.status.success(), "{}", stderr_of(&out));
    (worst, json_of(&out.stdout))
}

#[test]
fn move_pose_linear_keeps_the_flange_on_the_line() {
    let model = RobotModel::fs020n();
    let start = fs020n_proto::JointsDeg::new([30.0, 10.0, -80.0, 0.0, -80.0, 0.0]);
    let a = model.forward(&start.to_rad());
    let target = Xyzoat {
        x_mm: a.to_xyzoat().x_mm + 150.0,
        y_mm: a.to_xyzoat().y_mm - 350.0,
        ..a.to_xyzoat()
    };
    let b = Pose::from_xyzoat(target);
    let t = target.to_array().map(|v| format!("{v}"));
    let pose_args: Vec<&str> = t.iter().map(String::as_str).collect();
    let start_arg = ["--joints", "30", "10", "-80", "0", "-80", "0"];

    let sim = Sim::spawn(&start_arg, true);
    let mut args = vec!["--pose"];
    args.extend(&pose_args);
    args.extend(["--linear", "--speed", "20"]);
    let (line_dev, v) = deviation_while(&sim, &args, &a, &b);
    assert_eq!(v["stream"]["outcome"], "completed", "{v}");
    let end = Pose::from_xyzoat(pose_of(&v["final_pose"]));
    assert!(end.distance_m(&b) < 2e-3, "{v}");
    assert!(line_dev < 3.0, "off the line by {line_dev:.2} mm");

    // The same poses with a joint move: the flange leaves the line (so the check above can fail).
    let sim = Sim::spawn(&start_arg, true);
    let mut args = vec!["--pose"];
    args.extend(&pose_args);
    args.extend(["--speed", "20"]);
    let (joint_dev, _) = deviation_while(&sim, &args, &a, &b);
    println!("largest distance from the line: {line_dev:.2} mm (--linear), {joint_dev:.2} mm (joint move)");
    assert!(joint_dev > 10.0, "a joint move deviates: {joint_dev:.2} mm");
}

// ------------------------------------------------------------------ 9. help and README

#[test]
fn sim_help_shows_only_the_emulator_options_and_every_option_lists_its_values() {
    let out = fs020n().args(["sim", "--help"]).output().unwrap();
    let help = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success());
    assert!(
        !help.contains("--robot") && !help.contains("--connect-timeout"),
        "{help}"
    );
    for want in [
        "--listen",
        "--pendant",
        "[possible values: on, off]",
        "[possible values: run, hold]",
    ] {
        assert!(help.contains(want), "{want}: {help}");
    }
    let help =
        String::from_utf8_lossy(&fs020n().arg("--help").output().unwrap().stdout).into_owned();
    assert!(
        help.contains("--color <WHEN>") && help.contains("always"),
        "{help}"
    );
    let help = String::from_utf8_lossy(&fs020n().args(["play", "-h"]).output().unwrap().stdout)
        .into_owned();
    assert!(
        help.contains("[possible values: stream, waypoints]"),
        "{help}"
    );
    assert!(
        help.contains("4–500") && help.contains("--hold-timeout"),
        "{help}"
    );
    // The robot options still work where they mean something, and are refused for sim.
    fs020n()
        .args(["sim", "--robot", "127.0.0.1:1", "--listen", "127.0.0.1:0"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("--listen"));
}

#[test]
fn the_readme_says_how_to_install_and_run_the_examples() {
    let readme = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../README.md"),
    )
    .unwrap();
    assert!(readme.contains("cargo install --path crates/cli"));
    assert!(readme.contains("--example emulated_tour"));
    assert!(readme.contains("--example blocking_move"));
}

#[test]
fn watch_output_in_a_pipe_has_no_screen_escapes() {
    let sim = Sim::start(&[]);
    let mut child = StdCommand::new(assert_cmd::cargo::cargo_bin("fs020n"))
        .args(["--robot", &sim.addr, "status", "--watch", "--rate", "20"])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut reader = BufReader::new(child.stdout.take().unwrap());
    let mut text = String::new();
    for _ in 0..25 {
        reader.read_line(&mut text).unwrap();
    }
    interrupt(&child);
    let _ = child.wait();
    assert!(text.contains("flange pose"), "{text}");
    assert!(!text.contains('\x1b'), "{text:?}");
}
