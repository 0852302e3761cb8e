//! The terminal client as a state machine: no sockets, no clocks.
//!
//! In quinn's shape: the driver feeds what the controller sent ([`TerminalClient::handle_input`])
//! and the time when the next deadline comes ([`TerminalClient::handle_timeout`]), sends what
//! [`TerminalClient::poll_transmit`] gives, sleeps until [`TerminalClient::poll_timeout`], and
//! reads the outcome from [`TerminalClient::poll_event`]. One operation runs at a time: the
//! login, a command ([`TerminalClient::command`]), a `LOAD` ([`TerminalClient::load`]) or a
//! `SAVE` ([`TerminalClient::save`]).
//!
//! How a reply ends. The controller ends every reply with CR LF `>`, but `>` may also come
//! inside output, and text can arrive at any time. So an output counts as complete when it
//! ends with the prompt and nothing more arrives for the quiet time
//! ([`ClientConfig::quiet`]); a question (a text ending in its choices) is answered the same
//! way. The client answers the questions of a `LOAD` itself, always the safe way: a syntax
//! error with **1** (delete the program and abort), never "change to comment"; `Confirm !`
//! with a line end; a paged listing with a blank.
//!
//! The client sends no telnet commands and answers none (the controller works without).

use std::collections::VecDeque;
use std::time::Duration;

use crate::frame::{client_frame, Letter, Piece, Scanner, Sender, SUB};
use crate::telnet::TelnetFilter;
use crate::text;

/// How the client talks.
#[derive(Debug, Clone, PartialEq)]
pub struct ClientConfig {
    /// What ends a line the client sends (CR LF, as most clients send; CR and LF alone work
    /// too).
    pub line_end: &'static [u8],
    /// Bytes of the file per block of a `LOAD` (the smallest block any client uses on a
    /// D controller is 486 bytes; 480 is safe on every generation).
    pub block_bytes: usize,
    /// How long the controller must stay silent after a prompt or a question before the
    /// client acts on it.
    pub quiet: Duration,
    /// How long a command, the login, or one step of a transfer may take.
    pub timeout: Duration,
}

impl Default for ClientConfig {
    fn default() -> Self {
        ClientConfig {
            line_end: b"\r\n",
            block_bytes: 480,
            quiet: Duration::from_millis(40),
            timeout: Duration::from_secs(10),
        }
    }
}

/// A question the controller asked and how the client answered it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Question {
    /// `Are you sure ? (Yes:1, No:0)`.
    AreYouSure,
    /// A syntax error in the middle of a `LOAD`, with the line the controller quoted.
    SyntaxError(String),
    /// `Confirm !`.
    Confirm,
    /// `Press SPACE key to continue.`
    MorePages,
}

/// What the client saw complete.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Event {
    /// Logged in; the terminal's name when the greeting gave one (`AUX1`).
    LoggedIn {
        /// The name in the greeting.
        terminal: Option<String>,
    },
    /// A question was answered (for the transcript; the operation goes on).
    Answered {
        /// The question.
        question: Question,
        /// What the client sent.
        answer: String,
    },
    /// A command's output, without its echo and the final prompt, lines joined by `\n`.
    Reply {
        /// The command as sent.
        command: String,
        /// The output.
        output: String,
    },
    /// A `LOAD` ended (completed or aborted on a syntax error: see `syntax_error`).
    Loaded {
        /// Errors the controller counted.
        errors: usize,
        /// The first syntax error the controller asked about (the load was aborted there).
        syntax_error: Option<String>,
        /// The text of the load, frames left out.
        output: String,
    },
    /// A `SAVE` ended.
    Saved {
        /// The file as the controller sent it.
        file: Vec<u8>,
        /// The text of the save, frames left out.
        output: String,
    },
    /// The operation failed; the client is idle again.
    Failed(TerminalError),
}

