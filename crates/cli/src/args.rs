//! Command-line arguments.

use std::path::PathBuf;

use clap::builder::{PossibleValuesParser, TypedValueParser};
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
  fs020n sim --pendant 127.0.0.1:10051          # ... with its web pendant: http://127.0.0.1:10051/
  fs020n hub --http 127.0.0.1:8080 --listen 127.0.0.1:10060   # share the robot's session
  fs020n --robot 192.168.0.2:10050 status --watch
  fs020n move 0 10 -80 0 -90 0 --speed 20 --wait
  fs020n move --pose 850 0 1100 0 180 0 --linear
  fs020n play path.csv --mode stream
  fs020n decode ' 1040 -31088 -1 -1 0 -1 0     1.500     0.000     0.000   -90.000     0.000   -90.000     0.000 '
  fs020n ik 850 0 1153.5 0 180 0 --json")]
pub(crate) struct Cli {
    /// The robot's address (HOST:PORT); default 127.0.0.1:10050, where `fs020n sim` listens.
    /// `demo` and `bench` use an embedded emulator when it is not given.
    #[arg(long, global = true, env = "FS020N_ROBOT", value_name = "HOST:PORT")]
    pub robot: Option<String>,
    /// Print machine-readable JSON instead of tables.
    #[arg(long, global = true)]
    pub json: bool,
    /// More logs on stderr: -v sessions, -vv every request and reply with its bytes and round
    /// trip, -vvv also the keep-alive polls (`RUST_LOG` overrides).
    #[arg(short, long, global = true, action = clap::ArgAction::Count)]
    pub verbose: u8,
    /// Colours on stderr: auto = on a terminal unless NO_COLOR is set.
    #[arg(long, global = true, value_enum, default_value_t = ColorWhen::Auto, value_name = "WHEN")]
    pub color: ColorWhen,
    /// How long to keep trying to connect (the controller listens in 3 s windows), seconds,
    /// 0.1–3600.
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

/// When to colour stderr.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(crate) enum ColorWhen {
    /// On a terminal, unless the environment variable NO_COLOR is set (and not empty).
    Auto,
    /// Always.
    Always,
    /// Never.
    Never,
}

/// Subcommands.
#[derive(Debug, Subcommand)]
pub(crate) enum Cmd {
    /// Show the robot's status (switches, error, program, timer, joints).
    Status {
        /// Redraw the status continuously until Ctrl-C.
        #[arg(long)]
        watch: bool,
        /// Redraw rate with --watch, Hz, 0.01–100.
        #[arg(long, default_value_t = 5.0, value_name = "HZ")]
        rate: f64,
    },
    /// An interactive session: type start, move, speed, status… one after another.
    Shell,
    /// Set the monitor speed (percent, 1–100); it persists in the controller.
    Speed {
        /// Percent, 1–100.
        #[arg(value_name = "PCT")]
        percent: f64,
    },
    /// Start the program and move to a target: joints (degrees), or a flange pose with --pose.
    #[command(allow_negative_numbers = true)]
    Move(MoveArgs),
    /// Play a trajectory file (CSV `time_s,j1..j6[,v1..v6,a1..a6]` or JSON).
    Play(PlayArgs),
    /// Record the status: FILE.csv gets a status table; FILE.mcap or FILE.jsonl every request
    /// and reply (docs/RECORDING.md).
    Record(RecordArgs),
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
        /// Number of round trips, at least 1.
        #[arg(long, default_value_t = 1000, value_name = "N")]
        count: u32,
    },
    /// Run the controller emulator in the foreground until Ctrl-C.
    Sim(Box<SimArgs>),
    /// Hold the one session with a controller and share it: web page, protocol-1040 face,
    /// safety fence, Foxglove bridge, recording (docs/HUB.md).
    Hub(HubArgs),
    /// Put an AS program on a real controller over its terminal: check, stop an older copy
    /// (--replace), LOAD, AUTOSTART (--autostart), PCEXECUTE, verify (docs/DEPLOY.md).
    Deploy(DeployArgs),
    /// Walk a bring-up in order and stop at the first broken link, with its remedy: terminal
    /// and protocol ports, controller ID, the server program, AUTOSTART, a poll, the
    /// preflight, TIMER (docs/DEPLOY.md).
    Doctor(DoctorArgs),
    /// The full tour on the embedded emulator: preflight, speed, moves, a stream, a report.
    Demo {
        /// Speed percent for the joint moves, 1–100.
        #[arg(long, default_value_t = 50.0, value_name = "PCT")]
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
    /// Run the ROS 2 node (joint states, URDF, FollowJointTrajectory for MoveIt 2, services,
    /// diagnostics) on the robot until Ctrl-C. See docs/ROS2.md.
    #[cfg(feature = "ros2")]
    Ros2(Ros2Args),
    /// AS program files: `as check` loads each as the emulator would and lints it against
    /// the controller's limits (docs/AS.md).
    #[command(subcommand)]
    As(AsCmd),
    /// Print shell completions.
    Completions {
        /// The shell.
        shell: clap_complete::Shell,
    },
}

