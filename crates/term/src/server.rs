//! The controller's side of one terminal session as a state machine: no sockets, no clocks.
//!
//! [`TerminalSession`] plays the protocol — the telnet opening, login, echo, the prompt, line
//! ends, the `LOAD`/`SAVE` block transfer and the questions — and leaves what the commands *do*
//! to the controller behind it, a [`Monitor`]. The emulator implements `Monitor` on its
//! machine and interpreter; this crate's tests implement a small one.
//!
//! Feed bytes with [`TerminalSession::handle_input`]; send what
//! [`TerminalSession::poll_transmit`] gives. Text the controller prints on its own (a PC
//! program's end, `PRINT` output) goes through [`TerminalSession::print_unsolicited`].

use std::collections::VecDeque;

use crate::frame::{controller_frame, Letter, Piece, Scanner, Sender, SUB};
use crate::line::LineReader;
use crate::telnet::{
    TelnetCommand, TelnetFilter, CONTROLLER_OPENING, DO, IAC, OPT_TERMINAL_TYPE, SB, SE, WILL,
};
use crate::text::{self, MonitorError};

/// What a monitor command printed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Reply {
    /// Lines of output (none for a silent success).
    Lines(Vec<String>),
    /// A monitor error line, `(Pnnnn)text`.
    Error(MonitorError),
    /// Ask `Are you sure ? (Yes:1, No:0)` first; on `1`, [`Monitor::confirmed`] runs.
    AreYouSure,
    /// Values offered for editing (`HERE`, `POINT`): the lines, then `Change? (If not, Hit
    /// RETURN only)`; each line typed next goes to [`Monitor::change`], which answers with
    /// the edited values (asked again) or, for an empty line, ends the editing.
    Change(Vec<String>),
}

/// A syntax error found while loading: the session asks the controller's question about it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SyntaxError {
    /// The offending line as the controller quotes it.
    pub line: String,
}

/// How a load ended, for [`Monitor::finish_load`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum LoadAnswer {
    /// Every syntax error was answered "change to comment and continue" (or there was none):
    /// keep the file with those lines commented out.
    Keep,
    /// A syntax error was answered "delete program and abort".
    Abort,
}

/// The controller behind the terminal.
pub trait Monitor {
    /// The terminal's name for a new session (`AUX1`…), or `None` when every slot is taken.
    fn open_session(&mut self) -> Option<String>;
    /// The session ended (its slot is free again).
    fn close_session(&mut self, terminal: &str);
    /// Runs one command line (not `LOAD`/`SAVE`, which the session handles).
    fn run(&mut self, line: &str) -> Reply;
    /// The user answered `1` to the question of the last command.
    fn confirmed(&mut self) -> Reply;
    /// A line typed after `Change?` ([`Reply::Change`]): comma-separated new values (an empty
    /// field keeps its value), or an empty line, which ends the editing (answer with
    /// [`Reply::Lines`]: the prompt follows).
    fn change(&mut self, line: &str) -> Reply;
    /// `true` while an earlier transfer was left open (every `LOAD`/`SAVE` gets P2076).
    fn transfer_blocked(&self) -> bool;
    /// A transfer was left open: the link dropped or the client stopped mid-transfer.
    fn transfer_abandoned(&mut self);
    /// Checks a whole received file: its syntax errors, in order.
    fn check_load(&mut self, file: &[u8]) -> Vec<SyntaxError>;
    /// Loads the checked file (or not, on `Abort`); returns the lines to print (one
    /// `Program name()` per program) and the count of errors to report.
    fn finish_load(&mut self, file: &[u8], answer: LoadAnswer) -> (Vec<String>, usize);
    /// The file a `SAVE` spec asks for (`/P backup.as=prog`), or an error.
    fn save(&mut self, spec: &str) -> Result<Vec<u8>, MonitorError>;
}

/// The controller generation whose terminal a session plays (see [`SessionConfig::of`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Generation {
    /// C series.
    C,
    /// D series.
    D,
    /// E series (the default: the captures are of E controllers).
    #[default]
    E,
    /// F series.
    F,
}

