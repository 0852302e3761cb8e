//! The controller's terminal, command by command, on virtual time: the project's terminal
//! client against a [`TerminalLink`] over the emulated controller, in memory.

#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

use std::time::Duration;

use fs020n_as::TaskId;
use fs020n_sim::{Controller, ControllerConfig, Fault, TerminalLink};
use fs020n_term::frame::{client_frame, Letter, SUB};
use fs020n_term::text;
use fs020n_term::{ClientConfig, Event, Question, SessionConfig, TerminalClient, TerminalError};

/// The client and one terminal session on the controller, on one fake clock.
struct Term {
    now: Duration,
    c: Controller,
    client: TerminalClient,
    link: TerminalLink,
}

fn bare() -> Controller {
    Controller::bare(ControllerConfig::default(), fs020n_as::LoadOptions::new())
}

impl Term {
    fn new(c: Controller) -> Term {
        Term::with_piece(c, 7)
    }

    fn with_piece(mut c: Controller, piece: usize) -> Term {
        let link = TerminalLink::open(
            &mut c,
            SessionConfig {
                max_piece: piece,
                ..SessionConfig::default()
            },
        );
        let mut t = Term {
            now: Duration::ZERO,
            c,
            client: TerminalClient::new(ClientConfig::default()),
            link,
        };
        t.client.login(t.now).unwrap();
        match t.settle().as_slice() {
            [Event::LoggedIn { terminal }] => {
                assert!(terminal.as_deref().is_some_and(|t| t.starts_with("AUX")))
            }
            other => panic!("{other:?}"),
        }
        t
    }

    fn settle(&mut self) -> Vec<Event> {
        let mut events = Vec::new();
        for _ in 0..100_000 {
            let mut moved = false;
            while let Some(b) = self.client.poll_transmit() {
                self.link.handle_input(&mut self.c, &b);
                moved = true;
            }
            while let Some(b) = self.link.poll_transmit() {
                self.now += Duration::from_micros(50);
                self.client.handle_input(self.now, &b);
                moved = true;
            }
            while let Some(e) = self.client.poll_event() {
                events.push(e);
            }
            if self.client.is_idle() {
                return events;
            }
            if !moved {
                let t = self
                    .client
                    .poll_timeout()
                    .expect("a waiting client has a timeout");
                self.now = self.now.max(t);
                self.client.handle_timeout(self.now);
            }
        }
        panic!("the exchange did not settle: {events:?}");
    }

    /// A command's output (`confirm` answers `Are you sure ?` with 1).
    fn cmd(&mut self, line: &str, confirm: bool) -> String {
        self.client.command(self.now, line, confirm).unwrap();
        let events = self.settle();
        match events.last() {
            Some(Event::Reply { output, .. }) => output.clone(),
            other => panic!("{line}: {other:?}"),
        }
    }

    fn load(&mut self, name: &str, file: &str) -> Event {
        self.client.load(self.now, name, file.as_bytes()).unwrap();
        self.settle().pop().expect("an event")
    }

    /// Advances the controller (and its programs) by `d`.
    fn advance(&mut self, d: Duration) {
        let t = self.c.now() + d;
        self.c.advance_to(t);
    }
}

fn loaded_ok(e: &Event) -> &str {
    match e {
        Event::Loaded {
            errors: 0,
            syntax_error: None,
            output,
            ..
        } => output,
        other => panic!("{other:?}"),
    }
}

/// A poll of protocol 1040 through the program's served port: the reply's fields.
fn poll(c: &mut Controller) -> Vec<String> {
    let client = c
        .program_mut()
        .connect(None, [127, 0, 0, 1])
        .expect("the program listens");
    c.advance_by(Duration::from_millis(50));
    assert!(c.program_mut().send(client, b"1040 0 0"));
    c.advance_by(Duration::from_millis(100));
    let reply = c.program_mut().recv(client);
    c.program_mut().close(client);
    String::from_utf8_lossy(&reply.bytes)
        .split_whitespace()
        .map(str::to_owned)
        .collect()
}

const SERVER: &str = fs020n_as::SERVER_1040;

#[test]
fn a_bare_controller_lists_nothing_and_serves_no_port() {
    let mut t = Term::new(bare());
    assert_eq!(t.cmd("DIRECTORY/P", false).trim(), "Program list");
    t.advance(Duration::from_secs(1));
    assert!(!t.c.program().listening(None));
    assert!(t.c.program_mut().connect(None, [127, 0, 0, 1]).is_err());
}

#[test]
fn load_of_the_server_text_lists_its_programs_and_list_shows_their_text() {
    let mut t = Term::new(bare());
    let out = loaded_ok(&t.load("server1040.as", SERVER)).to_owned();
    assert!(out.contains("Loading...(server1040.as)"), "{out}");
    assert!(out.contains("Program autostart.pc()"), "{out}");
    assert!(out.contains("File load completed. (0 errors)"), "{out}");
    let dir = t.cmd("dir/p", false);
    assert!(
        dir.contains("autostart.pc") && dir.contains("ros_move"),
        "{dir}"
    );
    let listing = t.cmd("LIST/P ros_move", false);
    assert!(listing.starts_with(".PROGRAM ros_move"), "{listing}");
    assert!(listing.trim_end().ends_with(".END"), "{listing}");
    assert!(t.cmd("LIST/P nothing", false).starts_with("(P1038)"));
}

#[test]
fn pcexecute_starts_the_loaded_server_and_its_port_answers_a_poll() {
    let mut t = Term::new(bare());
    loaded_ok(&t.load("server1040.as", SERVER));
    assert_eq!(t.cmd("TYPE TASK (1001)", false), " 0");
    assert_eq!(t.cmd("pcexe 1: autostart.pc", false), "");
    t.advance(Duration::from_millis(200));
    assert_eq!(t.cmd("TYPE TASK(1001)", false), " 1");
    let status = t.cmd("PCSTATUS 1:", false);
    assert!(status.starts_with("PC status: Program running"), "{status}");
    assert!(
        status.lines().last().unwrap().starts_with("autostart.pc"),
        "{status}"
    );
    let fields = poll(&mut t.c);
    assert_eq!(fields.len(), 14, "{fields:?}");
    assert_eq!(fields[0], "1040");
}

#[test]
fn pcexecute_refuses_a_busy_task_a_program_in_use_and_a_missing_program() {
    let mut t = Term::new(bare());
    loaded_ok(&t.load("server1040.as", SERVER));
    t.cmd("PCEXECUTE 1: autostart.pc", false);
    t.advance(Duration::from_millis(100));
    assert!(t
        .cmd("PCEXECUTE 1: autostart.pc", false)
        .starts_with("(P1019)PC program is running."));
    assert!(t
        .cmd("PCEXECUTE 2: autostart.pc", false)
        .starts_with("(P1014)"));
    assert!(t
        .cmd("PCEXECUTE 3: nothing", false)
        .starts_with("(P1038)Program does not exist."));
}

#[test]
fn a_running_program_cannot_be_killed_and_an_aborted_one_can() {
    let mut t = Term::new(bare());
    loaded_ok(&t.load("server1040.as", SERVER));
    t.cmd("PCEXECUTE 1: autostart.pc", false);
    t.advance(Duration::from_millis(100));
    let out = t.cmd("PCKILL 1:", true);
    assert!(
        out.contains("(P1026)Cannot KILL program that is running."),
        "{out}"
    );
    assert!(t.c.program().task_running(TaskId::Pc(1)));
    // The server waits in its 3 s TCP_ACCEPT: PCABORT takes effect when that step completes.
    let out = t.cmd("PCABORT 1:", false);
    assert_eq!(out, "");
    assert_eq!(t.cmd("TYPE TASK (1001)", false), " 1");
    let out = t.cmd("PCKILL 1:", true);
    assert!(out.contains("(P1026)"), "{out}");
    t.advance(Duration::from_millis(3100));
    assert_eq!(t.cmd("TYPE TASK (1001)", false), " 0");
    assert_eq!(
        t.c.program().task_program(TaskId::Pc(1)).as_deref(),
        Some("autostart.pc")
    );
    // On the stack: a new LOAD of it is refused, the other program loads.
    match t.load("server1040.as", SERVER) {
        Event::Loaded { errors, output, .. } => {
            assert_eq!(errors, 1);
            assert!(output.contains("autostart.pc: (P1014)"), "{output}");
            assert!(output.contains("Program ros_move()"), "{output}");
        }
        other => panic!("{other:?}"),
    }
    t.cmd("PCKILL 1:", true);
    assert_eq!(t.c.program().task_program(TaskId::Pc(1)), None);
    loaded_ok(&t.load("server1040.as", SERVER));
}

