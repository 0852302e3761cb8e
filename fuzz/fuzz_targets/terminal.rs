//! The AS terminal's two ends (fs020n-term) on arbitrary bytes: the controller's session and
//! the deploy client, each fed the input cut at a byte the input chooses. Never panics, and the
//! client is always idle again after its deadline.
#![no_main]

use std::time::Duration;

use fs020n_term::testing::AnswerAnything;
use fs020n_term::{ClientConfig, SessionConfig, TerminalClient, TerminalSession};
use libfuzzer_sys::fuzz_target;


fuzz_target!(|data: &[u8]| {
    let Some((&cut, rest)) = data.split_first() else {
        return;
    };
    let cut = usize::from(cut).min(rest.len());
    let (a, b) = rest.split_at(cut);

    let mut m = AnswerAnything;
    let mut s = TerminalSession::open(&mut m, SessionConfig::default());
    for part in [a, b] {
        s.handle_input(&mut m, part);
        while s.poll_transmit().is_some() {}
    }
    s.handle_close(&mut m);

    let mut c = TerminalClient::new(ClientConfig::default());
    let mut now = Duration::ZERO;
    let _ = c.load(now, "x.as", b".PROGRAM x()\n.END\n");
    for part in [a, b] {
        now += Duration::from_millis(1);
        c.handle_input(now, part);
        while c.poll_transmit().is_some() {}
    }
    for _ in 0..10_000 {
        let Some(t) = c.poll_timeout() else { break };
        now = now.max(t);
        c.handle_timeout(now);
        while c.poll_transmit().is_some() {}
    }
    assert!(c.is_idle());
});