impl std::str::FromStr for Generation {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.to_ascii_lowercase().as_str() {
            "c" => Ok(Generation::C),
            "d" => Ok(Generation::D),
            "e" => Ok(Generation::E),
            "f" => Ok(Generation::F),
            _ => Err(format!(
                "unknown controller generation {s:?}: give c, d, e or f"
            )),
        }
    }
}

/// The last line of a `LOAD`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LoadEnding {
    /// `File load completed. (N errors)` (E and F captures).
    Completed,
    /// `Loading done.`, no count (the E manual's example).
    Done,
}

/// How the session talks.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SessionConfig {
    /// Largest piece of output handed out at once: a real controller's text comes in pieces
    /// (one virtual controller sends 1–16 bytes at a time). `usize::MAX` for whole replies.
    pub max_piece: usize,
    /// Bytes per `D` frame of a `SAVE`.
    pub save_chunk: usize,
    /// Before `login:`, ask the terminal type (`DO TTYPE`) and wait for `WILL TTYPE` and the
    /// type (`SB TTYPE IS …`), as some controllers do (**M**: a D controller's client and the
    /// vendor's terminal answer it); otherwise the E controller's opening, which needs no
    /// answer.
    pub ttype_login: bool,
    /// The last line of a `LOAD`.
    pub load_ending: LoadEnding,
    /// After the end of a `LOAD`'s file, print `Confirm !` and wait for a line (**M**).
    pub confirm_after_load: bool,
    /// The controller refuses to load a program whose name is in memory and aborts the LOAD
    /// there (AS-E p.5-34); otherwise it overwrites it (K-ROSET, real-robot macros). Read by
    /// the [`Monitor`] (the emulator), not by the session.
    pub refuse_overwrite: bool,
    /// A test hook: questions asked, one after the other, after the first block of every
    /// `LOAD` (`Load? (1:Yes, 0:No, 2:Load all, 3:Exit)`, `Press ENTER.`, `Are you sure ?
    /// (Yes:1, No:0) `…). Any line answers one; the client's end of file ends them all.
    pub load_questions: Vec<String>,
}

impl Default for SessionConfig {
    fn default() -> Self {
        SessionConfig {
            max_piece: usize::MAX,
            save_chunk: 512,
            ttype_login: false,
            load_ending: LoadEnding::Completed,
            confirm_after_load: false,
            refuse_overwrite: false,
            load_questions: Vec::new(),
        }
    }
}

impl SessionConfig {
    /// The terminal of a generation: C and D ask the terminal type before login, end a
    /// `LOAD` with `Loading done.` after `Confirm !`, and refuse to overwrite a program (the
    /// manual's and the older clients' account, **L** for C); E and F as captured (no option
    /// needed, `File load completed. (N errors)`, programs overwritten).
    pub fn of(generation: Generation) -> SessionConfig {
        let older = matches!(generation, Generation::C | Generation::D);
        SessionConfig {
            ttype_login: older,
            load_ending: if older {
                LoadEnding::Done
            } else {
                LoadEnding::Completed
            },
            confirm_after_load: older,
            refuse_overwrite: older,
            ..SessionConfig::default()
        }
    }
}

#[derive(Debug, Clone, PartialEq, Eq)]
enum State {
    /// Waiting for the client's terminal type before `login:`.
    TerminalType,
    Login,
    Monitor,
    Confirm,
    /// Values offered for editing: the next line goes to [`Monitor::change`].
    Change,
    LoadOpening,
    LoadBlocks,
    /// A question of [`SessionConfig::load_questions`]: `next` is the one asked.
    LoadExtra {
        next: usize,
    },
    /// `Confirm !` after the end of file, then the syntax errors found.
    LoadConfirm {
        errors: Vec<SyntaxError>,
    },
    LoadQuestion {
        errors: Vec<SyntaxError>,
        next: usize,
    },
    LoadClosing {
        answer: LoadAnswer,
        syntax_errors: usize,
    },
    SaveOpening {
        file: Vec<u8>,
    },
    SaveClosing,
    Closed,
}