#[test]
fn kill_of_the_running_robot_program_is_refused_and_abort_then_kill_works() {
    let mut t = Term::new(bare());
    let spin = ".PROGRAM spin()\n  WHILE TRUE DO\n    TWAIT 0.1\n  END\n.END\n";
    loaded_ok(&t.load("spin.as", spin));
    assert_eq!(t.cmd("EXECUTE spin", false), "");
    t.advance(Duration::from_millis(300));
    assert!(t.cmd("STATUS", false).contains("CYCLE START ON"));
    assert!(t.cmd("EX spin", false).starts_with("(P1009)"));
    assert!(t.cmd("KILL", true).contains("(P1026)"));
    assert_eq!(t.cmd("ABORT", false), "");
    // After the current step (a TWAIT of 0.1 s).
    t.advance(Duration::from_millis(150));
    assert_eq!(t.cmd("TYPE TASK (1)", false), " 0");
    assert!(t.cmd("DELETE/P spin", true).contains("(P1018)"));
    t.cmd("KILL", true);
    assert!(t.cmd("STATUS", false).ends_with("No program is running."));
    assert!(!t.cmd("DELETE/P spin", true).contains("(P"));
    assert_eq!(t.c.memory().programs(), Vec::<String>::new());
}

#[test]
fn prime_prepares_the_robot_program_and_continue_starts_it() {
    // AS-E p.5-39: PRIME prepares, it does not execute; CONTINUE executes.
    let mut t = Term::new(bare());
    t.c.set_power(true).unwrap();
    let count = ".PROGRAM count()\n  n = n + 1\n  TWAIT 0.2\n.END\n.REALS\nn = 0\n.END\n";
    loaded_ok(&t.load("count.as", count));
    assert!(t.cmd("PRIME nothing", false).starts_with("(P1038)"));
    assert_eq!(t.cmd("PRIME count, 2", false), "");
    t.advance(Duration::from_millis(300));
    assert_eq!(t.cmd("TYPE TASK (1)", false), " 0", "primed, not running");
    assert_eq!(typed_real(&mut t, "n"), 0.0);
    assert!(t.cmd("STATUS", false).contains("count"), "on the stack");
    assert_eq!(t.cmd("CONTINUE", false), "");
    t.advance(Duration::from_millis(100));
    assert_eq!(t.cmd("TYPE TASK (1)", false), " 1");
    assert!(t.cmd("PRIME count", false).starts_with("(P1009)"));
    t.advance(Duration::from_secs(2));
    assert_eq!(
        typed_real(&mut t, "n"),
        2.0,
        "the two cycles PRIME asked for"
    );
    // CONTINUE again: nothing primed any more, the program does not run a third time.
    assert_eq!(t.cmd("CONTINUE", false), "");
    t.advance(Duration::from_secs(1));
    assert_eq!(typed_real(&mut t, "n"), 2.0);
}

#[test]
fn list_with_a_switch_shows_the_variables_the_programs_hold_now() {
    // AS-E p.5-18: LIST/R, /L, /S, /INT; telnet tools type the switch after a blank.
    let mut t = Term::new(bare());
    let setx = ".PROGRAM setx()\n  x = 5\n  arr[2] = 0.5\n  @n = 3\n  $s = \"hi\"\n  POINT p = TRANS(100, 0, 600, 0, 180, 0)\n  POINT #j = #PPOINT(0, -30, -90, 0, -60, 0)\n.END\n.REALS\nx = 1\n.END\n";
    loaded_ok(&t.load("setx.as", setx));
    assert_eq!(
        t.cmd("LIST/R x", false),
        "x = 1",
        "the loaded value before the program runs"
    );
    t.cmd("PCEXECUTE 2: setx", false);
    t.advance(Duration::from_millis(50));
    assert_eq!(t.cmd("list /r x", false), "x = 5");
    assert_eq!(t.cmd("LIST/R", false), "arr[2] = 0.5\nx = 5");
    assert_eq!(t.cmd("LIST/INT", false), "@n = 3");
    assert_eq!(t.cmd("LIST/S", false), "$s \"hi\"");
    assert_eq!(
        t.cmd("LIST/L", false),
        "p 100 0 600 0 180 0\n#j 0 -30 -90 0 -60 0"
    );
    assert_eq!(t.cmd("LIST/L #j", false), "#j 0 -30 -90 0 -60 0");
    assert!(t.cmd("LIST/P setx", false).starts_with(".PROGRAM setx()"));
}

#[test]
fn a_program_that_ends_before_the_prompt_is_announced_completed() {
    // A PC program with no wait runs to its end within PCEXECUTE's first steps; telnet
    // tools wait for `Program completed.No = n` all the same.
    let mut t = Term::new(bare());
    loaded_ok(&t.load("quick.as", ".PROGRAM quick()\n  x = 1\n.END\n"));
    t.cmd("PCEXECUTE 3: quick", false);
    t.advance(Duration::from_millis(200));
    let out = drain_output(&mut t);
    assert!(out.contains(&text::pc_completed(3)), "{out:?}");
}

#[test]
fn a_bracket_ends_the_command_word_as_in_signal_of_a_number() {
    let mut t = Term::new(bare());
    loaded_ok(&t.load("hi.as", ".PROGRAM hi()\n.END\n"));
    assert_eq!(t.cmd("signal(2010)", false), "");
    assert_eq!(t.cmd("TYPE SIG(2010)", false), " -1");
    assert_eq!(t.cmd("SIGNAL (-2010)", false), "");
    assert_eq!(t.cmd("TYPE SIG(2010)", false), " 0");
}

#[test]
fn execute_of_the_robot_program_is_refused_in_error_until_ereset() {
    let mut t = Term::new(bare());
    loaded_ok(&t.load("spin.as", ".PROGRAM spin()\n  TWAIT 10\n.END\n"));
    t.c.inject(Fault::RaiseError {
        code: fs020n_proto::ErrorCode(-31130),
    });
    assert!(t.cmd("EXECUTE spin", false).starts_with("(P1013)"));
    assert_eq!(t.cmd("ERESET", false), "Cleared error state.");
    assert_eq!(t.cmd("ERESET", false), "");
    assert_eq!(t.cmd("EXECUTE spin", false), "");
}

#[test]
fn a_syntax_error_answered_abort_loads_nothing() {
    let mut t = Term::new(bare());
    let bad = ".PROGRAM good()\n  x = 1\n.END\n.PROGRAM bad()\n  THIS IS NOT AS (\n.END\n";
    t.client.load(t.now, "bad.as", bad.as_bytes()).unwrap();
    let events = t.settle();
    assert!(
        matches!(
            &events[0],
            Event::Answered { question: Question::SyntaxError(line), answer } if line.contains("THIS IS NOT AS") && answer == "1"
        ),
        "{events:?}"
    );
    assert!(matches!(
        events.last(),
        Some(Event::Loaded {
            syntax_error: Some(_),
            ..
        })
    ));
    assert!(t.c.memory().programs().is_empty());
}

#[test]
fn a_syntax_error_answered_comment_out_loads_the_file_with_the_line_commented() {
    let mut c = bare();
    let mut link = TerminalLink::open(&mut c, SessionConfig::default());
    let mut out = Vec::new();
    let mut feed = |c: &mut Controller, link: &mut TerminalLink, bytes: &[u8]| {
        link.handle_input(c, bytes);
        while let Some(b) = link.poll_transmit() {
            out.extend(b);
        }
        String::from_utf8_lossy(&out).into_owned()
    };
    feed(&mut c, &mut link, b"as\r\nLOAD x.as\r\n");
    feed(&mut c, &mut link, &client_frame(Letter::A, b""));
    let file = b".PROGRAM x()\n  y = 2\n  NOT AS AT ALL (\n.END\n";
    feed(&mut c, &mut link, &client_frame(Letter::C, file));
    let text = feed(&mut c, &mut link, &client_frame(Letter::C, &[SUB]));
    assert!(text.contains("STEP syntax error."), "{text}");
    feed(&mut c, &mut link, b"0\r\n");
    let text = feed(&mut c, &mut link, &client_frame(Letter::E, b""));
    assert!(text.contains("Program x()"), "{text}");
    assert!(text.contains("File load completed. (1 errors)"), "{text}");
    let listing = String::from_utf8_lossy(c.memory().program("x").unwrap()).into_owned();
    assert!(
        listing.contains("; ") && listing.contains("NOT AS AT ALL"),
        "{listing}"
    );
}

