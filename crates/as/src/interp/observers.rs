//! Observers: task states, terminal, trace, variables, signals and switches from outside.

use std::time::Duration;

use crate::compile::Ty;
use crate::keywords::SYSTEM_SWITCHES;
use crate::system::{PanelState, System, TaskId};

use super::report::{TaskInfo, TaskState, TerminalLine, TraceLine};
use super::task::{Run, TaskSlot, Wait};
use super::Interpreter;

impl Interpreter {
    /// The state of a task as `TASK(n)` reports it now.
    pub fn task_state(&self, task: TaskId, sys: &dyn System) -> TaskState {
        self.task_state_at(task, sys.panel(), sys.motion_in_progress())
    }

    /// The state of a task given the panel and whether the robot moves (for observers that
    /// hold the system's state rather than a [`System`]).
    pub fn task_state_at(&self, task: TaskId, panel: PanelState, moving: bool) -> TaskState {
        let i = TaskSlot::of(task);
        let t = match &self.aside {
            Some((slot, aside)) if *slot == i => aside,
            _ => &self.tasks[i],
        };
        match t.run {
            Run::Idle => TaskState::Idle,
            Run::Ending => {
                if moving {
                    TaskState::WaitingMotion
                } else {
                    TaskState::Idle
                }
            }
            Run::Running => {
                let held = i.is_robot() && (self.mc_hold || !panel.run);
                if held || matches!(t.wait, Some(Wait::Paused | Wait::Held)) {
                    TaskState::Paused
                } else {
                    TaskState::Running
                }
            }
        }
    }

    /// Every task: program, line, state, what it waits for.
    pub fn tasks(&self, sys: &dyn System) -> Vec<TaskInfo> {
        self.tasks_at(sys.panel(), sys.motion_in_progress())
    }

    /// [`Interpreter::tasks`] given the panel and whether the robot moves.
    pub fn tasks_at(&self, panel: PanelState, moving: bool) -> Vec<TaskInfo> {
        self.tasks
            .iter()
            .map(|t| {
                let frame = t.frames.last();
                let prog = frame.and_then(|f| self.code.programs.get(f.prog));
                let line = frame.and_then(|f| prog.and_then(|p| p.lines.get(f.pc).copied()));
                TaskInfo {
                    task: t.id.to_string(),
                    state: self.task_state_at(t.id, panel, moving),
                    program: prog.map(|p| p.name.clone()),
                    main: (t.frames.first())
                        .and_then(|f| self.code.programs.get(f.prog))
                        .map(|p| p.name.clone()),
                    line,
                    text: match (frame, line) {
                        (Some(f), Some(l)) => {
                            Some(self.code.line_text(f.prog, l).trim().to_owned())
                        }
                        _ => None,
                    },
                    waiting: t.wait.as_ref().map(Wait::describe),
                    last_error: t.last_error.clone(),
                    steps: t.steps,
                }
            })
            .collect()
    }

    /// The latest terminal lines (oldest first).
    pub fn terminal(&self) -> impl Iterator<Item = &TerminalLine> {
        self.terminal.iter()
    }

    /// Records every executed step from now on (`true`), or stops (`false`); see
    /// [`Interpreter::take_trace`].
    pub fn set_trace(&mut self, on: bool) {
        self.trace = if on { Some(Vec::new()) } else { None };
    }

    /// The steps executed since the last call (empty unless tracing).
    pub fn take_trace(&mut self) -> Vec<TraceLine> {
        self.trace.as_mut().map(std::mem::take).unwrap_or_default()
    }

    pub(super) fn global_slot(&self, ty: Ty, name: &str) -> Option<usize> {
        self.code.global_index[ty as usize]
            .get(&name.to_ascii_lowercase())
            .map(|&s| s as usize)
    }

    /// A global real (`None`: never assigned or unknown).
    pub fn real(&self, name: &str) -> Option<f32> {
        self.real_at(name, &[])
    }

    /// An element of a global real array.
    pub fn real_at(&self, name: &str, idx: &[i32]) -> Option<f32> {
        let s = self.global_slot(Ty::Real, name)?;
        self.globals.reals[s].get(idx).copied()
    }

    /// A global string (`name` without `$`).
    pub fn string(&self, name: &str) -> Option<Vec<u8>> {
        self.string_at(name, &[])
    }

    /// An element of a global string array.
    pub fn string_at(&self, name: &str, idx: &[i32]) -> Option<Vec<u8>> {
        let s = self.global_slot(Ty::Str, name)?;
        self.globals.strs[s].get(idx).map(|b| b.to_vec())
    }

