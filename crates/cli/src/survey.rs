//! What `deploy` and `doctor` both read from a controller over its terminal — which task holds
//! which program (the robot task and PC tasks 1–5) and which programs are in memory — and the
//! plan `deploy` derives from it: a pure function, so that every case is tested without a
//! controller.
//!
//! The survey is read with `STATUS`, `PCSTATUS 1:` … `5:` and `DIRECTORY/P`, each parsed by
//! the one parser `fs020n-term` has for it. A task *holds* a program while the program runs,
//! and also once stopped (aborted, or stopped by an error): it stays on the task's stack until
//! `KILL`/`PCKILL` (AS-E p.5-44), and a program on a stack can be neither loaded over nor
//! deleted.

use std::fmt;
use std::time::Duration;

use fs020n_term::connection::{ConnectionError, TerminalConnection};
use fs020n_term::text::{parse_directory, parse_task_number, parse_task_status};

/// PC tasks a controller has (`PCSTATUS 1:` … `5:`).
pub(crate) const PC_TASKS: u8 = 5;

/// A task of the controller.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub(crate) enum Task {
    /// The robot task (`EXECUTE`, `ABORT`, `KILL`).
    Robot,
    /// PC task 1–5 (`PCEXECUTE n:`, `PCABORT n:`, `PCKILL n:`).
    Pc(u8),
}

impl Task {
    /// The number `TYPE TASK (n)` takes: 1 for the robot task, 1001–1005 for PC tasks
    /// (AS-E p.9-20).
    pub(crate) fn type_number(self) -> u16 {
        match self {
            Task::Robot => 1,
            Task::Pc(n) => 1000 + u16::from(n),
        }
    }
}

impl fmt::Display for Task {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Task::Robot => f.write_str("the robot task"),
            Task::Pc(n) => write!(f, "PC task {n}"),
        }
    }
}

/// What one task holds.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Held {
    /// The task.
    pub(crate) task: Task,
    /// The program on its stack, lower case.
    pub(crate) program: String,
    /// It runs (or waits); otherwise it is stopped on the stack.
    pub(crate) running: bool,
}

impl Held {
    /// `prog runs in task`, `prog is stopped in task`.
    pub(crate) fn describe(&self) -> String {
        format!(
            "{} {} in {}",
            self.program,
            if self.running { "runs" } else { "is stopped" },
            self.task
        )
    }
}

/// The controller's tasks and memory as the terminal shows them.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub(crate) struct Survey {
    /// The tasks that hold a program, robot task first.
    pub(crate) held: Vec<Held>,
    /// The programs in memory (`DIRECTORY/P`), lower case.
    pub(crate) loaded: Vec<String>,
}

impl Survey {
    /// Reads the survey: `STATUS`, `PCSTATUS 1:` … `5:`, `DIRECTORY/P`.
    pub(crate) async fn read(term: &mut TerminalConnection) -> Result<Survey, ConnectionError> {
        let mut held = Vec::new();
        let tasks = std::iter::once(Task::Robot).chain((1..=PC_TASKS).map(Task::Pc));
        for task in tasks {
            let line = match task {
                Task::Robot => "STATUS".to_owned(),
                Task::Pc(n) => format!("PCSTATUS {n}:"),
            };
            let s = parse_task_status(&term.command(&line, false).await?);
            if let Some(program) = s.program {
                held.push(Held {
                    task,
                    program: program.to_ascii_lowercase(),
                    running: s.running,
                });
            }
        }
        let loaded = parse_directory(&term.command("DIRECTORY/P", false).await?);
        Ok(Survey { held, loaded })
    }

    /// The task running `program`, if one does.
    pub(crate) fn running(&self, program: &str) -> Option<Task> {
        self.held
            .iter()
            .find(|h| h.running && h.program.eq_ignore_ascii_case(program))
            .map(|h| h.task)
    }

    /// One line for a report: what runs and what is stopped on a stack.
    pub(crate) fn describe(&self) -> String {
        if self.held.is_empty() {
            return "no task holds a program".to_owned();
        }
        self.held
            .iter()
            .map(Held::describe)
            .collect::<Vec<_>>()
            .join(", ")
    }
}

/// One step of a plan, as typed at the terminal.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) enum Action {
    /// `PCABORT n:` or `ABORT`: the task stops after its current step.
    Abort(Task),
    /// Poll `TYPE TASK (n)` until the task has stopped (bounded).
    WaitStopped(Task),
    /// `PCKILL n:` or `KILL`, answered `1`: the program leaves the stack.
    Kill(Task),
    /// `DELETE/P name`, answered `1`.
    Delete(String),
}