#[test]
fn a_transfer_left_open_gives_p2076_until_a_power_cycle() {
    let mut c = bare();
    let mut dropped = TerminalLink::open(&mut c, SessionConfig::default());
    dropped.handle_input(&mut c, b"as\r\nLOAD x.as\r\n");
    dropped.handle_close(&mut c);
    assert!(c.memory().transfer_open());
    let mut t = Term::new(c);
    t.client
        .load(t.now, "y.as", b".PROGRAM y()\n.END\n")
        .unwrap();
    assert_eq!(
        t.settle(),
        vec![Event::Failed(TerminalError::TransferInProgress)]
    );
    t.c.power_cycle();
    loaded_ok(&t.load("y.as", ".PROGRAM y()\n.END\n"));
}

#[test]
fn a_transfer_in_progress_in_one_session_gives_p2076_in_another() {
    let mut c = bare();
    let mut busy = TerminalLink::open(&mut c, SessionConfig::default());
    busy.handle_input(&mut c, b"as\r\nLOAD x.as\r\n");
    let mut t = Term::new(c);
    t.client
        .load(t.now, "y.as", b".PROGRAM y()\n.END\n")
        .unwrap();
    assert_eq!(
        t.settle(),
        vec![Event::Failed(TerminalError::TransferInProgress)]
    );
    // The first session finishes its transfer: the other may load again.
    busy.handle_input(&mut t.c, &client_frame(Letter::A, b""));
    busy.handle_input(&mut t.c, &client_frame(Letter::C, b".PROGRAM x()\n.END\n"));
    busy.handle_input(&mut t.c, &client_frame(Letter::C, &[SUB]));
    busy.handle_input(&mut t.c, &client_frame(Letter::E, b""));
    assert!(!t.c.memory().transfer_open());
    loaded_ok(&t.load("y.as", ".PROGRAM y()\n.END\n"));
    assert_eq!(t.c.memory().programs(), vec!["x", "y"]);
}

#[test]
fn switch_reads_and_sets_autostart_in_both_forms_and_refuses_unknown_names() {
    let mut t = Term::new(bare());
    assert_eq!(t.cmd("SWITCH AUTOSTART.PC", false), "AUTOSTART.PC    OFF");
    assert_eq!(t.cmd("SWITCH AUTOSTART.PC = ON", false), "");
    assert_eq!(t.cmd("sw autostart.pc", false), "AUTOSTART.PC    ON");
    assert_eq!(t.cmd("SWITCH AUTOSTART3.PC ON", false), "");
    assert_eq!(t.c.memory().switch("AUTOSTART3.PC"), Some(true));
    assert_eq!(t.cmd("SWITCH CP", false), "CP              ON");
    assert_eq!(t.cmd("SWITCH ABS.SPEED=ON", false), "");
    assert!(t.c.abs_speed());
    assert!(t.cmd("SWITCH NO.SUCH", false).starts_with("(P0117)"));
    let all = t.cmd("SWITCH", false);
    assert!(
        all.contains("AUTOSTART5.PC") && all.contains("SCREEN"),
        "{all}"
    );
}

#[test]
fn a_power_cycle_starts_autostart_pc_only_when_its_switch_is_on() {
    let mut t = Term::new(bare());
    loaded_ok(&t.load("server1040.as", SERVER));
    t.c.power_cycle();
    t.advance(Duration::from_millis(200));
    assert!(!t.c.program().listening(None));
    t.cmd("SWITCH AUTOSTART.PC = ON", false);
    let started = t.c.power_cycle();
    assert_eq!(started.started, vec![(1, "autostart.pc".to_owned())]);
    t.advance(Duration::from_millis(200));
    assert_eq!(poll(&mut t.c).len(), 14);
    assert_eq!(t.c.memory().programs(), vec!["autostart.pc", "ros_move"]);
}

#[test]
fn a_power_cycle_stops_tasks_closes_sockets_and_clears_the_error() {
    let mut t = Term::new(bare());
    loaded_ok(&t.load("server1040.as", SERVER));
    t.cmd("PCEXECUTE 1: autostart.pc", false);
    t.advance(Duration::from_millis(200));
    let client = t.c.program_mut().connect(None, [127, 0, 0, 1]).unwrap();
    t.c.inject(Fault::RaiseError {
        code: fs020n_proto::ErrorCode(-31130),
    });
    t.c.power_cycle();
    assert!(!t.c.program().task_running(TaskId::Pc(1)));
    assert!(t.c.error().is_none());
    assert!(!t.c.panel().power);
    assert!(t.c.program_mut().recv(client).closed);
    assert_eq!(t.c.program().task_program(TaskId::Pc(1)), None);
}

#[test]
fn id_names_the_robot_and_the_emulators_as_version() {
    let mut t = Term::new(bare());
    let id = t.cmd("ID", false);
    assert!(id.contains("Robot name: FS020N (emulator)"), "{id}");
    assert!(
        id.contains("[Software version]") && id.contains("EMULATOR-FS020N-AS"),
        "{id}"
    );
}

#[test]
fn type_prints_variables_timers_and_literals() {
    let mut t = Term::new(bare());
    let p = ".PROGRAM setx()\n  x = 42\n  y[2] = 0.5\n  $s = \"hello\"\n  TIMER 2 = 0\n.END\n";
    loaded_ok(&t.load("setx.as", p));
    t.cmd("PCEXECUTE 2: setx", false);
    t.advance(Duration::from_millis(1500));
    assert_eq!(t.cmd("TYPE x", false), " 42");
    assert_eq!(t.cmd("TYPE y[2]", false), " 0.5");
    assert_eq!(t.cmd("TYPE $s", false), "hello");
    assert_eq!(t.cmd("TYPE 7", false), " 7");
    let timer: f32 = t.cmd("TYPE TIMER(2)", false).trim().parse().unwrap();
    assert!((1.3..1.6).contains(&timer), "{timer}");
    assert!(t.cmd("TYPE nothing", false).starts_with("(E0102)"));
    assert!(t.cmd("TYPE $nothing", false).starts_with("(E0104)"));
}

#[test]
fn type_takes_any_expression_a_program_may_type() {
    let mut t = Term::new(bare());
    let p = ".PROGRAM setp()\n  POINT p[1] = TRANS(100, 200, 300, 0, 90, 0)\n  n = 3\n.END\n";
    loaded_ok(&t.load("setp.as", p));
    t.cmd("PCEXECUTE 1: setp", false);
    t.advance(Duration::from_millis(100));
    // A function of a pose array element, arithmetic and a string function, as TYPE in a
    // program prints them (one blank before each number).
    assert_eq!(t.cmd("TYPE DX(p[1]) + n", false), " 103");
    assert_eq!(t.cmd("TYPE $LEFT(\"abcdef\", n), n * 2", false), "abc 6");
    assert_eq!(t.cmd("TYPE DX(p[2])", false).get(..7), Some("(E0103)"));
}

