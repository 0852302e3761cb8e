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
//! A question is looked for in the last lines of what came, not only at the very end: a
//! program's `PRINT` or `Program completed.No = 1` may follow it.
//!
//! A `LOAD` always ends cleanly once begun: an unexpected question (`Load? (1:Yes, 0:No, 2:Load
//! all, 3:Exit)` answered **3**, `Force load` answered **0**, `Press ENTER.` answered with a
//! line end, `Are you sure ?` not answered at all) or a refusal printed in the middle stops the
//! blocks: the client sends the end of file at once or at the next request, acknowledges the
//! end frame, then fails with [`TerminalError::LoadInterrupted`]. A controller that stops
//! asking for blocks gets the end of file at the deadline. No block is sent after a refusal.
//!
//! Telnet: before login the client answers the terminal-type option (`WILL TTYPE`, then
//! `TTYPE IS VT100`), which some controllers wait for before `login:`; after login it sends no
//! telnet command.

use std::collections::VecDeque;
use std::time::Duration;

mod reading;

pub use reading::Question;
use reading::{
    completed_errors, last_line, load_ending, loaded_programs, pending_question, quoted_step,
    strip_echo,
};

use crate::frame::{client_frame, Letter, Piece, Scanner, Sender, SUB};
use crate::telnet::{TelnetCommand, TelnetFilter, DO, IAC, OPT_TERMINAL_TYPE, SB, SE, WILL};
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
    /// The terminal type answered to the controller's terminal-type option before login
    /// (`VT100`, as the vendor's terminal and the clients of D controllers send); `None`
    /// answers no telnet option.
    pub terminal_type: Option<&'static str>,
}

impl Default for ClientConfig {
    fn default() -> Self {
        ClientConfig {
            line_end: b"\r\n",
            block_bytes: 480,
            quiet: Duration::from_millis(40),
            timeout: Duration::from_secs(10),
            terminal_type: Some("VT100"),
        }
    }
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
        /// The programs the controller said it loaded (`Program name()`), lower case, in
        /// order.
        programs: Vec<String>,
        /// The last line of the load (`File load completed. (0 errors)` or `Loading
        /// done.`), when one came.
        ending: Option<String>,
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
    /// The `LOAD` was stopped in the middle (an unexpected question, a refusal, a stall): the
    /// client sent the end of file and closed the transfer, so nothing is left open — but
    /// what was loaded is uncertain.
    #[error("the LOAD was stopped before the end of the file ({why}); the client ended the transfer cleanly (end of file, end frame): list the programs (DIRECTORY/P) to see what the controller kept, then load again")]
    LoadInterrupted {
        /// What stopped it (the question or the refusal, as printed).
        why: String,
        /// The text of the load.
        output: String,
    },
    /// A transfer began and could not be closed: the controller neither asked for the end of
    /// file nor ended it (it waits for an answer the client will not give).
    #[error("the controller stopped in the middle of the LOAD ({why}) and did not end the transfer; answer it on the teach pendant or a terminal, or restart the controller if the next LOAD reports P2076")]
    TransferLeftOpen {
        /// What it waited for.
        why: String,
        /// The text of the load.
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
        /// Why no more blocks are sent (a question, a refusal, a stall).
        interrupted: Option<String>,
        /// Bytes of text when the transfer began (a prompt before that does not end it).
        began_at: usize,
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
    /// The user name was sent: no telnet option is answered any more.
    login_sent: bool,
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
            login_sent: false,
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
                interrupted: None,
                began_at: 0,
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
        let commands = self.telnet.push(bytes, &mut data);
        if !self.login_sent {
            for c in commands {
                self.answer_option(&c);
            }
        }
        let mut pieces = Vec::new();
        self.scanner.push(&data, &mut pieces);
        if !pieces.is_empty() {
            self.last_input = now;
            self.quiet_seen = false;
        }
        for piece in pieces {
            match piece {
                Piece::Text(t) => {
                    self.text.extend_from_slice(&t);
                    self.refusal_in_transfer();
                }
                Piece::Frame { letter, payload } => self.on_frame(now, letter, payload),
                Piece::Malformed { .. } => {}
            }
        }
    }

