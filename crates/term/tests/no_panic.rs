//! Any bytes, cut anywhere, into either end: no panic, bounded state, and the client always
//! comes back idle by its deadline.

use std::time::Duration;

use fs020n_term::testing::AnswerAnything;
use fs020n_term::{ClientConfig, Event, SessionConfig, TerminalClient, TerminalSession};
use proptest::prelude::*;

fn chunks() -> impl Strategy<Value = Vec<Vec<u8>>> {
    let byte = prop_oneof![
        any::<u8>(),
        Just(0x02u8),
        Just(0x05),
        Just(0x17),
        Just(0x1A),
        Just(0xFF),
        Just(b'\r'),
        Just(b'\n'),
        Just(b'C'),
        Just(b'A'),
        Just(b'>'),
    ];
    prop::collection::vec(prop::collection::vec(byte, 0..64), 0..24)
}

proptest! {
    #[test]
    fn a_session_takes_any_bytes(input in chunks()) {
        let mut m = AnswerAnything;
        let mut s = TerminalSession::open(&mut m, SessionConfig { max_piece: 7, save_chunk: 3, ..SessionConfig::default() });
        for c in &input {
            s.handle_input(&mut m, c);
            while s.poll_transmit().is_some() {}
        }
        s.handle_close(&mut m);
        prop_assert!(s.is_closed());
    }

    #[test]
    fn a_client_takes_any_bytes_and_is_idle_after_its_deadline(input in chunks(), op in 0u8..4) {
        let config = ClientConfig::default();
        let mut c = TerminalClient::new(config.clone());
        let mut now = Duration::ZERO;
        match op {
            0 => c.login(now).unwrap(),
            1 => c.command(now, "PCSTATUS 1:", true).unwrap(),
            2 => c.load(now, "x.as", b".PROGRAM x()\n.END\n").unwrap(),
            _ => c.save(now, "x.as").unwrap(),
        }
        for chunk in &input {
            now += Duration::from_millis(1);
            c.handle_input(now, chunk);
            while c.poll_transmit().is_some() {}
        }
        // However the bytes left it, time alone brings it back to idle.
        for _ in 0..10_000 {
            match c.poll_timeout() {
                Some(t) => {
                    now = now.max(t);
                    c.handle_timeout(now);
                    while c.poll_transmit().is_some() {}
                }
                None => break,
            }
        }
        prop_assert!(c.is_idle());
        let mut finished = false;
        while let Some(e) = c.poll_event() {
            finished |= !matches!(e, Event::Answered { .. });
        }
        prop_assert!(finished);
    }
}