#[test]
fn do_and_the_commands_that_are_instructions_run_at_once() {
    let mut t = Term::new(bare());
    let p = ".PROGRAM setp()\n  POINT a = TRANS(100, 200, 300, 0, 90, 0)\n.END\n";
    loaded_ok(&t.load("setp.as", p));
    t.cmd("PCEXECUTE 1: setp", false);
    t.advance(Duration::from_millis(100));
    // POINT at the prompt (a monitor command and an instruction): a new pose variable.
    assert_eq!(t.cmd("POINT b = SHIFT(a BY 0, 0, 50)", false), "");
    assert_eq!(t.cmd("TYPE DZ(b)", false), " 350");
    // DO: one instruction; DO alone runs it again.
    assert_eq!(t.cmd("DO count = 1", false), "");
    assert_eq!(t.cmd("DO count = count + 1", false), "");
    assert_eq!(t.cmd("DO", false), "");
    assert_eq!(t.cmd("TYPE count", false), " 3");
    assert_eq!(t.cmd("DO PRINT \"count:\", count", false), "count: 3");
    // BITS at the prompt sets the outputs, as the instruction does.
    assert_eq!(t.cmd("BITS 1, 3 = 5", false), "");
    assert_eq!(t.cmd("TYPE SIG(1), SIG(2), SIG(3)", false), " -1 0 -1");
    // A motion is not made from the prompt (E1095, as in a PC program): the arm stays.
    let before = t.c.joints();
    let out = t.cmd("DO JMOVE a", false);
    assert!(out.starts_with("(E1095)"), "{out}");
    t.advance(Duration::from_millis(500));
    assert_eq!(t.c.joints(), before);
    // A wait is not run; a statement that does not parse is P0108.
    let out = t.cmd("DO TWAIT 2", false);
    assert!(out.contains("TWAIT 2 waits"), "{out}");
    assert_eq!(t.cmd("DO count = = 2", false), "(P0108)Syntax error.");
    // The interface panel's instruction at the prompt writes the window.
    assert_eq!(t.cmd("IFPWPRINT 2, 2 = \"from the terminal\"", false), "");
    let panel = t.c.program().interface_panel().expect("AS programs run");
    assert_eq!(panel.windows[1].rows[1], "from the terminal");
    // SPEED at the prompt is the monitor speed (the instruction's MC form).
    assert_eq!(t.cmd("SPEED 40", false), "");
    assert_eq!(t.c.monitor_speed(), 40.0);
    // No controller error was raised by any of it.
    assert_eq!(t.c.error(), fs020n_proto::ErrorCode::NONE);
}

#[test]
fn print_output_of_a_program_reaches_the_terminal_unsolicited() {
    let mut t = Term::new(bare());
    loaded_ok(&t.load("hi.as", ".PROGRAM hi()\n  PRINT \"hello from AS\"\n.END\n"));
    t.cmd("PCEXECUTE 2: hi", false);
    t.advance(Duration::from_millis(100));
    t.link.print_output(&mut t.c);
    let mut out = Vec::new();
    while let Some(b) = t.link.poll_transmit() {
        out.extend(b);
    }
    let text = String::from_utf8_lossy(&out);
    assert!(text.contains("hello from AS\r\n"), "{text}");
}

#[test]
fn a_pc_program_that_completes_is_announced_and_an_aborted_one_is_not() {
    let mut t = Term::new(bare());
    let p = ".PROGRAM short()\n  TWAIT 0.2\n.END\n.PROGRAM long()\n  TWAIT 100\n.END\n";
    loaded_ok(&t.load("p.as", p));
    t.cmd("PCEXECUTE 2: short", false);
    t.cmd("PCEXECUTE 3: long", false);
    let mut out = Vec::new();
    let mut drain = |t: &mut Term| {
        t.link.print_output(&mut t.c);
        while let Some(b) = t.link.poll_transmit() {
            out.extend(b);
        }
        String::from_utf8_lossy(&out).into_owned()
    };
    assert!(!drain(&mut t).contains("Program completed."));
    t.advance(Duration::from_millis(500));
    let text = drain(&mut t);
    assert!(text.contains("Program completed.No = 2\r\n"), "{text}");
    // `long` is in a TWAIT of 100 s: it stops when that step completes, and says so then.
    assert_eq!(t.cmd("PCABORT 3:", false), "");
    t.advance(Duration::from_millis(100));
    assert!(!drain(&mut t).contains("aborted"));
    t.advance(Duration::from_secs(100));
    let text = drain(&mut t);
    assert!(text.contains("PC program aborted.No = 3\r\n"), "{text}");
    assert!(!text.contains("Program completed.No = 3"), "{text}");
}

/// Counts in a loop, one step every 0.1 s.
const COUNT: &str =
    ".PROGRAM count()\n  n = 0\n  WHILE TRUE DO\n    n = n + 1\n    TWAIT 0.1\n  END\n.END\n";

/// Another counter, in a file of its own.
const OTHER: &str =
    ".PROGRAM other()\n  m = 0\n  WHILE TRUE DO\n    m = m + 1\n    TWAIT 0.1\n  END\n.END\n";

/// `TYPE name` as a number.
fn type_real(t: &mut Term, name: &str) -> f64 {
    let out = t.cmd(&format!("TYPE {name}"), false);
    out.trim()
        .parse()
        .unwrap_or_else(|_| panic!("TYPE {name}: {out}"))
}

/// `count` running in PC task 1 for 450 ms.
fn counting() -> Term {
    let mut t = Term::new(bare());
    loaded_ok(&t.load("count.as", COUNT));
    assert_eq!(t.cmd("PCEXECUTE 1: count", false), "");
    t.advance(Duration::from_millis(450));
    t
}

#[test]
fn a_load_while_a_task_counts_takes_effect_at_once_and_the_count_never_resets_or_jumps() {
    let mut reference = counting();
    let mut t = counting();
    assert_eq!(type_real(&mut t, "n"), 5.0);
    loaded_ok(&t.load("other.as", OTHER));
    assert_eq!(
        t.cmd("PCEXECUTE 2: other", false),
        "",
        "no P1014: no waiting"
    );
    for k in 1..=20 {
        t.advance(Duration::from_millis(100));
        reference.advance(Duration::from_millis(100));
        let n = type_real(&mut t, "n");
        assert_eq!(
            n,
            5.0 + f64::from(k),
            "one count per 0.1 s, from where it was"
        );
        assert_eq!(
            n,
            type_real(&mut reference, "n"),
            "as if nothing was loaded"
        );
    }
    assert_eq!(t.cmd("TYPE TASK (1001)", false), " 1");
    assert_eq!(t.cmd("TYPE TASK (1002)", false), " 1");
    assert_eq!(type_real(&mut t, "m"), 20.0);
    assert_eq!(
        t.c.program().task_program(TaskId::Pc(1)).as_deref(),
        Some("count")
    );
}

/// The 1040 server in PC task 1 and one client session of six polls; with `load`, a file of
/// another program is loaded (and its program started in PC task 2) between the third and
/// the fourth. The replies, byte for byte.
fn server_session(load: bool) -> Vec<Vec<u8>> {
    let mut t = Term::new(bare());
    loaded_ok(&t.load("server1040.as", SERVER));
    t.cmd("PCEXECUTE 1: autostart.pc", false);
    t.advance(Duration::from_millis(100));
    let client =
        t.c.program_mut()
            .connect(None, [127, 0, 0, 1])
            .expect("the program listens");
    t.c.advance_by(Duration::from_millis(50));
    let mut replies = Vec::new();
    for k in 0..6 {
        if k == 3 && load {
            // The terminal moves the controller's clock only by the first steps of what
            // PCEXECUTE starts (microseconds): the polls keep their times.
            loaded_ok(&t.load("other.as", OTHER));
            assert_eq!(t.cmd("PCEXECUTE 2: other", false), "");
        }
        assert!(t.c.program_mut().send(client, b"1040 0 0"), "poll {k} sent");
        t.c.advance_by(Duration::from_millis(100));
        replies.push(t.c.program_mut().recv(client).bytes);
    }
    if load {
        assert_eq!(t.cmd("TYPE TASK (1002)", false), " 1");
    }
    assert_eq!(t.cmd("TYPE TASK (1001)", false), " 1");
    replies
}

#[test]
fn the_1040_server_keeps_its_client_session_across_a_load_of_another_file() {
    let with = server_session(true);
    let without = server_session(false);
    for (k, r) in with.iter().enumerate() {
        let text = String::from_utf8_lossy(r);
        let fields: Vec<&str> = text.split_whitespace().collect();
        assert_eq!((fields.len(), fields[0]), (14, "1040"), "reply {k}: {text}");
    }
    // The session's clock (TIMER(1)) runs on: each reply differs from the one before.
    assert!(with.windows(2).all(|w| w[0] != w[1]), "{with:?}");
    // Differential: the same socket answers the same bytes at the same times, as if nothing
    // had been loaded (the controller's clock, and with it TIMER(1), runs the same).
    assert_eq!(with, without);
}