/// One terminal session (see the module's documentation).
#[derive(Debug)]
pub struct TerminalSession {
    config: SessionConfig,
    terminal: Option<String>,
    telnet: TelnetFilter,
    scanner: Scanner,
    lines: LineReader,
    state: State,
    file_name: String,
    file: Vec<u8>,
    out: VecDeque<u8>,
    /// The last byte typed was a CR (a LF right after it is the same line end).
    after_cr: bool,
    /// `Are you sure ?` was just answered by its key: a line end typed after it belongs to the
    /// answer (it is swallowed, not an empty command).
    after_answer: bool,
    /// The last byte queued for the client.
    last_byte: u8,
}

impl TerminalSession {
    /// A session on a new connection: the opening, the banner and `login: ` are queued. When
    /// the monitor has no free slot, the session says so and is closed at once.
    pub fn open(monitor: &mut impl Monitor, config: SessionConfig) -> TerminalSession {
        let terminal = monitor.open_session();
        let mut s = TerminalSession {
            config,
            terminal,
            telnet: TelnetFilter::new(),
            scanner: Scanner::new(Sender::Client),
            lines: LineReader::new(),
            state: State::Login,
            file_name: String::new(),
            file: Vec::new(),
            out: VecDeque::new(),
            after_cr: false,
            after_answer: false,
            last_byte: 0,
        };
        if s.config.ttype_login {
            s.out.extend([IAC, DO, OPT_TERMINAL_TYPE]);
        } else {
            s.out.extend(CONTROLLER_OPENING);
        }
        if s.terminal.is_none() {
            s.say(&format!("\r{}\r\n", "All terminal sessions are in use."));
            s.state = State::Closed;
        } else if s.config.ttype_login {
            s.state = State::TerminalType;
        } else {
            s.greet();
        }
        s
    }

    fn greet(&mut self) {
        self.say(&format!("\r{}\r\n\r\n{}", text::BANNER, text::LOGIN_PROMPT));
        self.state = State::Login;
    }

    /// The client's telnet answers while the session waits for its terminal type.
    fn on_telnet(&mut self, c: TelnetCommand) {
        if self.state != State::TerminalType {
            return;
        }
        match c {
            TelnetCommand::Negotiate {
                verb: WILL,
                option: OPT_TERMINAL_TYPE,
            } => self.out.extend([IAC, SB, OPT_TERMINAL_TYPE, 1, IAC, SE]),
            TelnetCommand::Subnegotiation {
                option: OPT_TERMINAL_TYPE,
                data,
            } if data.first() == Some(&0) && data.len() > 1 => self.greet(),
            _ => {}
        }
    }

    /// The config the session runs with.
    pub fn config(&self) -> &SessionConfig {
        &self.config
    }

    /// `true` once the session has ended (the driver closes the connection).
    pub fn is_closed(&self) -> bool {
        self.state == State::Closed && self.out.is_empty()
    }

    /// `true` while a `LOAD` or `SAVE` of this session has begun and not ended (its
    /// question included): the controller refuses other transfers meanwhile (P2076).
    pub fn in_transfer(&self) -> bool {
        matches!(
            self.state,
            State::LoadOpening
                | State::LoadBlocks
                | State::LoadExtra { .. }
                | State::LoadConfirm { .. }
                | State::LoadQuestion { .. }
                | State::LoadClosing { .. }
                | State::SaveOpening { .. }
                | State::SaveClosing
        )
    }

    /// The terminal's name (`AUX1`), once logged in or refused (`None`).
    pub fn terminal(&self) -> Option<&str> {
        self.terminal.as_deref()
    }

    /// The next bytes to send (at most [`SessionConfig::max_piece`]).
    pub fn poll_transmit(&mut self) -> Option<Vec<u8>> {
        if self.out.is_empty() {
            return None;
        }
        let n = self.out.len().min(self.config.max_piece.max(1));
        Some(self.out.drain(..n).collect())
    }

