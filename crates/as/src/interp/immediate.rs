//! A statement typed at the terminal: `DO statement`, and the monitor commands that are also
//! program instructions (`TYPE`, `POINT`, `SOUT`, `BITS`, `PRINT`, `IFPWPRINT`, …, AS-E
//! chapter 5). It is compiled against the loaded programs — their global variables, a new
//! name becoming a new global — and run at once to its end in a task slot of its own.

use std::sync::Arc;

use crate::compile::{compile_immediate, Op};
use crate::system::{System, TaskId};

use super::report::ImmediateError;
use super::task::{Flow, Task, TaskSlot};
use super::Interpreter;

/// Most steps a typed statement may take (a runaway `WHILE` at the terminal ends here).
const MAX_STEPS: u32 = 100_000;

impl Interpreter {
    /// Runs `statement` (one line of AS, as a program step) at once, the way the monitor runs
    /// a command: its effects on variables, signals and the system are made now, and the lines
    /// it prints (`TYPE`, `PRINT`) are given back rather than sent to the terminal as a
    /// program's output. It runs as a PC program would (a motion instruction is refused with
    /// E1095) in the slot of an idle PC task, or beside PC task 5 when every one runs: no task
    /// is disturbed, and `TASK(n)` reports the task of that slot as it was. A statement that
    /// would wait is stopped before it waits ([`ImmediateError::Waits`]).
    pub fn immediate(
        &mut self,
        statement: &str,
        sys: &mut dyn System,
    ) -> Result<Vec<String>, ImmediateError> {
        let source = format!(".PROGRAM immediate()\n{statement}\n.END\n");
        let module = crate::parser::parse("terminal", &source)
            .map_err(|e| ImmediateError::Syntax(first_message(&e)))?;
        // The statement joins the loaded code for its run (copied only when shared).
        let code = Arc::make_mut(&mut self.code);
        let prog = compile_immediate(code, &module)
            .map_err(|e| ImmediateError::Syntax(first_message(&e)))?;
        let sizes = code.globals.each_ref().map(Vec::len);
        self.globals.grow_to(sizes);

        // A slot of its own: an idle PC task's, or PC task 5's with its task kept aside.
        let slot = (1..=5)
            .map(TaskSlot::at)
            .find(|&s| self.tasks[s].frames.is_empty())
            .unwrap_or(TaskSlot::at(5));
        let id = TaskId::from_index(slot.index());
        let aside = std::mem::replace(&mut self.tasks[slot], Task::new(id));
        self.aside = Some((slot, Box::new(aside)));
        let kept_active = self.active;
        let kept_terminal = std::mem::take(&mut self.terminal);

        let outcome = self.run_immediate(slot, prog, sys);

        let printed = std::mem::replace(&mut self.terminal, kept_terminal);
        if let Some((_, aside)) = self.aside.take() {
            self.tasks[slot] = *aside;
        }
        self.active = kept_active;
        self.kept.remove(&(slot, prog));
        self.int_epoch += 1;
        let code = Arc::make_mut(&mut self.code);
        code.programs.pop();
        code.lines.pop();
        outcome.map(|()| printed.into_iter().map(|l| l.text).collect())
    }

    /// The task of `slot` as the other tasks see it: the one put aside there while a typed
    /// statement runs in that slot.
    pub(super) fn task_seen_mut(&mut self, slot: TaskSlot) -> &mut Task {
        match &mut self.aside {
            Some((s, aside)) if *s == slot => aside,
            _ => &mut self.tasks[slot],
        }
    }

    /// Runs program `prog` in `slot` until it reaches its end.
    fn run_immediate(
        &mut self,
        slot: TaskSlot,
        prog: usize,
        sys: &mut dyn System,
    ) -> Result<(), ImmediateError> {
        if !self.start_task(slot, prog, &[], 1) {
            return Err(ImmediateError::Syntax(
                "the statement could not start".into(),
            ));
        }
        let code = self.code.clone();
        for _ in 0..MAX_STEPS {
            let Some(frame) = self.tasks[slot].frames.last() else {
                return Ok(());
            };
            let (p, pc) = (frame.prog, frame.pc);
            let program = code.programs.get(p);
            // The end of the typed statement: done (a program's end would count a cycle).
            if p == prog && matches!(program.and_then(|q| q.ops.get(pc)), Some(Op::End) | None) {
                return Ok(());
            }
            match self.step(slot, sys, &code, false, true, program, pc) {
                Ok(Flow::Next | Flow::Shared) => {}
                Ok(Flow::Wait(_)) => {
                    let line = program.and_then(|q| q.lines.get(pc)).copied().unwrap_or(0);
                    return Err(ImmediateError::Waits(
                        code.line_text(p, line).trim().to_owned(),
                    ));
                }
                Err(e) => {
                    return Err(ImmediateError::Runtime {
                        code: e.code(),
                        text: e.to_string(),
                    })
                }
            }
        }
        Err(ImmediateError::Waits(format!(
            "a statement still running after {MAX_STEPS} steps"
        )))
    }
}

/// The first message of a load error, without the file and line of the wrapper program.
fn first_message(e: &crate::error::LoadError) -> String {
    e.errors
        .first()
        .map_or_else(|| "syntax error".to_owned(), |p| p.message.clone())
}