    /// The terminal-type option, answered before login only.
    fn answer_option(&mut self, c: &TelnetCommand) {
        let Some(tt) = self.config.terminal_type else {
            return;
        };
        match c {
            TelnetCommand::Negotiate {
                verb: DO,
                option: OPT_TERMINAL_TYPE,
            } => self.transmit.push_back(vec![IAC, WILL, OPT_TERMINAL_TYPE]),
            // SEND (1): the answer is IS (0) and the name.
            TelnetCommand::Subnegotiation {
                option: OPT_TERMINAL_TYPE,
                data,
            } if data.first() == Some(&1) => {
                let mut v = vec![IAC, SB, OPT_TERMINAL_TYPE, 0];
                v.extend_from_slice(tt.as_bytes());
                v.extend_from_slice(&[IAC, SE]);
                self.transmit.push_back(v);
            }
            _ => {}
        }
    }

    /// A refusal printed before or while blocks are going: no block is sent after it (the
    /// transfer, once begun, is ended with the end of file).
    fn refusal_in_transfer(&mut self) {
        if let Op::Load {
            phase: Phase::Opening | Phase::Transfer,
            eof_sent: false,
            interrupted,
            ..
        } = &mut self.op
        {
            if interrupted.is_none() {
                let start = self.acted.min(self.text.len());
                let fresh = lossy(&self.text[start..]);
                // Only whole lines: a refusal's text may come in pieces.
                let whole = fresh.rsplit_once('\n').map_or("", |(w, _)| w);
                // Coded refusals and the "already …" ones: a quoted step of a syntax error may
                // hold any word.
                if let Some(r) =
                    text::refusal(whole).filter(|r| r.code.is_some() || r.line.contains("already"))
                {
                    *interrupted = Some(r.line);
                }
            }
        }
    }