    /// Text the controller prints on its own, at any time (after the prompt already sent).
    /// At the prompt and while `Are you sure ?` waits for its answer (on a line of its own:
    /// the question stays pending); not during a transfer.
    pub fn print_unsolicited(&mut self, line: &str) {
        match self.state {
            State::Monitor | State::Change => self.say(&format!("{line}\r\n")),
            State::Confirm => self.say(&format!("\r\n{line}")),
            _ => {}
        }
    }

    /// The connection ended: a transfer in progress is left open on the controller.
    pub fn handle_close(&mut self, monitor: &mut impl Monitor) {
        if self.in_transfer() {
            monitor.transfer_abandoned();
        }
        if self.state != State::Closed {
            if let Some(t) = &self.terminal {
                monitor.close_session(t);
            }
        }
        self.state = State::Closed;
        self.out.clear();
    }

    /// Feeds bytes from the client.
    pub fn handle_input(&mut self, monitor: &mut impl Monitor, bytes: &[u8]) {
        let mut data = Vec::with_capacity(bytes.len());
        for c in self.telnet.push(bytes, &mut data) {
            self.on_telnet(c);
        }
        let mut pieces = Vec::new();
        self.scanner.push(&data, &mut pieces);
        for piece in pieces {
            match piece {
                Piece::Frame { letter, payload } => self.on_frame(monitor, letter, payload),
                Piece::Malformed { .. } => {}
                Piece::Text(t) => self.on_text(monitor, &t),
            }
        }
    }

    fn on_text(&mut self, monitor: &mut impl Monitor, bytes: &[u8]) {
        if matches!(self.state, State::Closed) {
            return;
        }
        // The controller echoes what is typed (it offered WILL ECHO), except during a transfer.
        let typing = matches!(
            self.state,
            State::Login
                | State::Monitor
                | State::Confirm
                | State::Change
                | State::LoadQuestion { .. }
                | State::LoadExtra { .. }
                | State::LoadConfirm { .. }
        );
        let mut lines = Vec::new();
        for &b in bytes {
            if std::mem::take(&mut self.after_answer) && matches!(b, b'\r' | b'\n') {
                // `1` CR LF: the line end after the answer's key.
                self.after_answer = true;
                self.after_cr = b == b'\r';
                continue;
            }
            if self.state == State::Confirm && b.is_ascii_graphic() {
                // The question takes one key (a client may send `1` alone and wait for the
                // prompt); it is echoed on the question's line and acted on at once.
                self.after_cr = false;
                self.after_answer = true;
                self.emit(&[b, b'\r', b'\n']);
                self.state = State::Monitor;
                if b == b'1' {
                    let reply = monitor.confirmed();
                    self.reply(reply);
                } else {
                    self.prompt();
                }
                continue;
            }
            let after_cr = std::mem::replace(&mut self.after_cr, b == b'\r');
            if typing {
                match b {
                    // A line end is echoed as CR LF, once, before what the line prints.
                    b'\n' if after_cr => {}
                    b'\r' | b'\n' => self.emit(b"\r\n"),
                    0 => {}
                    _ => self.emit(&[b]),
                }
            }
            self.lines.push(std::slice::from_ref(&b), &mut lines);
            for line in lines.drain(..) {
                self.on_line(monitor, &line.text());
            }
        }
    }

    fn on_line(&mut self, monitor: &mut impl Monitor, line: &str) {
        let line = line.trim();
        match std::mem::replace(&mut self.state, State::Monitor) {
            State::Login => {
                if line.eq_ignore_ascii_case(text::LOGIN_USER) {
                    let name = self.terminal.clone().unwrap_or_default();
                    self.say(&text::greeting(&name));
                    self.prompt();
                } else {
                    self.say(text::LOGIN_PROMPT);
                    self.state = State::Login;
                }
            }
            State::Monitor => self.on_command(monitor, line),
            // An empty line (or blanks) answers no; a key answers at once (`on_text`).
            State::Confirm => self.prompt(),
            State::Change => {
                let reply = monitor.change(line);
                self.reply(reply);
            }
            State::LoadExtra { next } => self.ask_extra(next + 1),
            State::LoadConfirm { errors } => self.ask_or_close(errors, 0),
            State::LoadQuestion { errors, next } => {
                if line == text::ANSWER_ABORT_LOAD {
                    self.close_load(LoadAnswer::Abort, next + 1);
                } else if line == text::ANSWER_COMMENT_OUT {
                    self.ask_or_close(errors, next + 1);
                } else {
                    self.state = State::LoadQuestion { errors, next };
                }
            }
            other => self.state = other,
        }
    }

