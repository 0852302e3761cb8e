//! A small controller behind the terminal session, for the tests: programs by name, a
//! transfer lock, the last load's answer.
#![allow(dead_code)]

use std::collections::BTreeMap;

use fs020n_term::text::{self, MonitorError};
use fs020n_term::{LoadAnswer, Monitor, Reply, SyntaxError};

/// A small controller for the session: programs by name, a switch, a transfer lock.
#[derive(Default)]
pub(crate) struct Shelf {
    pub(crate) programs: BTreeMap<String, String>,
    pub(crate) sessions: usize,
    pub(crate) blocked: bool,
    pub(crate) abandoned: usize,
    pub(crate) pending_kill: Option<String>,
    pub(crate) last_answer: Option<LoadAnswer>,
    pub(crate) received: Vec<u8>,
    /// What `1` to the next question prints instead of doing it.
    pub(crate) refuse_confirmed: Option<MonitorError>,
    /// The lines typed after `Change?`, in order.
    pub(crate) edits: Vec<String>,
}

fn programs_of(file: &[u8]) -> Vec<(String, String)> {
    let text = String::from_utf8_lossy(file);
    let mut out = Vec::new();
    let mut current: Option<(String, String)> = None;
    for line in text.lines() {
        if let Some(rest) = line.trim().strip_prefix(".PROGRAM ") {
            let name = rest.split('(').next().unwrap_or("").trim().to_owned();
            current = Some((name, String::new()));
        } else if line.trim() == ".END" {
            out.extend(current.take());
        } else if let Some((_, body)) = &mut current {
            body.push_str(line);
            body.push_str("\r\n");
        }
    }
    out
}

impl Monitor for Shelf {
    fn open_session(&mut self) -> Option<String> {
        (self.sessions < text::MAX_SESSIONS).then(|| {
            self.sessions += 1;
            format!("AUX{}", self.sessions)
        })
    }
    fn close_session(&mut self, _terminal: &str) {
        self.sessions -= 1;
    }
    fn run(&mut self, line: &str) -> Reply {
        let (word, rest) = fs020n_term::server::split_word(line);
        match word.to_ascii_uppercase().as_str() {
            "DIRECTORY/P" => Reply::Lines(vec![
                "Program list".into(),
                self.programs.keys().cloned().collect::<Vec<_>>().join(" "),
            ]),
            // Offers made-up values for editing; an edit line is recorded and shown back.
            "HERE" => Reply::Change(vec!["JT1 JT2".into(), "1.000 2.000".into()]),
            "KILL" => match self.programs.contains_key(rest) {
                true => {
                    self.pending_kill = Some(rest.to_owned());
                    Reply::AreYouSure
                }
                false => Reply::Error(text::P1038_NO_PROGRAM),
            },
            _ => Reply::Error(text::UNKNOWN_COMMAND),
        }
    }
    fn confirmed(&mut self) -> Reply {
        if let Some(e) = self.refuse_confirmed {
            self.pending_kill = None;
            return Reply::Error(e);
        }
        if let Some(name) = self.pending_kill.take() {
            self.programs.remove(&name);
        }
        Reply::Lines(vec![])
    }
    fn change(&mut self, line: &str) -> Reply {
        if line.is_empty() {
            return Reply::Lines(vec![]);
        }
        self.edits.push(line.to_owned());
        Reply::Change(vec!["JT1 JT2".into(), line.to_owned()])
    }
    fn transfer_blocked(&self) -> bool {
        self.blocked
    }
    fn transfer_abandoned(&mut self) {
        self.abandoned += 1;
        self.blocked = true;
    }
    fn check_load(&mut self, file: &[u8]) -> Vec<SyntaxError> {
        self.received = file.to_vec();
        String::from_utf8_lossy(file)
            .lines()
            .filter(|l| l.contains("NOT AS"))
            .map(|l| SyntaxError {
                line: l.trim().to_owned(),
            })
            .collect()
    }
    fn finish_load(&mut self, file: &[u8], answer: LoadAnswer) -> (Vec<String>, usize) {
        self.last_answer = Some(answer.clone());
        if answer == LoadAnswer::Abort {
            return (vec![], 1);
        }
        let mut lines = Vec::new();
        for (name, body) in programs_of(file) {
            lines.push(text::program_loaded(&name, ""));
            self.programs.insert(name, body);
        }
        (lines, 0)
    }
    fn save(&mut self, spec: &str) -> Result<Vec<u8>, MonitorError> {
        let name = spec.split('=').nth(1).unwrap_or("").trim();
        match self.programs.get(name) {
            Some(body) => Ok(format!(".PROGRAM {name}()\r\n{body}.END\r\n").into_bytes()),
            None => Err(text::P1038_NO_PROGRAM),
        }
    }
}
