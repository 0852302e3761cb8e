//! `fs020n`: the command-line tool for the Kawasaki FS020N over protocol 1040.
#![forbid(unsafe_code)]

mod args;
mod bringup;
mod cmd;
mod context;
mod error;
mod fleet;
mod linear;
mod output;
mod recording;
mod survey;
mod trajectory_file;

use std::io::IsTerminal;
use std::process::ExitCode;

use clap::{CommandFactory, FromArgMatches};
use fs020n_kin::RobotModel;

use crate::args::{Cli, Cmd, ColorWhen};
use crate::error::{CliError, CliResult};

/// The command line, with `sim --help` showing only what applies to the emulator: the global
/// options that mean nothing to it (it has no robot to reach) get hidden twins in `sim`, which
/// clap then does not replace by the visible global ones.
fn command() -> clap::Command {
    use clap::{value_parser, Arg};
    Cli::command().mut_subcommand("sim", |sim| {
        sim.arg(
            Arg::new("robot")
                .long("robot")
                .hide(true)
                .value_parser(value_parser!(String)),
        )
        .arg(
            Arg::new("connect_timeout")
                .long("connect-timeout")
                .hide(true)
                .value_parser(value_parser!(f64)),
        )
    })
}

fn main() -> ExitCode {
    let matches = command().get_matches();
    let cli = match Cli::from_arg_matches(&matches) {
        Ok(cli) => cli,
        Err(e) => e.exit(),
    };
    let color = use_color(cli.color);
    init_logging(cli.verbose, color);
    let json = cli.json;
    // `--robot` typed for `sim` (not from FS020N_ROBOT, which may be set for other commands).
    let typed = |m: &clap::ArgMatches| {
        m.value_source("robot") == Some(clap::parser::ValueSource::CommandLine)
    };
    let robot_typed = typed(&matches) || matches.subcommand().is_some_and(|(_, m)| typed(m));
    match run(cli, robot_typed) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            report(&e, json, color);
            ExitCode::from(e.code())
        }
    }
}

/// Whether stderr gets colours: `--color`, else a terminal without `NO_COLOR` (no-color.org).
fn use_color(when: ColorWhen) -> bool {
    match when {
        ColorWhen::Always => true,
        ColorWhen::Never => false,
        ColorWhen::Auto => {
            std::io::stderr().is_terminal()
                && std::env::var_os("NO_COLOR").is_none_or(|v| v.is_empty())
                && std::env::var("TERM").map_or(true, |t| t != "dumb")
        }
    }
}

/// Prints an error on stderr: one JSON object with `--json`, else `error: …` (red on a
/// colour terminal) with what to do.
fn report(e: &CliError, json: bool, color: bool) {
    if json {
        eprintln!("{}", e.to_json());
    } else if color {
        eprintln!("\x1b[1;31merror:\x1b[0m {e}");
    } else {
        eprintln!("error: {e}");
    }
}

fn init_logging(verbose: u8, color: bool) {
    // -vv: every exchange of the client (debug); -vvv: also the keep-alive polls (trace).
    let default = match verbose {
        0 => "warn",
        1 => "info",
        2 => "warn,fs020n=debug,fs020n_client=debug,fs020n_sim=debug",
        _ => "info,fs020n=trace,fs020n_client=trace,fs020n_sim=trace",
    };
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        // The DDS stack (the `ros2` command) reports every unreachable peer as a warning.
        .unwrap_or_else(|_| {
            tracing_subscriber::EnvFilter::new(format!("{default},rustdds=error,ros2_client=error"))
        });
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_ansi(color)
        .with_writer(std::io::stderr)
        .try_init();
}

fn load_model(cli: &Cli) -> CliResult<RobotModel> {
    match &cli.model {
        None => Ok(RobotModel::fs020n()),
        Some(path) => {
            RobotModel::from_file(path).map_err(|e| CliError::input(format!("robot model: {e}")))
        }
    }
}

fn ctx(cli: &Cli, model: RobotModel) -> context::Ctx {
    let record = cli
        .record
        .as_deref()
        .and_then(|p| recording::recording(p).ok());
    context::Ctx {
        record,
        addr: cli.robot.clone(),
        json: cli.json,
        model,
        connect_timeout: std::time::Duration::from_secs_f64(cli.connect_timeout.clamp(0.1, 3600.0)),
        interactive: std::io::stderr().is_terminal(),
    }
}