    /// The transformation a program's `HERE` gives for the flange pose `flange` (the tool in
    /// the world: BASE · flange · TOOL, with the BASE and TOOL the programs set last).
    pub fn tool_in_world(&self, flange: &crate::system::Trans) -> [f32; 6] {
        self.world_of_flange(flange)
    }

    /// What `HERE a+b` stores in `b` for the flange pose `flange` (AS-E p.6-108): the value
    /// that makes `a+b` the tool in the world, `-a + HERE`. `frames` are the variables on the
    /// left (`a`, or `a` and `b` of `HERE a+b+c`), global transformations that must be
    /// defined: `Err(name)` names the first that is not.
    pub fn here_relative(
        &self,
        frames: &[&str],
        flange: &crate::system::Trans,
    ) -> Result<[f32; 6], String> {
        let world = self.world_of_flange(flange);
        let mut base = None;
        for &f in frames {
            let t = self.trans(f).ok_or_else(|| f.to_owned())?;
            base = Some(match base {
                None => super::frames::pose_of(&t),
                Some(b) => b * super::frames::pose_of(&t),
            });
        }
        Ok(match base {
            Some(b) => super::frames::trans_of(&(b.inverse() * super::frames::pose_of(&world))),
            None => world,
        })
    }

    /// A global transformation variable.
    pub fn trans(&self, name: &str) -> Option<[f32; 6]> {
        let s = self.global_slot(Ty::Trans, name)?;
        self.globals.trans[s].get(&[]).copied()
    }

    /// A global joint point (`name` without `#`).
    pub fn joints(&self, name: &str) -> Option<[f32; 6]> {
        let s = self.global_slot(Ty::Joint, name)?;
        self.globals.joints[s].get(&[]).copied()
    }

    /// Sets a global real that the programs use (returns `false` when no program names it).
    pub fn set_real(&mut self, name: &str, value: f32) -> bool {
        match self.global_slot(Ty::Real, name) {
            Some(s) => {
                self.globals.reals[s].set(&[], value);
                true
            }
            None => false,
        }
    }

    /// Every global real scalar and array element, by name (for dumps and tests).
    pub fn globals_dump(&self) -> Vec<(String, f32)> {
        let mut out = Vec::new();
        for (i, name) in self.code.globals[0].iter().enumerate() {
            if let Some(v) = self.globals.reals[i].get(&[]) {
                out.push((name.clone(), *v));
            }
            for (idx, v) in self.globals.reals[i].elements() {
                let idx: Vec<String> = idx.iter().map(|i| i.to_string()).collect();
                out.push((format!("{name}[{}]", idx.join(",")), v));
            }
        }
        out
    }

    /// `TIMER(n)` now (0 for a timer never set or out of range), seconds, 1 ms resolution.
    pub fn timer(&self, n: usize) -> f32 {
        let since = match n {
            0 => Some(0),
            1..=10 => self.timers[n],
            _ => None,
        };
        since.map_or(0.0, |s| {
            let ms = (i128::from(self.now) - s).div_euclid(1_000_000);
            (ms as f64 / 1000.0) as f32
        })
    }

    /// A signal's state (outputs 1–999, inputs 1001–1999, internal 2001–2960).
    pub fn signal(&self, n: i32) -> bool {
        self.signals.get(&n).is_some_and(|s| s.on)
    }

    /// Sets an external input (1001–1999) or any signal from outside, at the current time.
    pub fn set_signal(&mut self, n: i32, on: bool) {
        self.write_signal(n, on);
    }

    /// A system switch (`ABS.SPEED`, `CP`, …), `None` for an unknown name.
    pub fn system_switch(&self, name: &str) -> Option<bool> {
        let name = name.to_ascii_lowercase();
        SYSTEM_SWITCHES
            .iter()
            .position(|(n, _)| *n == name)
            .map(|i| self.switches[i])
    }

    /// Sets a system switch from outside (the pendant); `false` for an unknown name.
    pub fn set_system_switch(&mut self, name: &str, on: bool) -> bool {
        let name = name.to_ascii_lowercase();
        match SYSTEM_SWITCHES.iter().position(|(n, _)| *n == name) {
            Some(i) => {
                self.switches[i] = on;
                true
            }
            None => false,
        }
    }

    pub(super) fn switch_on(&self, name: &str) -> bool {
        SYSTEM_SWITCHES
            .iter()
            .position(|(n, _)| *n == name)
            .is_some_and(|i| self.switches[i])
    }

    /// The time of the next thing the interpreter will do by itself (a step, a timeout, a
    /// poll of a waiting condition, an interrupt), `None` when every task is idle or waits
    /// only for outside events.
    pub fn next_event(&self) -> Option<Duration> {
        self.next_event_from(None)
            .map(|(t, _)| Duration::from_nanos(t))
    }
}
