//! Helpers for the interpreter tests: load a program text, run it on the test system.
#![allow(dead_code)]
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

use std::time::Duration;

use fs020n_as::testing::VirtualSystem;
use fs020n_as::{Config, Interpreter, TaskId};

/// Milliseconds.
pub(crate) fn ms(v: u64) -> Duration {
    Duration::from_millis(v)
}

/// Loads `src` (panics with the load errors), starts it on a fresh test system.
pub(crate) fn start(src: &str) -> (Interpreter, VirtualSystem) {
    start_with(src, Config::default())
}

/// As [`start`] with a configuration.
pub(crate) fn start_with(src: &str, cfg: Config) -> (Interpreter, VirtualSystem) {
    let mut interp = match Interpreter::from_source("test.as", src, cfg) {
        Ok(i) => i,
        Err(e) => panic!("load failed:\n{e}"),
    };
    let mut sys = VirtualSystem::new();
    interp.start(&mut sys);
    (interp, sys)
}

/// A program body as `autostart.pc`.
pub(crate) fn pc(body: &str) -> String {
    format!(".PROGRAM autostart.pc()\n{body}\n.END\n")
}

/// Runs `body` as autostart.pc for `secs` seconds.
pub(crate) fn run_pc(body: &str, secs: f64) -> (Interpreter, VirtualSystem) {
    let (mut i, mut s) = start(&pc(body));
    i.run_until(&mut s, Duration::from_secs_f64(secs));
    (i, s)
}

/// The lines PC task 1 printed (without the start message).
pub(crate) fn printed(sys: &VirtualSystem) -> Vec<String> {
    sys.lines_of(TaskId::Pc(1))
        .into_iter()
        .filter(|l| !l.ends_with("started in PC task 1"))
        .map(str::to_owned)
        .collect()
}

/// The load error text of `src`.
pub(crate) fn load_error(src: &str) -> String {
    match Interpreter::from_source("test.as", src, Config::default()) {
        Ok(_) => panic!("expected a load error"),
        Err(e) => e.to_string(),
    }
}