impl Action {
    /// The command line, and whether its question is answered yes.
    pub(crate) fn line(&self) -> (String, bool) {
        match self {
            Action::Abort(Task::Robot) => ("ABORT".into(), false),
            Action::Abort(Task::Pc(n)) => (format!("PCABORT {n}:"), false),
            Action::WaitStopped(t) => (format!("TYPE TASK ({})", t.type_number()), false),
            Action::Kill(Task::Robot) => ("KILL".into(), true),
            Action::Kill(Task::Pc(n)) => (format!("PCKILL {n}:"), true),
            Action::Delete(name) => (format!("DELETE/P {name}"), true),
        }
    }
}

impl fmt::Display for Action {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Action::WaitStopped(t) => write!(f, "wait until {t} has stopped"),
            other => f.write_str(&other.line().0),
        }
    }
}

/// Why the controller cannot be prepared without the user.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) enum Conflict {
    /// Programs of the file are loaded or held, and `--replace` was not given.
    NeedsReplace(String),
    /// A program not of the file holds a task the deployment needs.
    Foreign(String),
}

/// Whether `name` is one of the file's programs.
fn ours(programs: &[String], name: &str) -> bool {
    programs.iter().any(|p| p.eq_ignore_ascii_case(name))
}

/// The plan that clears the way for loading `programs` and starting one of them in PC task
/// `task`: every task holding one of them is stopped (and waited for) and killed, then every
/// one of them still in memory is deleted. Refuses when the task is held by a program not of
/// the file, when the robot task runs a program not of the file (the file's programs would
/// be started beside a motion the user did not ask to stop), or, without `replace`, when
/// anything of the file is there.
pub(crate) fn plan(
    survey: &Survey,
    programs: &[String],
    task: u8,
    replace: bool,
) -> Result<Vec<Action>, Conflict> {
    for h in &survey.held {
        if ours(programs, &h.program) {
            continue;
        }
        if h.task == Task::Pc(task) {
            return Err(Conflict::Foreign(format!(
                "{} {} in PC task {task}, which this deployment would use",
                h.program,
                if h.running { "runs" } else { "is stopped" }
            )));
        }
        if h.task == Task::Robot && h.running {
            return Err(Conflict::Foreign(format!(
                "{} runs in the robot task",
                h.program
            )));
        }
    }
    let mut actions = Vec::new();
    let ours_held: Vec<&Held> = (survey.held.iter())
        .filter(|h| ours(programs, &h.program))
        .collect();
    for h in &ours_held {
        if h.running {
            actions.push(Action::Abort(h.task));
            actions.push(Action::WaitStopped(h.task));
        }
        actions.push(Action::Kill(h.task));
    }
    for p in programs {
        if survey.loaded.iter().any(|l| l.eq_ignore_ascii_case(p)) {
            actions.push(Action::Delete(p.to_ascii_lowercase()));
        }
    }
    if !actions.is_empty() && !replace {
        let what = if ours_held.is_empty() {
            let loaded: Vec<&str> = (programs.iter())
                .filter(|p| survey.loaded.iter().any(|l| l.eq_ignore_ascii_case(p)))
                .map(String::as_str)
                .collect();
            format!("{} already loaded", loaded.join(", "))
        } else {
            ours_held
                .iter()
                .map(|h| h.describe())
                .collect::<Vec<_>>()
                .join(", ")
        };
        return Err(Conflict::NeedsReplace(what));
    }
    Ok(actions)
}

/// How long a task may take to finish its current step after an abort: the longest waits of
/// the server are its 3 s `TCP_ACCEPT` and 5 s `TCP_RECV`.
pub(crate) const STOP_TIMEOUT: Duration = Duration::from_secs(12);

/// How often a stopping task is polled.
pub(crate) const STOP_POLL: Duration = Duration::from_millis(250);

