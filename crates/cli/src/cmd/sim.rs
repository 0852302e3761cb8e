//! `sim`: the controller emulator in the foreground, one or several robots.

use std::net::{SocketAddr, ToSocketAddrs};

use fs020n_kin::RobotModel;
use fs020n_proto::{ErrorCode, JointsDeg};
use fs020n_sim::{Panel, ProgramStart, SimOptions};
use fs020n_web::run_robot;
use serde_json::json;

use crate::args::SimArgs;
use crate::context::ctrl_c;
use crate::error::{CliError, CliResult};

fn resolve(text: &str, what: &str) -> CliResult<SocketAddr> {
    text.to_socket_addrs()
        .map_err(|e| CliError::input(format!("{what} {text:?}: {e} (expected HOST:PORT)")))?
        .next()
        .ok_or_else(|| CliError::input(format!("{what} {text:?}: no address")))
}

/// Builds the options of each robot from the flags.
pub(crate) fn options(args: &SimArgs, model: &RobotModel) -> CliResult<Vec<SimOptions>> {
    if !args.pendant.is_empty() && args.pendant.len() != args.listen.len() {
        return Err(CliError::input(format!(
            "{} --listen but {} --pendant: give one pendant address per robot, or none",
            args.listen.len(),
            args.pendant.len()
        )));
    }
    let panel = Panel {
        power: args.power,
        run: args.run == "run",
        repeat: args.mode == "repeat",
        teach_lock: args.teach_lock,
        estop: false,
    };
    let error = match &args.error {
        Some(e) => e
            .parse::<ErrorCode>()
            .map_err(|e| CliError::input(format!("--error: {e}")))?,
        None => ErrorCode::NONE,
    };
    let joints = match &args.joints {
        Some(v) => {
            let arr: [f64; 6] = v
                .as_slice()
                .try_into()
                .map_err(|_| CliError::input("--joints: expected 6 angles"))?;
            let j = JointsDeg::new(arr);
            model
                .check_limits(&j)
                .map_err(|e| CliError::input(format!("--joints: {e}")))?;
            Some(j)
        }
        None => None,
    };
    if let Some(p) = args.monitor_speed {
        if !(p.is_finite() && p > 0.0 && p <= 100.0) {
            return Err(CliError::input(
                "--monitor-speed must be above 0 and at most 100 %",
            ));
        }
    }
    let listen = (args.listen.iter())
        .map(|l| resolve(l, "--listen"))
        .collect::<CliResult<Vec<_>>>()?;
    let pendant = (args.pendant.iter())
        .map(|p| resolve(p, "--pendant"))
        .collect::<CliResult<Vec<_>>>()?;
    let terminal = args
        .terminal
        .as_deref()
        .map(|t| resolve(t, "--terminal"))
        .transpose()?;
    if !args.stubs.is_empty() && args.as_program.is_none() && !args.bare {
        return Err(CliError::input(
            "--stub applies to AS programs: give it with --as-program FILE or --bare \
             (the native server runs no AS program)",
        ));
    }
    let generation: fs020n_term::Generation = args.generation.parse().map_err(CliError::input)?;
    let terminal_session = fs020n_term::SessionConfig {
        load_questions: args.terminal_load_questions.clone(),
        ..fs020n_term::SessionConfig::of(generation)
    };
    let network = network(args)?;
    let ports = port_map(args)?;
    let inputs = (args.signals.iter())
        .map(|s| input_signal(s))
        .collect::<CliResult<Vec<_>>>()?;
    let mut start = (args.pc_execute.iter())
        .map(|s| ProgramStart::pc(s).map_err(|e| CliError::input(format!("--pcexecute {e}"))))
        .collect::<CliResult<Vec<_>>>()?;
    if let Some(s) = &args.execute {
        start.push(ProgramStart::robot(s).map_err(|e| CliError::input(format!("--execute {e}")))?);
    }
    let mut out = Vec::new();
    let robots = crate::fleet::expand(&listen, &pendant, args.robots)?;
    if terminal.is_some() && robots.len() > 1 {
        return Err(CliError::input(
            "--terminal serves one robot's terminal: start one robot with it",
        ));
    }
    let ports = fleet_ports(ports, robots.len(), args.as_program.is_some() || args.bare)?;
    for (listen, pendant) in robots {
        out.push(SimOptions {
            listen,
            pendant,
            pendant_token: args.token.clone(),
            model_file: None,
            model: Some(model.clone()),
            panel,
            monitor_speed_percent: args.monitor_speed,
            joints,
            error,
            program: args.as_program.clone(),
            program_load: (args.stubs.iter()).fold(fs020n_as::LoadOptions::new(), |o, s| o.stub(s)),
            bare: args.bare,
            terminal,
            terminal_piece: args.terminal_piece,
            terminal_session: terminal_session.clone(),
            network: network.clone(),
            ports: ports.clone(),
            inputs: inputs.clone(),
            start: start.clone(),
        });
    }
    Ok(out)
}

