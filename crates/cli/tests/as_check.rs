//! `fs020n as check FILE…` through the binary: text and JSON reports with file:line:column,
//! exit 0 / 1 / 2, `--controller`, `--stub`, and the same warnings as `sim --as-program`.
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

use std::process::{Command, Output};

fn bin() -> std::path::PathBuf {
    assert_cmd::cargo::cargo_bin("fs020n")
}

fn write(dir: &tempfile::TempDir, name: &str, bytes: &[u8]) -> std::path::PathBuf {
    let p = dir.path().join(name);
    std::fs::write(&p, bytes).expect("write");
    p
}

fn run(args: &[&str], files: &[&std::path::Path]) -> Output {
    Command::new(bin())
        .args(args)
        .args(files)
        .output()
        .expect("runs")
}

const GOOD: &[u8] = b".** a backup\r\n.NETCONF 192.168.0.2\r\n.PROGRAM autostart.pc() #0 ; \x83\x52\x83\x81\r\n  EXTCALL 2\r\n  TCP_LISTEN .r, 10050\r\n.END\r\n";

#[test]
fn a_file_that_loads_exits_0_and_lists_its_warnings() {
    let dir = tempfile::tempdir().expect("tempdir");
    let f = write(&dir, "good.as", GOOD);
    let out = run(&["as", "check"], &[&f]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "{text}");
    let name = f.display().to_string();
    assert!(
        text.contains(&format!(
            "{name}:2:1: warning: section .NETCONF (line 2) is kept as it is"
        )),
        "{text}"
    );
    assert!(
        text.contains(&format!(
            "{name}:4:3: warning: EXTCALL loads but is not emulated"
        )),
        "{text}"
    );
    assert!(
        text.contains(&format!("{name}: loads (2 warning(s), 0 lint finding(s)")),
        "{text}"
    );
}

#[test]
fn json_gives_one_object_per_file_per_line() {
    let dir = tempfile::tempdir().expect("tempdir");
    let good = write(&dir, "good.as", GOOD);
    let bad = write(&dir, "bad.as", b".PROGRAM p()\n  IF a THEN\n.END\n");
    let out = run(&["as", "check", "--json"], &[&good, &bad]);
    assert_eq!(out.status.code(), Some(1));
    let text = String::from_utf8_lossy(&out.stdout);
    let lines: Vec<serde_json::Value> = text
        .lines()
        .map(|l| serde_json::from_str(l).expect("one JSON object per line"))
        .collect();
    assert_eq!(lines.len(), 2);
    // The keys come in the documented order.
    let first = text.lines().next().unwrap_or_default();
    let at = |k: &str| first.find(&format!("\"{k}\":")).unwrap_or(usize::MAX);
    assert!(
        at("file") < at("loaded")
            && at("loaded") < at("errors")
            && at("errors") < at("warnings")
            && at("warnings") < at("lint")
            && at("lint") < first.len(),
        "{first}"
    );
    assert_eq!(lines[0]["file"], good.display().to_string());
    assert_eq!(lines[0]["loaded"], true);
    assert_eq!(lines[0]["errors"], serde_json::json!([]));
    assert_eq!(lines[0]["warnings"][1]["line"], 4);
    assert_eq!(lines[0]["warnings"][1]["column"], 3);
    assert_eq!(lines[1]["loaded"], false);
    assert_eq!(
        lines[1]["errors"][0],
        serde_json::json!({"line": 2, "column": 3, "message": "expected END to close this IF before .END"})
    );
    assert_eq!(lines[1]["lint"], serde_json::json!([]));
}

#[test]
fn a_lint_error_exits_1_and_the_controller_choice_changes_the_rules() {
    let dir = tempfile::tempdir().expect("tempdir");
    let first_json = |out: &std::process::Output| -> serde_json::Value {
        serde_json::from_slice(out.stdout.split(|b| *b == b'\n').next().unwrap_or_default())
            .expect("json")
    };
    // A listen port the TCP option does not open: an error on every controller.
    let p = write(
        &dir,
        "p.as",
        b".PROGRAM autostart.pc()\n  TCP_LISTEN .r, 5000\n.END\n",
    );
    let out = run(&["as", "check", "--json"], &[&p]);
    assert_eq!(out.status.code(), Some(1));
    let v = first_json(&out);
    assert_eq!(v["loaded"], true);
    assert_eq!(v["lint"][0]["rule"], "tcp-port-range");
    assert_eq!(v["lint"][0]["severity"], "error");
    assert_eq!(v["lint"][0]["line"], 2);
    // A timeout of 0 s: an E controller takes 0–60 s, an F controller 1–60 s (a warning).
    let t = write(
        &dir,
        "t.as",
        b".PROGRAM autostart.pc()\n  TCP_RECV .r, .s, .$b[1], .n, 0, 255\n.END\n",
    );
    let out = run(&["as", "check", "--json", "--controller", "e"], &[&t]);
    assert_eq!(out.status.code(), Some(0));
    assert_eq!(first_json(&out)["lint"], serde_json::json!([]));
    let out = run(&["as", "check", "--json", "--controller", "f"], &[&t]);
    assert_eq!(out.status.code(), Some(0));
    assert_eq!(first_json(&out)["lint"][0]["rule"], "tcp-timeout-range");
    // A D-only warning: TCP_RECV without its max-bytes argument.
    let w = write(
        &dir,
        "w.as",
        b".PROGRAM autostart.pc()\n  TCP_RECV .r, .s, .$b[1], .n, 5\n.END\n",
    );
    let out = run(&["as", "check", "--json", "--controller", "d"], &[&w]);
    assert_eq!(out.status.code(), Some(0));
    let v = first_json(&out);
    assert_eq!(v["lint"][0]["rule"], "d-tcp-recv-arguments");
    assert_eq!(v["lint"][0]["severity"], "warning");
    let out = run(&["as", "check", "--json", "--controller", "f"], &[&w]);
    assert_eq!(first_json(&out)["lint"], serde_json::json!([]));
}