/// `as` subcommands.
#[derive(Debug, Subcommand)]
pub(crate) enum AsCmd {
    /// Load each file exactly as the emulator would and report errors, warnings and a lint
    /// against the real controller's limits (exit 0: all load and no lint error; 1: a file
    /// does not load or is linted as an error; 2: usage).
    Check(AsCheckArgs),
}

/// `as check` arguments.
#[derive(Debug, Args)]
pub(crate) struct AsCheckArgs {
    /// The controller generation to lint for (default: the rules of every generation, the
    /// strictest ranges).
    #[arg(long, value_name = "GEN", value_parser = ["c", "d", "e", "f"], ignore_case = true)]
    pub controller: Option<String>,
    /// Declare an instruction a no-op (repeatable): it loads and does nothing.
    #[arg(long = "stub", value_name = "INSTR")]
    pub stubs: Vec<String>,
    /// AS files (a program, a controller backup).
    #[arg(required = true, value_name = "FILE")]
    pub files: Vec<PathBuf>,
}

/// `record` arguments.
#[derive(Debug, Args)]
pub(crate) struct RecordArgs {
    /// Output file: .csv (the status table), .mcap or .jsonl (every request and reply); refused
    /// if it exists, unless --force (or --append, CSV only).
    pub file: PathBuf,
    /// Samples per second, 0.01–1000.
    #[arg(long, default_value_t = 10.0, value_name = "HZ")]
    pub rate: f64,
    /// Stop after this many seconds, up to a day (default: until Ctrl-C).
    #[arg(long, value_name = "S")]
    pub duration: Option<f64>,
    /// Overwrite the file if it exists.
    #[arg(long, conflicts_with = "append")]
    pub force: bool,
    /// Add rows to the file if it exists (its header must be this command's).
    #[arg(long)]
    pub append: bool,
}

/// `move` arguments.
#[derive(Debug, Args)]
pub(crate) struct MoveArgs {
    /// JT1..JT6, degrees.
    #[arg(num_args = 6, value_names = ["J1", "J2", "J3", "J4", "J5", "J6"], required_unless_present = "pose", conflicts_with = "pose", allow_negative_numbers = true)]
    pub joints: Vec<f64>,
    /// A flange pose instead of joints: X Y Z (mm) O A T (deg, Z-Y-Z Euler angles as in AS);
    /// the inverse-kinematics solution nearest the current joints.
    #[arg(long, num_args = 6, value_names = ["X", "Y", "Z", "O", "A", "T"], allow_negative_numbers = true)]
    pub pose: Option<Vec<f64>>,
    /// With --pose: a straight line of the flange, streamed with command 7 (monitor speed set
    /// to 100 %, which streaming needs; the line's pace is --speed).
    #[arg(long, requires = "pose")]
    pub linear: bool,
    /// Speed percent, 1–100: the monitor speed set before a joint move (default: leave it);
    /// with --linear, the pace of the line as a percentage of the joints' top speeds
    /// (default 10).
    #[arg(long, value_name = "PCT")]
    pub speed: Option<f64>,
    /// Show a progress bar while moving (the command always waits for the target).
    #[arg(long)]
    pub wait: bool,
    /// Per-joint tolerance at the target, degrees, above 0 and at most 5.
    #[arg(long, default_value_t = 0.1, value_name = "DEG")]
    pub tolerance: f64,
    /// Give up waiting after this many seconds, up to a day (default: twice the planned
    /// duration plus 5 s).
    #[arg(long, value_name = "S")]
    pub timeout: Option<f64>,
    /// When RUN/HOLD is switched to HOLD, wait up to this many seconds for RUN (the controller
    /// resumes the motion), up to a day; 0 fails at once.
    #[arg(long, default_value_t = 60.0, value_name = "S")]
    pub hold_timeout: f64,
}