/// `--address` and `--host`: the controller's address and the hosts its programs reach.
fn network(args: &SimArgs) -> CliResult<fs020n_sim::Network> {
    let a = &args.address;
    let mut network = fs020n_sim::Network::default().address(a.parse().map_err(|e| {
        CliError::input(format!(
            "--address {a:?}: {e} (expected the controller's IPv4 address, e.g. 192.168.0.2)"
        ))
    })?);
    for h in &args.hosts {
        let (cell, real) = fs020n_sim::Network::parse_host(h)
            .map_err(|e| CliError::input(format!("--host {e}")))?;
        network.hosts.insert(cell, real);
    }
    Ok(network)
}

/// `--port-map`: where the program's listening ports are served.
fn port_map(args: &SimArgs) -> CliResult<fs020n_sim::PortMap> {
    let mut map = fs020n_sim::PortMap::same();
    for p in &args.port_map {
        let (port, host) = fs020n_sim::PortMap::parse_entry(p)
            .map_err(|e| CliError::input(format!("--port-map {e}")))?;
        map.ports.insert(port, host);
    }
    Ok(map)
}

/// The port map of each of `robots` robots running AS programs: with several, every program
/// port is served at a free host port (each robot's own, read on its pendant: `GET /network`),
/// since the same number for every robot would clash; a `--port-map` to a fixed host port is
/// refused with the remedy. The first port of each robot stays at its own `--listen`.
fn fleet_ports(
    ports: fs020n_sim::PortMap,
    robots: usize,
    programs: bool,
) -> CliResult<fs020n_sim::PortMap> {
    if robots <= 1 || !programs {
        return Ok(ports);
    }
    if let Some((p, h)) = ports.ports.iter().find(|(_, h)| **h != 0) {
        return Err(CliError::input(format!(
            "--port-map {p}={h} with --robots {robots}: every robot's program port {p} would be              served at host port {h}; give --port-map {p}=0 (a free port for each robot, shown by              GET /network on its pendant) or start the robots one by one"
        )));
    }
    Ok(fs020n_sim::PortMap {
        unlisted: fs020n_sim::UnlistedPorts::Free,
        ..ports
    })
}

/// Loads `--as-program` once before anything starts: a program that does not load is refused
/// with every error (file:line:column).
fn check_program(args: &SimArgs) -> CliResult<Option<String>> {
    let Some(path) = &args.as_program else {
        return Ok(None);
    };
    let stubs = (args.stubs.iter()).fold(fs020n_as::LoadOptions::new(), |o, s| o.stub(s));
    let program = fs020n_sim::ServerProgram::from_file_with(path, &stubs)
        .map_err(|e| CliError::input(format!("--as-program: {e}")))?;
    for w in program.warnings() {
        eprintln!("warning: {w}");
    }
    Ok(Some(program.name().to_owned()))
}