/// Why an operation failed.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum TerminalError {
    /// Nothing complete within the timeout.
    #[error("the controller's terminal did not answer {waiting_for} within {timeout:?}; check that the address is the controller's terminal port (23) and that nothing else holds it")]
    Timeout {
        /// What the client waited for.
        waiting_for: &'static str,
        /// The timeout.
        timeout: Duration,
        /// What came meanwhile.
        output: String,
    },
    /// P2076: an earlier LOAD or SAVE never ended.
    #[error("the controller reports an earlier SAVE/LOAD still in progress (P2076); a transfer was left unfinished (a client that stopped answering, or a link that dropped): restart the controller, then load again")]
    TransferInProgress,
    /// The controller refused the `LOAD` or `SAVE` before the transfer began.
    #[error("the controller refused the transfer: {output}")]
    TransferRefused {
        /// What it printed.
        output: String,
    },
    /// Another operation is running.
    #[error("the terminal client is busy with another operation")]
    Busy,
    /// Text that cannot be sent: a control character, or longer than the controller reads.
    #[error("{0}")]
    Unsendable(String),
}

#[derive(Debug, Clone, PartialEq)]
enum Phase {
    /// Waiting for the transfer's first frame (A or B).
    Opening,
    /// Blocks going (LOAD) or coming (SAVE).
    Transfer,
    /// E exchanged: waiting for the last line and the prompt.
    Closing,
}

#[derive(Debug, Clone, PartialEq)]
enum Op {
    Idle,
    Login {
        sent: bool,
    },
    Command {
        line: String,
        confirm: bool,
    },
    Load {
        data: Vec<u8>,
        offset: usize,
        eof_sent: bool,
        phase: Phase,
        syntax_error: Option<String>,
    },
    Save {
        phase: Phase,
        file: Vec<u8>,
    },
}

/// The sans-IO terminal client (see the module's documentation).
#[derive(Debug)]
pub struct TerminalClient {
    config: ClientConfig,
    telnet: TelnetFilter,
    scanner: Scanner,
    op: Op,
    /// Text since the operation began (frames left out).
    text: Vec<u8>,
    /// Bytes of `text` already acted on (questions answered).
    acted: usize,
    last_input: Duration,
    /// The text since the last input was examined after its quiet time.
    quiet_seen: bool,
    deadline: Option<Duration>,
    transmit: VecDeque<Vec<u8>>,
    events: VecDeque<Event>,
}

impl TerminalClient {
    /// A client at the start of a connection: call [`login`](Self::login) first.
    pub fn new(config: ClientConfig) -> TerminalClient {
        TerminalClient {
            config,
            telnet: TelnetFilter::new(),
            scanner: Scanner::new(Sender::Controller),
            op: Op::Idle,
            text: Vec::new(),
            acted: 0,
            last_input: Duration::ZERO,
            quiet_seen: true,
            deadline: None,
            transmit: VecDeque::new(),
            events: VecDeque::new(),
        }
    }

    /// `true` when no operation runs.
    pub fn is_idle(&self) -> bool {
        self.op == Op::Idle
    }

    /// Logs in (user `as`, no password) once the controller asks.
    pub fn login(&mut self, now: Duration) -> Result<(), TerminalError> {
        self.begin(now, Op::Login { sent: false })
    }

    /// Sends one monitor command and waits for its prompt. With `confirm`, a question
    /// `Are you sure ? (Yes:1, No:0)` is answered `1` (`KILL`, `PCKILL`, `DELETE`); without,
    /// it is answered `0`.
    pub fn command(
        &mut self,
        now: Duration,
        line: &str,
        confirm: bool,
    ) -> Result<(), TerminalError> {
        check_line(line)?;
        self.begin(
            now,
            Op::Command {
                line: line.to_owned(),
                confirm,
            },
        )?;
        self.send_line(line);
        Ok(())
    }

    /// Loads a file: types `LOAD name`, then sends `data` in blocks as the controller asks.
    /// A syntax-error question is answered **1** (the program is deleted, the load aborted).
    pub fn load(&mut self, now: Duration, name: &str, data: &[u8]) -> Result<(), TerminalError> {
        let line = format!("LOAD {name}");
        check_line(&line)?;
        if let Some(b) = data
            .iter()
            .find(|b| matches!(**b, 0x02 | 0x05 | 0x17 | SUB))
        {
            return Err(TerminalError::Unsendable(format!(
                "the file holds the control byte 0x{b:02X}, which the block transfer uses; remove it"
            )));
        }
        let mut data = data.to_vec();
        // The last line must end with a line end, or the controller loses it.
        if !data.is_empty() && !data.ends_with(b"\n") {
            data.extend_from_slice(b"\r\n");
        }
        self.begin(
            now,
            Op::Load {
                data,
                offset: 0,
                eof_sent: false,
                phase: Phase::Opening,
                syntax_error: None,
            },
        )?;
        self.send_line(&line);
        Ok(())
    }

