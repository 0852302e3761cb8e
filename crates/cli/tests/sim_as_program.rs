//! `fs020n sim --as-program FILE`: a program that does not load is refused with
//! file:line:column; a user's modified server (an extra command) serves at --listen, the CLI's
//! own client talks to it, and `--trace` prints the executed lines.
#![cfg(unix)]
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

fn bin() -> std::path::PathBuf {
    assert_cmd::cargo::cargo_bin("fs020n")
}

#[test]
fn a_program_that_does_not_load_is_refused_with_its_position() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("bad.as");
    std::fs::write(
        &file,
        ".PROGRAM autostart.pc()\n  IF a = 1 THEN\n  END\n.END\n",
    )
    .unwrap();
    let out = Command::new(bin())
        .args(["sim", "--listen", "127.0.0.1:0", "--as-program"])
        .arg(&file)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("bad.as:2:8: expected THEN or GOTO after the IF condition, found \"=\" (a comparison is written ==)"),
        "{err}"
    );
}

#[test]
fn a_modified_server_runs_and_traces() {
    let example = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../as/programs/examples/gripper.as"
    );
    let mut child = Command::new(bin())
        .args([
            "sim",
            "--listen",
            "127.0.0.1:0",
            "--trace",
            "--as-program",
            example,
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let out = BufReader::new(child.stdout.take().unwrap());
    let (tx, rx) = mpsc::channel::<String>();
    std::thread::spawn(move || {
        for line in out.lines().map_while(Result::ok) {
            if tx.send(line).is_err() {
                return;
            }
        }
    });
    let wait_for = |pred: &dyn Fn(&str) -> bool| -> String {
        let start = Instant::now();
        while start.elapsed() < Duration::from_secs(30) {
            if let Ok(l) = rx.recv_timeout(Duration::from_millis(200)) {
                if pred(&l) {
                    return l;
                }
            }
        }
        panic!("no such line");
    };
    let line = wait_for(&|l| l.starts_with("robot 1: protocol 1040 on "));
    let addr = line
        .trim_start_matches("robot 1: protocol 1040 on ")
        .split(',')
        .next()
        .unwrap()
        .to_owned();
    wait_for(&|l| l.contains("running the AS program"));
    let raw = Command::new(bin())
        .args(["--robot", &addr, "raw", "1040 8 1 1", "--yes"])
        .output()
        .unwrap();
    assert!(
        raw.status.success(),
        "{}",
        String::from_utf8_lossy(&raw.stderr)
    );
    assert!(String::from_utf8_lossy(&raw.stdout).contains("reply    \" 1040 0 -1 -1 0 -1 0 "));
    // The trace shows the added command executing.
    let traced = wait_for(&|l| l.contains("autostart.pc:") && l.contains("SIGNAL 1, -2"));
    assert!(traced.contains("pc1"), "{traced}");
    stop(child);
}

#[test]
fn the_pick_and_place_example_runs_on_a_signal_given_on_the_command_line() {
    use std::io::Read as _;
    let example = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../as/programs/examples/pick_place.as"
    );
    let mut child = Command::new(bin())
        .args([
            "sim",
            "--listen",
            "127.0.0.1:0",
            "--signal",
            "1001=1",
            "--as-program",
            example,
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let out = BufReader::new(child.stdout.take().unwrap());
    let mut lines = out.lines().map_while(Result::ok);
    let addr = lines
        .find_map(|l| {
            l.strip_prefix("robot 1: protocol 1040 on ")
                .map(|a| a.split(',').next().unwrap_or_default().to_owned())
        })
        .expect("the address");
    // The reporting task serves its port (10060) at --listen: one line per part placed.
    let start = Instant::now();
    let mut stream = loop {
        match std::net::TcpStream::connect(&addr) {
            Ok(s) => break s,
            Err(_) if start.elapsed() < Duration::from_secs(20) => {
                std::thread::sleep(Duration::from_millis(50))
            }
            Err(e) => panic!("cannot connect to {addr}: {e}"),
        }
    };
    stream
        .set_read_timeout(Some(Duration::from_secs(60)))
        .unwrap();
    let mut got = Vec::new();
    let mut buf = [0u8; 64];
    while !got.ends_with(b"\r\n") {
        let n = stream.read(&mut buf).expect("a report within 60 s");
        assert!(n > 0, "closed: {:?}", String::from_utf8_lossy(&got));
        got.extend_from_slice(&buf[..n]);
    }
    assert_eq!(String::from_utf8_lossy(&got), "PLACED 1\r\n");
    stop(child);
}

#[test]
fn a_signal_that_is_no_input_is_refused() {
    let example = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../as/programs/examples/pick_place.as"
    );
    let out = Command::new(bin())
        .args([
            "sim",
            "--listen",
            "127.0.0.1:0",
            "--signal",
            "5=1",
            "--as-program",
            example,
        ])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("input signal 1001–1999"));
}