/// How `play` sends the trajectory.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(crate) enum PlayMode {
    /// Command 7: time-stamped samples extrapolated by the controller.
    Stream,
    /// Command 6: joint-move waypoints at a fixed rate.
    Waypoints,
}

/// `play` arguments.
#[derive(Debug, Args)]
pub(crate) struct PlayArgs {
    /// Trajectory file: CSV (`time_s,j1..j6[,v1..v6,a1..a6]`) or JSON.
    pub file: PathBuf,
    /// Streaming mode.
    #[arg(long, value_enum, default_value_t = PlayMode::Stream)]
    pub mode: PlayMode,
    /// Send rate, Hz, 4–500.
    #[arg(long, default_value_t = 50.0, value_name = "HZ")]
    pub rate: f64,
    /// Monitor speed percent (command 3) before playing, 1–100.
    #[arg(long, default_value_t = 100.0, value_name = "PCT")]
    pub speed: f64,
    /// If the robot is not at the first point, move there first with a joint move.
    #[arg(long)]
    pub approach: bool,
    /// When RUN/HOLD is switched to HOLD, wait up to this many seconds for RUN and go on from
    /// the same point of the trajectory, up to a day; 0 fails at once.
    #[arg(long, default_value_t = 60.0, value_name = "S")]
    pub hold_timeout: f64,
}

/// `ros2` arguments (flags override the parameter file, which overrides the environment).
#[cfg(feature = "ros2")]
#[derive(Debug, Args)]
pub(crate) struct Ros2Args {
    /// Print a MoveIt configuration file for this robot model and these settings, and exit:
    /// urdf, srdf, joint-limits (joint_limits.yaml) or controllers (moveit_controllers.yaml);
    /// or moveit-config DIR: write a whole MoveIt configuration package into DIR.
    #[arg(long, value_name = "WHAT", value_parser = ["urdf", "srdf", "joint-limits", "controllers", "moveit-config"])]
    pub(crate) print: Option<String>,
    /// With --print moveit-config: the package directory to write.
    #[arg(value_name = "DIR")]
    pub(crate) output: Option<PathBuf>,
    /// Run on an emulator inside this process instead of a robot (to try MoveIt, or in tests).
    #[arg(long)]
    pub(crate) embedded: bool,
    /// With --embedded: serve the emulator's pendant API (switches, E-stop, faults) here.
    #[arg(long, value_name = "HOST:PORT")]
    pub(crate) pendant: Option<String>,
    /// The node's settings.
    #[command(flatten)]
    pub(crate) node: Ros2NodeArgs,
}