fn run(cli: Cli, robot_typed: bool) -> CliResult {
    if !(cli.connect_timeout.is_finite() && cli.connect_timeout > 0.0) {
        return Err(CliError::input(
            "--connect-timeout must be a positive number of seconds",
        ));
    }
    let model = load_model(&cli)?;
    if let Some(path) = &cli.record {
        recording::recording(path)?;
        let without_session = match &cli.command {
            Cmd::Decode(_) => Some("decode"),
            Cmd::Fk { .. } => Some("fk"),
            Cmd::Ik { .. } => Some("ik"),
            Cmd::Completions { .. } => Some("completions"),
            Cmd::As(_) => Some("as"),
            Cmd::Sim(_) => Some("sim"),
            Cmd::Plot(_) => Some("plot"),
            Cmd::Replay(_) => Some("replay"),
            _ => None,
        };
        if let Some(name) = without_session {
            return Err(CliError::input(format!(
                "--record records the requests and replies of a session with a robot; `{name}` \
                 has none: leave out --record"
            )));
        }
    }
    match &cli.command {
        Cmd::Decode(args) => cmd::decode::decode(args, cli.json),
        Cmd::Fk { joints } => cmd::fk::fk(&model, joints, cli.json),
        Cmd::Ik { pose, near } => cmd::ik::ik(&model, pose, near.as_deref(), cli.json),
        Cmd::As(args::AsCmd::Check(args)) => cmd::as_check::check(args, cli.json),
        Cmd::Completions { shell } => {
            clap_complete::generate(*shell, &mut command(), "fs020n", &mut std::io::stdout());
            Ok(())
        }
        Cmd::Status { watch, rate } => cmd::status::status(&ctx(&cli, model), *watch, *rate),
        Cmd::Shell => cmd::shell::shell(&ctx(&cli, model)),
        Cmd::Speed { percent } => cmd::speed::speed(&ctx(&cli, model), *percent),
        Cmd::Move(args) => cmd::move_cmd::move_cmd(&ctx(&cli, model), args),
        Cmd::Play(args) => cmd::play::play(&ctx(&cli, model), args),
        Cmd::Record(args) => cmd::record::record(&ctx(&cli, model), args, cli.record.is_some()),
        Cmd::Plot(args) => cmd::plot::plot(args, cli.json),
        Cmd::Replay(args) => cmd::replay::run(&ctx(&cli, model), args),
        Cmd::Raw { text, yes } => cmd::raw::raw(&ctx(&cli, model), text, *yes),
        Cmd::Bench { count } => cmd::bench::bench(&ctx(&cli, model), *count),
        Cmd::Demo { speed, yes, plot } => {
            if let Some(p) = plot {
                if fs020n_record::plot::ImageFormat::from_path(p).is_none() {
                    return Err(CliError::input(format!(
                        "--plot {}: name the picture .png or .svg",
                        p.display()
                    )));
                }
            }
            let mut c = ctx(&cli, model);
            // The plot is drawn from a recording: a temporary one without --record.
            let temporary =
                (plot.is_some() && c.record.is_none()).then(recording::temporary_recording);
            if let Some(t) = &temporary {
                c.record = Some(fs020n_client::Recording::new(t));
            }
            let r = cmd::demo::demo(&c, *speed, *yes, plot.as_deref());
            if let Some(t) = temporary {
                let _ = std::fs::remove_file(t);
            }
            r
        }
        Cmd::Sim(args) => {
            if robot_typed {
                return Err(CliError::input(
                    "--robot has no meaning for `sim` (it is the robot); use --listen HOST:PORT",
                ));
            }
            cmd::sim::sim(args, &model, cli.json)
        }
        #[cfg(feature = "ros2")]
        Cmd::Ros2(args) => cmd::ros2::ros2(&ctx(&cli, model), args),
        Cmd::Hub(args) => cmd::hub::hub(args, &ctx(&cli, model), cli.json),
        Cmd::Deploy(args) => cmd::deploy::deploy(&ctx(&cli, model), args),
        Cmd::Doctor(args) => cmd::doctor::doctor(&ctx(&cli, model), args),
    }
}