    /// Saves: types `SAVE spec` (e.g. `SAVE/P backup.as=name`) and collects the file.
    pub fn save(&mut self, now: Duration, spec: &str) -> Result<(), TerminalError> {
        let line = format!("SAVE {spec}");
        check_line(&line)?;
        self.begin(
            now,
            Op::Save {
                phase: Phase::Opening,
                file: Vec::new(),
            },
        )?;
        self.send_line(&line);
        Ok(())
    }

    fn begin(&mut self, now: Duration, op: Op) -> Result<(), TerminalError> {
        if self.op != Op::Idle {
            return Err(TerminalError::Busy);
        }
        self.op = op;
        self.text.clear();
        self.acted = 0;
        self.last_input = now;
        self.deadline = Some(now + self.config.timeout);
        Ok(())
    }

    fn send_line(&mut self, line: &str) {
        let mut v = line.as_bytes().to_vec();
        v.extend_from_slice(self.config.line_end);
        self.transmit.push_back(v);
    }

    /// The next bytes to send.
    pub fn poll_transmit(&mut self) -> Option<Vec<u8>> {
        self.transmit.pop_front()
    }

    /// The next event.
    pub fn poll_event(&mut self) -> Option<Event> {
        self.events.pop_front()
    }

    /// When [`handle_timeout`](Self::handle_timeout) must be called next.
    pub fn poll_timeout(&self) -> Option<Duration> {
        if self.op == Op::Idle {
            return None;
        }
        let quiet = self.last_input + self.config.quiet;
        match self.deadline {
            Some(d) if !self.quiet_seen => Some(quiet.min(d)),
            Some(d) => Some(d),
            None => None,
        }
    }

    /// Feeds bytes from the controller.
    pub fn handle_input(&mut self, now: Duration, bytes: &[u8]) {
        let mut data = Vec::with_capacity(bytes.len());
        self.telnet.push(bytes, &mut data);
        let mut pieces = Vec::new();
        self.scanner.push(&data, &mut pieces);
        if !pieces.is_empty() {
            self.last_input = now;
            self.quiet_seen = false;
        }
        for piece in pieces {
            match piece {
                Piece::Text(t) => self.text.extend_from_slice(&t),
                Piece::Frame { letter, payload } => self.on_frame(now, letter, payload),
                Piece::Malformed { .. } => {}
            }
        }
    }

    fn on_frame(&mut self, now: Duration, letter: Letter, payload: Vec<u8>) {
        let step = self.config.timeout;
        let block = self.config.block_bytes.max(1);
        match (&mut self.op, letter) {
            (Op::Load { phase, .. }, Letter::A) if *phase == Phase::Opening => {
                *phase = Phase::Transfer;
                self.transmit.push_back(client_frame(Letter::A, b""));
            }
            (
                Op::Load {
                    data,
                    offset,
                    eof_sent,
                    phase: Phase::Transfer,
                    syntax_error,
                },
                Letter::C,
            ) => {
                if *offset < data.len() && syntax_error.is_none() {
                    let end = (*offset + block).min(data.len());
                    self.transmit
                        .push_back(client_frame(Letter::C, &data[*offset..end]));
                    *offset = end;
                } else if !*eof_sent {
                    *eof_sent = true;
                    self.transmit.push_back(client_frame(Letter::C, &[SUB]));
                }
            }
            (Op::Save { phase, .. }, Letter::B) if *phase == Phase::Opening => {
                *phase = Phase::Transfer;
                self.transmit.push_back(client_frame(Letter::B, b""));
            }
            (Op::Save { file, .. }, Letter::D) => file.extend_from_slice(&payload),
            (Op::Load { phase, .. } | Op::Save { phase, .. }, Letter::E) => {
                *phase = Phase::Closing;
                self.transmit.push_back(client_frame(Letter::E, b""));
            }
            _ => {}
        }
        self.deadline = Some(now + step);
    }

