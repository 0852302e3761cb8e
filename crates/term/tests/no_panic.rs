//! Any bytes, cut anywhere, into either end: no panic, bounded state, and the client always
//! comes back idle by its deadline.

use std::time::Duration;

use fs020n_term::frame::{controller_frame, Letter};
use fs020n_term::testing::{load_against, AnswerAnything};
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

/// Controller text a LOAD meets: frames, refusals, questions, prompts, arbitrary bytes.
fn controller_pieces() -> impl Strategy<Value = Vec<Vec<u8>>> {
    let piece = prop_oneof![
        Just(controller_frame(Letter::A, b"x.as")),
        Just(controller_frame(Letter::C, b"")),
        Just(controller_frame(Letter::C, b"")),
        Just(controller_frame(Letter::E, b"")),
        Just(b"(P1014)Cannot execute because program already in use.\r\n".to_vec()),
        Just(b"Loading...(x.as)\r\n".to_vec()),
        Just(b"Are you sure ? (Yes:1, No:0) ".to_vec()),
        Just(b"Load? (1:Yes, 0:No, 2:Load all, 3:Exit)".to_vec()),
        Just(b"STEP syntax error.\r\n(0:Change to comment and continue, 1:Delete program and abort)\r\n".to_vec()),
        Just(b"Confirm !\r\n".to_vec()),
        Just(b"Program x()\r\n".to_vec()),
        Just(b"File load completed. (0 errors)\r\n>".to_vec()),
        Just(b"\r\n>".to_vec()),
        prop::collection::vec(any::<u8>(), 0..12),
    ];
    prop::collection::vec(piece, 0..16)
}

proptest! {
    #[test]
    fn a_load_never_sends_a_block_after_a_refusal_and_always_ends_a_begun_transfer(
        input in controller_pieces()
    ) {
        let pieces: Vec<&[u8]> = input.iter().map(Vec::as_slice).collect();
        let run = load_against(&pieces);
        prop_assert!(!run.block_after_refusal, "{run:?}");
        prop_assert!(!run.began || run.ended || run.returned, "{run:?}");
        prop_assert!(run.idle && run.finished, "{run:?}");
    }

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
