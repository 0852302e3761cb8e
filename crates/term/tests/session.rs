//! The terminal client against the terminal session, in memory on a fake clock: every exchange
//! the deploy client relies on, with the controller's output cut in small pieces and the
//! client's line ends in each form terminals use.

mod common;

use std::time::Duration;

use common::Shelf;
use fs020n_term::text;
use fs020n_term::{
    ClientConfig, Event, Generation, LoadAnswer, Monitor, Question, SessionConfig, TerminalClient,
    TerminalError, TerminalSession,
};

/// Both ends on one fake clock.
struct Link {
    now: Duration,
    client: TerminalClient,
    session: TerminalSession,
    shelf: Shelf,
    /// Every event the client produced, in order.
    events: Vec<Event>,
}

impl Link {
    fn new(client: ClientConfig, piece: usize) -> Link {
        Link::with(
            client,
            SessionConfig {
                max_piece: piece,
                ..SessionConfig::default()
            },
        )
    }

    fn with(client: ClientConfig, session: SessionConfig) -> Link {
        let mut shelf = Shelf::default();
        let session = TerminalSession::open(&mut shelf, session);
        Link {
            now: Duration::ZERO,
            client: TerminalClient::new(client),
            session,
            shelf,
            events: Vec::new(),
        }
    }

    /// Runs until the client is idle again; returns the events of this operation.
    fn settle(&mut self) -> Vec<Event> {
        let start = self.events.len();
        for _ in 0..100_000 {
            let mut moved = false;
            while let Some(bytes) = self.client.poll_transmit() {
                self.session.handle_input(&mut self.shelf, &bytes);
                moved = true;
            }
            while let Some(bytes) = self.session.poll_transmit() {
                self.now += Duration::from_micros(100);
                self.client.handle_input(self.now, &bytes);
                moved = true;
            }
            while let Some(e) = self.client.poll_event() {
                self.events.push(e);
            }
            if self.client.is_idle() {
                return self.events[start..].to_vec();
            }
            if !moved {
                match self.client.poll_timeout() {
                    Some(t) => {
                        self.now = self.now.max(t);
                        self.client.handle_timeout(self.now);
                    }
                    None => break,
                }
            }
        }
        panic!("the exchange did not settle: {:?}", self.events);
    }

    fn login(&mut self) {
        self.client.login(self.now).unwrap();
        let events = self.settle();
        assert_eq!(
            events,
            vec![Event::LoggedIn {
                terminal: Some("AUX1".into())
            }]
        );
    }

    fn command(&mut self, line: &str, confirm: bool) -> Vec<Event> {
        self.client.command(self.now, line, confirm).unwrap();
        self.settle()
    }
}

fn file_of(size: usize) -> Vec<u8> {
    let mut f = b".PROGRAM big()\r\n".to_vec();
    let mut i = 0;
    while f.len() < size {
        f.extend_from_slice(format!("  x{i} = {i}\r\n").as_bytes());
        i += 1;
    }
    f.extend_from_slice(b".END\r\n.PROGRAM autostart.pc()\r\n  PRINT \"hi\"\r\n.END\r\n");
    f
}

#[test]
fn a_client_logs_in_and_a_command_replies_without_its_echo_and_prompt() {
    for (line_end, piece) in [(&b"\r\n"[..], usize::MAX), (b"\n", 1), (b"\r", 7)] {
        let mut link = Link::new(
            ClientConfig {
                line_end,
                ..ClientConfig::default()
            },
            piece,
        );
        link.login();
        let events = link.command("DIRECTORY/P", false);
        assert_eq!(
            events,
            vec![Event::Reply {
                command: "DIRECTORY/P".into(),
                output: "Program list".into()
            }],
            "line end {line_end:?}, pieces of {piece}"
        );
    }
}

#[test]
fn a_load_sends_the_file_in_blocks_as_asked_and_the_controller_gets_every_byte() {
    for block in [486, 1000, 3000] {
        let mut link = Link::new(
            ClientConfig {
                block_bytes: block,
                ..ClientConfig::default()
            },
            16,
        );
        link.login();
        let file = file_of(3_000);
        link.client.load(link.now, "deploy.as", &file).unwrap();
        let events = link.settle();
        assert_eq!(link.shelf.received, file, "blocks of {block}");
        match events.last() {
            Some(Event::Loaded {
                errors: 0,
                syntax_error: None,
                output,
                programs,
                ending,
            }) => {
                assert_eq!(programs, &["big", "autostart.pc"]);
                assert_eq!(ending.as_deref(), Some("File load completed. (0 errors)"));
                assert!(output.contains("Loading...(deploy.as)"), "{output}");
                assert!(output.contains("Program autostart.pc()"), "{output}");
                assert!(
                    output.contains("File load completed. (0 errors)"),
                    "{output}"
                );
            }
            other => panic!("{other:?}"),
        }
        assert!(link.shelf.programs.contains_key("autostart.pc"));
    }
}

