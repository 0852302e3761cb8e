//! Test doubles (feature `testing`): a [`Monitor`] that answers every input, for the
//! property tests and the fuzz target that feed a session arbitrary bytes.

use crate::server::{LoadAnswer, Monitor, Reply, SyntaxError};
use crate::text::MonitorError;

/// A controller that answers everything, and in every way the session knows: an even-length
/// command asks "Are you sure", an odd one echoes; a `LOAD` of `n` bytes finds `n % 3` syntax
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
        } else {
            Reply::Lines(vec![line.to_owned()])
        }
    }
    fn confirmed(&mut self) -> Reply {
        Reply::Lines(vec![])
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
