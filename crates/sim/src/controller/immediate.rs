//! The monitor's `DO` and the monitor commands that are also program instructions (`TYPE`,
//! `POINT`, `SOUT`, `BITS`, `PRINT`, …): the statement run at once against the programs in
//! memory.

use fs020n_as::ImmediateError;
use fs020n_term::text::{self, MonitorError};

use super::{ProgramMut, Server};

/// Why a statement typed at the terminal did not run.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ImmediateRefusal {
    /// The monitor refused it (the programs in memory do not build; a native server has no
    /// AS interpreter).
    Monitor(MonitorError),
    /// The statement itself: a syntax error, a runtime error, a wait.
    Statement(ImmediateError),
}

impl ProgramMut<'_> {
    /// Runs `statement` at once as the monitor does (`DO`, AS-E p.5-45, and the commands that
    /// are also instructions): against the programs and variables in memory, the running tasks
    /// undisturbed; the lines it printed. Refused when the controller runs the native server
    /// (no AS interpreter) or the memory's programs do not build.
    pub fn immediate(&mut self, statement: &str) -> Result<Vec<String>, ImmediateRefusal> {
        let c = &mut *self.c;
        c.sync_runtime().map_err(ImmediateRefusal::Monitor)?;
        let Server::Program(p) = &mut c.server else {
            return Err(ImmediateRefusal::Monitor(text::P1038_NO_PROGRAM));
        };
        let out = p
            .immediate(&mut c.machine, statement)
            .map_err(ImmediateRefusal::Statement);
        c.bump();
        out
    }
}