/// The ROS 2 node's settings, for `ros2` and `hub --ros2`.
#[cfg(feature = "ros2")]
#[derive(Debug, Args)]
#[command(next_help_heading = "ROS 2 node")]
pub(crate) struct Ros2NodeArgs {
    /// A ROS 2 parameter file (YAML: `fs020n: {ros__parameters: {joint_names: [...], ...}}`).
    #[arg(long, value_name = "FILE")]
    pub(crate) params_file: Option<PathBuf>,
    /// ROS domain (default: ROS_DOMAIN_ID, else 0).
    #[arg(long, value_name = "ID")]
    pub(crate) domain_id: Option<u16>,
    /// Keep DDS on 127.0.0.1 (also with ROS_LOCALHOST_ONLY=1 or
    /// ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST).
    #[arg(long)]
    pub(crate) localhost_only: bool,
    /// Service mapping of the ROS 2 middleware of the peers: enhanced (FastDDS, the default of
    /// Humble and Jazzy), cyclone (rmw_cyclonedds_cpp) or basic.
    #[arg(long, value_name = "MAPPING")]
    pub(crate) service_mapping: Option<String>,
    /// Node name (default fs020n).
    #[arg(long, value_name = "NAME")]
    pub(crate) node_name: Option<String>,
    /// Node namespace (default /).
    #[arg(long, value_name = "NS")]
    pub(crate) namespace: Option<String>,
    /// /joint_states rate, Hz (default 100).
    #[arg(long, value_name = "HZ")]
    pub(crate) rate: Option<f64>,
    /// The action is NS/follow_joint_trajectory (default /fs020n_controller).
    #[arg(long, value_name = "NS")]
    pub(crate) action_namespace: Option<String>,
    /// Let goals start the motion program from the node's start on, until the first fault
    /// (then ~/start re-arms). Default: call ~/start first.
    #[arg(long)]
    pub(crate) auto_start: bool,
    /// ROS 2's own arguments, last on the line, as launch_ros's Node() passes them:
    /// -r FROM:=TO (also __node, __ns), -p NAME:=VALUE, --params-file FILE, --log-level L.
    #[arg(long = "ros-args", num_args = 0.., allow_hyphen_values = true, value_name = "ARG")]
    pub(crate) ros_args: Option<Vec<String>>,
}

