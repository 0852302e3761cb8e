//! AS program files (fs020n-as) as raw bytes, in any encoding: the byte loader, the check and
//! its lint never panic, the text entry point agrees with the byte loader on UTF-8, and
//! a program that loads runs for 100 ms of virtual time on the test system — with a client
//! sending the tail of the input as requests — without panicking. Interpreter time only moves
//! forward and every task reports a valid state.
#![no_main]

use std::time::Duration;

use fs020n_as::lint::Generation;
use fs020n_as::testing::VirtualSystem;
use fs020n_as::{Config, Interpreter, LoadOptions};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    // The first part is the program, what follows a NUL byte the client's requests.
    let (program, requests) = match data.iter().position(|&b| b == 0) {
        Some(k) => (&data[..k], &data[k + 1..]),
        None => (data, &[][..]),
    };
    let opts = LoadOptions::new().stub("tool");
    let _ = fs020n_as::check("fuzz.as", program, &opts, Some(Generation::D));
    // The same bytes as two files of one controller memory (split at a 0x01 byte).
    if let Some(k) = program.iter().position(|&b| b == 1) {
        let files = [("a.as", &program[..k]), ("b.as", &program[k + 1..])];
        let reports = fs020n_as::check_memory(&files, &opts, None);
        assert_eq!(reports.len(), 2);
    }
    if let Ok(text) = std::str::from_utf8(program) {
        assert_eq!(
            fs020n_as::parse("fuzz.as", text),
            fs020n_as::parse_bytes("fuzz.as", program, &LoadOptions::new())
        );
    }
    let Ok(module) = fs020n_as::parse_bytes("fuzz.as", program, &opts) else {
        return;
    };
    let Ok(mut interp) = Interpreter::new(&[module], Config::default()) else {
        return;
    };
    let mut sys = VirtualSystem::new();
    interp.start(&mut sys);
    let _ = interp.execute("main", &mut sys);
    let mut client = None;
    let mut last = Duration::ZERO;
    for (k, chunk) in requests.split(|&b| b == b'\n').take(20).enumerate() {
        let t = Duration::from_millis(5 * (k as u64 + 1));
        interp.run_until(&mut sys, t);
        assert!(interp.now() >= last);
        last = interp.now();
        if client.is_none() {
            client = sys.connect(10050).or_else(|| sys.connect(9000));
        }
        if let Some(c) = client {
            sys.send(c, chunk);
            let _ = sys.recv(c);
        }
    }
    interp.run_until(&mut sys, Duration::from_millis(100));
    assert_eq!(interp.now(), Duration::from_millis(100));
    for t in interp.tasks(&sys) {
        assert!((0.0..=3.0).contains(&t.state.number()));
    }
});