/// Polls `TYPE TASK (n)` until it reads 0, at most [`STOP_TIMEOUT`]; the inner `Err` says
/// that the task still runs then, with the last value read.
pub(crate) async fn wait_stopped(
    term: &mut TerminalConnection,
    task: Task,
) -> Result<Result<(), String>, ConnectionError> {
    let line = Action::WaitStopped(task).line().0;
    let start = tokio::time::Instant::now();
    loop {
        let out = term.command(&line, false).await?;
        match parse_task_number(&out) {
            Some(0) => return Ok(Ok(())),
            _ if start.elapsed() >= STOP_TIMEOUT => {
                return Ok(Err(format!(
                    "{task} still runs {STOP_TIMEOUT:?} after the abort (`{line}` reads {})",
                    out.trim()
                )))
            }
            _ => tokio::time::sleep(STOP_POLL).await,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn held(task: Task, program: &str, running: bool) -> Held {
        Held {
            task,
            program: program.into(),
            running,
        }
    }

    fn server() -> Vec<String> {
        vec!["autostart.pc".into(), "ros_move".into()]
    }

    #[test]
    fn a_bare_controller_needs_no_step() {
        assert_eq!(plan(&Survey::default(), &server(), 1, false), Ok(vec![]));
    }

    #[test]
    fn a_running_server_is_aborted_waited_for_killed_and_deleted_with_its_robot_program() {
        let survey = Survey {
            held: vec![
                held(Task::Robot, "ros_move", true),
                held(Task::Pc(1), "autostart.pc", true),
            ],
            loaded: server(),
        };
        assert_eq!(
            plan(&survey, &server(), 1, true),
            Ok(vec![
                Action::Abort(Task::Robot),
                Action::WaitStopped(Task::Robot),
                Action::Kill(Task::Robot),
                Action::Abort(Task::Pc(1)),
                Action::WaitStopped(Task::Pc(1)),
                Action::Kill(Task::Pc(1)),
                Action::Delete("autostart.pc".into()),
                Action::Delete("ros_move".into()),
            ])
        );
    }

    #[test]
    fn a_program_stopped_on_a_stack_is_killed_without_an_abort() {
        let survey = Survey {
            held: vec![held(Task::Robot, "ros_move", false)],
            loaded: server(),
        };
        let actions = plan(&survey, &server(), 1, true).unwrap();
        assert_eq!(actions[0], Action::Kill(Task::Robot));
        assert!(!actions.iter().any(|a| matches!(a, Action::Abort(_))));
    }

    #[test]
    fn without_replace_anything_of_the_file_is_a_conflict_that_names_it() {
        let loaded = Survey {
            held: vec![],
            loaded: vec!["ros_move".into()],
        };
        assert_eq!(
            plan(&loaded, &server(), 1, false),
            Err(Conflict::NeedsReplace("ros_move already loaded".into()))
        );
        let running = Survey {
            held: vec![held(Task::Pc(1), "autostart.pc", true)],
            loaded: server(),
        };
        match plan(&running, &server(), 1, false) {
            Err(Conflict::NeedsReplace(what)) => {
                assert_eq!(what, "autostart.pc runs in PC task 1")
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn other_programs_are_left_alone_unless_they_hold_the_task_or_move_the_robot() {
        let beside = Survey {
            held: vec![
                held(Task::Pc(2), "count", true),
                held(Task::Robot, "weld", false),
            ],
            loaded: vec!["count".into(), "weld".into()],
        };
        assert_eq!(plan(&beside, &server(), 1, true), Ok(vec![]));
        assert!(matches!(
            plan(&beside, &server(), 2, true),
            Err(Conflict::Foreign(_))
        ));
        let moving = Survey {
            held: vec![held(Task::Robot, "weld", true)],
            loaded: vec!["weld".into()],
        };
        match plan(&moving, &server(), 1, true) {
            Err(Conflict::Foreign(what)) => assert_eq!(what, "weld runs in the robot task"),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn each_action_is_the_monitor_command_and_only_kill_and_delete_confirm() {
        assert_eq!(
            Action::Abort(Task::Pc(3)).line(),
            ("PCABORT 3:".into(), false)
        );
        assert_eq!(Action::Abort(Task::Robot).line(), ("ABORT".into(), false));
        assert_eq!(
            Action::WaitStopped(Task::Pc(2)).line(),
            ("TYPE TASK (1002)".into(), false)
        );
        assert_eq!(
            Action::WaitStopped(Task::Robot).line(),
            ("TYPE TASK (1)".into(), false)
        );
        assert_eq!(Action::Kill(Task::Robot).line(), ("KILL".into(), true));
        assert_eq!(
            Action::Delete("x".into()).line(),
            ("DELETE/P x".into(), true)
        );
    }
}