/// `--trace`: prints the executed program lines of every robot as they run.
async fn print_trace(emulators: Vec<fs020n_sim::Emulator>, as_json: bool) {
    for e in &emulators {
        e.with(|c| c.program_mut().set_trace(true));
    }
    let mut tick = tokio::time::interval(std::time::Duration::from_millis(20));
    loop {
        tick.tick().await;
        for (i, e) in emulators.iter().enumerate() {
            let lines = e.with(|c| c.program_mut().take_trace());
            let mut out = String::new();
            for l in lines {
                if as_json {
                    out.push_str(&json!({"robot": i + 1, "trace": l}).to_string());
                } else if emulators.len() > 1 {
                    out.push_str(&format!("[robot {}] {l}", i + 1));
                } else {
                    out.push_str(&l.to_string());
                }
                out.push('\n');
            }
            if !out.is_empty() {
                use std::io::Write as _;
                let mut stdout = std::io::stdout().lock();
                if stdout
                    .write_all(out.as_bytes())
                    .and_then(|_| stdout.flush())
                    .is_err()
                {
                    return;
                }
            }
        }
    }
}

/// The programs running, each with its task (`autostart.pc in PC task 1`): the program each
/// task was started with, not the subroutine it is in.
fn running_programs(c: &fs020n_sim::Controller) -> Vec<String> {
    let tasks = c.program().tasks().unwrap_or_default();
    (tasks.iter().enumerate())
        .filter(|(_, t)| t.state != fs020n_as::TaskState::Idle)
        .filter_map(|(i, t)| {
            let name = t.main.as_ref()?;
            Some(match i {
                0 => format!("{name} in the robot task"),
                n => format!("{name} in PC task {n}"),
            })
        })
        .collect()
}

/// The tasks an error stopped, with the error (`PC task 1 stopped: (E0102) … (autostart.pc line 2)`).
fn stopped_programs(c: &fs020n_sim::Controller) -> Vec<String> {
    let tasks = c.program().tasks().unwrap_or_default();
    (tasks.iter().enumerate())
        .filter(|(_, t)| t.state == fs020n_as::TaskState::Idle)
        .filter_map(|(i, t)| {
            // The error names the program and line (`… (autostart.pc line 2)`).
            let error = t.last_error.as_ref()?;
            Some(match i {
                0 => format!("the robot task stopped: {error}"),
                n => format!("PC task {n} stopped: {error}"),
            })
        })
        .collect()
}

/// `--signal N=1`: an input signal (1001–1999) and its state.
fn input_signal(text: &str) -> CliResult<(i32, bool)> {
    let bad = || {
        CliError::input(format!(
            "--signal {text}: expected N=1 or N=0 with N an input signal 1001–1999"
        ))
    };
    let (n, v) = text.split_once('=').ok_or_else(bad)?;
    let n: i32 = n.trim().parse().map_err(|_| bad())?;
    let on = match v.trim().to_ascii_lowercase().as_str() {
        "1" | "on" => true,
        "0" | "off" => false,
        _ => return Err(bad()),
    };
    if !(1001..=1999).contains(&n) {
        return Err(bad());
    }
    Ok((n, on))
}

