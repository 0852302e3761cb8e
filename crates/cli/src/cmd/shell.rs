//! `shell`: one long session with a prompt, while the keep-alive runs.

use std::time::Duration;

use fs020n_client::{Completion, MoveHandle, Robot};
use rustyline::error::ReadlineError;
use rustyline::history::DefaultHistory;
use rustyline::Editor;

use crate::context::{check_speed, check_target, close_quietly, connect, runtime, Ctx, Interrupt};
use crate::error::{describe, Place};
use crate::error::{CliError, CliResult, Exit};
use crate::output::{robot_status_json, robot_status_table, rtt_line, status_table};

/// A client error at the prompt: remedies name what to type here.
fn shell_error(e: fs020n_client::ClientError) -> CliError {
    describe(e, Place::Shell)
}

const COMMANDS: &[(&str, &str)] = &[
    ("status", "show the latest status"),
    ("preflight", "list what blocks motion, with remedies"),
    (
        "start",
        "start the motion program (command 1), after the preflight",
    ),
    ("stop", "stop the motion program (command 2)"),
    ("speed", "speed PCT — set the monitor speed (command 3)"),
    (
        "cancel",
        "stop the current motion for sure (commands 5 then 2; `start` again to move)",
    ),
    (
        "move",
        "move J1 J2 J3 J4 J5 J6 [wait] — joint move (command 6)",
    ),
    ("wait", "wait for the last move to finish"),
    ("raw", "raw TEXT [--yes] — send any request"),
    ("stats", "round-trip statistics of this session"),
    (
        "reconnect",
        "open a new session after a lost link (never resumes motion)",
    ),
    ("help", "this list"),
    ("quit", "end the session (255) and leave"),
];

struct ShellHelper;

impl rustyline::completion::Completer for ShellHelper {
    type Candidate = String;

    fn complete(
        &self,
        line: &str,
        pos: usize,
        _ctx: &rustyline::Context<'_>,
    ) -> rustyline::Result<(usize, Vec<String>)> {
        let head = &line[..pos];
        if head.contains(' ') {
            return Ok((pos, Vec::new()));
        }
        let c = COMMANDS
            .iter()
            .filter(|(name, _)| name.starts_with(head))
            .map(|(name, _)| (*name).to_owned())
            .collect();
        Ok((0, c))
    }
}

impl rustyline::hint::Hinter for ShellHelper {
    type Hint = String;
}
impl rustyline::highlight::Highlighter for ShellHelper {}
impl rustyline::validate::Validator for ShellHelper {}
impl rustyline::Helper for ShellHelper {}

fn history_path() -> Option<std::path::PathBuf> {
    std::env::var_os("HOME").map(|h| std::path::PathBuf::from(h).join(".fs020n_history"))
}

/// `shell`.
pub(crate) fn shell(ctx: &Ctx) -> CliResult {
    let rt = runtime()?;
    let addr = ctx.addr_or_default();
    let mut robot = rt.block_on(connect(&addr, ctx))?;
    let stop = rt.block_on(async { Interrupt::install() });
    println!("connected to {addr}; type `help` for commands, `quit` to leave");
    let mut rl: Editor<ShellHelper, DefaultHistory> =
        Editor::new().map_err(|e| CliError::failure(format!("cannot open the prompt: {e}")))?;
    rl.set_helper(Some(ShellHelper));
    if let Some(p) = history_path() {
        let _ = rl.load_history(&p);
    }
    let mut last_move: Option<MoveHandle> = None;
    loop {
        let line = match rl.readline("fs020n> ") {
            Ok(l) => l,
            Err(ReadlineError::Interrupted | ReadlineError::Eof) => break,
            Err(e) => {
                eprintln!("error: {e}");
                break;
            }
        };
        let line = line.trim();
        if line.is_empty() {
            continue;
        }
        let _ = rl.add_history_entry(line);
        let words: Vec<&str> = line.split_whitespace().collect();
        if matches!(words[0], "quit" | "exit") {
            break;
        }
        let outcome = if words[0] == "reconnect" {
            rt.block_on(robot.reconnect())
                .map_err(shell_error)
                .map(|()| {
                    last_move = None;
                    println!(
                    "reconnected: a new session; the program is not running — `start` it to move"
                );
                })
        } else {
            rt.block_on(async {
                stop.clear();
                tokio::select! {
                    r = execute(ctx, &robot, &words, line, &mut last_move) => r,
                    _ = stop.wait() => {
                        // Ctrl-C while a command runs (e.g. `move … wait`): stop the arm, keep
                        // the session.
                        let _ = robot.cancel().await;
                        Err(CliError::new(Exit::Interrupted, "interrupted: motion cancelled and the program stopped; the session stays open (`start` to move again)"))
                    }
                }
            })
        };
        if let Err(e) = outcome {
            eprintln!("error: {e}");
        }
    }
    if let Some(p) = history_path() {
        let _ = rl.save_history(&p);
    }
    let lost = robot.link_error();
    rt.block_on(close_quietly(&robot));
    match lost {
        // The shell ends here: the remedy is to run it again.
        Some(e) => Err(crate::error::client_error(e)),
        None => {
            println!("session closed");
            Ok(())
        }
    }
}