    /// Acts on the time: a quiet controller after a prompt or a question, or a deadline.
    pub fn handle_timeout(&mut self, now: Duration) {
        if self.op == Op::Idle {
            return;
        }
        if !self.quiet_seen && now >= self.last_input + self.config.quiet {
            self.quiet_seen = true;
            if self.text.len() > self.acted {
                self.on_quiet(now);
            }
        }
        if self.op != Op::Idle && self.deadline.is_some_and(|d| now >= d) {
            let waiting_for = match &self.op {
                Op::Login { .. } => "the login",
                Op::Command { .. } => "the command",
                Op::Load { .. } => "the LOAD",
                Op::Save { .. } => "the SAVE",
                Op::Idle => "nothing",
            };
            let output = lossy(&self.text);
            self.finish(Event::Failed(TerminalError::Timeout {
                waiting_for,
                timeout: self.config.timeout,
                output,
            }));
        }
    }

    fn on_quiet(&mut self, now: Duration) {
        // Text a program prints (PRINT to every terminal) may follow the prompt already sent:
        // the reply ends at the last prompt when only whole lines came after it, and those
        // lines are not part of it.
        if !self.text.ends_with(text::PROMPT) {
            let start = self.acted.min(self.text.len());
            if let Some(i) = self.text[start..]
                .windows(text::PROMPT.len())
                .rposition(|w| w == text::PROMPT)
            {
                let end = start + i + text::PROMPT.len();
                if self.text[end..].ends_with(b"\r\n") {
                    self.text.truncate(end);
                }
            }
        }
        let tail = lossy(&self.text[self.acted..]);
        let trimmed = tail.trim_end();
        let at_prompt = self.text.ends_with(text::PROMPT);
        // Questions first: they end without a prompt.
        if let Some((question, answer)) = self.question(trimmed) {
            self.acted = self.text.len();
            self.send_answer(question, answer);
            self.deadline = Some(now + self.config.timeout);
            return;
        }
        match &mut self.op {
            Op::Login { sent } => {
                if !*sent && trimmed.ends_with(text::LOGIN_PROMPT.trim_end()) {
                    *sent = true;
                    self.acted = self.text.len();
                    self.send_line(text::LOGIN_USER);
                    self.deadline = Some(now + self.config.timeout);
                } else if at_prompt {
                    let all = lossy(&self.text);
                    let terminal = all
                        .split("terminal \"")
                        .nth(1)
                        .and_then(|r| r.split('"').next())
                        .map(str::to_owned);
                    self.finish(Event::LoggedIn { terminal });
                }
            }
            Op::Command { line, .. } if at_prompt => {
                let command = line.clone();
                let output = strip_echo(&lossy(&self.text), &command);
                self.finish(Event::Reply { command, output });
            }
            Op::Load {
                phase,
                syntax_error,
                ..
            } if at_prompt => {
                let all = lossy(&self.text);
                let syntax_error = syntax_error.clone();
                if *phase == Phase::Opening {
                    let failure = if text::monitor_error_code(last_line(&all))
                        == Some(text::P2076_TRANSFER_IN_PROGRESS.code)
                        || all.contains("LOAD in progress")
                    {
                        TerminalError::TransferInProgress
                    } else {
                        TerminalError::TransferRefused {
                            output: strip_echo(&all, ""),
                        }
                    };
                    self.finish(Event::Failed(failure));
                } else {
                    let errors =
                        completed_errors(&all).unwrap_or(usize::from(syntax_error.is_some()));
                    self.finish(Event::Loaded {
                        errors,
                        syntax_error,
                        output: strip_echo(&all, ""),
                    });
                }
            }
            Op::Save { phase, file } if at_prompt => {
                let all = lossy(&self.text);
                if *phase == Phase::Opening {
                    let failure = if all.contains("LOAD in progress") {
                        TerminalError::TransferInProgress
                    } else {
                        TerminalError::TransferRefused {
                            output: strip_echo(&all, ""),
                        }
                    };
                    self.finish(Event::Failed(failure));
                } else {
                    let file = std::mem::take(file);
                    self.finish(Event::Saved {
                        file,
                        output: strip_echo(&all, ""),
                    });
                }
            }
            _ => {}
        }
    }

