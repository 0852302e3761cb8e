//! `deploy`: puts an AS program on a controller over its terminal, the way a careful engineer
//! would, printing each step (docs/DEPLOY.md):
//!
//! 1. `as check` of the file with the controller's profile — refuses on errors;
//! 2. the terminal: log in, `ID` (the AS version), `PCSTATUS 1:`…`5:` and `DIRECTORY/P`;
//! 3. programs of the same names: loaded or running, they are stopped (`PCABORT`), killed
//!    (`PCKILL`) and deleted only with `--replace`;
//! 4. `LOAD`, a syntax error answered **abort** (never "change to comment");
//! 5. with `--autostart`, `SWITCH AUTOSTART.PC = ON`, read back;
//! 6. `PCEXECUTE`, then `PCSTATUS` shows it running and the protocol port answers a poll.
//!
//! `--dry-run` reads the controller's state and prints the plan without changing anything.

use std::path::Path;
use std::time::Duration;

use fs020n_as::lint::Generation;
use fs020n_as::LoadOptions;
use fs020n_client::Robot;
use fs020n_term::connection::TerminalConnection;
use fs020n_term::text::{self, parse_as_version, parse_switch, parse_task_status};

use crate::args::DeployArgs;
use crate::bringup::{open_terminal, terminal_addr, terminal_remedy, write_transcript, Steps};
use crate::context::{runtime, Ctx};
use crate::error::{CliError, CliResult, Exit};