async fn execute(
    ctx: &Ctx,
    robot: &Robot,
    words: &[&str],
    line: &str,
    last_move: &mut Option<MoveHandle>,
) -> CliResult {
    match words[0] {
        "help" => {
            for (name, what) in COMMANDS {
                println!("  {name:<10} {what}");
            }
        }
        "status" => {
            let s = robot.poll().await.map_err(shell_error)?;
            if ctx.json {
                println!("{}", robot_status_json(&s, &ctx.model));
            } else {
                print!("{}", robot_status_table(&s, &ctx.model));
            }
        }
        "preflight" => {
            robot.preflight().await.map_err(shell_error)?;
            println!("ready: nothing blocks motion");
        }
        "start" => {
            robot.start().await.map_err(shell_error)?;
            println!("program running");
        }
        "stop" => {
            robot.stop_program().await.map_err(shell_error)?;
            println!("program stopped");
        }
        "cancel" => {
            robot.cancel().await.map_err(shell_error)?;
            println!("motion cancelled and the program stopped; `start` to move again");
        }
        "speed" => {
            let p = words
                .get(1)
                .and_then(|w| w.parse::<f64>().ok())
                .ok_or_else(|| CliError::input("usage: speed PCT"))?;
            robot
                .set_speed(check_speed(p)?)
                .await
                .map_err(shell_error)?;
            println!("monitor speed {p} %");
        }
        "move" => {
            let values: Result<Vec<f64>, _> = words[1..]
                .iter()
                .filter(|w| **w != "wait")
                .map(|w| w.parse::<f64>())
                .collect();
            let values =
                values.map_err(|_| CliError::input("usage: move J1 J2 J3 J4 J5 J6 [wait]"))?;
            let target = check_target(&ctx.model, &values, "; nothing was sent")?;
            let h = robot.move_joints(target).await.map_err(shell_error)?;
            println!(
                "moving to {target} (about {:.1} s); `wait` to wait, `cancel` to stop",
                h.planned_duration().as_secs_f64()
            );
            *last_move = Some(h);
            if words.contains(&"wait") {
                wait_last(last_move).await?;
            }
        }
        "wait" => wait_last(last_move).await?,
        "raw" => {
            let rest = line.trim_start_matches("raw").trim();
            let yes = rest.ends_with("--yes");
            let text = rest.trim_end_matches("--yes").trim().trim_matches('"');
            let f = robot.send_raw(text, yes).await.map_err(shell_error)?;
            println!("reply {:?}", f.text);
            print!("{}", status_table(&f.status));
        }
        "stats" => {
            let s = robot.stats();
            println!(
                "{} requests, {} replies, round trip {}, late replies {}, keep-alive polls {}",
                s.requests,
                s.replies,
                rtt_line(&s.rtt),
                s.late_replies,
                s.keepalive_polls
            );
        }
        other => {
            return Err(CliError::input(format!(
                "unknown command {other:?}; type `help`"
            )));
        }
    }
    Ok(())
}

async fn wait_last(last_move: &mut Option<MoveHandle>) -> CliResult {
    let h = last_move
        .take()
        .ok_or_else(|| CliError::input("no move to wait for"))?;
    let timeout = h.planned_duration() * 2 + Duration::from_secs(5);
    let r = h
        .wait(Completion {
            timeout: Some(timeout),
            ..Completion::default()
        })
        .await
        .map_err(shell_error)?;
    println!(
        "reached {} in {:.2} s (error {:.4} deg)",
        r.final_joints,
        r.elapsed.as_secs_f64(),
        r.error_deg
    );
    Ok(())
}