/// `sim`.
pub(crate) fn sim(args: &SimArgs, model: &RobotModel, as_json: bool) -> CliResult {
    let all = options(args, model)?;
    let program = check_program(args)?;
    // Native robots with nothing beside their protocol port, on one thread: one readiness loop
    // serves them all (`fs020n_sim::FleetServer`), without a task per robot.
    let plain = all
        .iter()
        .all(|o| o.pendant.is_none() && o.terminal.is_none() && o.program.is_none() && !o.bare);
    if args.threads == 1 && plain && !args.trace {
        return sim_fleet(all, model, as_json);
    }
    let rt = crate::fleet::runtime(args.threads)?;
    rt.block_on(async {
        // Handlers first: a signal that arrives as soon as the addresses are printed must
        // already find them.
        let mut signals = ShutdownSignals::install();
        let mut robots = Vec::new();
        for opts in all {
            let r = run_robot(opts)
                .await
                .map_err(|e| CliError::input(format!("cannot start the emulator: {e}")))?;
            robots.push(r);
        }
        let addrs: Vec<RobotAddrs> = (robots.iter())
            .map(|r| RobotAddrs {
                listen: r.robot_addr(),
                pendant: r.pendant_addr(),
                terminal: r.terminal_addr(),
            })
            .collect();
        announce(&addrs, as_json);
        if !as_json {
            if args.bare {
                println!(
                    "{} emulated {} with nothing loaded (--bare): load and start a program \
                     through the terminal; Ctrl-C to stop",
                    robots.len(),
                    model.name()
                );
            } else {
                let (running, stopped) = (robots.first())
                    .map(|r| {
                        r.emulator()
                            .with(|c| (running_programs(c), stopped_programs(c)))
                    })
                    .unwrap_or_default();
                match &program {
                    Some(p) if running.is_empty() && !stopped.is_empty() => println!(
                        "{} emulated {} with the AS program {p} loaded; nothing runs: {}; \
                         Ctrl-C to stop",
                        robots.len(),
                        model.name(),
                        stopped.join("; ")
                    ),
                    Some(p) if running.is_empty() => println!(
                        "{} emulated {} with the AS program {p} loaded; nothing runs: the file \
                         has no autostart program (autostart.pc …); start one with --pcexecute \
                         PROG or --execute PROG, or at the terminal (--terminal); Ctrl-C to stop",
                        robots.len(),
                        model.name()
                    ),
                    Some(p) => println!(
                        "{} emulated {} running the AS program {p}: {}; Ctrl-C to stop",
                        robots.len(),
                        model.name(),
                        running.join(", ")
                    ),
                    None => println!(
                        "{} emulated {} running; Ctrl-C to stop",
                        robots.len(),
                        model.name()
                    ),
                }
            }
        }
        let tracer = args.trace.then(|| {
            let emulators = robots.iter().map(|r| r.emulator().clone()).collect();
            tokio::spawn(print_trace(emulators, as_json))
        });
        use std::io::Write as _;
        let _ = std::io::stdout().flush();
        let signal = signals.recv().await;
        tracing::info!("{signal}: stopping the emulator");
        if let Some(t) = tracer {
            t.abort();
        }
        for r in robots {
            r.stop();
        }
        if !as_json {
            println!("stopped ({signal})");
        }
        Ok(())
    })
}

/// Where one robot is served.
struct RobotAddrs {
    listen: SocketAddr,
    pendant: Option<SocketAddr>,
    terminal: Option<SocketAddr>,
}

/// Prints where each robot is served (one JSON line per robot with `--json`), and warns of a
/// robot port reachable from the network.
fn announce(robots: &[RobotAddrs], as_json: bool) {
    for (i, r) in robots.iter().enumerate() {
        if as_json {
            println!(
                "{}",
                json!({
                    "robot": i + 1,
                    "listen": r.listen.to_string(),
                    "pendant": r.pendant.map(|a| format!("http://{a}")),
                    "terminal": r.terminal.map(|a| a.to_string()),
                })
            );
        } else {
            if let Some(t) = r.terminal {
                println!("robot {}: AS terminal on {t} (login: as)", i + 1);
            }
            match r.pendant {
                Some(p) => println!(
                    "robot {}: protocol 1040 on {}, pendant on http://{p}/ (API: /api)",
                    i + 1,
                    r.listen
                ),
                None => println!("robot {}: protocol 1040 on {}", i + 1, r.listen),
            }
        }
    }
    for r in robots {
        if !r.listen.ip().is_loopback() {
            eprintln!(
                "WARNING: the robot port {} is reachable from the network: protocol 1040 has \
                 no authentication, anyone who can reach it can start the emulated program \
                 and move the arm. Bind --listen to 127.0.0.1 unless you mean it.",
                r.listen
            );
        }
    }
}

