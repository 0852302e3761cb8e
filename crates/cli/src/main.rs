//! `fs020n`: the command-line tool for the Kawasaki FS020N over protocol 1040.
#![forbid(unsafe_code)]

mod args;
mod demo;
mod error;
mod offline;
mod output;
mod plot;
mod recording;
mod replay;
mod robot_cmds;
mod session;
mod shell;
mod sim;
mod trajectory_file;

use std::process::ExitCode;

use clap::{CommandFactory, Parser};
use fs020n_kin::RobotModel;

use crate::args::{Cli, Cmd};
use crate::error::{CliError, CliResult};

fn main() -> ExitCode {
    let cli = Cli::parse();
    init_logging(cli.verbose);
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(e.exit as u8)
        }
    }
}

fn init_logging(verbose: u8) {
    let default = match verbose {
        0 => "warn",
        1 => "info",
        2 => "debug",
        _ => "trace",
    };
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(default));
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
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

fn ctx(cli: &Cli, model: RobotModel) -> session::Ctx {
    let record = cli
        .record
        .as_deref()
        .and_then(|p| recording::recording(p).ok());
    session::Ctx {
        record,
        addr: cli.robot.clone(),
        json: cli.json,
        model,
        connect_timeout: std::time::Duration::from_secs_f64(cli.connect_timeout.clamp(0.1, 3600.0)),
    }
}

fn run(cli: Cli) -> CliResult {
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
        Cmd::Decode(args) => offline::decode(args, cli.json),
        Cmd::Fk { joints } => offline::fk(&model, joints, cli.json),
        Cmd::Ik { pose, near } => offline::ik(&model, pose, near.as_deref(), cli.json),
        Cmd::Completions { shell } => {
            clap_complete::generate(
                *shell,
                &mut Cli::command(),
                "fs020n",
                &mut std::io::stdout(),
            );
            Ok(())
        }
        Cmd::Status { watch, rate } => robot_cmds::status(&ctx(&cli, model), *watch, *rate),
        Cmd::Shell => shell::shell(&ctx(&cli, model)),
        Cmd::Speed { percent } => robot_cmds::speed(&ctx(&cli, model), *percent),
        Cmd::Move(args) => robot_cmds::move_joints(&ctx(&cli, model), args),
        Cmd::Play(args) => robot_cmds::play(&ctx(&cli, model), args, args.approach),
        Cmd::Record {
            file,
            rate,
            duration,
        } if recording::is_client_recording(file) => {
            if cli.record.is_some() {
                return Err(CliError::input(
                    "record FILE already records every request and reply: leave out --record",
                ));
            }
            recording::record(&ctx(&cli, model), file, *rate, *duration)
        }
        Cmd::Record {
            file,
            rate,
            duration,
        } => robot_cmds::record(&ctx(&cli, model), file, *rate, *duration),
        Cmd::Plot(args) => plot::plot(args, cli.json),
        Cmd::Replay(args) => replay::run(&ctx(&cli, model), args),
        Cmd::Raw { text, yes } => robot_cmds::raw(&ctx(&cli, model), text, *yes),
        Cmd::Bench { count } => robot_cmds::bench(&ctx(&cli, model), *count),
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
            let r = demo::demo(&c, *speed, *yes, plot.as_deref());
            if let Some(t) = temporary {
                let _ = std::fs::remove_file(t);
            }
            r
        }
        Cmd::Sim(args) => sim::sim(args, &model, cli.json),
    }
}
