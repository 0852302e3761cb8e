//! The terminal's side of the controller: its sessions (AUX1–AUX3), the transfers in
//! progress or abandoned (P2076), and the lines programs print, numbered for every session.

use fs020n_term::text;

use super::memory::OUTPUT_LINES;
use super::Controller;

impl Controller {
    // ----------------------------------------------------------------- terminal

    /// A terminal session opens: its name (`AUX1`…`AUX3`), or `None` when all are in use.
    pub(crate) fn open_terminal(&mut self) -> Option<String> {
        let i = self.monitor.sessions.iter().position(|used| !used)?;
        self.monitor.sessions[i] = true;
        Some(format!("AUX{}", i + 1))
    }

    /// A terminal session ended.
    pub(crate) fn close_terminal(&mut self, terminal: &str) {
        let slot = terminal
            .strip_prefix("AUX")
            .and_then(|n| n.parse::<usize>().ok())
            .and_then(|n| n.checked_sub(1));
        if let Some(s) = slot.and_then(|i| self.monitor.sessions.get_mut(i)) {
            *s = false;
        }
    }

    /// A session began (`true`) or ended (`false`) a transfer.
    pub(crate) fn transfer_running(&mut self, running: bool) {
        let n = &mut self.monitor.transfers_running;
        *n = if running {
            n.saturating_add(1)
        } else {
            n.saturating_sub(1)
        };
    }

    /// A `LOAD`/`SAVE` was left open (a dropped link, a client that stopped answering).
    pub(crate) fn abandon_transfer(&mut self) {
        tracing::warn!(
            "a terminal transfer was abandoned: SAVE/LOAD in progress until a power cycle"
        );
        self.monitor.transfer_open = true;
    }

    pub(super) fn push_output(&mut self, line: String) {
        self.monitor
            .output
            .push_back((self.monitor.next_line, line));
        self.monitor.next_line += 1;
        while self.monitor.output.len() > OUTPUT_LINES {
            self.monitor.output.pop_front();
        }
    }

    /// Takes the lines the programs printed since the last call into the terminal's list,
    /// and announces the programs that completed since (`Program completed.No = n`, a robot
    /// program started by `EXECUTE` as `No = 1`) and the PC tasks an abort stopped after
    /// their step (`PC program aborted.No = n`).
    fn pull_output(&mut self) {
        self.pull_printed();
        let tasks = self.server_program().map(|p| p.tasks(&self.machine));
        for i in 0..=5usize {
            let info = tasks.as_ref().and_then(|t| t.get(i));
            let running = info.is_some_and(|t| t.state != fs020n_as::TaskState::Idle);
            let completed = info.is_some_and(|t| t.last_error.is_none());
            // The robot task's number in the message is 1 (**M**: a capture after EXECUTE).
            let n = u8::try_from(i.max(1)).unwrap_or(1);
            if self.monitor.ran[i] && !running {
                if self.monitor.aborting[i] {
                    if i > 0 {
                        self.push_output(text::pc_aborted(n));
                    }
                } else if completed && !self.monitor.kept[i] {
                    self.push_output(text::pc_completed(n));
                }
            }
            if !running {
                self.monitor.aborting[i] = false;
            }
            self.monitor.ran[i] = running;
        }
    }

    /// Takes the lines the programs printed since the last call.
    fn pull_printed(&mut self) {
        let Some(interp) = self.interpreter() else {
            return;
        };
        let (seen_at, seen_n) = self.monitor.seen;
        let mut at_count = 0;
        let mut new = Vec::new();
        let mut newest = (seen_at, seen_n);
        for l in interp.terminal() {
            if l.at < seen_at {
                continue;
            }
            if l.at == seen_at {
                at_count += 1;
                if at_count <= seen_n {
                    continue;
                }
            }
            new.push(l.text.clone());
            newest = if l.at == newest.0 {
                (l.at, newest.1 + 1)
            } else {
                (l.at, 1)
            };
        }
        self.monitor.seen = newest;
        for l in new {
            self.push_output(l);
        }
    }

    /// The lines programs printed (`PRINT`, the controller's messages) numbered from `from`
    /// on, and the number to ask from next time. Lines older than the last 200 are gone.
    pub(crate) fn terminal_output_since(&mut self, from: u64) -> (Vec<String>, u64) {
        self.pull_output();
        let lines = self
            .monitor
            .output
            .iter()
            .filter(|(n, _)| *n >= from)
            .map(|(_, l)| l.clone())
            .collect();
        (lines, self.monitor.next_line)
    }

    /// The number the next printed line will have (a new session reads from there).
    pub(crate) fn terminal_output_next(&mut self) -> u64 {
        self.pull_output();
        self.monitor.next_line
    }
}
