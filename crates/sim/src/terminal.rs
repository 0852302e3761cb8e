//! The controller's AS monitor terminal: [`TerminalLink`], one session of the terminal
//! protocol ([`fs020n_term::TerminalSession`]) over the emulated [`Controller`], sans-IO; the
//! monitor commands in `terminal/monitor.rs`; serving it over TCP in `terminal/serve.rs`
//! ([`crate::Emulator::serve_terminal`]).
//!
//! The session plays the protocol (login, echo, prompts, the `LOAD`/`SAVE` block transfer);
//! the commands act on the controller's memory, tasks and switches
//! (`controller/memory.rs`). Text the programs print reaches every session as unsolicited
//! lines ([`TerminalLink::print_output`]).

mod monitor;
mod serve;

use fs020n_term::{SessionConfig, TerminalSession};

use crate::controller::Controller;
use monitor::{ControllerMonitor, SessionState};

/// One connection to the controller's terminal, as a state machine: feed the client's bytes
/// with [`TerminalLink::handle_input`], send what [`TerminalLink::poll_transmit`] gives, and
/// report the end of the connection with [`TerminalLink::handle_close`] (a transfer then in
/// progress stays open on the controller: P2076 until a power cycle).
#[derive(Debug)]
pub struct TerminalLink {
    session: TerminalSession,
    /// The monitor's state of this session (its question, `MESSAGES`, the last `DO`).
    state: SessionState,
    /// The next line of program output this session prints.
    output_from: u64,
    /// The session is in the middle of a transfer (the controller counts it).
    in_transfer: bool,
}

impl TerminalLink {
    /// A new connection: the telnet opening, the banner and `login: ` are queued, or, when
    /// AUX1–AUX3 are all in use, a refusal and the end of the session.
    pub fn open(controller: &mut Controller, config: SessionConfig) -> TerminalLink {
        let mut state = SessionState::default();
        controller
            .memory_mut()
            .set_refuse_overwrite(config.refuse_overwrite);
        let session = TerminalSession::open(
            &mut ControllerMonitor {
                c: controller,
                state: &mut state,
            },
            config,
        );
        TerminalLink {
            session,
            state,
            output_from: controller.terminal_output_next(),
            in_transfer: false,
        }
    }

    /// The terminal's name (`AUX1`…), `None` when the session was refused.
    pub fn terminal(&self) -> Option<&str> {
        self.session.terminal()
    }

    /// Bytes from the client.
    pub fn handle_input(&mut self, controller: &mut Controller, bytes: &[u8]) {
        self.session.handle_input(
            &mut ControllerMonitor {
                c: controller,
                state: &mut self.state,
            },
            bytes,
        );
        self.note_transfer(controller);
    }

    /// Tells the controller when this session's transfer begins or ends: while it runs, the
    /// other sessions' `LOAD`/`SAVE` get P2076.
    fn note_transfer(&mut self, controller: &mut Controller) {
        let now = self.session.in_transfer();
        if now != self.in_transfer {
            self.in_transfer = now;
            controller.transfer_running(now);
        }
    }

    /// The connection ended.
    pub fn handle_close(&mut self, controller: &mut Controller) {
        self.session.handle_close(&mut ControllerMonitor {
            c: controller,
            state: &mut self.state,
        });
        self.note_transfer(controller);
    }

    /// Queues what the programs printed since this session last looked (after the prompt
    /// already sent, as the controller does); nothing while a transfer or a question runs.
    pub fn print_output(&mut self, controller: &mut Controller) {
        let (lines, next) = controller.terminal_output_since(self.output_from);
        self.output_from = next;
        // MESSAGES OFF: PRINT and TYPE output is not shown on this terminal (AS-E p.7-5).
        if !self.state.messages {
            return;
        }
        for l in lines {
            self.session.print_unsolicited(&l);
        }
    }

    /// The next bytes to send (at most the session's `max_piece`).
    pub fn poll_transmit(&mut self) -> Option<Vec<u8>> {
        self.session.poll_transmit()
    }

    /// `true` once the session has ended and its last bytes were taken.
    pub fn is_closed(&self) -> bool {
        self.session.is_closed()
    }
}
