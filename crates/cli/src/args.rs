//! Command-line arguments.

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand, ValueEnum};

/// Drive a Kawasaki FS020N over protocol 1040, or emulate one.
///
/// One invocation is one session: the controller ends the motion program whenever a session
/// ends, so commands that move (`move`, `play`) run the preflight, start the program, do their
/// work and close the session cleanly. Use `shell` for several commands in one session.
#[derive(Debug, Parser)]
#[command(name = "fs020n", version, propagate_version = true)]
#[command(after_help = "EXAMPLES:
  fs020n demo                                   # everything, on the embedded emulator
  fs020n sim                                    # an emulator on 127.0.0.1:10050
  fs020n --robot 192.168.0.2:10050 status --watch
  fs020n move 0 10 -80 0 -90 0 --speed 20 --wait
  fs020n play path.csv --mode stream
  fs020n decode ' 1040 -31088 -1 -1 0 -1 0     1.500     0.000     0.000   -90.000     0.000   -90.000     0.000 '
  fs020n ik 850 0 1153.5 0 180 0 --json")]
pub struct Cli {
    /// The robot's address (HOST:PORT); default 127.0.0.1:10050, where `fs020n sim` listens.
    /// `demo` and `bench` use an embedded emulator when it is not given.
    #[arg(long, global = true, env = "FS020N_ROBOT", value_name = "HOST:PORT")]
    pub robot: Option<String>,
    /// Print machine-readable JSON instead of tables.
    #[arg(long, global = true)]
    pub json: bool,
    /// More logs (-v info, -vv debug: every request and reply, -vvv trace).
    #[arg(short, long, global = true, action = clap::ArgAction::Count)]
    pub verbose: u8,
    /// How long to keep trying to connect (the controller listens in 3 s windows), seconds.
    #[arg(long, global = true, default_value_t = 10.0, value_name = "S")]
    pub connect_timeout: f64,
    /// A robot model file (TOML) instead of the embedded FS020N model.
    #[arg(long, global = true, value_name = "FILE")]
    pub model: Option<PathBuf>,
    /// Record every request and reply of the session to FILE: .mcap (Foxglove, PlotJuggler,
    /// ros2 bag), .csv or .jsonl (docs/RECORDING.md).
    #[arg(long, global = true, value_name = "FILE")]
    pub record: Option<PathBuf>,
    /// The command.
    #[command(subcommand)]
    pub command: Cmd,
}

