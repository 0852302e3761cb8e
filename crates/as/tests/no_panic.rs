//! No input panics the parser or the interpreter: arbitrary bytes, mutations of real program
//! texts, and random programs built from the statements the interpreter supports, each run for
//! a bounded stretch of virtual time with a client sending random requests, and statements
//! typed at the terminal while they run.
//!
//! The number of cases defaults to a few hundred per property (seconds in a debug build); set
//! `FS020N_FUZZ_CASES` for more. The coverage-guided target is `fuzz/fuzz_targets/as_program.rs`.
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

mod common;

use std::time::Duration;

use fs020n_as::testing::VirtualSystem;
use fs020n_as::{Config, Interpreter, SERVER_1040};
use proptest::prelude::*;

fn cases(default: u32) -> u32 {
    std::env::var("FS020N_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

/// Parses, loads and (if it loads) runs `text` for `ms` of virtual time, feeding `requests`
/// to whatever listens on the ports the programs use. Returns whether it loaded.
fn exercise(text: &str, ms: u64, requests: &[Vec<u8>]) -> bool {
    let Ok(module) = fs020n_as::parse("fuzz.as", text) else {
        return false;
    };
    let Ok(mut interp) = Interpreter::new(&[module], Config::default()) else {
        return false;
    };
    let mut sys = VirtualSystem::new();
    interp.start(&mut sys);
    let _ = interp.execute("main", &mut sys);
    let _ = interp.pc_execute(2, "main");
    let mut clients = Vec::new();
    let step = Duration::from_millis(ms.max(1)) / (requests.len() as u32 + 2);
    let mut t = Duration::ZERO;
    for (k, req) in requests.iter().enumerate() {
        t += step;
        interp.run_until(&mut sys, t);
        for port in [10050u16, 9000, 9001] {
            if let Some(c) = sys.connect(port) {
                clients.push(c);
            }
        }
        if let Some(&c) = clients.get(k % clients.len().max(1)) {
            sys.send(c, req);
            let _ = sys.recv(c);
        }
        match k % 7 {
            3 => sys.panel.run = !sys.panel.run,
            5 => interp.set_signal(1001, k % 2 == 0),
            _ => {}
        }
    }
    interp.run_until(&mut sys, Duration::from_millis(ms));
    // Observers must not panic either.
    let _ = interp.tasks(&sys);
    let _ = interp.terminal().count();
    let _ = interp.globals_dump();
    let _ = interp.next_event();
    true
}

/// A tiny deterministic generator (xorshift) for random programs.
struct Gen(u64);

impl Gen {
    fn next(&mut self) -> u64 {
        let mut x = self.0;
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        self.0 = x;
        x
    }

    fn pick<'a>(&mut self, v: &[&'a str]) -> &'a str {
        v[(self.next() % v.len() as u64) as usize]
    }

    fn num(&mut self) -> String {
        match self.next() % 6 {
            0 => "0".into(),
            1 => format!("-{}", self.next() % 100),
            2 => format!("{}.{}", self.next() % 1000, self.next() % 100),
            3 => "1E38".into(),
            _ => format!("{}", self.next() % 20),
        }
    }

    fn real(&mut self, depth: u32) -> String {
        if depth == 0 {
            return match self.next() % 4 {
                0 => self.num(),
                1 => self
                    .pick(&["a", "b", ".c", "x[1]", "x[.c]", "t[1,2,3]", "TRUE", "ERROR"])
                    .into(),
                2 => self
                    .pick(&[
                        "TIMER(1)",
                        "TASK(1)",
                        "SIG(2001)",
                        "SWITCH(RUN)",
                        "LEN($s)",
                        "VAL($s)",
                        "UTIMER(@t)",
                        "STRTOVAL($s)",
                        "MAXINDEX($s, 2)",
                        "WHICHTASK($s)",
                        "SYSDATA(ZROB.NOWAXIS, .c)",
                        "EXISTDATA($s, T)",
                    ])
                    .into(),
                _ => self.num(),
            };
        }
        match self.next() % 8 {
            0 => format!(
                "({} {} {})",
                self.real(depth - 1),
                self.pick(&[
                    "+", "-", "*", "/", "MOD", "^", "==", "<>", "<", "AND", "OR", "BAND", "BXOR"
                ]),
                self.real(depth - 1)
            ),
            1 => format!("-{}", self.real(depth - 1)),
            2 => format!("NOT {}", self.real(depth - 1)),
            3 => format!(
                "{}({})",
                self.pick(&["ABS", "SQRT", "SIN", "INT", "COS"]),
                self.real(depth - 1)
            ),
            4 => format!("MAXVAL({}, {})", self.real(depth - 1), self.real(depth - 1)),
            5 => format!("ASC({}, {})", self.string(depth - 1), self.real(depth - 1)),
            6 => format!(
                "INSTR({}, {})",
                self.string(depth - 1),
                self.string(depth - 1)
            ),
            _ => self.real(0),
        }
    }

    fn string(&mut self, depth: u32) -> String {
        if depth == 0 {
            return self
                .pick(&[
                    "\"\"",
                    "\"a b\"",
                    "$s",
                    ".$l",
                    "$arr[2]",
                    "\"1040 6 9 1 2 3\"",
                ])
                .into();
        }
        match self.next() % 7 {
            0 => format!("{} + {}", self.string(depth - 1), self.string(depth - 1)),
            1 => format!(
                "$MID({}, {}, {})",
                self.string(depth - 1),
                self.real(depth - 1),
                self.real(depth - 1)
            ),
            2 => format!(
                "$ENCODE({}, /F{}.{}, {})",
                self.real(depth - 1),
                self.next() % 12,
                self.next() % 5,
                self.real(depth - 1)
            ),
            3 => format!("$DECODE($s, \" \", {})", self.real(depth - 1)),
            4 => format!("$CHR({})", self.real(depth - 1)),
            5 => format!("$SPACE({})", self.real(depth - 1)),
            _ => self.string(0),
        }
    }

    fn stmt(&mut self, depth: u32) -> String {
        let r = self.real(2);
        match self.next() % 31 {
            0 => format!("a = {r}"),
            1 => format!("x[{}] = {}", self.real(1), self.real(2)),
            2 => format!("$s = {}", self.string(2)),
            3 => format!(".c = {r}"),
            4 if depth > 0 => format!("IF {r} THEN\n{}\nELSE\n{}\nEND", self.stmt(depth - 1), self.stmt(depth - 1)),
            5 if depth > 0 => format!("WHILE {r} DO\n{}\nEND", self.stmt(depth - 1)),
            6 if depth > 0 => format!("FOR .i = {} TO {} STEP {}\n{}\nEND", self.real(1), self.real(1), self.real(0), self.stmt(depth - 1)),
            7 if depth > 0 => format!("CASE {r} OF\nVALUE 1, 2:\n{}\nANY :\n{}\nEND", self.stmt(depth - 1), self.stmt(depth - 1)),
            8 => format!("TWAIT {}", self.real(1)),
            9 => format!("SIGNAL {}", self.real(1)),
            10 => format!("PRINT {}, /I3, {}, {}", self.string(1), r, self.string(1)),
            11 => "GOTO top".into(),
            12 => format!("IF {r} GOTO top"),
            13 => format!("JMOVE #PPOINT({}, 0, -90, 0, -90, 0)", self.real(1)),
            14 => format!("LMOVE TRANS({}, 0, 1000)", self.real(1)),
            15 => "BRAKE".into(),
            16 => "BREAK".into(),
            17 => format!("SPEED {} {}", self.real(0), self.pick(&["", "ALWAYS", "S", "MM/S"])),
            18 => format!("ON {} CALL sub", self.real(0)),
            19 => format!("ONI {} GOTO top", self.real(0)),
            20 => format!("TCP_LISTEN r, {}", self.pick(&["9000", "9001", "80"])),
            21 => "TCP_ACCEPT sock, 9000, 0.05\nTCP_RECV r, sock, $arr[1], n, 0.05\nTCP_SEND r, sock, $arr[1], n, 0.05".into(),
            22 => format!("MC {}", self.pick(&["EXECUTE main", "HOLD", "CONTINUE", "ABORT", "ERESET", "SPEED 50", "PCEXECUTE 3: sub", "ZPOWER OFF"])),
            23 => format!("CALL sub({r})"),
            24 => format!("DECOMPOSE x[{}] = #HERE", self.real(0)),
            25 => format!("UTIMER @t = {}", self.real(1)),
            26 => "HERE f+g".into(),
            27 => "CALL sub(x[])".into(),
            28 => format!("ONE sub\nx[1] = 1 / {r}\nRETURNE"),
            29 => format!("DECOMPOSE x[0] = STRTOPOS({})", self.string(1)),
            _ => format!("WAIT {r}"),
        }
    }

    fn program(&mut self) -> String {
        let mut s = String::from(".PROGRAM autostart.pc()\ntop:\n");
        for _ in 0..(3 + self.next() % 10) {
            s.push_str(&self.stmt(2));
            s.push('\n');
        }
        s.push_str(".END\n.PROGRAM main()\ntop:\n");
        for _ in 0..(2 + self.next() % 6) {
            s.push_str(&self.stmt(2));
            s.push('\n');
        }
        s.push_str(".END\n.PROGRAM sub(.v)\ntop:\n");
        s.push_str(&self.stmt(1));
        s.push_str("\n.END\n.REALS\na = 1\n.END\n.STRINGS\n$s = \"1040 3 1 50\"\n.END\n");
        s
    }
}

