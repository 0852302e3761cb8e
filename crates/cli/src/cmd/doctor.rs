//! `doctor`: walks a bring-up in order and stops at the first broken link, each with its
//! remedy (docs/DEPLOY.md): the protocol port, the terminal (a login, never a bare
//! connection: the controller serves three sessions), the controller's ID, the survey `deploy`
//! also reads (the server program loaded and running, what every task holds), AUTOSTART.PC, a
//! poll with its 14 fields, the preflight, TIMER.

use std::time::Duration;

use fs020n_client::Robot;
use fs020n_proto::TIMER_WIRE_STEP_S;
use fs020n_term::text::{parse_as_version, parse_switch};
use tokio::net::TcpStream;

use crate::args::DoctorArgs;
use crate::bringup::{open_terminal, terminal_addr, terminal_remedy, Steps};
use crate::context::{runtime, Ctx};
use crate::error::{CliResult, Exit};
use crate::survey::Survey;

/// `doctor`.
pub(crate) fn doctor(ctx: &Ctx, args: &DoctorArgs) -> CliResult {
    let robot_addr = ctx.addr_or_default();
    let terminal = terminal_addr(args.terminal.as_deref(), &robot_addr);
    let program = args.program.to_ascii_lowercase();
    let mut steps = Steps::new(ctx.json);
    runtime()?.block_on(async {
        // The network: the protocol port answers TCP. (The terminal is probed by logging in:
        // a bare connection would take one of its three sessions.)
        for (step, addr, remedy) in [(
            "protocol port",
            robot_addr.as_str(),
            "the server program is not listening: load and start it (`fs020n deploy`); a \
             controller without the Ethernet TCP/IP option cannot listen at all",
        )] {
            match tokio::time::timeout(ctx.connect_timeout, TcpStream::connect(addr)).await {
                Ok(Ok(_)) => steps.ok(step, format!("{addr} accepts connections")),
                Ok(Err(e)) if step == "protocol port" && e.kind() == std::io::ErrorKind::ConnectionRefused => {
                    // The server listens in 3 s windows: one refusal is not yet a failure.
                    tokio::time::sleep(Duration::from_millis(300)).await;
                    if TcpStream::connect(addr).await.is_ok() {
                        steps.ok(step, format!("{addr} accepts connections"));
                    } else {
                        return Err(steps.fail(step, Exit::Link, format!("{addr}: {e}"), remedy));
                    }
                }
                Ok(Err(e)) => return Err(steps.fail(step, Exit::Link, format!("{addr}: {e}"), remedy)),
                Err(_) => {
                    return Err(steps.fail(
                        step,
                        Exit::Link,
                        format!("{addr}: no answer within {:?}", ctx.connect_timeout),
                        remedy,
                    ))
                }
            }
        }

        // The controller over its terminal.
        let mut term = match open_terminal(&terminal, 480, ctx.connect_timeout).await {
            Ok(t) => t,
            Err(e) => return Err(steps.fail("terminal", Exit::Link, e.to_string(), terminal_remedy(&e))),
        };
        let id = match term.command("ID", false).await {
            Ok(out) => out,
            Err(e) => return Err(steps.fail("identify", Exit::Link, e.to_string(), terminal_remedy(&e))),
        };
        steps.ok(
            "identify",
            format!(
                "terminal {} — {}",
                term.terminal().unwrap_or("?"),
                parse_as_version(&id).unwrap_or_else(|| "unknown AS version".to_owned())
            ),
        );
        let survey = match Survey::read(&mut term).await {
            Ok(s) => s,
            Err(e) => return Err(steps.fail("server program", Exit::Link, e.to_string(), terminal_remedy(&e))),
        };
        if !survey.loaded.contains(&program) {
            return Err(steps.fail(
                "server program",
                Exit::NotReady,
                format!("{program} is not loaded ({})", survey.describe()),
                "load it: `fs020n deploy --autostart`",
            ));
        }
        match survey.running(&program) {
            Some(task) => steps.ok(
                "server program",
                format!("{program} is loaded and runs in {task}; {}", survey.describe()),
            ),
            None => {
                return Err(steps.fail(
                    "server program",
                    Exit::NotReady,
                    format!("{program} is loaded but does not run ({})", survey.describe()),
                    format!("start it: `fs020n deploy --replace` or type `PCEXECUTE 1: {program}` on the terminal"),
                ))
            }
        }
        let autostart = term.command("SWITCH AUTOSTART.PC", false).await.ok().and_then(|o| parse_switch(&o));
        match autostart {
            Some(true) => steps.ok("autostart", "AUTOSTART.PC is ON: the server starts at power-on"),
            _ => steps.note(
                "autostart",
                "warning",
                "AUTOSTART.PC is OFF: after a power cycle the server does not run until started \
                 (`fs020n deploy --autostart` turns it on)",
            ),
        }

        // The protocol.
        let robot = match Robot::connect(&robot_addr, ctx.client_config()).await {
            Ok(r) => r,
            Err(e) => {
                return Err(steps.fail(
                    "poll",
                    Exit::Link,
                    e.to_string(),
                    "the program runs but does not answer as a protocol-1040 server: check that \
                     --robot names its port",
                ))
            }
        };
        let status = match robot.poll().await {
            Ok(s) => s,
            Err(e) => {
                let _ = robot.close().await;
                return Err(steps.fail("poll", Exit::Link, e.to_string(), "check the server's messages on the terminal"));
            }
        };
        steps.ok("poll", "the server answers with the 14 fields".to_owned());
        let preflight = robot.preflight().await;
        let _ = robot.close().await;
        match preflight {
            Ok(()) => steps.ok("preflight", "switches, error and motor power allow motion"),
            Err(e) => {
                return Err(steps.fail(
                    "preflight",
                    Exit::NotReady,
                    e.to_string(),
                    "set what is listed on the teach pendant, then run doctor again",
                ))
            }
        }
        match (status.timer.seconds(), status.timer.step_s()) {
            (Some(t), Some(step)) if t >= 0.0 && step <= TIMER_WIRE_STEP_S => {
                steps.ok("timer", format!("TIMER(1) {t:.3} s: command 7's time stamps keep 1 ms"))
            }
            (Some(t), Some(step)) if t >= 0.0 => steps.note(
                "timer",
                "warning",
                format!(
                    "TIMER(1) {t:.0} s: at this age the session's clock (a 32-bit AS real) steps \
                     by {:.1} ms, and so do command 7's time stamps; reconnect to start a new \
                     session",
                    step * 1e3
                ),
            ),
            _ => {
                return Err(steps.fail(
                    "timer",
                    Exit::NotReady,
                    format!("TIMER(1) reads {:?}", status.timer),
                    "reconnect: a new session restarts TIMER(1)",
                ))
            }
        }
        Ok(())
    })
}
