//! CLI tests of the commands that need no robot.
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

use assert_cmd::Command;
use predicates::prelude::*;
use serde_json::Value;

fn fs020n() -> Command {
    let mut c = Command::cargo_bin("fs020n").expect("binary");
    c.env_remove("FS020N_ROBOT");
    c
}

fn json_of(out: &[u8]) -> Value {
    serde_json::from_slice(out).expect("JSON output")
}

const REPLY: &str =
    " 1040 -31088 -1 -1 0 -1 0     1.500    10.000     0.000   -90.000     0.000   -90.000     0.000 ";

#[test]
fn decode_reply_json_has_exactly_the_documented_keys() {
    let out = fs020n().args(["--json", "decode", REPLY]).output().unwrap();
    assert!(out.status.success());
    let v = json_of(&out.stdout);
    let mut keys: Vec<&str> = v.as_object().unwrap().keys().map(String::as_str).collect();
    keys.sort_unstable();
    assert_eq!(
        keys,
        [
            "error",
            "error_code",
            "joints_deg",
            "power",
            "repeat",
            "run",
            "task_running",
            "teach_lock",
            "timer_s",
            "timer_step_s",
            "version"
        ]
    );
    assert_eq!(v["version"], 1040);
    assert_eq!(v["error_code"], -31088);
    assert_eq!(v["error"], "E1088");
    assert_eq!(v["run"], true);
    assert_eq!(v["teach_lock"], false);
    assert_eq!(v["task_running"], false);
    assert_eq!(v["timer_s"], 1.5);
    assert_eq!(v["timer_step_s"], 0.001);
    assert_eq!(
        v["joints_deg"],
        serde_json::json!([10.0, 0.0, -90.0, 0.0, -90.0, 0.0])
    );
}

#[test]
fn decode_reply_no_error_and_timer_overflow_are_null() {
    let text = " 1040 0 -1 -1 0 -1 -1**********     0.000     0.000   -90.000     0.000   -90.000     0.000 ";
    let out = fs020n()
        .args(["decode", "--reply", "--json", text])
        .output()
        .unwrap();
    assert!(out.status.success());
    let v = json_of(&out.stdout);
    assert!(v["error"].is_null());
    assert!(v["timer_s"].is_null());
    assert_eq!(v["task_running"], true);
}

#[test]
fn decode_reply_table_for_people() {
    fs020n().args(["decode", REPLY]).assert().success().stdout(
        predicate::str::contains("E1088").and(predicate::str::contains(
            "Destination is out of motion range",
        )),
    );
}

#[test]
fn decode_request_as_the_controller_reads_it() {
    let out = fs020n()
        .args(["--json", "decode", "1040 3 1 20"])
        .output()
        .unwrap();
    assert!(out.status.success());
    let v = json_of(&out.stdout);
    assert_eq!(v["kind"], "request");
    assert_eq!(v["effective"], true);
    assert_eq!(v["command"], "set speed");
    assert_eq!(v["detail"]["percent"], 20.0);
    let out = fs020n()
        .args(["--json", "decode", "--request", " 1040 1 0"])
        .output()
        .unwrap();
    let v = json_of(&out.stdout);
    assert_eq!(
        v["effective"], false,
        "a leading blank is a version mismatch"
    );
}

#[test]
fn decode_invalid_text_fails_and_says_where() {
    fs020n()
        .args(["decode", "1040 6 x"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("column 8"));
    fs020n()
        .args(["decode", "--reply", " 1040 0 -1 -1 0 -1 -1 oops"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("not a valid reply"));
    fs020n().args(["decode", ""]).assert().code(2);
}

#[test]
fn fk_json_home_pose() {
    let out = fs020n()
        .args(["--json", "fk", "0", "0", "-90", "0", "-90", "0"])
        .output()
        .unwrap();
    assert!(out.status.success());
    let v = json_of(&out.stdout);
    assert!((v["x_mm"].as_f64().unwrap() - 850.0).abs() < 1e-6);
    assert!((v["y_mm"].as_f64().unwrap()).abs() < 1e-6);
    assert!((v["z_mm"].as_f64().unwrap() - 1153.5).abs() < 1e-6);
    assert!((v["a_deg"].as_f64().unwrap() - 180.0).abs() < 1e-6);
    for k in ["o_deg", "t_deg"] {
        assert!(v[k].is_number());
    }
}

#[test]
fn ik_json_solutions_and_nearest() {
    let out = fs020n()
        .args([
            "--json", "ik", "850", "0", "1153.5", "0", "180", "0", "--near", "0", "0", "-90", "0",
            "-90", "0",
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v = json_of(&out.stdout);
    let nearest: Vec<f64> = serde_json::from_value(v["nearest"].clone()).unwrap();
    let home = [0.0, 0.0, -90.0, 0.0, -90.0, 0.0];
    for (a, b) in nearest.iter().zip(home) {
        assert!((a - b).abs() < 1e-6, "{nearest:?}");
    }
    let sols = v["solutions"].as_array().unwrap();
    assert!(!sols.is_empty());
    let ranges = [
        (-160.0, 160.0),
        (-105.0, 140.0),
        (-155.0, 120.0),
        (-270.0, 270.0),
        (-145.0, 145.0),
        (-360.0, 360.0),
    ];
    for s in sols {
        let s: Vec<f64> = serde_json::from_value(s.clone()).unwrap();
        assert_eq!(s.len(), 6);
        for (x, (lo, hi)) in s.iter().zip(ranges) {
            assert!(*x >= lo - 1e-9 && *x <= hi + 1e-9, "{s:?}");
        }
    }
}

#[test]
fn ik_unreachable_fails() {
    fs020n()
        .args(["ik", "5000", "0", "0", "0", "0", "0"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("unreachable"));
}

#[test]
fn completions_and_help() {
    fs020n()
        .args(["completions", "bash"])
        .assert()
        .success()
        .stdout(predicate::str::contains("fs020n"));
    fs020n()
        .arg("--help")
        .assert()
        .success()
        .stdout(predicate::str::contains("EXAMPLES"));
}

#[test]
fn bad_model_file_is_reported() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.toml");
    std::fs::write(&path, "name = 3\n").unwrap();
    fs020n()
        .args([
            "--model",
            path.to_str().unwrap(),
            "fk",
            "0",
            "0",
            "0",
            "0",
            "0",
            "0",
        ])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("robot model"));
}

#[test]
fn a_long_sessions_timer_says_how_coarse_it_and_command_7s_stamps_have_become() {
    let aged = " 1040 0 -1 -1 0 -1 0 70000.000    10.000     0.000   -90.000     0.000   -90.000     0.000 ";
    let out = fs020n().args(["decode", aged]).output().unwrap();
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("steps by 7.8 ms"), "{text}");
    let out = fs020n().args(["--json", "decode", aged]).output().unwrap();
    assert_eq!(json_of(&out.stdout)["timer_step_s"], 1.0 / 128.0);
    let young = fs020n().args(["decode", REPLY]).output().unwrap();
    assert!(!String::from_utf8_lossy(&young.stdout).contains("long session"));
}
