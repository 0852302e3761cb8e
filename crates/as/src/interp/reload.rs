//! Taking a new set of programs while tasks run (`LOAD` on a running controller):
//! [`Interpreter::adopt`] (what is kept and how it is mapped is in its documentation).

use std::collections::HashMap;
use std::sync::Arc;

use crate::ast::{DataItem, DataValue};
use crate::compile::{Code, Ty};
use crate::value::{Bytes, Store, Var};

use super::report::ReloadError;
use super::task::{Frame, Interrupt};
use super::Interpreter;

impl Interpreter {
    /// Takes `new`'s programs and globals without stopping the running tasks, then assigns
    /// the `assigned` data items (those of the file just loaded) over the kept values. On an
    /// error nothing changes.
    ///
    /// The running interpreter keeps its state (tasks, clock, signals, timers, switches,
    /// `TOOL`, `BASE`, terminal) and takes the new interpreter's compiled programs and its
    /// globals; every reference into the old code is mapped onto the new one **by name**:
    /// - a task's frames keep their program-relative step and their locals: the program of
    ///   each frame must be in the new set with the same text (else [`ReloadError`]);
    /// - the programs an armed interrupt (`ON … CALL`) or an error program (`ONE`) names must
    ///   be in the new set (their text may change: they run from their first step);
    /// - by-reference arguments that name a global follow its (type, name);
    /// - locals kept between executions ([`crate::Config::persistent_locals`]) follow their
    ///   program when its text is unchanged, and are dropped otherwise;
    /// - globals by (type, name): a value held stays (a running task keeps what it computed);
    ///   a global that holds no value takes the new set's (from its data sections); a global
    ///   the new programs no longer use is kept all the same (a controller keeps its variables
    ///   until they are deleted), so a later program naming it finds its value;
    /// - the `assigned` data items (the data sections of the file just loaded) then overwrite
    ///   the elements they name: AS-E (the `LOAD` command) says a load overwrites variables
    ///   silently.
    ///
    /// Nothing of `new` but its code and globals is used (its configuration neither).
    ///
    /// ```
    /// use std::time::Duration;
    /// use fs020n_as::{Config, Interpreter, TaskId, TaskState};
    /// use fs020n_as::testing::VirtualSystem;
    ///
    /// let count = ".PROGRAM autostart.pc()\n  n = 0\n  WHILE TRUE DO\n    n = n + 1\n    TWAIT 0.1\n  END\n.END\n";
    /// let mut interp = Interpreter::from_source("a.as", count, Config::default())?;
    /// let mut sys = VirtualSystem::new();
    /// interp.start(&mut sys);
    /// interp.run_until(&mut sys, Duration::from_millis(450));
    ///
    /// let more = format!("{count}.PROGRAM other()\n  m = 1\n.END\n");
    /// interp.adopt(Interpreter::from_source("b.as", &more, Config::default())?, &[])
    ///     .expect("the counting program is unchanged");
    /// interp.pc_execute(2, "other").expect("a new program starts at once");
    /// interp.run_until(&mut sys, Duration::from_millis(1050));
    /// assert_eq!(interp.real("n"), Some(11.0)); // never reset
    /// assert_eq!(interp.real("m"), Some(1.0));
    /// assert_eq!(interp.task_state(TaskId::Pc(1), &sys), TaskState::Running);
    /// # Ok::<(), fs020n_as::LoadError>(())
    /// ```
    pub fn adopt(&mut self, new: Interpreter, assigned: &[DataItem]) -> Result<(), ReloadError> {
        let programs = self.program_map(&new.code)?;
        let mut code = Code::clone(&new.code);
        let mut globals = new.globals;
        let old_global_elements = self.globals.element_count();
        let mut old = std::mem::take(&mut self.globals);
        // Global slots: old slot -> merged slot, per type.
        let slots = [
            merge(
                &mut old.reals,
                &mut globals.reals,
                &mut code,
                Ty::Real,
                &self.code,
            ),
            merge(
                &mut old.strs,
                &mut globals.strs,
                &mut code,
                Ty::Str,
                &self.code,
            ),
            merge(
                &mut old.joints,
                &mut globals.joints,
                &mut code,
                Ty::Joint,
                &self.code,
            ),
            merge(
                &mut old.trans,
                &mut globals.trans,
                &mut code,
                Ty::Trans,
                &self.code,
            ),
        ];
        for item in assigned {
            assign(&mut globals, &mut code, item);
        }
        for t in &mut self.tasks {
            for f in &mut t.frames {
                remap_frame(f, &programs, &slots);
            }
            for int in t.interrupts.iter_mut().chain(t.pending_on.iter_mut()) {
                remap_interrupt(int, &programs);
            }
            t.error_program = t.error_program.and_then(|p| programs.get(&p).copied());
        }
        let mut dropped = 0;
        let kept = std::mem::take(&mut self.kept);
        for ((task, p), store) in kept {
            match self.same_program_in(&code, p) {
                Some(np) => {
                    self.kept.insert((task, np), store);
                }
                None => dropped += store.element_count(),
            }
        }
        self.elements = (self.elements + globals.element_count())
            .saturating_sub(old_global_elements)
            .saturating_sub(dropped);
        self.globals = globals;
        self.code = Arc::new(code);
        self.int_epoch += 1;
        Ok(())
    }