/// `sim` for native robots with no pendant, terminal, program, trace or input: the robots'
/// ports served by one readiness loop on its own thread, until Ctrl-C or SIGTERM.
fn sim_fleet(all: Vec<SimOptions>, model: &RobotModel, as_json: bool) -> CliResult {
    let robots = all
        .iter()
        .map(|o| {
            let config = o
                .controller_config()
                .map_err(|e| CliError::input(format!("cannot start the emulator: {e}")))?;
            Ok((fs020n_sim::Controller::new(config), o.listen))
        })
        .collect::<CliResult<Vec<_>>>()?;
    let fleet = fs020n_sim::FleetServer::bind(robots)
        .map_err(|e| CliError::input(format!("cannot start the emulator: {e}")))?;
    let addrs = fleet.local_addrs();
    let stop = fleet.stopper();
    let rt = crate::fleet::runtime(1)?;
    rt.block_on(async {
        // Handlers first, as in the other path.
        let mut signals = ShutdownSignals::install();
        let running = std::thread::Builder::new()
            .name("fs020n-fleet".into())
            .spawn(move || fleet.run())
            .map_err(|e| CliError::failure(format!("cannot start the emulator's thread: {e}")))?;
        let robots: Vec<RobotAddrs> = (addrs.iter())
            .map(|&listen| RobotAddrs {
                listen,
                pendant: None,
                terminal: None,
            })
            .collect();
        announce(&robots, as_json);
        if !as_json {
            println!(
                "{} emulated {} running; Ctrl-C to stop",
                addrs.len(),
                model.name()
            );
        }
        use std::io::Write as _;
        let _ = std::io::stdout().flush();
        let signal = signals.recv().await;
        tracing::info!("{signal}: stopping the emulator");
        stop.stop();
        match running.join() {
            Ok(Ok(_)) => {}
            Ok(Err(e)) => return Err(CliError::failure(format!("the emulator stopped: {e}"))),
            Err(_) => return Err(CliError::failure("the emulator's thread panicked")),
        }
        if !as_json {
            println!("stopped ({signal})");
        }
        Ok(())
    })
}

/// SIGINT (Ctrl-C) and SIGTERM, handled even when the process was started in the background,
/// where the shell leaves SIGINT ignored: installing a handler replaces that disposition.
pub(crate) struct ShutdownSignals {
    #[cfg(unix)]
    unix: Option<(tokio::signal::unix::Signal, tokio::signal::unix::Signal)>,
}

impl ShutdownSignals {
    pub(crate) fn install() -> ShutdownSignals {
        #[cfg(unix)]
        {
            use tokio::signal::unix::{signal, SignalKind};
            ShutdownSignals {
                unix: signal(SignalKind::interrupt())
                    .and_then(|i| Ok((i, signal(SignalKind::terminate())?)))
                    .ok(),
            }
        }
        #[cfg(not(unix))]
        {
            ShutdownSignals {}
        }
    }

    /// Waits for the first signal and names it.
    pub(crate) async fn recv(&mut self) -> &'static str {
        #[cfg(unix)]
        if let Some((int, term)) = &mut self.unix {
            return tokio::select! {
                _ = int.recv() => "SIGINT",
                _ = term.recv() => "SIGTERM",
            };
        }
        ctrl_c().await;
        "Ctrl-C"
    }
}

#[cfg(test)]
mod tests {
    use super::fleet_ports;
    use fs020n_sim::{PortMap, UnlistedPorts};

    #[test]
    fn several_robots_serve_their_program_ports_at_free_host_ports() {
        let one = fleet_ports(PortMap::same(), 1, true).unwrap();
        assert_eq!(one.host_port(9111), 9111, "one robot: the same number");
        let native = fleet_ports(PortMap::same(), 3, false).unwrap();
        assert_eq!(
            native.unlisted,
            UnlistedPorts::Same,
            "no program: nothing to serve"
        );
        let fleet = fleet_ports(PortMap::same().map(9112, 0), 3, true).unwrap();
        assert_eq!(fleet.host_port(9111), 0, "a free port for each robot");
        assert_eq!(fleet.host_port(9112), 0);
    }

    #[test]
    fn several_robots_refuse_a_fixed_host_port_with_the_remedy() {
        let e = fleet_ports(PortMap::same().map(9111, 19111), 2, true)
            .unwrap_err()
            .to_string();
        assert!(e.contains("--port-map 9111=0"), "{e}");
        assert!(e.contains("--robots 2"), "{e}");
    }
}
