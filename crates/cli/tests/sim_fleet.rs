//! `fs020n sim --robots N`: N robots in one process, each on its own port, each answering its
//! own client.
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

use std::io::{BufRead, BufReader, Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::process::{Child, Command, Stdio};
use std::time::Duration;

use fs020n_proto::Status;

struct Killed(Child);

impl Drop for Killed {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Sends the poll `0 0 0` and reads until one reply decodes.
fn poll(addr: SocketAddr) -> Status {
    let mut s = TcpStream::connect_timeout(&addr, Duration::from_secs(10)).expect("connect");
    s.set_read_timeout(Some(Duration::from_secs(10)))
        .expect("timeout");
    s.write_all(b"0 0 0").expect("write");
    let mut got = Vec::new();
    let mut buf = [0u8; 512];
    loop {
        let n = s.read(&mut buf).expect("read");
        assert!(n > 0, "{addr} closed the connection");
        got.extend_from_slice(&buf[..n]);
        if let Ok(status) = Status::decode(std::str::from_utf8(&got).expect("ASCII")) {
            return status;
        }
    }
}

#[test]
fn robots_n_starts_n_robots_on_their_own_ports_each_answering() {
    let child = Command::new(assert_cmd::cargo::cargo_bin("fs020n"))
        .args([
            "--json",
            "sim",
            "--robots",
            "3",
            "--threads",
            "1",
            "--listen",
            "127.0.0.1:0",
            "--joints",
            "0",
            "10",
            "-80",
            "0",
            "-80",
            "0",
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("spawn");
    let mut child = Killed(child);
    let mut out = BufReader::new(child.0.stdout.take().expect("stdout"));
    let mut addrs = Vec::new();
    for k in 1..=3 {
        let mut line = String::new();
        assert!(
            out.read_line(&mut line).expect("read") > 0,
            "sim ended early"
        );
        let v: serde_json::Value = serde_json::from_str(&line).expect("one JSON line per robot");
        assert_eq!(v["robot"], k);
        let addr: SocketAddr = v["listen"].as_str().expect("listen").parse().expect("addr");
        assert_ne!(addr.port(), 0);
        addrs.push(addr);
    }
    let mut ports: Vec<u16> = addrs.iter().map(SocketAddr::port).collect();
    ports.sort_unstable();
    ports.dedup();
    assert_eq!(ports.len(), 3, "three distinct ports: {addrs:?}");
    for addr in addrs {
        let status = poll(addr);
        assert_eq!(status.version, 1040);
        assert_eq!(status.joints.0, [0.0, 10.0, -80.0, 0.0, -80.0, 0.0]);
    }
}

#[test]
fn robots_refuses_what_it_cannot_do() {
    for args in [
        &["sim", "--robots", "2", "--listen", "127.0.0.1:65535"][..],
        &[
            "sim",
            "--robots",
            "2",
            "--listen",
            "127.0.0.1:1",
            "--listen",
            "127.0.0.1:2",
        ],
        &["sim", "--robots", "0"],
        &["sim", "--threads", "0"],
    ] {
        let out = Command::new(assert_cmd::cargo::cargo_bin("fs020n"))
            .args(args)
            .output()
            .expect("run");
        assert_eq!(out.status.code(), Some(2), "{args:?}: {out:?}");
    }
}