/// Subcommands.
#[derive(Debug, Subcommand)]
pub enum Cmd {
    /// Show the robot's status (switches, error, program, timer, joints).
    Status {
        /// Redraw the status continuously until Ctrl-C.
        #[arg(long)]
        watch: bool,
        /// Redraw rate with --watch, Hz.
        #[arg(long, default_value_t = 5.0, value_name = "HZ")]
        rate: f64,
    },
    /// An interactive session: type start, move, speed, status… one after another.
    Shell,
    /// Set the monitor speed (percent, 1–100); it persists in the controller.
    Speed {
        /// Percent, 1–100.
        percent: f64,
    },
    /// Start the program and move the joints to a target (degrees).
    #[command(allow_negative_numbers = true)]
    Move(MoveArgs),
    /// Play a trajectory file (CSV `time_s,j1..j6[,v1..v6,a1..a6]` or JSON).
    Play(PlayArgs),
    /// Record the status: FILE.csv gets a status table; FILE.mcap or FILE.jsonl every request
    /// and reply (docs/RECORDING.md).
    Record {
        /// Output file (.csv, .mcap or .jsonl).
        file: PathBuf,
        /// Samples per second.
        #[arg(long, default_value_t = 10.0, value_name = "HZ")]
        rate: f64,
        /// Stop after this many seconds (default: until Ctrl-C).
        #[arg(long, value_name = "S")]
        duration: Option<f64>,
    },
    /// Send one raw request and print the raw reply and its decoding.
    Raw {
        /// The request text, e.g. "0 0 0" or "1040 3 1 20".
        text: String,
        /// Allow motion commands (6 and 7 with version 1040).
        #[arg(long)]
        yes: bool,
    },
    /// Decode a reply or request line.
    Decode(DecodeArgs),
    /// Forward kinematics: joints (deg) → flange X Y Z (mm) O A T (deg).
    #[command(allow_negative_numbers = true)]
    Fk {
        /// JT1..JT6, degrees.
        #[arg(num_args = 6, value_names = ["J1", "J2", "J3", "J4", "J5", "J6"], required = true)]
        joints: Vec<f64>,
    },
    /// Inverse kinematics: flange X Y Z (mm) O A T (deg) → joint solutions.
    #[command(allow_negative_numbers = true)]
    Ik {
        /// X Y Z O A T.
        #[arg(num_args = 6, value_names = ["X", "Y", "Z", "O", "A", "T"], required = true)]
        pose: Vec<f64>,
        /// Pick the solution nearest these joints (default: the home pose).
        #[arg(long, num_args = 6, value_names = ["J1", "J2", "J3", "J4", "J5", "J6"], allow_negative_numbers = true)]
        near: Option<Vec<f64>>,
    },
    /// Lock-step round-trip statistics using side-effect-free status polls.
    Bench {
        /// Number of round trips.
        #[arg(long, default_value_t = 1000)]
        count: u32,
    },
    /// Run the controller emulator in the foreground until Ctrl-C.
    Sim(SimArgs),
    /// The full tour on the embedded emulator: preflight, speed, moves, a stream, a report.
    Demo {
        /// Speed percent for the joint moves.
        #[arg(long, default_value_t = 50.0)]
        speed: f64,
        /// Confirm running the demo on the real robot given by --robot (it moves the arm).
        #[arg(long)]
        yes: bool,
        /// Draw a picture of the run into FILE (.png or .svg).
        #[arg(long, value_name = "FILE")]
        plot: Option<PathBuf>,
    },
    /// Draw a recording (.mcap, .csv, .jsonl): joints commanded and actual, tracking error,
    /// round trips.
    Plot(PlotArgs),
    /// Send a recording's requests again with their original timing (to the embedded emulator,
    /// or --robot) and report where the replies differ.
    Replay(ReplayArgs),
    /// Print shell completions.
    Completions {
        /// The shell.
        shell: clap_complete::Shell,
    },
}

/// `move` arguments.
#[derive(Debug, Args)]
pub struct MoveArgs {
    /// JT1..JT6, degrees.
    #[arg(num_args = 6, value_names = ["J1", "J2", "J3", "J4", "J5", "J6"], required = true, allow_negative_numbers = true)]
    pub joints: Vec<f64>,
    /// Set this speed (percent) before moving.
    #[arg(long, value_name = "PCT")]
    pub speed: Option<f64>,
    /// Wait until the target is reached (with a progress bar).
    #[arg(long)]
    pub wait: bool,
    /// Per-joint tolerance for --wait, degrees.
    #[arg(long, default_value_t = 0.1, value_name = "DEG")]
    pub tolerance: f64,
    /// Give up waiting after this many seconds (default: from the move's duration).
    #[arg(long, value_name = "S")]
    pub timeout: Option<f64>,
}

/// How `play` sends the trajectory.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum PlayMode {
    /// Command 7: time-stamped samples extrapolated by the controller.
    Stream,
    /// Command 6: joint-move waypoints at a fixed rate.
    Waypoints,
}

/// `play` arguments.
#[derive(Debug, Args)]
pub struct PlayArgs {
    /// Trajectory file: CSV (`time_s,j1..j6[,v1..v6,a1..a6]`) or JSON.
    pub file: PathBuf,
    /// Streaming mode.
    #[arg(long, value_enum, default_value_t = PlayMode::Stream)]
    pub mode: PlayMode,
    /// Send rate, Hz.
    #[arg(long, default_value_t = 50.0, value_name = "HZ")]
    pub rate: f64,
    /// Speed percent (command 3) before playing.
    #[arg(long, default_value_t = 100.0, value_name = "PCT")]
    pub speed: f64,
    /// If the robot is not at the first point, move there first with a joint move.
    #[arg(long)]
    pub approach: bool,
}

