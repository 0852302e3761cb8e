//! `ONE`: the program a task runs when one of its statements fails, and how the task stops
//! after it (docs/AS.md, "ONE").

use fs020n_proto::ErrorCode;

use crate::system::System;

use super::task::TaskSlot;
use super::Interpreter;

/// How a task goes on when a return leaves its error program.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Resume {
    /// `RETURN`: the step where the error occurred runs again.
    FailedStep,
    /// `RETURNE`: the step after it.
    NextStep,
    /// The error program's `.END`: the task stops.
    Stop,
}

impl Interpreter {
    /// A statement of task `i` failed (`text` says how, with where): when the task has an
    /// error program (`ONE`) and is not already in it, the error is raised as usual (the
    /// robot stops, `ERROR` gives its code) and the task calls its error program instead of
    /// stopping; `false` when the task has none (it stops as usual).
    pub(super) fn enter_error_program(
        &mut self,
        i: TaskSlot,
        text: &str,
        code: ErrorCode,
        sys: &mut dyn System,
    ) -> bool {
        let t = &self.tasks[i];
        let Some(prog) = t.error_program else {
            return false;
        };
        // An error inside the error program stops the task; so does one with no room left
        // on the call stack.
        if t.error_depth.is_some()
            || t.frames.is_empty()
            || t.frames.len() >= self.cfg.max_call_depth
        {
            return false;
        }
        let id = t.id;
        self.tasks[i].last_error = Some(text.to_owned());
        self.message(sys, id, text.to_owned());
        sys.raise_error(code);
        if i.is_robot() {
            sys.cut_motion();
        }
        // The task leaves what it waited for; its interrupts are disarmed, so that nothing
        // takes it out of the error program but its own RETURN.
        let now = self.now;
        let t = &mut self.tasks[i];
        t.wait = None;
        t.pending_on = None;
        t.interrupts.clear();
        t.ready_at = now;
        self.int_epoch += 1;
        if self.push_frame(i, prog, &[]).is_err() {
            return false;
        }
        self.tasks[i].error_depth = Some(self.tasks[i].frames.len());
        let name = self.code.programs[prog].name.clone();
        self.message(sys, id, format!("error program {name} runs (ONE)"));
        true
    }

    /// After a return of task `i` (its frames now `depth` deep): when that left the error
    /// program, the task goes on as AS-E p.6-45 says — `RETURN` runs the step where the error
    /// occurred again, `RETURNE` the step after it, and an error program that ends without
    /// either stops the task.
    pub(super) fn after_return(
        &mut self,
        i: TaskSlot,
        depth: usize,
        resume: Resume,
        sys: &mut dyn System,
    ) {
        if self.tasks[i].error_depth != Some(depth + 1) {
            return;
        }
        self.tasks[i].error_depth = None;
        let id = self.tasks[i].id;
        match resume {
            Resume::Stop => {
                self.abort(id);
                self.message(
                    sys,
                    id,
                    "program stopped at the end of its error program (ONE): no RETURN or \
                     RETURNE resumed it"
                        .into(),
                );
            }
            Resume::FailedStep => {}
            Resume::NextStep => self.advance_pc(i),
        }
    }

    /// `true` while task `i` runs its error program.
    pub(super) fn in_error_program(&self, i: TaskSlot) -> bool {
        self.tasks[i].error_depth.is_some()
    }
}