/// `plot` arguments.
#[derive(Debug, Args)]
pub(crate) struct PlotArgs {
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
pub(crate) struct ReplayArgs {
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
pub(crate) struct DecodeArgs {
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
pub(crate) struct SimArgs {
    /// Robot port(s); repeat for several robots in one process (port 0 picks a free one).
    #[arg(long, default_value = "127.0.0.1:10050", value_name = "HOST:PORT")]
    pub listen: Vec<String>,
    /// Pendant address(es), one per robot: the web page at `/`, the JSON API (`/api` lists it).
    #[arg(long, value_name = "HOST:PORT")]
    pub pendant: Vec<String>,
    /// Emulate N robots on consecutive ports from --listen (and --pendant); with port 0 each
    /// robot picks a free port. With --json, one line per robot gives its addresses.
    #[arg(long, default_value_t = 1, value_name = "N")]
    pub robots: u16,
    /// Threads serving the robots (1: one thread does everything, without cross-thread
    /// wake-ups, and leaves the other cores to the clients of a fleet on the same machine;
    /// robots with nothing but their protocol port are then served by one readiness loop).
    #[arg(long, default_value_t = 2, value_name = "N")]
    pub threads: u16,
    /// Token required by the pendant API (mandatory off loopback).
    #[arg(long, env = "FS020N_PENDANT_TOKEN", value_name = "TOKEN")]
    pub token: Option<String>,
    /// Motor power at start.
    #[arg(long, default_value = "on", value_parser = on_off(), action = clap::ArgAction::Set)]
    pub power: bool,
    /// RUN/HOLD at start.
    #[arg(long, default_value = "run", value_parser = ["run", "hold"])]
    pub run: String,
    /// TEACH/REPEAT at start.
    #[arg(long, default_value = "repeat", value_parser = ["repeat", "teach"])]
    pub mode: String,
    /// TEACH LOCK at start.
    #[arg(long, default_value = "off", value_parser = on_off(), action = clap::ArgAction::Set)]
    pub teach_lock: bool,
    /// Monitor speed at start, percent, above 0 and at most 100 (default: the model's, 10 %).
    #[arg(long, value_name = "PCT")]
    pub monitor_speed: Option<f64>,
    /// Initial joints, degrees, inside the joint ranges (default: the home pose).
    #[arg(long, num_args = 6, allow_negative_numbers = true, value_names = ["J1", "J2", "J3", "J4", "J5", "J6"])]
    pub joints: Option<Vec<f64>>,
    /// An error present at start: an AS code such as E1088 (or its number, -31088).
    #[arg(long, value_name = "CODE", allow_hyphen_values = true)]
    pub error: Option<String>,
    /// Run this AS program file (e.g. a modified protocol-1040 server) instead of the native
    /// server; the first port it listens on is served at --listen. Its autostart programs
    /// (autostart.pc …) start; start others with --pcexecute / --execute.
    #[arg(long, value_name = "FILE")]
    pub as_program: Option<std::path::PathBuf>,
    /// With --as-program: print every executed program line (time, task, program:line, text).
    #[arg(long, requires = "as_program")]
    pub trace: bool,
    /// With --as-program or --bare: declare an instruction a no-op (repeatable), as
    /// `as check --stub`; on a bare controller it holds for every program loaded through the
    /// terminal and at every power cycle.
    #[arg(long = "stub", value_name = "INSTR")]
    pub stubs: Vec<String>,
    /// Start a new controller with nothing loaded: no protocol port answers until a program is
    /// loaded through the terminal (--terminal) and started; then the first port it listens
    /// on is served at --listen.
    #[arg(long, conflicts_with = "as_program")]
    pub bare: bool,
    /// Serve the controller's AS monitor terminal (telnet, login `as`) here, e.g.
    /// 127.0.0.1:2323 (a real controller's is port 23). One robot only.
    #[arg(long, value_name = "HOST:PORT")]
    pub terminal: Option<String>,
    /// Send the terminal's output in pieces of at most N bytes, as a real controller does
    /// (default: whole replies).
    #[arg(long, value_name = "N", requires = "terminal")]
    pub terminal_piece: Option<usize>,
    /// The controller generation whose terminal is played: c and d ask the terminal type
    /// (telnet TTYPE) before `login:`, end a LOAD with `Confirm !` and `Loading done.`, and
    /// refuse to load over a program in memory; e and f (the default: e) as captured.
    #[arg(
        long,
        value_name = "c|d|e|f",
        default_value = "e",
        requires = "terminal"
    )]
    pub generation: String,
    /// A test hook: the terminal asks this question after the first block of every LOAD
    /// (repeatable, asked in order), e.g. "Load? (1:Yes, 0:No, 2:Load all, 3:Exit)".
    #[arg(
        long = "terminal-load-question",
        value_name = "TEXT",
        requires = "terminal",
        hide = true
    )]
    pub terminal_load_questions: Vec<String>,
    /// With --as-program: set an input signal (1001–1999) at start, `N=1` ON or `N=0` OFF
    /// (repeatable); e.g. `--signal 1001=1` for a part-present sensor the program waits for.
    #[arg(long = "signal", value_name = "N=0|1", requires = "as_program")]
    pub signals: Vec<String>,
    /// With --as-program: start a PC program once the ports are served, as the monitor's
    /// `PCEXECUTE [task:] program[, cycles]` (repeatable), e.g. `--pcexecute "2: comm,-1"`.
    /// Without it only the file's autostart programs (autostart.pc …) run.
    #[arg(
        long = "pcexecute",
        value_name = "[N:]PROG[,CYCLES]",
        requires = "as_program"
    )]
    pub pc_execute: Vec<String>,
    /// With --as-program: start the robot program, as the monitor's `EXECUTE program[, cycles]`
    /// (with its checks: motor power, REPEAT, teach lock, no error).
    #[arg(
        long = "execute",
        value_name = "PROG[,CYCLES]",
        requires = "as_program"
    )]
    pub execute: Option<String>,
    /// The controller's own IP address, as its AS programs see it (a `TCP_CONNECT` or
    /// `UDP_SENDTO` to it reaches its own ports).
    #[arg(long, default_value = "192.168.0.2", value_name = "IPV4")]
    pub address: String,
    /// A host of the cell: programs reach REAL when they send to CELL, e.g.
    /// `--host 192.168.0.10=127.0.0.1` for a PC server on this machine (repeatable). An
    /// address not mapped is not reached: the program gets E4023 and the log says so.
    #[arg(long = "host", value_name = "CELL=REAL")]
    pub hosts: Vec<String>,
    /// Serve the AS program's port PROGRAM at host port HOST (repeatable; 0 picks a free
    /// one). Every port a program listens on is served at the address of --listen, at the
    /// same number unless mapped (the first also at --listen).
    #[arg(long = "port-map", value_name = "PROGRAM=HOST")]
    pub port_map: Vec<String>,
}