/// `plot` arguments.
#[derive(Debug, Args)]
pub struct PlotArgs {
    /// The recording: .mcap, .csv (the client's, or `fs020n record`'s status table) or .jsonl.
    pub recording: PathBuf,
    /// The picture: .png or .svg.
    #[arg(short, long, value_name = "FILE")]
    pub output: PathBuf,
    /// Joints to draw, e.g. 1,2 (default all six).
    #[arg(long, value_delimiter = ',', value_name = "J")]
    pub joints: Vec<usize>,
    /// Start of the window, seconds since the recording started.
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    pub from: Option<f64>,
    /// End of the window, seconds since the recording started.
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    pub to: Option<f64>,
    /// Image width, pixels.
    #[arg(long, default_value_t = 1600, value_name = "PX")]
    pub width: u32,
    /// Image height, pixels (default: from the number of panels).
    #[arg(long, value_name = "PX")]
    pub height: Option<u32>,
}

/// `replay` arguments.
#[derive(Debug, Args)]
pub struct ReplayArgs {
    /// The recording: .mcap, .csv or .jsonl written with --record.
    pub recording: PathBuf,
    /// A joint differing by more than this is a divergence, degrees.
    #[arg(long, default_value_t = 1.0, value_name = "DEG")]
    pub tolerance: f64,
    /// Monitor speed of the embedded emulator at start, percent (the recording does not say
    /// it unless it set it; default the model's, 10 %).
    #[arg(long, value_name = "PCT")]
    pub monitor_speed: Option<f64>,
    /// Confirm replaying on the real robot given by --robot (it moves the arm).
    #[arg(long)]
    pub yes: bool,
}

/// `decode` arguments.
#[derive(Debug, Args)]
pub struct DecodeArgs {
    /// The text to decode (quote it: replies start with a blank).
    pub text: String,
    /// Decode as a reply.
    #[arg(long, conflicts_with = "request")]
    pub reply: bool,
    /// Decode as a request (as the controller reads it).
    #[arg(long)]
    pub request: bool,
}

/// `sim` arguments.
#[derive(Debug, Args)]
pub struct SimArgs {
    /// Robot port(s); repeat for several robots in one process.
    #[arg(long, default_value = "127.0.0.1:10050", value_name = "HOST:PORT")]
    pub listen: Vec<String>,
    /// Pendant API address(es) (HTTP+JSON), one per robot.
    #[arg(long, value_name = "HOST:PORT")]
    pub pendant: Vec<String>,
    /// Token required by the pendant API (mandatory off loopback).
    #[arg(long, env = "FS020N_PENDANT_TOKEN")]
    pub token: Option<String>,
    /// Motor power at start.
    #[arg(long, default_value = "on", value_parser = on_off, action = clap::ArgAction::Set)]
    pub power: bool,
    /// RUN/HOLD at start: run or hold.
    #[arg(long, default_value = "run", value_parser = ["run", "hold"])]
    pub run: String,
    /// TEACH/REPEAT at start: repeat or teach.
    #[arg(long, default_value = "repeat", value_parser = ["repeat", "teach"])]
    pub mode: String,
    /// TEACH LOCK at start.
    #[arg(long, default_value = "off", value_parser = on_off, action = clap::ArgAction::Set)]
    pub teach_lock: bool,
    /// Monitor speed at start, percent (default: the model's, 10 %).
    #[arg(long, value_name = "PCT")]
    pub monitor_speed: Option<f64>,
    /// Initial joints, degrees (default: the home pose).
    #[arg(long, num_args = 6, allow_negative_numbers = true, value_name = "DEG")]
    pub joints: Option<Vec<f64>>,
    /// An error present at start, e.g. E1088.
    #[arg(long)]
    pub error: Option<String>,
}

fn on_off(s: &str) -> Result<bool, String> {
    match s.to_ascii_lowercase().as_str() {
        "on" | "true" | "1" => Ok(true),
        "off" | "false" | "0" => Ok(false),
        _ => Err(format!("{s:?}: expected on or off")),
    }
}
