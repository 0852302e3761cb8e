//! Test doubles (feature `testing`): a [`Monitor`] that answers every input, for the
//! property tests and the fuzz target that feed a session arbitrary bytes; and
//! [`load_against`], the client's `LOAD` against arbitrary controller text with the promises
//! it keeps checked, for the property test and the fuzz target of the client.

use std::time::Duration;

use crate::client::{ClientConfig, Event, TerminalClient};
use crate::frame::{Letter, Piece, Scanner, Sender, SUB};
use crate::server::{LoadAnswer, Monitor, Reply, SyntaxError};
use crate::telnet::TelnetFilter;
use crate::text::{self, MonitorError};

/// A controller that answers everything, and in every way the session knows: an even-length
/// command asks "Are you sure", an odd one of a length divisible by 3 offers itself for
/// editing (`Change?`, until an empty line), another odd one echoes; a `LOAD` of `n` bytes finds `n % 3` syntax
/// errors; `SAVE` sends its own spec back.
#[derive(Debug, Default, Clone, Copy)]
pub struct AnswerAnything;

impl Monitor for AnswerAnything {
    fn open_session(&mut self) -> Option<String> {
        Some("AUX1".into())
    }
    fn close_session(&mut self, _terminal: &str) {}
    fn run(&mut self, line: &str) -> Reply {
        if line.len() % 2 == 0 {
            Reply::AreYouSure
        } else if line.len() % 3 == 0 {
            Reply::Change(vec![line.to_owned()])
        } else {
            Reply::Lines(vec![line.to_owned()])
        }
    }
    fn confirmed(&mut self) -> Reply {
        Reply::Lines(vec![])
    }
    fn change(&mut self, line: &str) -> Reply {
        if line.is_empty() {
            Reply::Lines(vec![])
        } else {
            Reply::Change(vec![line.to_owned()])
        }
    }
    fn transfer_blocked(&self) -> bool {
        false
    }
    fn transfer_abandoned(&mut self) {}
    fn check_load(&mut self, file: &[u8]) -> Vec<SyntaxError> {
        (0..file.len() % 3)
            .map(|i| SyntaxError {
                line: format!("step {i}"),
            })
            .collect()
    }
    fn finish_load(&mut self, _file: &[u8], _answer: LoadAnswer) -> (Vec<String>, usize) {
        (vec![], 0)
    }
    fn save(&mut self, spec: &str) -> Result<Vec<u8>, MonitorError> {
        Ok(spec.as_bytes().to_vec())
    }
}

/// What a `LOAD` did against arbitrary controller text (see [`load_against`]).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct LoadRun {
    /// The client accepted the transfer (sent its `A`).
    pub began: bool,
    /// The client ended it: it sent the end of file or acknowledged the controller's `E`.
    pub ended: bool,
    /// The controller printed its prompt after the transfer began (it ended it itself).
    pub returned: bool,
    /// A block of the file was sent after the controller printed a coded refusal line
    /// (`(Pnnnn)…`): a broken promise.
    pub block_after_refusal: bool,
    /// The client was idle again once time had passed.
    pub idle: bool,
    /// The operation ended with an event (loaded, or failed).
    pub finished: bool,
}

/// Runs the client's `LOAD` of a small file against a controller that sends `input` (each
/// piece at its own millisecond, fed byte by byte so that what the client sends is seen in
/// order), then lets time pass until the client is idle. The promises: it never panics; no
/// block after a refusal; a begun transfer is always ended; idle again by its deadlines.
pub fn load_against(input: &[&[u8]]) -> LoadRun {
    let mut run = LoadRun::default();
    let mut c = TerminalClient::new(ClientConfig::default());
    let mut now = Duration::ZERO;
    let file = b".PROGRAM x()\n  a = 1\n  b = 2\n.END\n.PROGRAM y()\n  c = 3\n.END\n";
    if c.load(now, "x.as", file).is_err() {
        return run;
    }
    // The controller's text as the client reads it, and what the client sends.
    let mut telnet = TelnetFilter::new();
    let mut seen = Scanner::new(Sender::Controller);
    let mut line = Vec::new();
    let mut refused = false;
    let mut sent = Scanner::new(Sender::Client);
    let mut check = |c: &mut TerminalClient, run: &mut LoadRun, refused: bool| {
        while let Some(bytes) = c.poll_transmit() {
            let mut pieces = Vec::new();
            sent.push(&bytes, &mut pieces);
            for p in pieces {
                if let Piece::Frame { letter, payload } = p {
                    match letter {
                        Letter::A => run.began = true,
                        Letter::E => run.ended |= run.began,
                        Letter::C if payload.last() == Some(&SUB) => run.ended |= run.began,
                        Letter::C => run.block_after_refusal |= refused,
                        _ => {}
                    }
                }
            }
        }
    };
    for piece in input {
        now += Duration::from_millis(1);
        for b in piece.iter() {
            c.handle_input(now, std::slice::from_ref(b));
            let mut data = Vec::new();
            telnet.push(std::slice::from_ref(b), &mut data);
            let mut pieces = Vec::new();
            seen.push(&data, &mut pieces);
            for p in pieces {
                if let Piece::Text(t) = p {
                    for &ch in &t {
                        if ch == b'>' && line.is_empty() && run.began {
                            run.returned = true;
                        }
                        if ch == b'\n' {
                            let l = String::from_utf8_lossy(&line).into_owned();
                            refused |= text::refusal(&l).is_some_and(|r| r.code.is_some());
                            line.clear();
                        } else {
                            line.push(ch);
                        }
                    }
                }
            }
            check(&mut c, &mut run, refused);
        }
    }
    for _ in 0..10_000 {
        let Some(t) = c.poll_timeout() else { break };
        now = now.max(t);
        c.handle_timeout(now);
        check(&mut c, &mut run, refused);
    }
    run.idle = c.is_idle();
    while let Some(e) = c.poll_event() {
        run.finished |= !matches!(e, Event::Answered { .. });
    }
    run
}
