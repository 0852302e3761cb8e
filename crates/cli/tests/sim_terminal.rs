//! `fs020n sim --bare --terminal ADDR`: the terminal logs in and says what it is, and the robot
//! port refuses connections while nothing is loaded.
#![cfg(unix)]
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::process::{Command, Stdio};
use std::time::Duration;

/// Reads until `end` arrives (or the connection ends); the text so far.
fn read_until(s: &mut TcpStream, end: &str) -> String {
    let mut seen = Vec::new();
    let mut buf = [0u8; 512];
    while !String::from_utf8_lossy(&seen).ends_with(end) {
        let n = s.read(&mut buf).expect("the terminal answers");
        assert!(n > 0, "closed after {:?}", String::from_utf8_lossy(&seen));
        seen.extend_from_slice(&buf[..n]);
    }
    String::from_utf8_lossy(&seen).into_owned()
}

/// The value of `"key":"…"` in a JSON line.
fn field(line: &str, key: &str) -> Option<String> {
    let start = line.find(&format!("\"{key}\":\""))? + key.len() + 4;
    Some(line[start..].split('"').next()?.to_owned())
}

#[test]
fn a_bare_controller_serves_its_terminal_and_no_protocol_port() {
    let mut child = Command::new(assert_cmd::cargo::cargo_bin("fs020n"))
        .args([
            "--json",
            "sim",
            "--bare",
            "--listen",
            "127.0.0.1:0",
            "--terminal",
            "127.0.0.1:0",
            "--terminal-piece",
            "5",
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("fs020n starts");
    let mut out = BufReader::new(child.stdout.take().expect("stdout"));
    let mut line = String::new();
    out.read_line(&mut line).expect("the addresses");
    let terminal = field(&line, "terminal").expect("a terminal address");
    let listen = field(&line, "listen").expect("a robot address");
    assert!(TcpStream::connect(&listen).is_err(), "{listen} answers");
    let mut s = TcpStream::connect(&terminal).expect("the terminal accepts");
    s.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    read_until(&mut s, "login: ");
    s.write_all(b"as\r\n").unwrap();
    assert!(read_until(&mut s, ">").contains("\"AUX1\""));
    s.write_all(b"ID\n").unwrap();
    let id = read_until(&mut s, ">");
    assert!(id.contains("EMULATOR-FS020N-AS"), "{id}");
    let _ = child.kill();
    let _ = child.wait();
}
