//! `deploy`: puts an AS program on a controller over its terminal, the way a careful engineer
//! would, printing each step (docs/DEPLOY.md):
//!
//! 1. `as check` of the file with the controller's profile — refuses on errors;
//! 2. the terminal: log in, `ID` (the AS version), the survey (`STATUS`, `PCSTATUS 1:`…`5:`,
//!    `DIRECTORY/P`: which task holds which program, the robot task included);
//! 3. the plan computed from the survey (`survey::plan`, a pure function): programs of the
//!    file that run are aborted (`PCABORT`/`ABORT`), polled until stopped (a task stops after
//!    its current step), killed (`PCKILL`/`KILL`) and deleted — only with `--replace`; every
//!    command's whole output is searched for a refusal; then the survey again shows nothing
//!    of the file left;
//! 4. `LOAD` under a short fixed name, a syntax error answered **abort** (never "change to
//!    comment"), an unexpected question ended cleanly; every program of the file must be
//!    echoed by the load and listed by `DIRECTORY/P` afterwards;
//! 5. with `--autostart`, `SWITCH AUTOSTART.PC = ON`, read back;
//! 6. `PCEXECUTE`, then `PCSTATUS` shows it running and the protocol port answers a poll.
//!
//! Any surprise stops the walk; once the controller was changed, the failure also says what it
//! holds now.
//!
//! `--dry-run` reads the controller's state and prints the plan without changing anything.

use std::path::Path;
use std::time::Duration;

use fs020n_as::lint::Generation;
use fs020n_as::LoadOptions;
use fs020n_client::Robot;
use fs020n_term::connection::{ConnectionError, TerminalConnection};
use fs020n_term::text::{self, parse_as_version, parse_directory, parse_switch, parse_task_status};
use fs020n_term::TerminalError;

use crate::args::DeployArgs;
use crate::bringup::{open_terminal, terminal_addr, terminal_remedy, write_transcript, Steps};
use crate::context::{runtime, Ctx};
use crate::error::{CliError, CliResult, Exit};
use crate::survey::{self, Action, Conflict, Survey, PC_TASKS};

/// The name the file is loaded under: short and fixed, as the vendor's tools do (the name only
/// passes through the controller, which prints it in `Loading...(name)`).
pub(crate) const LOAD_NAME: &str = "deploy.as";

/// The names of the programs a file defines (`.PROGRAM name(…)`), in order.
pub(crate) fn program_names(bytes: &[u8]) -> Vec<String> {
    String::from_utf8_lossy(bytes)
        .lines()
        .filter_map(|l| {
            let l = l.trim_start();
            l.get(..9).filter(|h| h.eq_ignore_ascii_case(".PROGRAM "))?;
            let name = l.get(9..)?.split('(').next()?.trim();
            (!name.is_empty()).then(|| name.to_ascii_lowercase())
        })
        .collect()
}

/// `deploy`.
pub(crate) fn deploy(ctx: &Ctx, args: &DeployArgs) -> CliResult {
    if !(1..=PC_TASKS).contains(&args.task) {
        return Err(CliError::input(format!(
            "--task {} must be a PC task from 1 to {PC_TASKS}",
            args.task
        )));
    }
    if !(16..=3000).contains(&args.block_bytes) {
        return Err(CliError::input(
            "--block-bytes must be from 16 to 3000 (480 is safe on every controller)",
        ));
    }
    let mut steps = Steps::new(ctx.json);
    let plan = check(args, &mut steps)?;

    let robot_addr = ctx.addr_or_default();
    let terminal = terminal_addr(args.terminal.as_deref(), &robot_addr);
    let rt = runtime()?;
    rt.block_on(async {
        let mut term = match open_terminal(&terminal, args.block_bytes, ctx.connect_timeout).await {
            Ok(t) => t,
            Err(e) => {
                return Err(steps.fail("terminal", Exit::Link, e.to_string(), terminal_remedy(&e)));
            }
        };
        let result = walk(ctx, args, &mut steps, &mut term, &plan, &robot_addr).await;
        if let Some(path) = &args.transcript {
            write_transcript(path, &term)?;
        }
        result
    })
}

