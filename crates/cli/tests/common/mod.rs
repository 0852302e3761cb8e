//! Helpers of the CLI tests: the emulator in a child process, Ctrl-C, the pendant API.
#![allow(dead_code, clippy::expect_used)] // test code; not every test file uses every helper

use std::io::{BufRead, BufReader, Write};
use std::process::{Child, Command as StdCommand, Stdio};

use assert_cmd::Command;
use serde_json::Value;

/// An emulator child process, killed on drop.
pub(crate) struct Sim {
    pub(crate) child: Child,
    pub(crate) addr: String,
    /// The pendant API's HOST:PORT, when started with one.
    pub(crate) pendant: Option<String>,
}

impl Sim {
    pub(crate) fn start(extra: &[&str]) -> Sim {
        Sim::spawn(extra, false)
    }

    pub(crate) fn with_pendant() -> Sim {
        Sim::spawn(&[], true)
    }

    pub(crate) fn spawn(extra: &[&str], pendant: bool) -> Sim {
        let mut cmd = StdCommand::new(assert_cmd::cargo::cargo_bin("fs020n"));
        cmd.args(["--json", "sim", "--listen", "127.0.0.1:0"])
            .args(extra);
        if pendant {
            cmd.args(["--pendant", "127.0.0.1:0"]);
        }
        let mut child = cmd
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("spawn fs020n sim");
        let mut line = String::new();
        BufReader::new(child.stdout.take().expect("stdout"))
            .read_line(&mut line)
            .expect("first line");
        let v: Value = serde_json::from_str(&line).expect("JSON line with the address");
        Sim {
            child,
            addr: v["listen"].as_str().expect("listen").to_owned(),
            pendant: v["pendant"]
                .as_str()
                .map(|p| p.trim_start_matches("http://").to_owned()),
        }
    }

    pub(crate) fn cmd(&self) -> Command {
        let mut c = Command::cargo_bin("fs020n").expect("binary");
        c.env_remove("FS020N_ROBOT").args(["--robot", &self.addr]);
        c
    }
}

impl Drop for Sim {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

pub(crate) fn json_of(out: &[u8]) -> Value {
    serde_json::from_slice(out).unwrap_or_else(|e| panic!("{e}: {}", String::from_utf8_lossy(out)))
}

/// Sends SIGINT (Ctrl-C) to a child process.
pub(crate) fn interrupt(child: &Child) {
    let ok = StdCommand::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap()
        .success();
    assert!(ok, "kill -INT");
}

/// GET a pendant path, returning the JSON body.
pub(crate) fn pendant_get(addr: &str, path: &str) -> Value {
    use std::io::Read;
    let mut s = std::net::TcpStream::connect(addr).unwrap();
    write!(
        s,
        "GET {path} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\r\n"
    )
    .unwrap();
    let mut text = String::new();
    s.read_to_string(&mut text).unwrap();
    let body = text.split("\r\n\r\n").nth(1).unwrap();
    serde_json::from_str(body).unwrap()
}

/// POST a JSON body to a pendant path, returning the JSON reply.
pub(crate) fn pendant_post(addr: &str, path: &str, body: &str) -> Value {
    use std::io::Read;
    let mut s = std::net::TcpStream::connect(addr).unwrap();
    write!(
        s,
        "POST {path} HTTP/1.1\r\nHost: {addr}\r\nContent-Type: application/json\r\nContent-Length: {}\r\nConnection: close\r\n\r\n{body}",
        body.len()
    )
    .unwrap();
    let mut text = String::new();
    s.read_to_string(&mut text).unwrap();
    let body = text.split("\r\n\r\n").nth(1).unwrap_or("null");
    serde_json::from_str(body).unwrap_or(Value::Null)
}

/// Polls the pendant's `/state` until `ready` holds (at most 20 s, generous for a loaded
/// machine), returning that state.
pub(crate) fn wait_for_state(pendant: &str, ready: impl Fn(&Value) -> bool) -> Value {
    for _ in 0..2000 {
        let state = pendant_get(pendant, "/state");
        if ready(&state) {
            return state;
        }
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    panic!("the emulator never reached the expected state");
}

/// JT1 in a pendant state, degrees.
pub(crate) fn jt1_of(state: &Value) -> f64 {
    state["joints_deg"][0].as_f64().unwrap_or(f64::NAN)
}
