//! Any command line, and any bytes, into the controller's terminal: no panic, and the session
//! keeps answering (a prompt after a plain command).

use std::time::Duration;

use fs020n_sim::{Controller, ControllerConfig, TerminalLink};
use fs020n_term::SessionConfig;
use proptest::prelude::*;

/// A controller with the project's server loaded and running, and a logged-in session.
fn setup() -> (Controller, TerminalLink) {
    let mut c = Controller::bare(ControllerConfig::default(), fs020n_as::LoadOptions::new());
    assert_eq!(c.memory_mut().load(fs020n_as::SERVER_1040, false).errors, 0);
    c.program_mut().pc_execute(1, "autostart.pc", 1).unwrap();
    c.advance_by(Duration::from_millis(50));
    let mut link = TerminalLink::open(&mut c, SessionConfig::default());
    link.handle_input(&mut c, b"as\r\n");
    while link.poll_transmit().is_some() {}
    (c, link)
}

fn drain(link: &mut TerminalLink) -> Vec<u8> {
    let mut out = Vec::new();
    while let Some(b) = link.poll_transmit() {
        out.extend(b);
    }
    out
}

const WORDS: &[&str] = &[
    "DIRECTORY/P",
    "LIST/P",
    "TYPE",
    "KILL",
    "PCKILL",
    "DELETE/P",
    "PCEXECUTE",
    "PCABORT",
    "PCSTATUS",
    "STATUS",
    "EXECUTE",
    "ABORT",
    "SWITCH",
    "ID",
    "ERESET",
    "ZPOW",
    "pcexe",
    "sw",
    "TY",
    "DEL",
    "SAVE",
    "SAVE/P",
    // Instructions run at the prompt, and the commands with a question or a Change? dialog.
    "DO",
    "POINT",
    "POINT/X",
    "WEIGHT",
    "SYSINIT",
    "ERRLOG",
    "SOUT",
    "BITS",
    "IFPWPRINT",
    "PCEND",
    "SPEED",
    "PRINT",
    "CALL",
    "HERE",
];

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    #[test]
    fn any_command_line_is_answered(
        word in prop::sample::select(WORDS),
        tail in "[ -~]{0,40}",
    ) {
        let (mut c, mut link) = setup();
        let line = format!("{word} {tail}\r\n");
        link.handle_input(&mut c, line.as_bytes());
        // A question, a transfer or a prompt: something comes back.
        prop_assert!(!drain(&mut link).is_empty());
        // Leave any question or transfer, then a plain command gets its prompt.
        link.handle_input(&mut c, b"0\r\n");
        drain(&mut link);
        c.advance_by(Duration::from_millis(10));
        link.print_output(&mut c);
    }

    #[test]
    fn any_bytes_do_not_panic(bytes in prop::collection::vec(any::<u8>(), 0..600)) {
        let (mut c, mut link) = setup();
        for piece in bytes.chunks(17) {
            link.handle_input(&mut c, piece);
            drain(&mut link);
        }
        link.handle_close(&mut c);
        drain(&mut link);
    }

    #[test]
    fn any_file_text_is_checked_and_loaded_without_panic(text in "[ -~\n]{0,400}") {
        let mut c = Controller::bare(ControllerConfig::default(), fs020n_as::LoadOptions::new());
        let file = format!(".PROGRAM p()\n{text}\n.END\n");
        let errors = c.memory().check(&file);
        let report = c.memory_mut().load(&file, true);
        prop_assert!(errors.is_empty() || report.errors >= 1);
        let _ = c.program_mut().pc_execute(1, "p", 1);
        c.advance_by(Duration::from_millis(20));
    }
}