    fn on_frame(&mut self, now: Duration, letter: Letter, payload: Vec<u8>) {
        let step = self.config.timeout;
        let block = self.config.block_bytes.max(1);
        match (&mut self.op, letter) {
            (
                Op::Load {
                    phase, began_at, ..
                },
                Letter::A,
            ) if *phase == Phase::Opening => {
                *phase = Phase::Transfer;
                *began_at = self.text.len();
                self.transmit.push_back(client_frame(Letter::A, b""));
            }
            (
                Op::Load {
                    data,
                    offset,
                    eof_sent,
                    phase: Phase::Transfer,
                    syntax_error,
                    interrupted,
                    ..
                },
                Letter::C,
            ) => {
                if *offset < data.len() && syntax_error.is_none() && interrupted.is_none() {
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
            // A transfer that stalls gets its end of file first (a begun transfer is always
            // ended), then a last step's time.
            if let Op::Load {
                phase: Phase::Transfer,
                eof_sent,
                interrupted,
                ..
            } = &mut self.op
            {
                if !*eof_sent {
                    *eof_sent = true;
                    interrupted.get_or_insert_with(|| {
                        format!(
                            "the controller stopped asking for blocks for {:?}",
                            self.config.timeout
                        )
                    });
                    self.transmit.push_back(client_frame(Letter::C, &[SUB]));
                    self.deadline = Some(now + self.config.timeout);
                    return;
                }
            }
            let output = lossy(&self.text);
            let failure = match &self.op {
                Op::Load {
                    phase: Phase::Transfer,
                    interrupted,
                    ..
                } => TerminalError::TransferLeftOpen {
                    why: interrupted
                        .clone()
                        .unwrap_or_else(|| "no end frame after the end of file".to_owned()),
                    output,
                },
                op => TerminalError::Timeout {
                    waiting_for: match op {
                        Op::Login { .. } => "the login",
                        Op::Command { .. } => "the command",
                        Op::Load { .. } => "the LOAD",
                        Op::Save { .. } => "the SAVE",
                        Op::Idle => "nothing",
                    },
                    timeout: self.config.timeout,
                    output,
                },
            };
            self.finish(Event::Failed(failure));
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
        let at_prompt = self.text.ends_with(text::PROMPT);
        // Questions first: they end without a prompt (unsolicited lines may follow them).
        if !at_prompt {
            if let Some((question, context)) = pending_question(&tail) {
                self.acted = self.text.len();
                self.on_question(question, &context);
                self.deadline = Some(now + self.config.timeout);
                return;
            }
        }
        let trimmed = tail.trim_end();
        match &mut self.op {
            Op::Login { sent } => {
                if !*sent && trimmed.ends_with(text::LOGIN_PROMPT.trim_end()) {
                    *sent = true;
                    self.login_sent = true;
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
            // A prompt that came before the transfer began does not end it.
            Op::Load {
                phase,
                syntax_error,
                interrupted,
                began_at,
                ..
            } if at_prompt
                && (*phase == Phase::Opening
                    || self.text.len() >= *began_at + text::PROMPT.len()) =>
            {
                let all = lossy(&self.text);
                let syntax_error = syntax_error.clone();
                let output = strip_echo(&all, "");
                if *phase == Phase::Opening {
                    let failure = if text::monitor_error_code(last_line(&all))
                        == Some(text::P2076_TRANSFER_IN_PROGRESS.code)
                        || all.contains("LOAD in progress")
                    {
                        TerminalError::TransferInProgress
                    } else {
                        TerminalError::TransferRefused { output }
                    };
                    self.finish(Event::Failed(failure));
                } else if let Some(why) = interrupted.clone() {
                    self.finish(Event::Failed(TerminalError::LoadInterrupted {
                        why,
                        output,
                    }));
                } else if *phase == Phase::Transfer {
                    // Back at its prompt without the end frame: the controller ended the
                    // transfer itself; what it kept is unknown.
                    let why = "the controller returned to its prompt before the end of the \
                               transfer"
                        .to_owned();
                    self.finish(Event::Failed(TerminalError::LoadInterrupted {
                        why,
                        output,
                    }));
                } else {
                    let errors =
                        completed_errors(&all).unwrap_or(usize::from(syntax_error.is_some()));
                    self.finish(Event::Loaded {
                        errors,
                        syntax_error,
                        programs: loaded_programs(&all),
                        ending: load_ending(&all),
                        output,
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

    /// Answers a question the way this operation must (`context`: the text up to the
    /// question's line, for the syntax error's quoted step).
    fn on_question(&mut self, question: Question, context: &str) {
        let in_load = matches!(self.op, Op::Load { .. });
        let answer: Option<&'static str> = match &question {
            Question::AreYouSure if in_load => None,
            Question::AreYouSure => Some(if matches!(self.op, Op::Command { confirm: true, .. }) {
                "1"
            } else {
                "0"
            }),
            Question::SyntaxError(_) => Some(text::ANSWER_ABORT_LOAD),
            Question::Confirm | Question::PressEnter | Question::Change => Some(""),
            Question::MorePages => Some(" "),
            Question::LoadQuery => Some(text::ANSWER_LOAD_EXIT),
            Question::ForceLoad => Some(text::ANSWER_FORCE_LOAD_STOP),
        };
        let question = match question {
            Question::SyntaxError(_) => Question::SyntaxError(quoted_step(context)),
            q => q,
        };
        if let Op::Load {
            syntax_error,
            interrupted,
            eof_sent,
            phase,
            ..
        } = &mut self.op
        {
            match &question {
                Question::SyntaxError(step) => {
                    syntax_error.get_or_insert_with(|| step.clone());
                }
                Question::Confirm | Question::MorePages => {}
                other => {
                    let line = context.lines().last().unwrap_or("").trim().to_owned();
                    interrupted.get_or_insert_with(|| match other {
                        Question::AreYouSure => format!(
                            "the controller asked `{line}` in the middle of the LOAD; the \
                             client does not answer it there"
                        ),
                        _ => format!("the controller asked `{line}`"),
                    });
                    // Not answered: the transfer is ended from here.
                    if answer.is_none() && *phase == Phase::Transfer && !*eof_sent {
                        *eof_sent = true;
                        self.transmit.push_back(client_frame(Letter::C, &[SUB]));
                    }
                }
            }
        }
        if let Some(answer) = answer {
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