/// What step 1 found: the file, its programs and the one to start.
struct Plan {
    /// The file's name as the controller will know it (`LOAD name`).
    name: String,
    /// The file's bytes, sent as they are.
    bytes: Vec<u8>,
    /// The programs the file defines, lower case.
    programs: Vec<String>,
    /// The program `PCEXECUTE` starts.
    start: String,
}

/// Step 1: the file read, checked as the emulator loads it against the controller's limits, and
/// the program to start chosen.
fn check(args: &DeployArgs, steps: &mut Steps) -> Result<Plan, CliError> {
    let generation: Generation = args.controller.parse().map_err(CliError::input)?;
    let (name, bytes) = match &args.file {
        Some(path) => (
            file_name(path),
            std::fs::read(path)
                .map_err(|e| CliError::input(format!("cannot read {}: {e}", path.display())))?,
        ),
        None => (
            "server1040.as".to_owned(),
            fs020n_as::SERVER_1040.as_bytes().to_vec(),
        ),
    };
    // 1. The check, as the emulator loads it, against the controller's limits.
    let opts = (args.stubs.iter()).fold(LoadOptions::new(), |o, s| o.stub(s));
    let report = fs020n_as::check(&name, &bytes, &opts, Some(generation));
    if !report.passes() {
        let first = report
            .errors
            .first()
            .map(|e| format!("{}:{}: {}", name, e.span, e.message))
            .or_else(|| {
                report
                    .lint
                    .iter()
                    .find(|f| f.severity == fs020n_as::lint::Severity::Error)
                    .map(|f| format!("{name}:{}:{}: {}", f.line, f.column, f.message))
            })
            .unwrap_or_default();
        return Err(steps.fail(
            "check",
            Exit::Input,
            format!("{name} would not load on the controller: {first}"),
            format!("run `fs020n as check --controller {} {name}` for every finding, fix them and deploy again", args.controller),
        ));
    }
    let programs = program_names(&bytes);
    if programs.is_empty() {
        return Err(steps.fail(
            "check",
            Exit::Input,
            format!("{name} holds no program"),
            "give the AS file that holds the server program (.PROGRAM … .END)",
        ));
    }
    let start = match &args.program {
        Some(p) => p.to_ascii_lowercase(),
        None if programs.iter().any(|p| p == "autostart.pc") => "autostart.pc".to_owned(),
        None => programs[0].clone(),
    };
    if !programs.contains(&start) {
        return Err(steps.fail(
            "check",
            Exit::Input,
            format!("{name} has no program {start}"),
            format!(
                "name one of its programs with --program: {}",
                programs.join(", ")
            ),
        ));
    }
    steps.ok(
        "check",
        format!(
            "{name} loads ({} program(s): {}; {} warning(s)) and passes the {} profile",
            programs.len(),
            programs.join(", "),
            report.warnings.len(),
            args.controller
        ),
    );
    Ok(Plan {
        name,
        bytes,
        programs,
        start,
    })
}