    /// Old program index -> new index, for every program a task refers to; an error when a
    /// frame's program is missing or changed, or a handler's program is missing.
    fn program_map(&self, new: &Code) -> Result<HashMap<usize, usize>, ReloadError> {
        let mut map = HashMap::new();
        let name = |p: usize| {
            self.code
                .programs
                .get(p)
                .map_or_else(String::new, |c| c.name.clone())
        };
        for t in &self.tasks {
            let task = t.id.to_string();
            for f in &t.frames {
                let program = name(f.prog);
                let Some(&np) = new.by_name.get(&program) else {
                    return Err(ReloadError::ProgramMissing { task, program });
                };
                if !same_program(&self.code, f.prog, new, np) {
                    return Err(ReloadError::ProgramChanged { task, program });
                }
                map.insert(f.prog, np);
            }
            let handlers = (t.interrupts.iter().chain(t.pending_on.iter()))
                .filter_map(|int| int.call)
                .chain(t.error_program);
            for p in handlers {
                let program = name(p);
                let Some(&np) = new.by_name.get(&program) else {
                    return Err(ReloadError::HandlerMissing { task, program });
                };
                map.insert(p, np);
            }
        }
        Ok(map)
    }

    /// The index in `new` of old program `p`, when `new` holds it with the same text.
    fn same_program_in(&self, new: &Code, p: usize) -> Option<usize> {
        let name = &self.code.programs.get(p)?.name;
        let np = *new.by_name.get(name)?;
        same_program(&self.code, p, new, np).then_some(np)
    }

    /// The programs on the running tasks' stacks (those they started with and those they
    /// `CALL`ed), lower case, each once: a `LOAD` must not replace them.
    pub fn programs_in_use(&self) -> Vec<&str> {
        let mut out: Vec<&str> = Vec::new();
        for f in self.tasks.iter().flat_map(|t| t.frames.iter()) {
            if let Some(p) = self.code.programs.get(f.prog) {
                if !out.contains(&p.name.as_str()) {
                    out.push(&p.name);
                }
            }
        }
        out
    }
}

/// Whether program `o` of `old` and `n` of `new` are the same program: same name, parameters,
/// locals and steps (the source text of every step). Global slots and program indices inside
/// the steps may differ: they are the new set's.
fn same_program(old: &Code, o: usize, new: &Code, n: usize) -> bool {
    let (Some(a), Some(b)) = (old.programs.get(o), new.programs.get(n)) else {
        return false;
    };
    a.name == b.name
        && a.params.len() == b.params.len()
        && (a.params.iter().zip(&b.params))
            .all(|(x, y)| x.ty == y.ty && x.slot == y.slot && x.by_ref == y.by_ref)
        && a.locals == b.locals
        && a.local_names == b.local_names
        && a.ops.len() == b.ops.len()
        && a.touches == b.touches
        && (a.lines.iter().zip(&b.lines))
            .all(|(&la, &lb)| old.line_text(o, la).trim() == new.line_text(n, lb).trim())
}