#[test]
fn a_syntax_error_is_answered_abort_and_nothing_is_loaded() {
    let mut link = Link::new(ClientConfig::default(), 5);
    link.login();
    let file = b".PROGRAM bad()\r\n  THIS IS NOT AS\r\n.END\r\n";
    link.client.load(link.now, "bad.as", file).unwrap();
    let events = link.settle();
    assert_eq!(
        events[0],
        Event::Answered {
            question: Question::SyntaxError("THIS IS NOT AS".into()),
            answer: "1".into()
        }
    );
    match &events[1] {
        Event::Loaded {
            syntax_error: Some(line),
            errors,
            ..
        } => {
            assert_eq!(line, "THIS IS NOT AS");
            assert_eq!(*errors, 1);
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(link.shelf.last_answer, Some(LoadAnswer::Abort));
    assert!(link.shelf.programs.is_empty());
}

#[test]
fn a_blocked_transfer_is_p2076_and_the_client_says_to_restart() {
    let mut link = Link::new(ClientConfig::default(), usize::MAX);
    link.login();
    link.shelf.blocked = true;
    link.client
        .load(link.now, "x.as", b".PROGRAM x()\n.END\n")
        .unwrap();
    assert_eq!(
        link.settle(),
        vec![Event::Failed(TerminalError::TransferInProgress)]
    );
    assert!(TerminalError::TransferInProgress
        .to_string()
        .contains("restart the controller"));
}

#[test]
fn a_connection_dropped_mid_load_leaves_the_transfer_open() {
    let mut shelf = Shelf::default();
    let mut session = TerminalSession::open(&mut shelf, SessionConfig::default());
    session.handle_input(&mut shelf, b"as\r\nLOAD x.as\r\n");
    session.handle_close(&mut shelf);
    assert_eq!(shelf.abandoned, 1);
    assert!(shelf.transfer_blocked());
    assert_eq!(shelf.sessions, 0);
}

#[test]
fn kill_asks_are_you_sure_and_only_confirm_answers_yes() {
    let mut link = Link::new(ClientConfig::default(), 3);
    link.login();
    link.shelf.programs.insert("p".into(), String::new());
    let events = link.command("KILL p", false);
    assert_eq!(
        events[0],
        Event::Answered {
            question: Question::AreYouSure,
            answer: "0".into()
        }
    );
    assert!(link.shelf.programs.contains_key("p"));
    let events = link.command("KILL p", true);
    assert_eq!(
        events[0],
        Event::Answered {
            question: Question::AreYouSure,
            answer: "1".into()
        }
    );
    assert!(!link.shelf.programs.contains_key("p"));
}

#[test]
fn values_offered_for_editing_are_kept_with_a_line_end_and_the_reply_shows_them() {
    let mut link = Link::new(ClientConfig::default(), 4);
    link.login();
    let events = link.command("HERE #p", false);
    assert_eq!(
        events[0],
        Event::Answered {
            question: Question::Change,
            answer: String::new()
        }
    );
    match events.last() {
        Some(Event::Reply { output, .. }) => {
            assert!(output.contains("1.000 2.000"), "{output}");
            assert!(output.contains(text::CHANGE_QUESTION), "{output}");
        }
        other => panic!("{other:?}"),
    }
    assert!(link.shelf.edits.is_empty(), "a line end changes nothing");
}

#[test]
fn an_edit_line_after_change_is_offered_back_until_an_empty_line_ends_it() {
    let mut shelf = Shelf::default();
    let mut session = TerminalSession::open(&mut shelf, SessionConfig::default());
    session.handle_input(&mut shelf, b"as\r\n");
    while session.poll_transmit().is_some() {}
    let said = |session: &mut TerminalSession, shelf: &mut Shelf, line: &[u8]| {
        session.handle_input(shelf, line);
        let mut out = Vec::new();
        while let Some(p) = session.poll_transmit() {
            out.extend(p);
        }
        String::from_utf8_lossy(&out).into_owned()
    };
    let out = said(&mut session, &mut shelf, b"HERE #p\r\n");
    assert!(
        out.ends_with(&format!("{}\r\n", text::CHANGE_QUESTION)),
        "no prompt after the question: {out:?}"
    );
    let out = said(&mut session, &mut shelf, b",5\r\n");
    assert!(out.contains(",5\r\n"), "{out:?}");
    assert!(out.ends_with(&format!("{}\r\n", text::CHANGE_QUESTION)));
    assert_eq!(shelf.edits, [",5"]);
    let out = said(&mut session, &mut shelf, b"\r\n");
    assert!(
        out.ends_with('>'),
        "the prompt after an empty line: {out:?}"
    );
    let out = said(&mut session, &mut shelf, b"KILL x\r\n");
    assert!(out.contains("(P1038)"), "back at the monitor: {out:?}");
}

#[test]
fn a_monitor_error_comes_back_as_its_p_line() {
    let mut link = Link::new(ClientConfig::default(), usize::MAX);
    link.login();
    match &link.command("KILL nothing", true)[0] {
        Event::Reply { output, .. } => {
            assert_eq!(output, "(P1038)Program does not exist.");
            assert_eq!(text::monitor_error_code(output), Some(1038));
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn save_returns_the_file_the_controller_sent() {
    let mut link = Link::new(ClientConfig::default(), 9);
    link.login();
    link.client
        .load(link.now, "x.as", b".PROGRAM x()\r\n  a = 1\r\n.END\r\n")
        .unwrap();
    link.settle();
    link.client.save(link.now, "/P back.as=x").unwrap();
    match link.settle().last() {
        Some(Event::Saved { file, output }) => {
            assert_eq!(file, b".PROGRAM x()\r\n  a = 1\r\n.END\r\n");
            assert!(output.contains(text::SAVE_COMPLETED), "{output}");
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn a_silent_controller_fails_the_command_at_its_timeout() {
    let mut client = TerminalClient::new(ClientConfig::default());
    client.command(Duration::ZERO, "ID", false).unwrap();
    assert_eq!(client.poll_transmit(), Some(b"ID\r\n".to_vec()));
    let t = client.poll_timeout().unwrap();
    assert_eq!(t, ClientConfig::default().timeout);
    client.handle_timeout(t);
    match client.poll_event() {
        Some(Event::Failed(TerminalError::Timeout { waiting_for, .. })) => {
            assert_eq!(waiting_for, "the command")
        }
        other => panic!("{other:?}"),
    }
    assert!(client.is_idle());
}

#[test]
fn a_fourth_session_is_refused_and_closed() {
    let mut shelf = Shelf::default();
    let sessions: Vec<_> = (0..3)
        .map(|_| TerminalSession::open(&mut shelf, SessionConfig::default()))
        .collect();
    assert_eq!(sessions[2].terminal(), Some("AUX3"));
    let mut fourth = TerminalSession::open(&mut shelf, SessionConfig::default());
    assert_eq!(fourth.terminal(), None);
    while fourth.poll_transmit().is_some() {}
    assert!(fourth.is_closed());
}

#[test]
fn the_client_refuses_what_cannot_be_typed_or_framed() {
    let mut client = TerminalClient::new(ClientConfig::default());
    assert!(matches!(
        client.command(Duration::ZERO, "ID\nKILL x", true),
        Err(TerminalError::Unsendable(_))
    ));
    assert!(matches!(
        client.load(Duration::ZERO, "x.as", b".PROGRAM x()\x17\n"),
        Err(TerminalError::Unsendable(_))
    ));
    client.command(Duration::ZERO, "ID", false).unwrap();
    assert_eq!(
        client.command(Duration::ZERO, "ID", false),
        Err(TerminalError::Busy)
    );
}

#[test]
fn lines_printed_after_the_prompt_do_not_hold_up_the_reply() {
    let mut link = Link::new(ClientConfig::default(), 4);
    link.login();
    link.client.command(link.now, "DIRECTORY/P", false).unwrap();
    // The reply and its prompt reach the client, then a program prints before it is quiet.
    while let Some(bytes) = link.client.poll_transmit() {
        link.session.handle_input(&mut link.shelf, &bytes);
    }
    link.session.print_unsolicited("session closed ( 0)");
    let events = link.settle();
    assert_eq!(
        events,
        vec![Event::Reply {
            command: "DIRECTORY/P".into(),
            output: "Program list".into()
        }]
    );
}

#[test]
fn lines_printed_before_the_echo_are_not_part_of_the_reply() {
    let mut link = Link::new(ClientConfig::default(), 4);
    link.login();
    link.client.command(link.now, "DIRECTORY/P", false).unwrap();
    // A program prints while the command is on its way to the controller.
    link.session.print_unsolicited("session closed ( 0)");
    let events = link.settle();
    assert_eq!(
        events,
        vec![Event::Reply {
            command: "DIRECTORY/P".into(),
            output: "Program list".into()
        }]
    );
}

#[test]
fn a_refusal_printed_after_the_echoed_answer_is_in_the_reply() {
    let mut link = Link::new(ClientConfig::default(), 5);
    link.login();
    link.shelf.programs.insert("p".into(), String::new());
    link.shelf.refuse_confirmed = Some(text::P1026_CANNOT_KILL_RUNNING);
    let events = link.command("KILL p", true);
    let Some(Event::Reply { output, .. }) = events.last() else {
        panic!("{events:?}")
    };
    // The question keeps its blank, the answer is echoed on its line, the refusal follows.
    assert!(
        output.starts_with("Are you sure ? (Yes:1, No:0) 1\n"),
        "{output:?}"
    );
    assert_eq!(
        text::monitor_error_code(output),
        None,
        "not on the first line"
    );
    let refusal = text::refusal(output).expect("the refusal is found");
    assert_eq!(refusal.code, Some(('P', 1026)));
    assert!(link.shelf.programs.contains_key("p"));
}

/// What the session sends for `bytes` typed raw.
fn typed(link: &mut Link, bytes: &[u8]) -> String {
    link.session.handle_input(&mut link.shelf, bytes);
    let mut out = Vec::new();
    while let Some(b) = link.session.poll_transmit() {
        out.extend(b);
    }
    String::from_utf8_lossy(&out).into_owned()
}

#[test]
fn the_question_takes_one_key_and_a_line_end_after_it_is_no_second_command() {
    // A telnet library answers `1` alone and waits for the prompt; another sends `1` CR LF.
    for (answer, then) in [
        (&b"1"[..], &b""[..]),
        (b"1", b"\r\n"),
        (b"1\r\n", b""),
        (b"1\n", b""),
    ] {
        let mut link = Link::new(ClientConfig::default(), 64);
        link.login();
        link.shelf.programs.insert("p".into(), String::new());
        let asked = typed(&mut link, b"KILL p\r\n");
        assert!(asked.ends_with(text::ARE_YOU_SURE), "{asked:?}");
        let out = typed(&mut link, answer);
        assert_eq!(out, "1\r\n>", "answer {answer:?}");
        assert!(!link.shelf.programs.contains_key("p"), "killed on the key");
        assert_eq!(typed(&mut link, then), "", "the line end is the answer's");
        // The next command is answered once, with one prompt.
        let out = typed(&mut link, b"DIRECTORY/P\r\n");
        assert_eq!(out.matches('>').count(), 1, "{out:?}");
    }
    // `0` answers no at once, as does an empty line.
    for no in [&b"0"[..], b"\r\n"] {
        let mut link = Link::new(ClientConfig::default(), 64);
        link.login();
        link.shelf.programs.insert("p".into(), String::new());
        typed(&mut link, b"KILL p\r\n");
        let out = typed(&mut link, no);
        assert!(out.ends_with('>'), "{out:?}");
        assert!(link.shelf.programs.contains_key("p"), "kept after {no:?}");
    }
}

#[test]
fn a_controller_that_asks_the_terminal_type_logs_in_only_a_client_that_answers_it() {
    for generation in [Generation::C, Generation::D] {
        let mut link = Link::with(ClientConfig::default(), SessionConfig::of(generation));
        link.login();
    }
    let mut link = Link::with(
        ClientConfig {
            terminal_type: None,
            ..ClientConfig::default()
        },
        SessionConfig::of(Generation::D),
    );
    link.client.login(link.now).unwrap();
    match link.settle().last() {
        Some(Event::Failed(TerminalError::Timeout { waiting_for, .. })) => {
            assert_eq!(*waiting_for, "the login")
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn an_older_controller_asks_confirm_after_the_file_and_ends_with_loading_done() {
    let mut link = Link::with(ClientConfig::default(), SessionConfig::of(Generation::D));
    link.login();
    link.client
        .load(link.now, "x.as", b".PROGRAM x()\r\n  a = 1\r\n.END\r\n")
        .unwrap();
    let events = link.settle();
    assert_eq!(
        events[0],
        Event::Answered {
            question: Question::Confirm,
            answer: String::new()
        }
    );
    match &events[1] {
        Event::Loaded {
            errors: 0,
            programs,
            ending,
            ..
        } => {
            assert_eq!(programs, &["x"]);
            assert_eq!(ending.as_deref(), Some(text::LOADING_DONE));
        }
        other => panic!("{other:?}"),
    }
}

/// A LOAD with `question` asked after its first block: the client's events, the bytes the
/// controller received, and whether the transfer is still open on it.
fn load_with_question(question: &str) -> (Vec<Event>, Vec<u8>, bool) {
    let mut link = Link::with(
        ClientConfig {
            block_bytes: 100,
            ..ClientConfig::default()
        },
        SessionConfig {
            max_piece: 7,
            load_questions: vec![question.to_owned()],
            ..SessionConfig::default()
        },
    );
    link.login();
    let file = file_of(1_000);
    link.client.load(link.now, "x.as", &file).unwrap();
    let events = link.settle();
    (
        events,
        link.shelf.received.clone(),
        link.session.in_transfer(),
    )
}

#[test]
fn an_unexpected_question_mid_load_is_answered_safely_and_the_transfer_is_closed() {
    for (question, answer, kind) in [
        (text::LOAD_QUERY, "3", Question::LoadQuery),
        ("Force load ? (9:Yes, 0:No)", "0", Question::ForceLoad),
        (text::PRESS_ENTER, "", Question::PressEnter),
    ] {
        let (events, received, open) = load_with_question(question);
        assert_eq!(
            events[0],
            Event::Answered {
                question: kind,
                answer: answer.into()
            },
            "{question}"
        );
        match events.last() {
            Some(Event::Failed(TerminalError::LoadInterrupted { why, .. })) => {
                assert!(why.contains(question.trim()), "{why}")
            }
            other => panic!("{question}: {other:?}"),
        }
        // The first block only: none after the question; the transfer ended cleanly.
        assert_eq!(received.len(), 100, "{question}");
        assert!(!open, "{question}");
    }
}

#[test]
fn are_you_sure_inside_a_load_is_never_answered_and_the_file_is_ended_at_once() {
    let (events, received, open) = load_with_question(text::ARE_YOU_SURE);
    assert!(
        !events.iter().any(|e| matches!(e, Event::Answered { .. })),
        "{events:?}"
    );
    match events.last() {
        Some(Event::Failed(TerminalError::LoadInterrupted { why, .. })) => {
            assert!(why.contains("Are you sure"), "{why}")
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(received.len(), 100);
    assert!(!open);
}

#[test]
fn a_block_whose_data_ends_with_sub_is_the_end_of_the_file() {
    let mut shelf = Shelf::default();
    let mut session = TerminalSession::open(&mut shelf, SessionConfig::default());
    session.handle_input(&mut shelf, b"as\r\nLOAD x.as\r\n");
    session.handle_input(
        &mut shelf,
        &fs020n_term::frame::client_frame(fs020n_term::frame::Letter::A, b""),
    );
    let mut last = fs020n_term::frame::client_frame(
        fs020n_term::frame::Letter::C,
        b".PROGRAM x()\r\n.END\r\n\x1a",
    );
    session.handle_input(&mut shelf, &last);
    last = fs020n_term::frame::client_frame(fs020n_term::frame::Letter::E, b"");
    session.handle_input(&mut shelf, &last);
    let mut out = Vec::new();
    while let Some(b) = session.poll_transmit() {
        out.extend(b);
    }
    let out = String::from_utf8_lossy(&out);
    assert!(out.contains("Program x()"), "{out}");
    assert!(
        out.ends_with("File load completed. (0 errors)\r\n>"),
        "{out}"
    );
    assert_eq!(shelf.received, b".PROGRAM x()\r\n.END\r\n");
    assert!(!session.in_transfer());
}

/// The client alone against a scripted controller: what it sends after each piece.
struct Script {
    client: TerminalClient,
    now: Duration,
}

impl Script {
    fn load(file: &[u8]) -> Script {
        let mut client = TerminalClient::new(ClientConfig {
            block_bytes: 10,
            ..ClientConfig::default()
        });
        client.load(Duration::ZERO, "x.as", file).unwrap();
        let mut s = Script {
            client,
            now: Duration::ZERO,
        };
        s.sent();
        s
    }

    fn feed(&mut self, bytes: &[u8]) -> Vec<Vec<u8>> {
        self.now += Duration::from_millis(1);
        self.client.handle_input(self.now, bytes);
        self.sent()
    }

    fn wait(&mut self) -> Vec<Vec<u8>> {
        if let Some(t) = self.client.poll_timeout() {
            self.now = self.now.max(t);
            self.client.handle_timeout(self.now);
        }
        self.sent()
    }

    fn sent(&mut self) -> Vec<Vec<u8>> {
        std::iter::from_fn(|| self.client.poll_transmit()).collect()
    }
}

fn request(letter: fs020n_term::frame::Letter) -> Vec<u8> {
    fs020n_term::frame::controller_frame(letter, b"")
}

#[test]
fn no_block_is_sent_after_a_refusal_printed_mid_load() {
    use fs020n_term::frame::{client_frame, Letter, SUB};
    let mut s = Script::load(b".PROGRAM x()\r\n  a = 1\r\n  b = 2\r\n.END\r\n");
    assert_eq!(s.feed(&request(Letter::A)), [client_frame(Letter::A, b"")]);
    assert_eq!(s.feed(&request(Letter::C)).len(), 1);
    s.feed(format!("{}\r\n", text::P1014_IN_USE.line()).as_bytes());
    assert_eq!(
        s.feed(&request(Letter::C)),
        [client_frame(Letter::C, &[SUB])]
    );
    assert_eq!(s.feed(&request(Letter::E)), [client_frame(Letter::E, b"")]);
    s.feed(b"File load completed. (1 errors)\r\n>");
    s.wait();
    match s.client.poll_event() {
        Some(Event::Failed(TerminalError::LoadInterrupted { why, .. })) => {
            assert!(why.contains("P1014"), "{why}")
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn a_controller_that_stops_asking_for_blocks_gets_the_end_of_file_then_a_failure() {
    use fs020n_term::frame::{client_frame, Letter, SUB};
    let mut s = Script::load(b".PROGRAM x()\r\n  a = 1\r\n  b = 2\r\n.END\r\n");
    s.feed(&request(Letter::A));
    s.feed(&request(Letter::C));
    // Silence: at the deadline, the end of file.
    let mut sent = s.wait();
    while sent.is_empty() {
        sent = s.wait();
    }
    assert_eq!(sent, [client_frame(Letter::C, &[SUB])]);
    // Still nothing: the transfer could not be closed, and the error says so.
    let _ = s.wait();
    let _ = s.wait();
    match s.client.poll_event() {
        Some(Event::Failed(e @ TerminalError::TransferLeftOpen { .. })) => {
            assert!(e.to_string().contains("P2076"), "{e}")
        }
        other => panic!("{other:?}"),
    }
    assert!(s.client.is_idle());
}

#[test]
fn a_question_followed_by_unsolicited_lines_is_still_answered() {
    let mut client = TerminalClient::new(ClientConfig::default());
    client.command(Duration::ZERO, "PCKILL 1:", true).unwrap();
    client.poll_transmit();
    let now = Duration::from_millis(1);
    client.handle_input(
        now,
        format!(
            "PCKILL 1:\r\n{}\r\n{}\r\n",
            text::ARE_YOU_SURE,
            text::pc_completed(2)
        )
        .as_bytes(),
    );
    client.handle_timeout(now + Duration::from_secs(1));
    assert_eq!(client.poll_transmit(), Some(b"1\r\n".to_vec()));
}

#[test]
fn a_line_printed_while_are_you_sure_waits_does_not_hide_the_question() {
    let mut link = Link::new(ClientConfig::default(), 4);
    link.login();
    link.shelf.programs.insert("p".into(), String::new());
    link.client.command(link.now, "KILL p", true).unwrap();
    while let Some(bytes) = link.client.poll_transmit() {
        link.session.handle_input(&mut link.shelf, &bytes);
    }
    // The question is out; a program prints before the client answers.
    link.session.print_unsolicited("Program completed.No = 2");
    let events = link.settle();
    assert_eq!(
        events[0],
        Event::Answered {
            question: Question::AreYouSure,
            answer: "1".into()
        }
    );
    assert!(!link.shelf.programs.contains_key("p"));
}