    /// The question `tail` ends with, and the answer this operation gives.
    fn question(&mut self, tail: &str) -> Option<(Question, &'static str)> {
        if tail.ends_with("(Yes:1, No:0)") {
            let yes = matches!(self.op, Op::Command { confirm: true, .. });
            return Some((Question::AreYouSure, if yes { "1" } else { "0" }));
        }
        if tail.ends_with(')') && tail.contains(text::DELETE_AND_ABORT_MARK) {
            // The offending step, when the controller printed it before the question.
            let quoted = tail
                .lines()
                .map(str::trim)
                .rfind(|l| {
                    !l.is_empty()
                        && !l.contains(text::DELETE_AND_ABORT_MARK)
                        && *l != text::SYNTAX_ERROR
                        && !l.starts_with("Loading...")
                })
                .unwrap_or(text::SYNTAX_ERROR)
                .to_owned();
            if let Op::Load { syntax_error, .. } = &mut self.op {
                syntax_error.get_or_insert_with(|| quoted.clone());
            }
            return Some((Question::SyntaxError(quoted), text::ANSWER_ABORT_LOAD));
        }
        if tail.ends_with("Confirm !") {
            return Some((Question::Confirm, ""));
        }
        if tail.ends_with(text::PRESS_SPACE) {
            return Some((Question::MorePages, " "));
        }
        None
    }

    fn send_answer(&mut self, question: Question, answer: &'static str) {
        if question == Question::MorePages {
            self.transmit.push_back(b" ".to_vec());
        } else {
            self.send_line(answer);
        }
        self.events.push_back(Event::Answered {
            question,
            answer: answer.to_owned(),
        });
    }

    fn finish(&mut self, event: Event) {
        self.op = Op::Idle;
        self.deadline = None;
        self.acted = self.text.len();
        self.events.push_back(event);
    }
}

/// Refuses what cannot be typed: control characters, and lines longer than the controller reads.
fn check_line(line: &str) -> Result<(), TerminalError> {
    if line.chars().any(char::is_control) {
        return Err(TerminalError::Unsendable(format!(
            "{line:?} holds a control character; a command is one line of text"
        )));
    }
    if line.len() > text::MAX_LINE_CHARS {
        return Err(TerminalError::Unsendable(format!(
            "the command is {} characters; the controller reads only {}",
            line.len(),
            text::MAX_LINE_CHARS
        )));
    }
    Ok(())
}

fn lossy(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

fn last_line(s: &str) -> &str {
    s.trim_end_matches('>')
        .trim_end()
        .lines()
        .last()
        .unwrap_or("")
}

/// `N` of `File load completed. (N errors)`.
fn completed_errors(s: &str) -> Option<usize> {
    let rest = &s[s.rfind(text::LOAD_COMPLETED_MARK)?..];
    let open = rest.find('(')?;
    rest[open + 1..]
        .split_whitespace()
        .next()
        .and_then(|n| n.parse().ok())
}

/// The output of a command: its echo line and the final prompt removed, CR dropped, lines
/// joined by `\n`.
fn strip_echo(all: &str, command: &str) -> String {
    let body = all.strip_suffix('>').unwrap_or(all);
    let mut lines: Vec<&str> = body.split('\n').map(|l| l.trim_end_matches('\r')).collect();
    // The echo; lines before it were printed by a program while the command was on its way.
    if let Some(i) = lines
        .iter()
        .position(|l| !command.is_empty() && l.trim().eq_ignore_ascii_case(command.trim()))
    {
        lines.drain(..=i);
    }
    while lines.last().is_some_and(|l| l.trim().is_empty()) {
        lines.pop();
    }
    while lines.first().is_some_and(|l| l.trim().is_empty()) {
        lines.remove(0);
    }
    lines.join("\n")
}