/// A cell's server that is no autostart program: `srv` greets whoever connects.
const GREETER: &str = "\
.PROGRAM srv() ; greets every client on port 9200
  TCP_LISTEN .ret, 9200
  WHILE TRUE DO
    TCP_ACCEPT .sock, 9200, 60
    IF .sock >= 0 THEN
      .$out[1] = \"HELLO\" + $CHR(13) + $CHR(10)
      IF SIG(1001) THEN
        .$out[1] = \"HELLO, 1001 IS ON\" + $CHR(13) + $CHR(10)
      END
      TCP_SEND .ret, .sock, .$out[1], 1, 5
      TCP_CLOSE .ret, .sock
    END
  END
.END
";

/// Starts `fs020n sim` with `args` and returns it with its first stdout lines, up to the
/// line that says what runs.
fn sim_until_running(args: &[&str]) -> (std::process::Child, Vec<String>) {
    let mut child = Command::new(bin())
        .args(["sim", "--listen", "127.0.0.1:0", "--port-map", "9200=0"])
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let out = BufReader::new(child.stdout.take().unwrap());
    let mut lines = Vec::new();
    for line in out.lines().map_while(Result::ok) {
        let last = line.contains("Ctrl-C");
        lines.push(line);
        if last {
            break;
        }
    }
    (child, lines)
}

/// Stops `fs020n sim` with SIGTERM and waits for it to exit.
fn stop(mut child: std::process::Child) {
    let _ = Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status();
    let start = Instant::now();
    while child.try_wait().unwrap().is_none() {
        assert!(start.elapsed() < Duration::from_secs(20), "did not stop");
        std::thread::sleep(Duration::from_millis(20));
    }
}

#[test]
fn a_file_without_an_autostart_program_says_that_nothing_runs_and_how_to_start_one() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("greeter.as");
    std::fs::write(&file, GREETER).unwrap();
    let (child, lines) = sim_until_running(&["--as-program", file.to_str().unwrap()]);
    stop(child);
    let last = lines.last().cloned().unwrap_or_default();
    assert!(last.contains("nothing runs"), "{lines:?}");
    assert!(last.contains("--pcexecute PROG"), "{last}");
}

#[test]
fn pcexecute_on_the_command_line_starts_the_server_before_the_addresses_are_printed() {
    use std::io::Read as _;
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("greeter.as");
    std::fs::write(&file, GREETER).unwrap();
    let (child, lines) = sim_until_running(&[
        "--signal",
        "1001=1",
        "--pcexecute",
        "3: srv, -1",
        "--as-program",
        file.to_str().unwrap(),
    ]);
    let addr = (lines.iter())
        .find_map(|l| {
            l.strip_prefix("robot 1: protocol 1040 on ")
                .map(|a| a.split(',').next().unwrap_or_default().to_owned())
        })
        .expect("the address");
    assert!(
        lines
            .iter()
            .any(|l| l.contains("running the AS program") && l.contains("srv in PC task 3")),
        "{lines:?}"
    );
    // Its port listens when the addresses are printed: one connection, no retry. The signal
    // given on the command line was set before its first step.
    let mut stream = std::net::TcpStream::connect(&addr).expect("the server listens");
    stream
        .set_read_timeout(Some(Duration::from_secs(30)))
        .unwrap();
    let mut got = String::new();
    stream.read_to_string(&mut got).expect("a greeting");
    stop(child);
    assert_eq!(got, "HELLO, 1001 IS ON\r\n");
}

#[test]
fn a_start_the_controller_refuses_stops_the_emulator_with_the_monitor_error() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("greeter.as");
    std::fs::write(&file, GREETER).unwrap();
    let out = Command::new(bin())
        .args(["sim", "--listen", "127.0.0.1:0", "--pcexecute", "servr"])
        .arg("--as-program")
        .arg(&file)
        .output()
        .unwrap();
    assert_ne!(out.status.code(), Some(0));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("cannot PCEXECUTE 1: servr"), "{err}");
    assert!(err.contains("(P1038)"), "{err}");
    assert!(err.contains("the file's programs: srv"), "{err}");
}

#[test]
fn an_autostart_program_that_stopped_at_once_is_named_with_its_error() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("undef.as");
    std::fs::write(&file, ".PROGRAM autostart.pc()\n  x = y + 1\n.END\n").unwrap();
    let (child, lines) = sim_until_running(&["--as-program", file.to_str().unwrap()]);
    stop(child);
    let last = lines.last().cloned().unwrap_or_default();
    assert!(
        last.contains("nothing runs: PC task 1 stopped: (E0102)")
            && last.contains("autostart.pc line 2"),
        "{last}"
    );
}