/// Steps 2 to 6 on a logged-in terminal.
async fn walk(
    ctx: &Ctx,
    args: &DeployArgs,
    steps: &mut Steps,
    term: &mut TerminalConnection,
    plan: &Plan,
    robot_addr: &str,
) -> CliResult {
    let Plan {
        name: _,
        bytes,
        programs,
        start,
    } = plan;
    // Once the controller was changed, every failure also says what it holds now (when the
    // terminal still answers: not after a broken or silent link).
    let mut changed = false;
    macro_rules! fail {
        ($step:expr, $exit:expr, $detail:expr, $remedy:expr) => {{
            let mut detail: String = $detail.into();
            if changed && $exit != Exit::Link {
                if let Ok(now) = Survey::read(term).await {
                    detail.push_str(&format!("; the controller now: {}", now.describe()));
                }
            }
            return Err(steps.fail($step, $exit, detail, $remedy));
        }};
    }
    macro_rules! cmd {
        ($step:expr, $line:expr, $confirm:expr) => {
            match term.command($line, $confirm).await {
                Ok(out) => out,
                Err(e) => {
                    let remedy = terminal_remedy(&e);
                    fail!($step, Exit::Link, e.to_string(), remedy)
                }
            }
        };
    }
    // An action refused anywhere in its output (a refusal comes after the echoed answer).
    macro_rules! act {
        ($step:expr, $line:expr, $confirm:expr, $remedy:expr) => {{
            let out = cmd!($step, $line, $confirm);
            if let Some(r) = text::refusal(&out) {
                fail!(
                    $step,
                    Exit::NotReady,
                    format!("`{}` refused: {r}", $line),
                    $remedy
                )
            }
            out
        }};
    }

    // 2. Who the controller is and what it holds.
    let id = cmd!("identify", "ID", false);
    let version = parse_as_version(&id).unwrap_or_else(|| "unknown AS version".to_owned());
    steps.ok(
        "identify",
        format!("terminal {} — {version}", term.terminal().unwrap_or("?")),
    );
    let survey = match Survey::read(term).await {
        Ok(s) => s,
        Err(e) => {
            let remedy = terminal_remedy(&e);
            fail!("status", Exit::Link, e.to_string(), remedy)
        }
    };
    let ours_loaded: Vec<&String> = (programs.iter())
        .filter(|p| survey.loaded.contains(p))
        .collect();
    steps.ok(
        "status",
        format!(
            "{}; of this file already loaded: {}",
            survey.describe(),
            if ours_loaded.is_empty() {
                "none".to_owned()
            } else {
                ours_loaded
                    .iter()
                    .map(|s| s.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            }
        ),
    );

    // 3. The plan: an older copy stopped, waited for, killed and deleted.
    let actions = match survey::plan(&survey, programs, args.task, args.replace) {
        Ok(a) => a,
        Err(Conflict::NeedsReplace(what)) => fail!(
            "replace",
            Exit::NotReady,
            format!("{what}; nothing was changed"),
            "add --replace to stop, kill and delete the older copy and load this one (a running \
             server ends its session: the robot stops)"
        ),
        Err(Conflict::Foreign(what)) => fail!(
            "replace",
            Exit::NotReady,
            format!("{what}; nothing was changed"),
            "stop that program yourself if it may be stopped (ABORT/PCABORT, then KILL/PCKILL \
             on the terminal or the pendant), or deploy to another PC task with --task"
        ),
    };
    let plan_text: Vec<String> = actions.iter().map(ToString::to_string).collect();
    let mut rest = vec![format!("LOAD {LOAD_NAME}")];
    if args.autostart {
        rest.push("SWITCH AUTOSTART.PC = ON".to_owned());
    }
    rest.push(format!("PCEXECUTE {}: {start}", args.task));
    if args.dry_run {
        let all: Vec<String> = plan_text.iter().cloned().chain(rest).collect();
        steps.note("plan", "dry run", format!("would send: {}", all.join("; ")));
        return Ok(());
    }
    for action in &actions {
        changed = true;
        let (line, confirm) = action.line();
        match action {
            Action::WaitStopped(task) => match survey::wait_stopped(term, *task).await {
                Ok(Ok(())) => {}
                Ok(Err(why)) => fail!(
                    "replace",
                    Exit::NotReady,
                    why,
                    "the program did not stop after its current step: stop it on the teach \
                     pendant (or HOLD, then ABORT), then deploy again"
                ),
                Err(e) => {
                    let remedy = terminal_remedy(&e);
                    fail!("replace", Exit::Link, e.to_string(), remedy)
                }
            },
            _ => {
                act!(
                    "replace",
                    &line,
                    confirm,
                    "stop the program by hand on the teach pendant or the terminal, then deploy \
                     again"
                );
            }
        }
    }
    if !actions.is_empty() {
        // The plan took effect: nothing of the file is held or loaded any more.
        let after = match Survey::read(term).await {
            Ok(s) => s,
            Err(e) => {
                let remedy = terminal_remedy(&e);
                fail!("replace", Exit::Link, e.to_string(), remedy)
            }
        };
        let left: Vec<&String> = programs
            .iter()
            .filter(|p| after.loaded.contains(p) || after.held.iter().any(|h| &h.program == *p))
            .collect();
        if !left.is_empty() {
            fail!(
                "replace",
                Exit::NotReady,
                format!(
                    "after {} the controller still holds {}",
                    plan_text.join("; "),
                    left.iter()
                        .map(|s| s.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
                "remove them by hand (KILL/PCKILL, DELETE/P), then deploy again"
            );
        }
        steps.ok("replace", format!("sent {}", plan_text.join("; ")));
    }

    // 4. LOAD, then every program of the file echoed and listed.
    changed = true;
    match term.load(LOAD_NAME, bytes).await {
        Ok(r) if r.syntax_error.is_some() => fail!(
            "load",
            Exit::Input,
            format!(
                "the controller found a syntax error at `{}`; the load was aborted \
                 (answered 1: delete program and abort)",
                r.syntax_error.unwrap_or_default()
            ),
            format!(
                "fix that line (`fs020n as check --controller {} FILE` shows what it \
                 checks), then deploy again",
                args.controller
            )
        ),
        Ok(r) => {
            if let Some(refused) = text::refusal(&r.output) {
                fail!(
                    "load",
                    Exit::NotReady,
                    format!("the controller refused part of the load: {refused}"),
                    load_remedy(&refused)
                );
            }
            if r.errors > 0 {
                fail!(
                    "load",
                    Exit::Input,
                    format!("the controller counted {} error(s) in the load", r.errors),
                    "read the transcript (--transcript FILE) for the controller's messages"
                );
            }
            let missing: Vec<&String> = programs
                .iter()
                .filter(|p| !r.programs.contains(p))
                .collect();
            if !missing.is_empty() {
                fail!(
                    "load",
                    Exit::NotReady,
                    format!(
                        "the controller did not report loading {} ({})",
                        missing
                            .iter()
                            .map(|s| s.as_str())
                            .collect::<Vec<_>>()
                            .join(", "),
                        r.ending.as_deref().unwrap_or("no last line")
                    ),
                    "read the transcript (--transcript FILE): a program already in memory may \
                     have aborted the load (some controllers do not overwrite); deploy again with \
                     --replace"
                );
            }
            let listed = parse_directory(&cmd!("load", "DIRECTORY/P", false));
            let unlisted: Vec<&String> = programs.iter().filter(|p| !listed.contains(p)).collect();
            if !unlisted.is_empty() {
                fail!(
                    "load",
                    Exit::NotReady,
                    format!(
                        "{} not in memory after the load",
                        unlisted
                            .iter()
                            .map(|s| s.as_str())
                            .collect::<Vec<_>>()
                            .join(", ")
                    ),
                    "read the transcript (--transcript FILE) for the controller's messages, then \
                     deploy again"
                );
            }
            steps.ok(
                "load",
                format!(
                    "{} loaded ({} bytes); listed: {}",
                    plan.name,
                    bytes.len(),
                    programs.join(", ")
                ),
            );
        }
        Err(ConnectionError::Terminal(TerminalError::TransferInProgress)) => fail!(
            "load",
            Exit::NotReady,
            "the controller reports an earlier SAVE/LOAD still in progress (P2076)",
            "an earlier transfer was left unfinished: restart the controller (power off and \
             on), then deploy again"
        ),
        Err(ConnectionError::Terminal(e @ TerminalError::LoadInterrupted { .. })) => fail!(
            "load",
            Exit::NotReady,
            e.to_string(),
            "read the transcript (--transcript FILE) for the question or refusal; answer or \
             clear its cause on the controller, then deploy again with --replace"
        ),
        Err(e) => {
            let remedy = terminal_remedy(&e);
            fail!("load", Exit::Link, e.to_string(), remedy)
        }
    }

    // 5. AUTOSTART.
    if args.autostart {
        act!(
            "autostart",
            "SWITCH AUTOSTART.PC = ON",
            false,
            "set it on the teach pendant (Aux function, system switches)"
        );
        let out = cmd!("autostart", "SWITCH AUTOSTART.PC", false);
        if parse_switch(&out) != Some(true) {
            fail!(
                "autostart",
                Exit::NotReady,
                format!("AUTOSTART.PC does not read ON: {out}"),
                "set it on the teach pendant (Aux function, system switches)"
            );
        }
        steps.ok(
            "autostart",
            "AUTOSTART.PC is ON: at every power-on the controller starts autostart.pc in PC \
             task 1 by itself",
        );
    }

    // 6. Start and verify.
    let line = format!("PCEXECUTE {}: {start}", args.task);
    let out = cmd!("start", &line, false);
    if let Some(r) = text::refusal(&out) {
        fail!(
            "start",
            Exit::NotReady,
            format!("`{line}` refused: {r}"),
            match r.code {
                Some((_, 1013)) => "reset the controller's error (ERESET, or the pendant's reset), then deploy again",
                _ => "check the controller's state (fs020n doctor), then deploy again",
            }
        );
    }
    let out = cmd!("start", &format!("PCSTATUS {}:", args.task), false);
    let s = parse_task_status(&out);
    // The program line may name a program it has CALLed: any program of the file will do.
    let ours = s
        .program
        .as_deref()
        .is_some_and(|p| programs.iter().any(|q| q.eq_ignore_ascii_case(p)));
    if !s.running || !ours {
        fail!(
            "start",
            Exit::NotReady,
            format!("{start} does not run after PCEXECUTE: {out}"),
            "read the program's messages on the terminal (TYPE, the transcript) — a TCP_LISTEN \
             that failed ends the server"
        );
    }
    steps.ok("start", format!("{start} runs in PC task {}", args.task));
    verify_port(ctx, steps, robot_addr).await
}

/// The remedy for a refusal printed by a LOAD.
fn load_remedy(refused: &text::Refusal) -> &'static str {
    match refused.code {
        Some((_, 1014)) => {
            "a program of the file is on a task's stack: deploy again with --replace (it \
             kills it first)"
        }
        Some((_, 1039)) => {
            "this controller does not load over a program in memory: deploy again with \
             --replace (it deletes the older copy first)"
        }
        _ => "read the transcript (--transcript FILE) for the controller's messages",
    }
}

/// The protocol port answers a side-effect-free poll.
pub(crate) async fn verify_port(ctx: &Ctx, steps: &mut Steps, robot_addr: &str) -> CliResult {
    let mut config = ctx.client_config();
    config.connect_timeout = ctx.connect_timeout.max(Duration::from_secs(8));
    match Robot::connect(robot_addr, config).await {
        Ok(robot) => {
            let polled = robot.poll().await;
            let _ = robot.close().await;
            match polled {
                Ok(s) => {
                    steps.ok(
                        "verify",
                        format!(
                            "{robot_addr} answers a poll (error {}, program {})",
                            s.error,
                            if s.task_running { "running" } else { "stopped" }
                        ),
                    );
                    Ok(())
                }
                Err(e) => Err(steps.fail(
                    "verify",
                    Exit::Link,
                    e.to_string(),
                    "check the server's messages on the terminal",
                )),
            }
        }
        Err(e) => Err(steps.fail(
            "verify",
            Exit::Link,
            format!("the program runs but {robot_addr} does not answer: {e}"),
            "check that --robot names the port the program listens on (10050 unless changed), \
             that the controller has its Ethernet TCP/IP option, and that no firewall blocks \
             the port",
        )),
    }
}

fn file_name(path: &Path) -> String {
    path.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "deploy.as".to_owned())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn program_names_are_read_from_any_case_of_the_header() {
        let f = b".PROGRAM autostart.pc() ;x\r\n.END\r\n.program Motion (.a)\n.end\n";
        assert_eq!(program_names(f), ["autostart.pc", "motion"]);
    }
}
