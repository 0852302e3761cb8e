//! Programs started with the emulator (`fs020n sim --pcexecute 2: comm --execute main`), as the
//! monitor's `PCEXECUTE` and `EXECUTE` start them: a cell's programs run in CI without a
//! terminal session.

use std::fmt;

use fs020n_as::TaskId;
use fs020n_term::text::MonitorError;

use super::ProgramMut;

/// A program to start, in the monitor commands' words: `PCEXECUTE [task:] program[, cycles]`
/// (PC tasks 1–5) or `EXECUTE program[, cycles]` (the robot task). `cycles` as the monitor
/// takes it: 1 when omitted, −1 until aborted.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ProgramStart {
    /// The task it runs in.
    pub task: TaskId,
    /// The program's name (lower case, as the memory holds it).
    pub program: String,
    /// How many times it runs (0 counts as 1; negative: until aborted).
    pub cycles: i64,
}

/// A `--pcexecute`/`--execute` argument that is not `[task:] program[, cycles]`.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{spec:?}: {why}")]
pub struct StartSpecError {
    spec: String,
    why: &'static str,
}

/// `[n:] rest` of the monitor's task commands (`PCEXECUTE`, `PCABORT`, `PCKILL`,
/// `PCSTATUS`): the task number as written before the colon (`None` without one: task 1) and
/// the rest. Text before a colon that is not digits is no task number (it stays in the rest).
/// The monitor and the command line read starts with this one grammar; each judges the parts
/// (the monitor leniently, with its P-codes; the command line strictly, with
/// [`StartSpecError`]).
pub(crate) fn split_task(spec: &str) -> (Option<&str>, &str) {
    let spec = spec.trim();
    match spec.split_once(':') {
        Some((n, tail)) if n.trim().chars().all(|c| c.is_ascii_digit()) => {
            (Some(n.trim()), tail.trim())
        }
        _ => (None, spec),
    }
}

/// `program[, cycles[, step]]` of `EXECUTE`/`PCEXECUTE`/`PRIME`: the name as written (with any
/// arguments in brackets) and the cycle count as written (`None` when omitted or empty). The
/// step is not modelled: a program starts at its first step.
pub(crate) fn split_program(spec: &str) -> (&str, Option<&str>) {
    let mut parts = spec.splitn(3, ',');
    let name = parts.next().unwrap_or("").trim();
    let cycles = parts.next().map(str::trim).filter(|c| !c.is_empty());
    (name, cycles)
}

impl ProgramStart {
    /// `[task:] program[, cycles]` of `PCEXECUTE`: task 1 when omitted.
    pub fn pc(spec: &str) -> Result<ProgramStart, StartSpecError> {
        let err = |why| StartSpecError {
            spec: spec.to_owned(),
            why,
        };
        let (task, rest) = match split_task(spec) {
            (Some(n), rest) => match n.parse::<u8>() {
                Ok(n @ 1..=5) => (n, rest),
                _ => {
                    return Err(err(
                        "the PC task is a number 1–5 before the colon (`2: comm`)",
                    ))
                }
            },
            (None, rest) => (1, rest),
        };
        let (program, cycles) = program_and_cycles(rest).map_err(err)?;
        Ok(ProgramStart {
            task: TaskId::Pc(task),
            program,
            cycles,
        })
    }

    /// `program[, cycles]` of `EXECUTE`, in the robot task.
    pub fn robot(spec: &str) -> Result<ProgramStart, StartSpecError> {
        let (program, cycles) = program_and_cycles(spec).map_err(|why| StartSpecError {
            spec: spec.to_owned(),
            why,
        })?;
        Ok(ProgramStart {
            task: TaskId::Robot,
            program,
            cycles,
        })
    }
}

fn program_and_cycles(spec: &str) -> Result<(String, i64), &'static str> {
    let (name, cycles) = split_program(spec);
    let name = name.to_ascii_lowercase();
    let valid = name.chars().next().is_some_and(|c| c.is_ascii_alphabetic())
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '.');
    if !valid {
        return Err("the program's name starts with a letter and has letters, digits, `_` and `.`");
    }
    let cycles = match cycles {
        None => 1,
        Some(n) => n
            .parse::<i64>()
            .map_err(|_| "the cycle count is a whole number (-1: until aborted)")?,
    };
    Ok((name, cycles))
}

impl fmt::Display for ProgramStart {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.task {
            TaskId::Robot => write!(f, "EXECUTE {}", self.program)?,
            TaskId::Pc(n) => write!(f, "PCEXECUTE {n}: {}", self.program)?,
        }
        if self.cycles != 1 {
            write!(f, ",{}", self.cycles)?;
        }
        Ok(())
    }
}

impl ProgramMut<'_> {
    /// Starts `start` as the monitor command does (the same checks and refusals: power,
    /// REPEAT and teach lock for the robot task, P1019, P1038, P1014…) and runs it to its
    /// first wait, as a start at the terminal does: a port the program listens on is
    /// listened on when this returns.
    pub fn start(&mut self, start: &ProgramStart) -> Result<(), MonitorError> {
        match start.task {
            TaskId::Robot => self.execute(&start.program, start.cycles)?,
            TaskId::Pc(n) => self.pc_execute(n, &start.program, start.cycles)?,
        }
        self.run_first_steps(start.task);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pc_start_reads_task_program_and_cycles_as_pcexecute_does() {
        let s = ProgramStart::pc("2: Comm, -1").unwrap();
        assert_eq!(
            (s.task, s.program.as_str(), s.cycles),
            (TaskId::Pc(2), "comm", -1)
        );
        let s = ProgramStart::pc("autostart.pc").unwrap();
        assert_eq!((s.task, s.cycles), (TaskId::Pc(1), 1));
        assert_eq!(s.to_string(), "PCEXECUTE 1: autostart.pc");
    }

    #[test]
    fn a_robot_start_is_execute_in_the_robot_task() {
        let s = ProgramStart::robot("main,3").unwrap();
        assert_eq!((s.task, s.cycles), (TaskId::Robot, 3));
        assert_eq!(s.to_string(), "EXECUTE main,3");
    }

    #[test]
    fn a_start_that_is_not_the_monitor_grammar_names_what_is_wrong() {
        for bad in ["6: comm", "x: comm", "", "2:", "comm, twice", "9lives"] {
            let e = ProgramStart::pc(bad).unwrap_err().to_string();
            assert!(e.contains(&format!("{bad:?}")), "{e}");
        }
        assert!(ProgramStart::robot("main, 1.5").is_err());
    }
}