/// `deploy` arguments (the protocol port is `--robot`).
#[derive(Debug, Args)]
pub(crate) struct DeployArgs {
    /// The AS file to load (default: this project's protocol-1040 server text).
    pub file: Option<std::path::PathBuf>,
    /// The controller's terminal, HOST:PORT (default: the host of --robot, port 23).
    #[arg(long)]
    pub terminal: Option<String>,
    /// Stop, kill and replace programs of the same names that are loaded or running.
    #[arg(long)]
    pub replace: bool,
    /// Turn the AUTOSTART.PC switch ON, so the controller starts the program at power-on.
    #[arg(long)]
    pub autostart: bool,
    /// Show the plan (after reading the controller's state) and change nothing.
    #[arg(long)]
    pub dry_run: bool,
    /// Save the whole terminal conversation to FILE.
    #[arg(long, value_name = "FILE")]
    pub transcript: Option<std::path::PathBuf>,
    /// The controller's generation for the check (c, d, e or f; default d, the strictest
    /// known).
    #[arg(long, default_value = "d")]
    pub controller: String,
    /// The PC program to start (default: autostart.pc when the file has it, else its first
    /// program).
    #[arg(long)]
    pub program: Option<String>,
    /// The PC task to start it in, 1–5.
    #[arg(long, default_value_t = 1)]
    pub task: u8,
    /// Bytes per block of the LOAD (486 is the smallest any client uses on a D controller).
    #[arg(long, default_value_t = 480)]
    pub block_bytes: usize,
    /// An instruction the controller knows and this project's check does not (repeatable):
    /// the check accepts it; the controller still judges it during the LOAD.
    #[arg(long = "stub", value_name = "INSTR")]
    pub stubs: Vec<String>,
}

/// `doctor` arguments (the protocol port is `--robot`).
#[derive(Debug, Args)]
pub(crate) struct DoctorArgs {
    /// The controller's terminal, HOST:PORT (default: the host of --robot, port 23).
    #[arg(long)]
    pub terminal: Option<String>,
    /// The server program expected to run.
    #[arg(long, default_value = "autostart.pc")]
    pub program: String,
}

/// `hub` arguments (the controller is `--robot`).
#[derive(Debug, Args)]
pub(crate) struct HubArgs {
    /// Address of the web page (HTTP): the arm, the switches, guarded Cancel and Stop.
    #[arg(long, default_value = "127.0.0.1:8080", value_name = "HOST:PORT")]
    pub http: String,
    /// Serve a protocol-1040 face for existing clients here (one controlling client at a
    /// time, forwarded in lock-step; the others' polls are answered from the latest status).
    #[arg(long, value_name = "HOST:PORT")]
    pub listen: Option<String>,
    /// Serve a Foxglove WebSocket bridge here (joint states, TF, the URDF); needs the
    /// `foxglove` feature.
    #[arg(long, value_name = "HOST:PORT")]
    pub foxglove: Option<String>,
    /// A safety fence (TOML): joint ranges, speed cap, workspace box (docs/HUB.md).
    #[arg(long, value_name = "FILE")]
    pub fence: Option<PathBuf>,
    /// Token required by the web page's API (mandatory off loopback).
    #[arg(long, env = "FS020N_HUB_TOKEN")]
    pub token: Option<String>,
    /// Seconds of silence after which the controlling client is taken as gone (the robot is
    /// stopped with command 2).
    #[arg(long, default_value_t = 1.0, value_name = "S")]
    pub silence: f64,
    /// Also run the ROS 2 node on the hub's session (docs/ROS2.md): it holds control while it
    /// acts, and its goals pass the fence. Needs the `ros2` feature.
    #[arg(long)]
    pub ros2: bool,
    /// The ROS 2 node's settings (with --ros2).
    #[cfg(feature = "ros2")]
    #[command(flatten)]
    pub ros2_node: Ros2NodeArgs,
}

/// `on` or `off` (listed in the help).
fn on_off() -> impl TypedValueParser<Value = bool> {
    PossibleValuesParser::new(["on", "off"]).map(|s| s == "on")
}