/// Moves the old globals of one type into the new store: a value held replaces the new
/// set's; a global the new code does not name is appended (name and slot). Returns old slot
/// -> merged slot.
fn merge<T: Clone>(
    old: &mut [Var<T>],
    new: &mut Vec<Var<T>>,
    code: &mut Code,
    ty: Ty,
    old_code: &Code,
) -> Vec<u32> {
    let t = ty as usize;
    let mut slots = Vec::with_capacity(old.len());
    for (k, var) in old.iter_mut().enumerate() {
        let name = old_code.global_name(ty, k as u32).to_owned();
        let var = std::mem::take(var);
        let held = var.scalar.is_some() || var.element_count() > 0;
        let slot = match code.global_index[t].get(&name) {
            Some(&s) => {
                if held {
                    if let Some(v) = new.get_mut(s as usize) {
                        *v = var;
                    }
                }
                s
            }
            None => {
                let s = code.globals[t].len() as u32;
                code.globals[t].push(name.clone());
                code.global_index[t].insert(name, s);
                new.push(var);
                s
            }
        };
        slots.push(slot);
    }
    slots
}

/// Assigns one data item over the merged globals (a variable the code does not name yet is
/// added).
fn assign(globals: &mut Store, code: &mut Code, item: &DataItem) {
    let ty = match item.value {
        DataValue::Real(_) => Ty::Real,
        DataValue::Str(_) => Ty::Str,
        DataValue::Joints(_) => Ty::Joint,
        DataValue::Trans(_) => Ty::Trans,
    };
    let t = ty as usize;
    let name = &item.name.text;
    let s = match code.global_index[t].get(name) {
        Some(&s) => s as usize,
        None => {
            let s = code.globals[t].len();
            code.globals[t].push(name.clone());
            code.global_index[t].insert(name.clone(), s as u32);
            match ty {
                Ty::Real => globals.reals.push(Var::default()),
                Ty::Str => globals.strs.push(Var::default()),
                Ty::Joint => globals.joints.push(Var::default()),
                Ty::Trans => globals.trans.push(Var::default()),
            }
            s
        }
    };
    let idx = &item.indices;
    match &item.value {
        DataValue::Real(v) => {
            if let Some(x) = globals.reals.get_mut(s) {
                x.set(idx, *v as f32);
            }
        }
        DataValue::Str(b) => {
            if let Some(x) = globals.strs.get_mut(s) {
                x.set(idx, Bytes::from(b.as_slice()));
            }
        }
        DataValue::Joints(j) => {
            if let Some(x) = globals.joints.get_mut(s) {
                x.set(idx, j.map(|v| v as f32));
            }
        }
        DataValue::Trans(tr) => {
            if let Some(x) = globals.trans.get_mut(s) {
                x.set(idx, tr.map(|v| v as f32));
            }
        }
    }
}

/// A frame onto the new code: its program index, and the global slots of its by-reference
/// arguments (its step and locals stay: the program is the same).
fn remap_frame(f: &mut Frame, programs: &HashMap<usize, usize>, slots: &[Vec<u32>; 4]) {
    if let Some(&p) = programs.get(&f.prog) {
        f.prog = p;
    }
    for b in &mut f.byref {
        if b.var.global {
            if let Some(&s) = slots[b.ty as usize].get(b.var.slot as usize) {
                b.var.slot = s;
            }
        }
    }
}

/// An armed interrupt onto the new code: the program it calls.
fn remap_interrupt(int: &mut Interrupt, programs: &HashMap<usize, usize>) {
    if let Some(p) = int.call {
        int.call = programs.get(&p).copied();
    }
}