    fn on_command(&mut self, monitor: &mut impl Monitor, line: &str) {
        let (word, rest) = split_word(line);
        let word_upper = word.to_ascii_uppercase();
        if line.is_empty() {
            self.prompt();
        } else if is_abbreviation(&word_upper, "LOAD", 2) {
            self.begin_transfer(monitor, rest, true);
        } else if is_abbreviation(&word_upper, "SAVE", 2) || word_upper.starts_with("SAVE/") {
            let spec = if word_upper.starts_with("SAVE/") {
                format!("{} {rest}", &word[4..])
            } else {
                rest.to_owned()
            };
            self.begin_transfer(monitor, spec.trim(), false);
        } else {
            let reply = monitor.run(line);
            self.reply(reply);
        }
    }

    fn begin_transfer(&mut self, monitor: &mut impl Monitor, spec: &str, load: bool) {
        if monitor.transfer_blocked() {
            self.reply(Reply::Error(text::P2076_TRANSFER_IN_PROGRESS));
            return;
        }
        if load {
            let name = spec.trim();
            if name.is_empty() {
                self.reply(Reply::Error(text::P0117_INVALID_NAME));
                return;
            }
            self.file_name = name.to_owned();
            self.file.clear();
            self.out
                .extend(controller_frame(Letter::A, name.as_bytes()));
            self.state = State::LoadOpening;
        } else {
            match monitor.save(spec) {
                Ok(file) => {
                    let name = spec
                        .rsplit(' ')
                        .next()
                        .unwrap_or("")
                        .split('=')
                        .next()
                        .unwrap_or("")
                        .to_owned();
                    let name = if name.contains('.') {
                        name
                    } else {
                        format!("{name}.as")
                    };
                    self.file_name = name.clone();
                    self.emit(&controller_frame(Letter::B, name.as_bytes()));
                    self.state = State::SaveOpening { file };
                }
                Err(e) => self.reply(Reply::Error(e)),
            }
        }
    }

    fn on_frame(&mut self, monitor: &mut impl Monitor, letter: Letter, payload: Vec<u8>) {
        match (std::mem::replace(&mut self.state, State::Monitor), letter) {
            (State::LoadOpening, Letter::A) => {
                let line = text::loading(&self.file_name);
                self.say(&format!("{line}\r\n"));
                self.emit(&controller_frame(Letter::C, b""));
                self.state = State::LoadBlocks;
            }
            (State::LoadBlocks | State::LoadExtra { .. }, Letter::C) => {
                // A block whose data ends with SUB is the end of the file, its data first
                // (one client ends with CR LF SUB).
                let first = self.file.is_empty();
                if let Some(data) = payload.strip_suffix(&[SUB]) {
                    self.file.extend_from_slice(data);
                    let errors = monitor.check_load(&self.file);
                    if self.config.confirm_after_load {
                        self.say(&format!("{}\r\n", text::CONFIRM));
                        self.state = State::LoadConfirm { errors };
                    } else {
                        self.ask_or_close(errors, 0);
                    }
                } else {
                    self.file.extend_from_slice(&payload);
                    if first && !self.config.load_questions.is_empty() {
                        self.ask_extra(0);
                    } else {
                        self.emit(&controller_frame(Letter::C, b""));
                        self.state = State::LoadBlocks;
                    }
                }
            }
            (
                State::LoadClosing {
                    answer,
                    syntax_errors,
                },
                Letter::E,
            ) => {
                let file = std::mem::take(&mut self.file);
                let (lines, errors) = monitor.finish_load(&file, answer);
                for l in lines {
                    self.say(&format!("{l}\r\n"));
                }
                match self.config.load_ending {
                    LoadEnding::Completed => {
                        self.say(&text::load_completed(errors.max(syntax_errors)));
                    }
                    LoadEnding::Done => self.say(text::LOADING_DONE),
                }
                self.prompt();
            }
            (State::SaveOpening { file }, Letter::B) => {
                let line = text::saving(&self.file_name);
                self.say(&format!("{line}\r\n"));
                for chunk in file.chunks(self.config.save_chunk.max(1)) {
                    self.emit(&controller_frame(Letter::D, chunk));
                }
                self.emit(&controller_frame(Letter::E, b""));
                self.state = State::SaveClosing;
            }
            (State::SaveClosing, Letter::E) => {
                self.say(text::SAVE_COMPLETED);
                self.prompt();
            }
            (other, _) => self.state = other,
        }
    }