#[test]
fn stub_declares_an_instruction_a_no_op() {
    let dir = tempfile::tempdir().expect("tempdir");
    let f = write(&dir, "s.as", b".PROGRAM p()\n  GUNON 1\n.END\n");
    // An instruction of the keyword table the emulator does not run loads as not emulated.
    let out = run(&["as", "check"], &[&f]);
    assert_eq!(out.status.code(), Some(0));
    assert!(String::from_utf8_lossy(&out.stdout).contains("GUNON loads but is not emulated"));
    let out = run(&["as", "check", "--stub", "GUNON"], &[&f]);
    assert_eq!(out.status.code(), Some(0));
    assert!(String::from_utf8_lossy(&out.stdout)
        .contains("GUNON is stubbed: it loads and does nothing"));
}

#[test]
fn usage_errors_exit_2() {
    assert_eq!(run(&["as", "check"], &[]).status.code(), Some(2));
    let dir = tempfile::tempdir().expect("tempdir");
    let f = write(&dir, "good.as", GOOD);
    assert_eq!(
        run(&["as", "check", "--controller", "x"], &[&f])
            .status
            .code(),
        Some(2)
    );
    let missing = dir.path().join("missing.as");
    let out = run(&["as", "check"], &[&missing]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("cannot read"));
}

#[cfg(unix)]
#[test]
fn sim_reports_the_same_warnings_as_check() {
    use std::io::{BufRead, BufReader};
    use std::process::Stdio;
    let dir = tempfile::tempdir().expect("tempdir");
    let f = write(&dir, "good.as", GOOD);
    let check = run(&["as", "check"], &[&f]);
    let warnings: Vec<String> = String::from_utf8_lossy(&check.stdout)
        .lines()
        .filter(|l| l.contains(": warning: "))
        .map(|l| l.replacen(": warning: ", ": ", 1))
        .collect();
    assert_eq!(warnings.len(), 2);
    let mut child = Command::new(bin())
        .args(["sim", "--listen", "127.0.0.1:0", "--as-program"])
        .arg(&f)
        .stderr(Stdio::piped())
        .stdout(Stdio::null())
        .spawn()
        .expect("spawn");
    let stderr = child.stderr.take().expect("stderr");
    let mut seen = Vec::new();
    for line in BufReader::new(stderr).lines().map_while(Result::ok) {
        if let Some(w) = line.strip_prefix("warning: ") {
            seen.push(w.to_owned());
        }
        if seen.len() == warnings.len() {
            break;
        }
    }
    let _ = child.kill();
    let _ = child.wait();
    assert_eq!(seen, warnings);
}

#[cfg(unix)]
#[test]
fn sim_takes_stub_too() {
    use std::io::{BufRead, BufReader};
    use std::process::Stdio;
    let dir = tempfile::tempdir().expect("tempdir");
    let f = write(
        &dir,
        "weld.as",
        b".PROGRAM autostart.pc()\n  GUNON 1\n  TWAIT 1\n.END\n",
    );
    // Without --stub it loads as not emulated, and says so first.
    let mut child = Command::new(bin())
        .args(["sim", "--listen", "127.0.0.1:0", "--as-program"])
        .arg(&f)
        .stderr(Stdio::piped())
        .stdout(Stdio::null())
        .spawn()
        .expect("spawn");
    let stderr = child.stderr.take().expect("stderr");
    let first = BufReader::new(stderr).lines().map_while(Result::ok).next();
    let _ = child.kill();
    let _ = child.wait();
    assert!(
        first
            .as_deref()
            .is_some_and(|l| l.ends_with("GUNON loads but is not emulated: a task that reaches it stops with E0199 (--stub GUNON makes it a no-op)")),
        "{first:?}"
    );
    let mut child = Command::new(bin())
        .args([
            "sim",
            "--listen",
            "127.0.0.1:0",
            "--stub",
            "gunon",
            "--as-program",
        ])
        .arg(&f)
        .stderr(Stdio::piped())
        .stdout(Stdio::null())
        .spawn()
        .expect("spawn");
    let stderr = child.stderr.take().expect("stderr");
    let first = BufReader::new(stderr).lines().map_while(Result::ok).next();
    let _ = child.kill();
    let _ = child.wait();
    assert_eq!(
        first,
        Some(format!(
            "warning: {}:2:3: GUNON is stubbed: it loads and does nothing",
            f.display()
        ))
    );
}

#[test]
fn the_pick_and_place_example_loads_without_warnings() {
    let example = std::path::Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../as/programs/examples/pick_place.as"
    ));
    let out = run(&["as", "check"], &[example]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "{text}");
    assert!(
        text.contains("loads (0 warning(s), 0 lint finding(s)"),
        "every instruction it uses runs: {text}"
    );
}

#[test]
fn sim_refuses_stub_without_an_as_program_or_a_bare_controller() {
    let out = Command::new(bin())
        .args(["sim", "--listen", "127.0.0.1:0", "--stub", "GUNON"])
        .output()
        .expect("runs");
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("--stub applies to AS programs"), "{err}");
}