#[test]
fn a_load_replacing_the_running_program_is_refused_with_p1014_and_nothing_changes() {
    let mut reference = counting();
    let mut t = counting();
    let changed = COUNT.replace("n + 1", "n + 100");
    match t.load("count.as", &format!("{changed}{OTHER}")) {
        Event::Loaded { errors, output, .. } => {
            assert_eq!(errors, 1);
            assert!(output.contains("count: (P1014)"), "{output}");
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(t.c.memory().program("count"), Some(COUNT.as_bytes()));
    for _ in 0..10 {
        t.advance(Duration::from_millis(100));
        reference.advance(Duration::from_millis(100));
        assert_eq!(type_real(&mut t, "n"), type_real(&mut reference, "n"));
    }
    // The file's other program loaded and runs beside it.
    assert_eq!(t.cmd("PCEXECUTE 2: other", false), "");
}

#[test]
fn a_load_replacing_a_program_a_running_task_has_called_is_refused_with_p1014() {
    let mut t = Term::new(bare());
    let file =
        ".PROGRAM top()\n  CALL inner\n.END\n.PROGRAM inner()\n  TWAIT 10\n  done = 1\n.END\n";
    loaded_ok(&t.load("nest.as", file));
    t.cmd("PCEXECUTE 1: top", false);
    t.advance(Duration::from_millis(100));
    match t.load("inner.as", ".PROGRAM inner()\n  done = 2\n.END\n") {
        Event::Loaded { errors, output, .. } => {
            assert_eq!(errors, 1);
            assert!(output.contains("inner: (P1014)"), "{output}");
        }
        other => panic!("{other:?}"),
    }
    assert!(t.cmd("DELETE/P inner", true).contains("(P1018)"));
    t.advance(Duration::from_secs(10));
    assert_eq!(t.cmd("TYPE done", false), " 1");
}

#[test]
fn a_load_while_a_task_runs_keeps_variables_and_sets_those_its_data_sections_name() {
    let mut t = counting();
    let file = format!("{OTHER}.REALS\nlimit = 7\nn = 100\n.END\n");
    loaded_ok(&t.load("other.as", &file));
    assert_eq!(type_real(&mut t, "limit"), 7.0);
    // AS-E: a LOAD overwrites variables silently; the counter goes on from the loaded value.
    assert_eq!(type_real(&mut t, "n"), 100.0);
    t.advance(Duration::from_millis(100));
    assert_eq!(type_real(&mut t, "n"), 101.0);
}

#[test]
fn a_power_cycle_keeps_the_system_switches() {
    let mut t = Term::new(bare());
    loaded_ok(&t.load("server1040.as", SERVER));
    t.cmd("SWITCH CP = OFF", false);
    t.c.power_cycle();
    assert_eq!(t.cmd("SWITCH CP", false), "CP              OFF");
    assert_eq!(t.c.memory().switch("cp"), Some(false));
}

#[test]
fn save_sends_the_programs_and_they_load_again_elsewhere() {
    let mut t = Term::new(bare());
    loaded_ok(&t.load("server1040.as", SERVER));
    t.client.save(t.now, "/P backup.as").unwrap();
    let file = match t.settle().pop() {
        Some(Event::Saved { file, output }) => {
            assert!(output.contains("Saving...(backup.as)"), "{output}");
            file
        }
        other => panic!("{other:?}"),
    };
    let text = String::from_utf8(file).unwrap();
    assert!(text.contains(".PROGRAM autostart.pc()"), "{text}");
    assert!(text.contains(".END\r\n") && !text.replace("\r\n", "").contains('\n'));
    let mut other = Term::new(bare());
    loaded_ok(&other.load("backup.as", &text));
    assert_eq!(other.c.memory().programs(), t.c.memory().programs());
    assert_eq!(
        other.c.memory().program("ros_move"),
        t.c.memory().program("ros_move")
    );
}

#[test]
fn a_load_overwrites_a_program_of_the_same_name() {
    let mut t = Term::new(bare());
    loaded_ok(&t.load("a.as", ".PROGRAM p()\n  x = 1\n.END\n"));
    loaded_ok(&t.load("b.as", ".PROGRAM p()\n  x = 2\n.END\n"));
    assert_eq!(t.c.memory().programs(), vec!["p"]);
    assert!(String::from_utf8_lossy(t.c.memory().program("p").unwrap()).contains("x = 2"));
}

#[test]
fn data_sections_load_with_their_programs_and_are_saved_without_p() {
    let mut t = Term::new(bare());
    let file = ".PROGRAM p()\n  y = limit\n.END\n.REALS\nlimit = 3\n.END\n";
    loaded_ok(&t.load("d.as", file));
    loaded_ok(&t.load("d.as", file));
    assert_eq!(t.c.memory().data_sections().len(), 1);
    t.cmd("PCEXECUTE 2: p", false);
    t.advance(Duration::from_millis(50));
    assert_eq!(t.cmd("TYPE y", false), " 3");
    t.client.save(t.now, "all.as").unwrap();
    match t.settle().pop() {
        Some(Event::Saved { file, .. }) => {
            assert!(String::from_utf8_lossy(&file).contains(".REALS\r\nlimit = 3\r\n"))
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn at_most_three_sessions_and_a_fourth_is_refused() {
    let mut c = bare();
    let links: Vec<TerminalLink> = (0..3)
        .map(|_| TerminalLink::open(&mut c, SessionConfig::default()))
        .collect();
    let names: Vec<_> = links
        .iter()
        .map(|l| l.terminal().unwrap().to_owned())
        .collect();
    assert_eq!(names, ["AUX1", "AUX2", "AUX3"]);
    let mut fourth = TerminalLink::open(&mut c, SessionConfig::default());
    assert_eq!(fourth.terminal(), None);
    let mut out = Vec::new();
    while let Some(b) = fourth.poll_transmit() {
        out.extend(b);
    }
    assert!(String::from_utf8_lossy(&out).contains("All terminal sessions are in use."));
    assert!(fourth.is_closed());
    let mut second = links.into_iter().nth(1).unwrap();
    second.handle_close(&mut c);
    let again = TerminalLink::open(&mut c, SessionConfig::default());
    assert_eq!(again.terminal(), Some("AUX2"));
}

#[test]
fn an_unknown_command_is_refused() {
    let mut t = Term::new(bare());
    assert!(t.cmd("FROBNICATE", false).starts_with("(P0100)"));
}

#[test]
fn the_native_server_refuses_loads_and_says_how_to_load() {
    let mut t = Term::new(Controller::new(ControllerConfig::default()));
    match t.load("x.as", ".PROGRAM x()\n.END\n") {
        Event::Loaded { errors, output, .. } => {
            assert_eq!(errors, 1);
            assert!(output.contains("--bare"), "{output}");
        }
        other => panic!("{other:?}"),
    }
    assert!(t.c.memory().programs().is_empty());
}

#[test]
fn pcexecute_runs_the_program_as_many_cycles_as_asked_and_pcstatus_counts_them() {
    let mut t = Term::new(bare());
    let p = ".PROGRAM count()\n  n = n + 1\n  TWAIT 0.1\n.END\n.REALS\nn = 0\n.END\n";
    loaded_ok(&t.load("count.as", p));
    t.cmd("PCEXECUTE 2: count, 3", false);
    t.advance(Duration::from_millis(150));
    let status = t.cmd("PCSTATUS 2:", false);
    assert!(status.contains("Completed cycles: 1"), "{status}");
    assert!(status.contains("Remaining cycles: 2"), "{status}");
    t.advance(Duration::from_millis(2000));
    assert_eq!(t.cmd("TYPE n", false), " 3");
    assert!(!t.c.program().task_running(TaskId::Pc(2)));
    // A count that is not a number is refused and nothing starts.
    let refused = t.cmd("PCEXECUTE 2: count, many", false);
    assert!(refused.contains("whole number"), "{refused}");
    assert!(!t.c.program().task_running(TaskId::Pc(2)));
}

#[test]
fn pcexecute_minus_one_runs_until_pcabort() {
    let mut t = Term::new(bare());
    let p = ".PROGRAM count()\n  n = n + 1\n  TWAIT 0.1\n.END\n.REALS\nn = 0\n.END\n";
    loaded_ok(&t.load("count.as", p));
    t.cmd("PCEXECUTE 3: count, -1", false);
    t.advance(Duration::from_millis(5050));
    assert!(t.c.program().task_running(TaskId::Pc(3)));
    let status = t.cmd("PCSTATUS 3:", false);
    assert!(status.contains("Remaining cycles: Infinite"), "{status}");
    let n: u32 = t.cmd("TYPE n", false).trim().parse().unwrap();
    assert!((45..=51).contains(&n), "{n} cycles of 0.1 s in 5 s");
    t.cmd("PCABORT 3:", false);
    t.advance(Duration::from_millis(500));
    assert!(!t.c.program().task_running(TaskId::Pc(3)));
    let after: u32 = t.cmd("TYPE n", false).trim().parse().unwrap();
    t.advance(Duration::from_millis(1000));
    assert_eq!(
        t.cmd("TYPE n", false).trim().parse::<u32>().unwrap(),
        after,
        "no cycle after PCABORT"
    );
    assert!(after <= n + 1, "{after} after {n}");
}

#[test]
fn execute_with_a_cycle_count_repeats_the_robot_program() {
    let mut t = Term::new(bare());
    let p = ".PROGRAM rob()\n  m = m + 1\n  TWAIT 0.1\n.END\n.REALS\nm = 0\n.END\n";
    loaded_ok(&t.load("rob.as", p));
    t.c.set_power(true).unwrap();
    t.cmd("EXECUTE rob, 4", false);
    t.advance(Duration::from_millis(2000));
    assert_eq!(t.cmd("TYPE m", false), " 4");
    assert!(!t.c.program().task_running(TaskId::Robot));
}

/// A file as bytes: a Shift-JIS comment (「あ」 is 82 A0), a Windows-1250 string (`Łódź` is
/// A3 F3 64 9F), CR LF line ends.
const CODE_PAGE_FILE: &[u8] = b".PROGRAM enc()\r\n  ; \x82\xa0 comment\r\n  $s = \"\xa3\xf3d\x9f\"\r\n  n = LEN($s)\r\n  a = ASC($s)\r\n.END\r\n.STRINGS\r\n$t = \"\x82\xa0\"\r\n.END\r\n";

#[test]
fn a_file_in_any_code_page_loads_runs_and_saves_back_byte_for_byte() {
    let mut t = Term::new(bare());
    t.client.load(t.now, "enc.as", CODE_PAGE_FILE).unwrap();
    loaded_ok(&t.settle().pop().expect("an event"));
    t.cmd("PCEXECUTE 2: enc", false);
    t.advance(Duration::from_millis(50));
    // The string holds the file's four bytes, not their replacement characters.
    assert_eq!(t.cmd("TYPE n", false), " 4");
    assert_eq!(t.cmd("TYPE a", false), " 163");
    t.client.save(t.now, "enc.as").unwrap();
    match t.settle().pop() {
        Some(Event::Saved { file, .. }) => assert_eq!(file, CODE_PAGE_FILE),
        other => panic!("{other:?}"),
    }
}

#[test]
fn instructions_stubbed_for_a_bare_controller_stay_stubbed_through_loads_and_power_cycles() {
    let load = fs020n_as::LoadOptions::new().stub("FROBNICATE");
    let mut t = Term::new(Controller::bare(ControllerConfig::default(), load));
    let file = ".PROGRAM autostart.pc()\n  FROBNICATE 3\n  done = 1\n.END\n";
    loaded_ok(&t.load("s.as", file));
    t.cmd("PCEXECUTE 1: autostart.pc", false);
    t.advance(Duration::from_millis(50));
    assert_eq!(t.cmd("TYPE done", false), " 1");
    t.cmd("SWITCH AUTOSTART.PC = ON", false);
    t.c.power_cycle();
    t.advance(Duration::from_millis(50));
    assert_eq!(
        t.cmd("TYPE done", false),
        " 1",
        "the rebuilt program ran past the stub"
    );
    // Without the stub the controller does not know the word: a syntax error, nothing loads.
    let mut plain = Term::new(bare());
    match plain.load("s.as", file) {
        Event::Loaded {
            syntax_error: Some(line),
            ..
        } => assert_eq!(line, "FROBNICATE 3"),
        other => panic!("{other:?}"),
    }
    assert!(plain.c.memory().programs().is_empty());
}

#[test]
fn a_load_with_no_task_running_keeps_variables_signals_and_timers_and_its_data_overwrites() {
    let mut t = Term::new(bare());
    let p = ".PROGRAM setx()\n  x = 42\n  SIGNAL 1\n  TIMER 2 = 0\n.END\n";
    loaded_ok(&t.load("setx.as", p));
    t.cmd("PCEXECUTE 2: setx", false);
    t.advance(Duration::from_millis(500));
    assert!(!t.c.program().task_running(TaskId::Pc(2)));
    // An unrelated file: what the finished program left stays, as on a controller.
    loaded_ok(&t.load("other.as", ".PROGRAM other()\n  y = x\n.END\n"));
    assert_eq!(t.cmd("TYPE x", false), " 42");
    assert_eq!(t.cmd("TYPE SIG(1)", false), " -1");
    let timer: f32 = t.cmd("TYPE TIMER(2)", false).trim().parse().unwrap();
    assert!(
        (0.45..0.6).contains(&timer),
        "TIMER 2 kept running: {timer}"
    );
    t.cmd("PCEXECUTE 3: other", false);
    t.advance(Duration::from_millis(100));
    assert_eq!(t.cmd("TYPE y", false), " 42");
    // A file's data section overwrites the variable it names.
    loaded_ok(&t.load("data.as", ".REALS\nx = 7\n.END\n"));
    assert_eq!(t.cmd("TYPE x", false), " 7");
    // A power cycle starts the interpreter again: variables from the data sections only.
    t.c.power_cycle();
    assert_eq!(t.cmd("TYPE x", false), " 7");
    assert!(t.cmd("TYPE y", false).starts_with("(E0102)"));
}

/// Everything the session sent since the last call, program output included.
fn drain_output(t: &mut Term) -> String {
    t.link.print_output(&mut t.c);
    let mut out = Vec::new();
    while let Some(b) = t.link.poll_transmit() {
        out.extend(b);
    }
    String::from_utf8_lossy(&out).into_owned()
}

#[test]
fn pcabort_stops_a_pc_task_between_steps_at_once_and_says_so() {
    let mut t = Term::new(bare());
    let busy = ".PROGRAM busy()\n  WHILE TRUE DO\n    n = 1\n  END\n.END\n";
    loaded_ok(&t.load("busy.as", busy));
    t.cmd("PCEXECUTE 2: busy", false);
    t.advance(Duration::from_millis(10));
    assert_eq!(t.cmd("PCABORT 2:", false), "PC program aborted.No = 2");
    assert_eq!(t.cmd("TYPE TASK (1002)", false), " 0");
}

#[test]
fn a_running_program_blinks_a_star_after_its_name_in_the_directory() {
    let mut t = Term::new(bare());
    loaded_ok(&t.load("server1040.as", SERVER));
    t.cmd("PCEXECUTE 1: autostart.pc", false);
    let dir = t.cmd("DIRECTORY/P", false);
    assert!(dir.contains("autostart.pc*"), "{dir}");
    assert!(!dir.contains("ros_move*"), "{dir}");
    assert_eq!(
        fs020n_term::text::parse_directory(&dir),
        ["autostart.pc", "ros_move"]
    );
}

#[test]
fn a_pc_program_listens_by_the_time_the_prompt_of_pcexecute_returns() {
    let mut t = Term::new(bare());
    loaded_ok(&t.load("server1040.as", SERVER));
    assert_eq!(t.cmd("PCEXECUTE 1: autostart.pc", false), "");
    // No time given to the controller after the prompt.
    assert!(t.c.program().listening(Some(10050)));
}

#[test]
fn a_robot_program_started_by_execute_is_announced_when_it_completes() {
    let mut t = Term::new(bare());
    loaded_ok(&t.load("r.as", ".PROGRAM r()\n  TWAIT 0.2\n.END\n"));
    t.c.set_power(true).unwrap();
    assert_eq!(t.cmd("EXECUTE r", false), "");
    assert!(!drain_output(&mut t).contains("Program completed."));
    t.advance(Duration::from_millis(400));
    let text = drain_output(&mut t);
    assert!(text.contains("Program completed.No = 1\r\n"), "{text}");
}

#[test]
fn signal_where_zpower_hold_continue_and_messages_answer_as_the_controller() {
    let mut t = Term::new(bare());
    loaded_ok(&t.load("hi.as", ".PROGRAM hi()\n  PRINT \"hello\"\n.END\n"));
    assert_eq!(t.cmd("SIGNAL 1, -2, 2001", false), "");
    assert_eq!(t.cmd("TYPE SIG(1)", false), " -1");
    assert_eq!(t.cmd("TYPE SIG(2001)", false), " -1");
    assert_eq!(t.cmd("TYPE SIG(2)", false), " 0");
    assert!(t.cmd("SIGNAL 1001", false).starts_with("(P"));
    let w = t.cmd("WHERE", false);
    let lines: Vec<&str> = w.lines().collect();
    assert_eq!(lines.len(), 4, "{w}");
    assert!(lines[0].contains("JT1") && lines[0].contains("JT6"), "{w}");
    assert!(
        lines[2].contains("X[mm]") && lines[2].contains("T[deg]"),
        "{w}"
    );
    assert_eq!(lines[1].split_whitespace().count(), 6, "{w}");
    assert_eq!(t.cmd("ZPOWER ON", false), "");
    assert!(t.c.panel().power);
    assert_eq!(t.cmd("ZPOW OFF", false), "");
    assert!(!t.c.panel().power);
    assert_eq!(t.cmd("HOLD", false), "");
    assert!(!t.c.panel().run);
    assert_eq!(t.cmd("CONTINUE", false), "");
    assert!(t.c.panel().run);
    // MESSAGES OFF: a program's PRINT does not reach this terminal.
    assert_eq!(t.cmd("MESSAGES OFF", false), "");
    t.cmd("PCEXECUTE 2: hi", false);
    t.advance(Duration::from_millis(100));
    assert!(!drain_output(&mut t).contains("hello"));
    assert_eq!(t.cmd("MESSAGES ON", false), "");
    t.cmd("PCEXECUTE 2: hi", false);
    t.advance(Duration::from_millis(100));
    assert!(drain_output(&mut t).contains("hello"));
}

#[test]
fn an_older_generation_refuses_to_load_over_a_program_and_ends_with_loading_done() {
    let mut c = bare();
    let link = TerminalLink::open(
        &mut c,
        SessionConfig {
            max_piece: 5,
            ..SessionConfig::of(fs020n_term::Generation::D)
        },
    );
    let mut t = Term {
        now: Duration::ZERO,
        c,
        client: TerminalClient::new(ClientConfig::default()),
        link,
    };
    t.client.login(t.now).unwrap();
    assert!(matches!(t.settle().as_slice(), [Event::LoggedIn { .. }]));
    let a = ".PROGRAM a()\n  x = 1\n.END\n";
    match t.load("a.as", a) {
        Event::Loaded {
            errors: 0,
            ending,
            programs,
            ..
        } => {
            assert_eq!(ending.as_deref(), Some(fs020n_term::text::LOADING_DONE));
            assert_eq!(programs, ["a"]);
        }
        other => panic!("{other:?}"),
    }
    // The same name again: refused, the LOAD aborted there (the next program not loaded).
    let again = ".PROGRAM a()\n  x = 2\n.END\n.PROGRAM b()\n.END\n";
    match t.load("a.as", again) {
        Event::Loaded {
            errors,
            programs,
            output,
            ..
        } => {
            assert!(programs.is_empty(), "{output}");
            let r = fs020n_term::text::refusal(&output).expect("the refusal");
            assert_eq!(r.code, Some(('P', 1039)));
            assert_eq!(errors, 0, "Loading done. has no count: {output}");
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(t.c.memory().programs(), ["a"]);
    assert!(String::from_utf8_lossy(t.c.memory().program("a").unwrap()).contains("x = 1"));
}

#[test]
fn commands_take_the_manuals_abbreviations_and_nothing_shorter() {
    let mut t = Term::new(bare());
    loaded_ok(&t.load("server1040.as", SERVER));
    // PCEX is the manual's shortest PCEXECUTE, DI its DIRECTORY, STA its STATUS.
    assert_eq!(t.cmd("pcex 1: autostart.pc", false), "");
    t.advance(Duration::from_millis(200));
    assert_eq!(t.cmd("TYPE TASK(1001)", false), " 1");
    assert!(t.cmd("di", false).contains("autostart.pc"));
    let status = t.cmd("sta", false);
    assert!(
        status.contains("Monitor speed") || !status.starts_with('('),
        "{status}"
    );
    // PCE is shorter than the manual's PCEX: the command is unknown.
    assert!(t.cmd("PCE 1: autostart.pc", false).starts_with("(P0100)"));
}

/// What the session sends back for `typed` (raw, as a telnet user types it).
fn typed(t: &mut Term, line: &str) -> String {
    t.link.handle_input(&mut t.c, line.as_bytes());
    let mut out = Vec::new();
    while let Some(b) = t.link.poll_transmit() {
        out.extend(b);
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// A real the programs see, through `TYPE`.
fn typed_real(t: &mut Term, expr: &str) -> f64 {
    let out = t.cmd(&format!("TYPE {expr}"), false);
    out.trim()
        .parse()
        .unwrap_or_else(|_| panic!("TYPE {expr}: {out}"))
}

#[test]
fn here_stores_the_joints_offers_them_for_editing_and_the_programs_see_the_edit() {
    let mut t = Term::new(bare());
    let j = t.c.joints().0;
    let out = typed(&mut t, "HERE #p\r\n");
    assert!(out.contains("JT1") && out.contains("JT6"), "{out}");
    assert!(out.contains(&format!("{:>10.3}", j[0])), "{out}");
    assert!(
        out.ends_with(&format!("{}\r\n", text::CHANGE_QUESTION)),
        "the question, no prompt: {out:?}"
    );
    // AS-E p.5-49: `,,,-15` changes the fourth value; the values are offered again.
    let out = typed(&mut t, ",,,-15\r\n");
    assert!(out.contains("   -15.000"), "{out}");
    assert!(out.ends_with(&format!("{}\r\n", text::CHANGE_QUESTION)));
    // Not a number: nothing changes, asked again.
    let out = typed(&mut t, "x\r\n");
    assert!(out.contains("   -15.000"), "{out}");
    let out = typed(&mut t, "\r\n");
    assert!(
        out.ends_with('>'),
        "an empty line ends the editing: {out:?}"
    );

    loaded_ok(&t.load("show.as", ".PROGRAM show()\n  DECOMPOSE a[1] = #p\n.END\n"));
    t.cmd("PCEXECUTE 2: show", false);
    t.advance(Duration::from_millis(50));
    assert!((typed_real(&mut t, "a[1]") - j[0]).abs() < 1e-3);
    assert_eq!(typed_real(&mut t, "a[4]"), -15.0);

    // SAVE writes the variable once, with its last value, after a second HERE too.
    t.cmd("HERE #p", false);
    let saved = String::from_utf8(t.c.memory().data_sections().concat()).unwrap();
    assert_eq!(saved.matches("#p ").count(), 1, "{saved}");
    assert!(saved.contains(".JOINTS\n#p "), "{saved}");
}

#[test]
fn here_of_a_transformation_is_the_tool_in_the_world_as_a_programs_here_gives_it() {
    let mut t = Term::new(bare());
    t.c.set_power(true).unwrap();
    let program = ".PROGRAM tooled()\n  TOOL TRANS(0, 0, 100, 0, 0, 0)\n  HERE q\n  DECOMPOSE d[1] = q\n.END\n\
.PROGRAM seen()\n  DECOMPOSE c[1] = pose\n.END\n";
    loaded_ok(&t.load("tooled.as", program));
    t.cmd("EXECUTE tooled", false);
    t.advance(Duration::from_millis(200));
    let out = t.cmd("HERE pose", false);
    assert!(out.contains("X[mm]") && out.contains("T[deg]"), "{out}");
    assert!(out.contains(text::CHANGE_QUESTION), "{out}");
    t.cmd("PCEXECUTE 2: seen", false);
    t.advance(Duration::from_millis(50));
    for k in 1..=6 {
        let by_program = typed_real(&mut t, &format!("d[{k}]"));
        let by_terminal = typed_real(&mut t, &format!("c[{k}]"));
        assert!(
            (by_program - by_terminal).abs() < 0.01,
            "value {k}: the program's HERE {by_program}, the terminal's {by_terminal}"
        );
    }
    // The TOOL is applied: the tool tip is 100 mm from the flange WHERE shows.
    let w = t.cmd("WHERE", false);
    let flange: Vec<f64> = w
        .lines()
        .nth(3)
        .unwrap()
        .split_whitespace()
        .map(|v| v.parse().unwrap())
        .collect();
    let tip: Vec<f64> = (1..=3)
        .map(|k| typed_real(&mut t, &format!("c[{k}]")))
        .collect();
    let d = ((tip[0] - flange[0]).powi(2)
        + (tip[1] - flange[1]).powi(2)
        + (tip[2] - flange[2]).powi(2))
    .sqrt();
    assert!((d - 100.0).abs() < 0.1, "{d}");
}

#[test]
fn here_refuses_a_name_that_is_not_a_variable() {
    let mut t = Term::new(bare());
    assert!(t.cmd("HERE 1abc", false).starts_with("(P0117)"));
    assert!(t.cmd("HERE", false).starts_with("(P0117)"));
    assert!(t.cmd("HERE #a+b", false).starts_with("(P0117)"));
}

#[test]
fn here_of_a_compound_pose_defines_the_rightmost_so_that_the_sum_is_the_current_pose() {
    // AS-E p.6-108: `HERE a+b` defines b; a must exist. A touch-up relative to a camera frame.
    let mut t = Term::new(bare());
    let program =
        ".PROGRAM seen()\n  DECOMPOSE w[1] = c_cam+pick\n  HERE h\n  DECOMPOSE h[1] = h\n.END\n\
.TRANS\nc_cam 200 -100 50 0 0 90\n.END\n";
    loaded_ok(&t.load("cam.as", program));
    assert_eq!(
        t.cmd("HERE nowhere+pick", false),
        "(E0103) Location data is not defined: nowhere"
    );
    let out = t.cmd("HERE c_cam+pick", false);
    assert!(out.contains("X[mm]"), "{out}");
    assert!(out.ends_with(text::CHANGE_QUESTION), "{out:?}");
    assert!(typed(&mut t, "\r\n").ends_with('>'));
    t.cmd("PCEXECUTE 2: seen", false);
    t.advance(Duration::from_millis(50));
    for k in 1..=6 {
        let sum = typed_real(&mut t, &format!("w[{k}]"));
        let here = typed_real(&mut t, &format!("h[{k}]"));
        assert!(
            (sum - here).abs() < 0.01,
            "value {k}: c_cam+pick {sum}, HERE {here}"
        );
    }
}

#[test]
fn abort_lets_the_arm_finish_its_motion_and_the_one_planned_then_the_program_stops() {
    let mut t = Term::new(bare());
    t.c.set_power(true).unwrap();
    let program = ".PROGRAM three()\n  JMOVE #a\n  JMOVE #b\n  JMOVE #c\n.END\n\
.JOINTS\n#a 20 0 0 0 -30 0\n#b 20 20 0 0 -30 0\n#c -20 20 0 0 -30 0\n.END\n";
    loaded_ok(&t.load("three.as", program));
    assert_eq!(t.cmd("EXECUTE three", false), "");
    t.advance(Duration::from_millis(300));
    let moving = t.c.joints().0;
    assert!(
        moving[0] > 0.5 && moving[0] < 19.5,
        "on the way to #a: {moving:?}"
    );
    assert_eq!(t.cmd("ABORT", false), "");
    // The step in progress (JMOVE #b, waiting to be planned) completes: still running.
    assert_eq!(t.cmd("TYPE TASK (1)", false), " 1");
    t.advance(Duration::from_secs(20));
    assert_eq!(t.cmd("TYPE TASK (1)", false), " 0");
    let end = t.c.joints().0;
    let b = [20.0, 20.0, 0.0, 0.0, -30.0, 0.0];
    for k in 0..6 {
        assert!(
            (end[k] - b[k]).abs() < 0.01,
            "stopped at #b, not braked nor at #c: {end:?}"
        );
    }
}

#[test]
fn weight_sets_the_payload_shows_it_for_editing_and_refuses_more_than_the_rated() {
    let mut t = Term::new(bare());
    // A telnet library's `weight 0, 0, 0, 0`: the instruction, at once.
    assert_eq!(t.cmd("weight 5, 0, 0, 100", false), "");
    let out = typed(&mut t, "WEIGHT\r\n");
    assert!(
        out.contains("Mass[kg]") && out.contains("Iz[kgm2]"),
        "{out}"
    );
    assert!(
        out.contains("     5.000") && out.contains("   100.000"),
        "{out}"
    );
    assert!(
        out.ends_with(&format!("{}\r\n", text::CHANGE_QUESTION)),
        "{out:?}"
    );
    // `,,,50` changes the fourth value (the centre of gravity's Z), offered again.
    let out = typed(&mut t, ",,,50\r\n");
    assert!(
        out.contains("    50.000") && !out.contains("   100.000"),
        "{out}"
    );
    let out = typed(&mut t, "\r\n");
    assert!(out.ends_with('>'), "{out:?}");
    // More than the rated 20 kg: the program's error line, the payload kept.
    assert!(t.cmd("WEIGHT 25", false).starts_with("(E0106)"));
    let out = typed(&mut t, "WEIGHT\r\n");
    assert!(
        out.contains("     5.000") && out.contains("    50.000"),
        "{out}"
    );
    typed(&mut t, "\r\n");
}

#[test]
fn sysinit_asks_then_deletes_every_program_and_variable_unless_a_task_runs() {
    let mut t = Term::new(bare());
    loaded_ok(&t.load("server1040.as", SERVER));
    t.cmd("DO kept = 5", false);
    t.cmd("PCEXECUTE 1: autostart.pc", false);
    t.advance(Duration::from_millis(100));
    let out = t.cmd("SYSINIT", true);
    assert!(out.contains("(P1019)"), "a PC task runs: {out}");
    assert!(!t.c.memory().programs().is_empty());
    t.cmd("PCABORT 1:", false);
    t.advance(Duration::from_millis(3100));
    t.cmd("PCKILL 1:", true);
    // Answered 0: nothing happens.
    t.cmd("SYSINIT", false);
    assert!(!t.c.memory().programs().is_empty());
    let out = t.cmd("SYSINIT", true);
    assert!(!out.contains("(P"), "{out}");
    assert!(t.c.memory().programs().is_empty());
    assert!(t.c.memory().data_sections().is_empty());
    assert!(t.cmd("TYPE kept", false).starts_with("(E0102)"));
    // The empty controller takes a new file.
    loaded_ok(&t.load("server1040.as", SERVER));
    assert!(!t.c.memory().programs().is_empty());
}

#[test]
fn errlog_lists_the_errors_raised_oldest_first_with_their_time() {
    let mut t = Term::new(bare());
    assert_eq!(t.cmd("ERRLOG", false), "No error.");
    let p = ".PROGRAM bad()\n  x = 1 / 0\n.END\n";
    loaded_ok(&t.load("bad.as", p));
    t.advance(Duration::from_millis(1500));
    t.cmd("PCEXECUTE 1: bad", false);
    t.advance(Duration::from_millis(100));
    t.cmd("ERESET", false);
    t.advance(Duration::from_millis(61_000));
    t.c.set_estop(true);
    let log = t.cmd("ERRLOG", false);
    let lines: Vec<&str> = log.lines().collect();
    assert_eq!(lines.len(), 4, "{log}");
    assert!(lines[0].starts_with("1-[0:00:01."), "{log}");
    assert!(lines[1].starts_with("  (E0108)"), "{log}");
    assert!(lines[2].starts_with("2-[0:01:02."), "{log}");
    assert!(lines[3].starts_with("  (E3808)"), "{log}");
}

#[test]
fn point_without_an_assignment_offers_the_value_for_editing() {
    let mut t = Term::new(bare());
    assert_eq!(t.cmd("POINT a = TRANS(100, 200, 300, 0, 90, 0)", false), "");
    let out = typed(&mut t, "POINT a\r\n");
    assert!(out.contains("X[mm]") && out.contains("   200.000"), "{out}");
    assert!(
        out.ends_with(&format!("{}\r\n", text::CHANGE_QUESTION)),
        "{out:?}"
    );
    typed(&mut t, ",,350\r\n");
    typed(&mut t, "\r\n");
    assert_eq!(t.cmd("TYPE DZ(a)", false), " 350");
    // A variable without a value: zeros, which it then has.
    let out = typed(&mut t, "POINT #j\r\n");
    assert!(out.contains("JT1") && out.contains("     0.000"), "{out}");
    typed(&mut t, "\r\n");
    assert!(t
        .c
        .memory()
        .data_sections()
        .iter()
        .any(|d| String::from_utf8_lossy(d).contains("#j")));
}