    /// Asks extra question `next` (the test hook), or asks for the next block when none is
    /// left.
    fn ask_extra(&mut self, next: usize) {
        match self.config.load_questions.get(next).cloned() {
            Some(q) => {
                self.say(&format!("\r\n{q}"));
                self.state = State::LoadExtra { next };
            }
            None => {
                self.emit(&controller_frame(Letter::C, b""));
                self.state = State::LoadBlocks;
            }
        }
    }

    /// Asks about syntax error `next`, or closes the load when none is left.
    fn ask_or_close(&mut self, errors: Vec<SyntaxError>, next: usize) {
        match errors.get(next) {
            Some(e) => {
                self.say(&format!(
                    "\r\n{}\r\n{}\r\n{}\r\n",
                    e.line,
                    text::SYNTAX_ERROR,
                    text::SYNTAX_ERROR_CHOICES
                ));
                self.state = State::LoadQuestion { errors, next };
            }
            None => {
                self.emit(&controller_frame(Letter::E, b""));
                self.state = State::LoadClosing {
                    answer: LoadAnswer::Keep,
                    syntax_errors: next,
                };
            }
        }
    }

    fn close_load(&mut self, answer: LoadAnswer, errors: usize) {
        self.emit(&controller_frame(Letter::E, b""));
        self.state = State::LoadClosing {
            answer,
            syntax_errors: errors,
        };
    }

    fn reply(&mut self, reply: Reply) {
        match reply {
            Reply::Lines(lines) => {
                let text = lines.join("\r\n");
                self.say(&text);
                self.prompt();
            }
            Reply::Error(e) => {
                self.say(&e.line());
                self.prompt();
            }
            Reply::AreYouSure => {
                self.say(text::ARE_YOU_SURE);
                self.state = State::Confirm;
            }
            Reply::Change(lines) => {
                for l in lines {
                    self.say(&format!("{l}\r\n"));
                }
                self.say(text::CHANGE_QUESTION);
                self.say("\r\n");
                self.state = State::Change;
            }
        }
    }

    /// The prompt: CR LF `>`, where the CR LF is the echo's when nothing was printed since.
    fn prompt(&mut self) {
        if self.last_byte == b'\n' {
            self.emit(b">");
        } else {
            self.emit(text::PROMPT);
        }
        self.state = State::Monitor;
    }

    fn say(&mut self, s: &str) {
        self.emit(s.as_bytes());
    }

    fn emit(&mut self, bytes: &[u8]) {
        if let Some(&b) = bytes.last() {
            self.last_byte = b;
        }
        self.out.extend(bytes);
    }
}

/// The first word of a line and the rest, trimmed.
pub fn split_word(line: &str) -> (&str, &str) {
    let line = line.trim();
    match line.find([' ', '\t']) {
        Some(i) => (&line[..i], line[i..].trim()),
        None => (line, ""),
    }
}

/// `true` when `word` (upper case) abbreviates `keyword` with at least `min` characters, as the
/// monitor accepts abbreviated keywords (`PCEXE` for `PCEXECUTE`).
pub fn is_abbreviation(word: &str, keyword: &str, min: usize) -> bool {
    word.len() >= min.min(keyword.len()) && keyword.starts_with(word)
}