fn mutate(text: &str, seed: u64, n: usize) -> String {
    let mut g = Gen(seed | 1);
    let mut b = text.as_bytes().to_vec();
    let pool = b" \n;:,.()[]\"=+-*/^#$0123456789AEIOUaeiouTHENDOWhileFORMC";
    for _ in 0..n {
        let len = b.len().max(1);
        let at = (g.next() as usize) % len;
        match g.next() % 4 {
            0 if !b.is_empty() => b[at] = pool[(g.next() as usize) % pool.len()],
            1 => b.insert(at.min(b.len()), pool[(g.next() as usize) % pool.len()]),
            2 if !b.is_empty() => {
                b.remove(at);
            }
            _ => {
                // Duplicate a line.
                let lines: Vec<&[u8]> = b.split(|c| *c == b'\n').collect();
                let k = (g.next() as usize) % lines.len();
                let mut out = Vec::new();
                for (i, l) in lines.iter().enumerate() {
                    out.extend_from_slice(l);
                    out.push(b'\n');
                    if i == k {
                        out.extend_from_slice(l);
                        out.push(b'\n');
                    }
                }
                b = out;
            }
        }
    }
    String::from_utf8_lossy(&b).into_owned()
}

fn request() -> impl Strategy<Value = Vec<u8>> {
    prop_oneof![
        Just(b"1040 1 0".to_vec()),
        Just(b"1040 6 9 0 0 0 10 0 -90 0 -90 0".to_vec()),
        Just(b"1040 7 21 0 1 0 0 0 -90 0 -90 0 1 1 1 1 1 1 0 0 0 0 0 0".to_vec()),
        Just(b"1040 6 3 0 0 0".to_vec()),
        Just(b"1040 5 0".to_vec()),
        Just(b"1040 2 0".to_vec()),
        Just(b"1040 255 0".to_vec()),
        "[ 0-9.eE-]{0,40}".prop_map(String::into_bytes),
        proptest::collection::vec(any::<u8>(), 0..300),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(cases(400)))]

    #[test]
    fn arbitrary_text_never_panics_the_parser(bytes in proptest::collection::vec(any::<u8>(), 0..2000)) {
        let text = String::from_utf8_lossy(&bytes);
        let _ = fs020n_as::parse("fuzz.as", &text);
        let wrapped = format!(".PROGRAM p()\n{text}\n.END\n");
        let _ = fs020n_as::parse("fuzz.as", &wrapped);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(cases(150)))]

    #[test]
    fn random_programs_never_panic(seed in any::<u64>(), requests in proptest::collection::vec(request(), 0..6)) {
        let text = Gen(seed | 1).program();
        exercise(&text, 60, &requests);
    }

    #[test]
    fn mutated_server_text_never_panics(seed in any::<u64>(), n in 1usize..12, requests in proptest::collection::vec(request(), 1..8)) {
        let text = mutate(SERVER_1040, seed, n);
        exercise(&text, 120, &requests);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(cases(150)))]

    /// Statements typed at the terminal (`Interpreter::immediate`) while random programs run —
    /// generated statements, block statements cut in half and arbitrary bytes — never panic,
    /// and leave the loaded programs as they were.
    #[test]
    fn typed_statements_never_panic(seed in any::<u64>(), noise in proptest::collection::vec(any::<u8>(), 0..200)) {
        let mut g = Gen(seed | 1);
        let text = g.program();
        let Ok(module) = fs020n_as::parse("fuzz.as", &text) else {
            return Ok(());
        };
        let Ok(mut interp) = Interpreter::new(&[module], Config::default()) else {
            return Ok(());
        };
        let programs: Vec<String> = interp.programs().iter().map(|p| p.to_string()).collect();
        let mut sys = VirtualSystem::new();
        interp.start(&mut sys);
        let _ = interp.execute("main", &mut sys);
        let noise = String::from_utf8_lossy(&noise).into_owned();
        let mut t = Duration::ZERO;
        for k in 0..8u64 {
            t += Duration::from_millis(7);
            interp.run_until(&mut sys, t);
            let typed = match k % 4 {
                0 => g.stmt(2),
                1 => g.stmt(2).lines().next().unwrap_or("").to_owned(),
                2 => noise.clone(),
                _ => format!("TYPE {}", g.real(2)),
            };
            let _ = interp.immediate(&typed, &mut sys);
        }
        interp.run_until(&mut sys, t + Duration::from_millis(20));
        let after: Vec<String> = interp.programs().iter().map(|p| p.to_string()).collect();
        prop_assert_eq!(after, programs);
    }
}

#[test]
fn the_generator_produces_loadable_programs() {
    // The properties above are only meaningful if most random programs load.
    let loaded = (1..60u64)
        .filter(|s| exercise(&Gen(s * 7919).program(), 5, &[]))
        .count();
    assert!(loaded > 40, "{loaded} of 59 random programs loaded");
}