/// PC tasks a controller has (`PCSTATUS 1:` … `5:`).
const PC_TASKS: u8 = 5;

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
        name,
        bytes,
        programs,
        start,
    } = plan;
    let step_err = |e: fs020n_term::connection::ConnectionError| e.to_string();
    macro_rules! cmd {
        ($step:expr, $line:expr, $confirm:expr) => {
            match term.command($line, $confirm).await {
                Ok(out) => out,
                Err(e) => {
                    let remedy = terminal_remedy(&e);
                    return Err(steps.fail($step, Exit::Link, step_err(e), remedy));
                }
            }
        };
    }

    // 2. Who the controller is and what runs on it.
    let id = cmd!("identify", "ID", false);
    let version = parse_as_version(&id).unwrap_or_else(|| "unknown AS version".to_owned());
    steps.ok(
        "identify",
        format!("terminal {} — {version}", term.terminal().unwrap_or("?")),
    );
    let mut running: Vec<(u8, String)> = Vec::new();
    for task in 1..=PC_TASKS {
        let out = cmd!("status", &format!("PCSTATUS {task}:"), false);
        let s = parse_task_status(&out);
        if let (true, Some(p)) = (s.running, s.program) {
            running.push((task, p.to_ascii_lowercase()));
        }
    }
    let listing = cmd!("status", "DIRECTORY/P", false);
    let loaded: Vec<String> = listing
        .lines()
        .skip(1)
        .flat_map(str::split_whitespace)
        .map(|w| w.trim_start_matches(['*', '~']).to_ascii_lowercase())
        .collect();
    let ours_running: Vec<&(u8, String)> = running
        .iter()
        .filter(|(_, p)| programs.contains(p))
        .collect();
    let ours_loaded: Vec<&String> = programs.iter().filter(|p| loaded.contains(p)).collect();
    steps.ok(
        "status",
        format!(
            "running: {}; of this file already loaded: {}",
            if running.is_empty() {
                "nothing".to_owned()
            } else {
                running
                    .iter()
                    .map(|(t, p)| format!("{p} in PC task {t}"))
                    .collect::<Vec<_>>()
                    .join(", ")
            },
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

    // 3. An older copy.
    let mut plan: Vec<(String, bool)> = Vec::new();
    for (task, _) in &ours_running {
        plan.push((format!("PCABORT {task}:"), false));
        plan.push((format!("PCKILL {task}:"), true));
    }
    for p in &ours_loaded {
        plan.push((format!("DELETE/P {p}"), true));
    }
    if !plan.is_empty() && !args.replace {
        let what = if ours_running.is_empty() {
            format!(
                "{} already loaded",
                ours_loaded
                    .iter()
                    .map(|s| s.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        } else {
            ours_running
                .iter()
                .map(|(t, p)| format!("{p} runs in PC task {t}"))
                .collect::<Vec<_>>()
                .join(", ")
        };
        return Err(steps.fail(
            "replace",
            Exit::NotReady,
            format!("{what}; nothing was changed"),
            "add --replace to stop, kill and delete the older copy and load this one (a running \
             server ends its session: the robot stops)",
        ));
    }
    let plan_text: Vec<String> = plan.iter().map(|(l, _)| l.clone()).collect();
    let mut rest = vec![format!("LOAD {name}")];
    if args.autostart {
        rest.push("SWITCH AUTOSTART.PC = ON".to_owned());
    }
    rest.push(format!("PCEXECUTE {}: {start}", args.task));
    if args.dry_run {
        let all: Vec<String> = plan_text.iter().cloned().chain(rest).collect();
        steps.note("plan", "dry run", format!("would send: {}", all.join("; ")));
        return Ok(());
    }
    for (line, confirm) in &plan {
        let out = cmd!("replace", line, *confirm);
        if let Some(code) = text::monitor_error_code(&out) {
            return Err(steps.fail(
                "replace",
                Exit::NotReady,
                format!("`{line}` refused: {out} (P{code:04})"),
                "stop the program by hand on the teach pendant or the terminal, then deploy again",
            ));
        }
    }
    if !plan.is_empty() {
        steps.ok("replace", format!("sent {}", plan_text.join("; ")));
    }

    // 4. LOAD.
    match term.load(name, bytes).await {
        Ok(r) if r.syntax_error.is_some() => {
            return Err(steps.fail(
                "load",
                Exit::Input,
                format!(
                    "the controller found a syntax error at `{}`; the load was aborted \
                     (answered 1: delete program and abort)",
                    r.syntax_error.unwrap_or_default()
                ),
                format!(
                    "fix that line (`fs020n as check --controller {} {name}` shows what it \
                     checks), then deploy again",
                    args.controller
                ),
            ));
        }
        Ok(r) if r.errors > 0 => {
            return Err(steps.fail(
                "load",
                Exit::Input,
                format!("the controller counted {} error(s) in the load", r.errors),
                "read the transcript (--transcript FILE) for the controller's messages",
            ));
        }
        Ok(_) => steps.ok("load", format!("{name} loaded ({} bytes)", bytes.len())),
        Err(fs020n_term::connection::ConnectionError::Terminal(
            fs020n_term::TerminalError::TransferInProgress,
        )) => {
            return Err(steps.fail(
                "load",
                Exit::NotReady,
                "the controller reports an earlier SAVE/LOAD still in progress (P2076)",
                "an earlier transfer was left unfinished: restart the controller (power off and \
                 on), then deploy again",
            ));
        }
        Err(e) => {
            let remedy = terminal_remedy(&e);
            return Err(steps.fail("load", Exit::Link, e.to_string(), remedy));
        }
    }

    // 5. AUTOSTART.
    if args.autostart {
        cmd!("autostart", "SWITCH AUTOSTART.PC = ON", false);
        let out = cmd!("autostart", "SWITCH AUTOSTART.PC", false);
        if parse_switch(&out) != Some(true) {
            return Err(steps.fail(
                "autostart",
                Exit::NotReady,
                format!("AUTOSTART.PC does not read ON: {out}"),
                "set it on the teach pendant (Aux function, system switches)",
            ));
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
    if let Some(code) = text::monitor_error_code(&out) {
        return Err(steps.fail(
            "start",
            Exit::NotReady,
            format!("`{line}` refused: {out}"),
            match code {
                1013 => "reset the controller's error (ERESET, or the pendant's reset), then deploy again",
                _ => "check the controller's state (fs020n doctor), then deploy again",
            },
        ));
    }
    let out = cmd!("start", &format!("PCSTATUS {}:", args.task), false);
    let s = parse_task_status(&out);
    if !s.running {
        return Err(steps.fail(
            "start",
            Exit::NotReady,
            format!("{start} does not run after PCEXECUTE: {out}"),
            "read the program's messages on the terminal (TYPE, the transcript) — a TCP_LISTEN \
             that failed ends the server",
        ));
    }
    steps.ok("start", format!("{start} runs in PC task {}", args.task));
    verify_port(ctx, steps, robot_addr).await
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
