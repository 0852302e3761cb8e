//! `fs020n sim` ends cleanly (exit 0) on SIGINT and SIGTERM, also when started in the
//! background by a non-interactive shell (which leaves SIGINT ignored in the job).
#![cfg(unix)]
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

use std::io::{BufRead, BufReader};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

fn wait_with_timeout(child: &mut Child, limit: Duration) -> std::process::ExitStatus {
    let start = Instant::now();
    loop {
        if let Some(status) = child.try_wait().expect("wait") {
            return status;
        }
        if start.elapsed() > limit {
            let _ = child.kill();
            panic!("did not exit within {limit:?}");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// Starts `fs020n --json sim` in the background of `sh -c`, returns the shell and the
/// emulator's pid once it is serving.
fn background_sim() -> (Child, u32) {
    let bin = assert_cmd::cargo::cargo_bin("fs020n");
    let mut sh = Command::new("sh")
        .arg("-c")
        .arg(r#""$0" --json sim --listen 127.0.0.1:0 & echo "pid $!"; wait $!"#)
        .arg(bin)
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("sh");
    let mut out = BufReader::new(sh.stdout.take().expect("stdout"));
    let (mut pid, mut serving) = (None, false);
    while pid.is_none() || !serving {
        let mut line = String::new();
        assert!(
            out.read_line(&mut line).expect("read") > 0,
            "sh ended early"
        );
        if let Some(p) = line.trim().strip_prefix("pid ") {
            pid = Some(p.parse().expect("pid"));
        } else if line.contains("\"listen\"") {
            serving = true;
        }
    }
    (sh, pid.expect("pid"))
}

fn kill(signal: &str, pid: u32) {
    let ok = Command::new("kill")
        .args([signal, &pid.to_string()])
        .status()
        .expect("kill")
        .success();
    assert!(ok, "kill {signal} {pid}");
}

#[test]
fn sim_in_the_background_exits_cleanly_on_sigint_and_sigterm() {
    for signal in ["-INT", "-TERM"] {
        let (mut sh, pid) = background_sim();
        kill(signal, pid);
        let status = wait_with_timeout(&mut sh, Duration::from_secs(20));
        assert_eq!(status.code(), Some(0), "{signal}: {status:?}");
    }
}

/// Starts `fs020n` with `args` in the foreground, waits until it runs, sends SIGTERM: it must
/// exit 0 saying it stopped.
fn exits_cleanly_on_sigterm(args: &[&str]) {
    let mut child = Command::new(assert_cmd::cargo::cargo_bin("fs020n"))
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("spawn");
    let mut out = BufReader::new(child.stdout.take().expect("stdout"));
    let mut line = String::new();
    while !line.contains("running") {
        line.clear();
        assert!(out.read_line(&mut line).expect("read") > 0);
    }
    kill("-TERM", child.id());
    let status = wait_with_timeout(&mut child, Duration::from_secs(20));
    assert_eq!(status.code(), Some(0), "{status:?}");
    let mut rest = String::new();
    std::io::Read::read_to_string(&mut out, &mut rest).expect("read");
    assert!(rest.contains("stopped (SIGTERM)"), "{rest}");
}

#[test]
fn sim_in_the_foreground_exits_cleanly_on_sigterm() {
    exits_cleanly_on_sigterm(&["sim", "--listen", "127.0.0.1:0"]);
}

#[test]
fn a_fleet_on_one_thread_exits_cleanly_on_sigterm() {
    // `--threads 1` with plain native robots: the readiness loop on its own thread.
    exits_cleanly_on_sigterm(&[
        "sim",
        "--robots",
        "3",
        "--threads",
        "1",
        "--listen",
        "127.0.0.1:0",
    ]);
}
