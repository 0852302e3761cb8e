//! Recordings of real client sessions with the emulator (in memory, virtual time): read in every
//! format, plotted, replayed.

use std::path::{Path, PathBuf};
use std::time::Duration;

use fs020n_client::{
    BoxedStream, ClientConfig, Completion, ConnectFuture, Connector, JointsDeg, Recording, Robot,
    StreamOptions, Trajectory, TrajectoryPoint,
};
use fs020n_record::plot::{render, ImageFormat, PlotOptions};
use fs020n_record::replay::{replay, ReplayOptions};
use fs020n_record::{read, Run, SourceFormat};
use fs020n_sim::{ControllerConfig, Emulator};

struct Emu(Emulator);

impl Connector for Emu {
    fn connect(&self) -> ConnectFuture<'_> {
        let emu = self.0.clone();
        Box::pin(async move { Ok(Box::new(emu.connect()?) as BoxedStream) })
    }
    fn describe(&self) -> String {
        "in-memory emulator".into()
    }
}

fn home_with_jt1(deg: f64) -> JointsDeg {
    JointsDeg::new([deg, 0.0, -90.0, 0.0, -90.0, 0.0])
}

/// JT1 from `from` to `to` in `secs`, a cosine profile sampled every 20 ms with velocities.
fn ramp(from: f64, to: f64, secs: f64) -> Trajectory {
    let n = (secs / 0.02).round() as usize;
    let points = (0..=n)
        .map(|k| {
            let t = k as f64 * 0.02;
            let u = std::f64::consts::PI * t / secs;
            let mut p =
                TrajectoryPoint::new(t, home_with_jt1(from + (to - from) * (0.5 - 0.5 * u.cos())));
            let v = (to - from) * 0.5 * u.sin() * std::f64::consts::PI / secs;
            p.velocity = Some(JointsDeg::new([v, 0.0, 0.0, 0.0, 0.0, 0.0]));
            p
        })
        .collect();
    Trajectory::new(points).unwrap()
}

/// One run: connect, speed, start, a joint move, a streamed ramp, a pause, close. Returns the
/// time the emulator was created (virtual), so that a replay can start its own at the same
/// phase.
async fn record(path: &Path) {
    let emu = Emulator::new(ControllerConfig::default());
    let cfg = ClientConfig {
        record: Some(Recording::new(path)),
        ..ClientConfig::default()
    };
    let robot = Robot::connect_with(Emu(emu.clone()), cfg).await.unwrap();
    robot.set_speed(50.0).await.unwrap();
    robot.start().await.unwrap();
    let h = robot.move_joints(home_with_jt1(20.0)).await.unwrap();
    h.wait(Completion::default()).await.unwrap();
    let s = robot
        .stream(ramp(20.0, 0.0, 2.0), StreamOptions::default())
        .await
        .unwrap();
    s.wait().await.unwrap();
    tokio::time::sleep(Duration::from_millis(500)).await;
    robot.close().await.unwrap();
    drop(robot);
    // The last owner of the recording ends the file.
    tokio::time::sleep(Duration::from_millis(10)).await;
}

fn dir() -> tempfile::TempDir {
    tempfile::tempdir().unwrap()
}

#[tokio::test(start_paused = true)]
async fn the_same_run_reads_the_same_from_csv_jsonl_and_mcap() {
    let d = dir();
    let mut runs: Vec<Run> = Vec::new();
    for name in ["run.csv", "run.jsonl", "run.mcap"] {
        let path = d.path().join(name);
        record(&path).await;
        runs.push(read(&path).unwrap());
    }
    assert_eq!(runs[0].format, SourceFormat::Csv);
    assert_eq!(runs[1].format, SourceFormat::JsonLines);
    assert_eq!(runs[2].format, SourceFormat::Mcap);
    for r in &runs {
        assert!(r.truncated.is_none());
        assert_eq!(r.robot(), Some("in-memory emulator"));
        assert!(r.info.is_some());
        assert!(r.exchanges.len() > 100, "{}", r.exchanges.len());
        assert!(r.commanded.len() > 50);
        assert!(!r.commanded[0].streamed && r.commanded[1].streamed);
        let events: Vec<&str> = r.events.iter().map(|e| e.event.as_str()).collect();
        assert_eq!(events, ["start", "connect", "end"]);
    }
    // Virtual time makes the three runs identical: every format carries the same data.
    let base = &runs[0];
    for r in &runs[1..] {
        assert_eq!(r.exchanges.len(), base.exchanges.len(), "{:?}", r.format);
        for (a, b) in base.exchanges.iter().zip(&r.exchanges) {
            assert_eq!(
                (&a.request, &a.reply, &a.kind),
                (&b.request, &b.reply, &b.kind)
            );
            assert!(
                (a.sent_s - b.sent_s).abs() < 2e-6,
                "{} {}",
                a.sent_s,
                b.sent_s
            );
        }
        assert_eq!(r.states.len(), base.states.len());
        for (a, b) in base.states.iter().zip(&r.states) {
            assert!((a.t_s - b.t_s).abs() < 2e-6);
            for j in 0..6 {
                assert!((a.joints_deg[j] - b.joints_deg[j]).abs() < 1e-9);
            }
            assert_eq!(a.status, b.status);
            assert_eq!(a.session, b.session);
        }
        assert_eq!(r.commanded.len(), base.commanded.len());
        for (a, b) in base.commanded.iter().zip(&r.commanded) {
            assert!((a.joints_deg[0] - b.joints_deg[0]).abs() < 1e-9);
        }
    }
    // The move reached its target; the ramp came back.
    let max = base
        .states
        .iter()
        .map(|s| s.joints_deg[0])
        .fold(f64::MIN, f64::max);
    assert!((max - 20.0).abs() < 0.01, "{max}");
    assert!(base.states.last().unwrap().joints_deg[0].abs() < 0.05);
}

#[tokio::test(start_paused = true)]
async fn files_cut_short_read_up_to_the_cut() {
    let d = dir();
    let csv = d.path().join("cut.csv");
    record(&csv).await;
    let full = std::fs::read_to_string(&csv).unwrap();
    let whole = read(&csv).unwrap();
    let cut = &full[..full.len() * 2 / 3];
    // Cut after a field, and inside a quoted reply.
    for cut in [
        &cut[..cut.rfind(',').unwrap()],
        &cut[..cut.rfind(" 1040").unwrap() + 8],
    ] {
        std::fs::write(&csv, cut).unwrap();
        let part = read(&csv).unwrap();
        assert!(part.truncated.is_some());
        assert!(part.exchanges.len() > whole.exchanges.len() / 2);
        assert!(part.exchanges.len() < whole.exchanges.len());
    }

    let jsonl = d.path().join("cut.jsonl");
    record(&jsonl).await;
    let full = std::fs::read_to_string(&jsonl).unwrap();
    std::fs::write(&jsonl, &full[..full.len() - 20]).unwrap();
    let part = read(&jsonl).unwrap();
    assert!(part.truncated.is_some());

    // MCAP: a killed writer leaves complete chunks and, at worst, a partial one after them.
    let mcap = d.path().join("cut.mcap");
    record(&mcap).await;
    let bytes = std::fs::read(&mcap).unwrap();
    let whole = read(&mcap).unwrap();
    for keep in [bytes.len() / 2, bytes.len() - 100, 30] {
        std::fs::write(&mcap, &bytes[..keep]).unwrap();
        let part = read(&mcap).unwrap();
        assert!(part.exchanges.len() <= whole.exchanges.len());
    }
}

#[tokio::test(start_paused = true)]
async fn plots_have_a_panel_per_joint_plus_tracking_and_round_trips() {
    let d = dir();
    let path = d.path().join("run.mcap");
    record(&path).await;
    let run = read(&path).unwrap();

    let (svg, summary) = render(&run, ImageFormat::Svg, &PlotOptions::default()).unwrap();
    let svg = String::from_utf8(svg).unwrap();
    assert_eq!(summary.panels, 8);
    assert!(svg.starts_with("<svg"));
    // plotters writes each text on a line of its own.
    let count = |prefix: &str| svg.lines().filter(|l| l.starts_with(prefix)).count();
    for j in 1..=6 {
        assert_eq!(count(&format!("joint {j} (deg)")), 1, "joint {j}");
    }
    assert_eq!(
        count("tracking error of streamed samples: commanded − actual (deg)"),
        1
    );
    assert_eq!(count("round trip (ms): n "), 1);
    assert_eq!(
        count("joint ") + count("tracking error") + count("round trip (ms):"),
        8
    );
    assert!(
        svg.contains("in-memory emulator"),
        "the title names the robot"
    );
    assert!(summary.commanded > 50 && summary.round_trips > 100);
    assert_eq!(summary.late_replies, 0);

    let zoom = PlotOptions {
        joints: vec![1, 2],
        from_s: Some(0.5),
        to_s: Some(2.0),
        ..PlotOptions::default()
    };
    let (svg, summary) = render(&run, ImageFormat::Svg, &zoom).unwrap();
    let svg = String::from_utf8(svg).unwrap();
    assert_eq!(summary.panels, 4);
    assert_eq!(svg.lines().filter(|l| l.starts_with("joint ")).count(), 2);
    assert!(summary.states < run.states.len());
    assert!(svg.contains("(showing 0.5 to 2.0 s)"));

    let (png_bytes, summary) = render(&run, ImageFormat::Png, &PlotOptions::default()).unwrap();
    let decoder = png::Decoder::new(std::io::Cursor::new(png_bytes));
    let mut reader = decoder.read_info().unwrap();
    let mut pixels = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut pixels).unwrap();
    assert_eq!((info.width, info.height), (summary.width, summary.height));
    assert_eq!((info.width, info.height), (1600, 64 + 3 * 280 + 320));
    let pixels = &pixels[..info.buffer_size()];
    let non_white = pixels.chunks(3).filter(|p| p != &[255, 255, 255]).count();
    let total = pixels.len() / 3;
    assert!(non_white > total / 50, "{non_white} of {total}");
    // The actual (blue) and commanded (orange) lines are drawn.
    assert!(pixels.chunks(3).any(|p| p == [31, 119, 180]));
    assert!(pixels.chunks(3).any(|p| p == [255, 127, 14]));
    // Text is rendered with the bundled font: dark grey anti-aliased pixels in the title band.
    let title_band = &pixels[..1600 * 60 * 3];
    assert!(title_band.chunks(3).filter(|p| p[0] < 100).count() > 500);
}

#[tokio::test(start_paused = true)]
async fn plot_options_are_checked() {
    let d = dir();
    let path = d.path().join("run.csv");
    record(&path).await;
    let run = read(&path).unwrap();
    for bad in [
        PlotOptions {
            joints: vec![0],
            ..PlotOptions::default()
        },
        PlotOptions {
            joints: vec![7],
            ..PlotOptions::default()
        },
        PlotOptions {
            from_s: Some(5.0),
            to_s: Some(1.0),
            ..PlotOptions::default()
        },
        PlotOptions {
            width: 10,
            ..PlotOptions::default()
        },
    ] {
        assert!(render(&run, ImageFormat::Svg, &bad).is_err(), "{bad:?}");
    }
}

fn emulator_connect(
    emu: &Emulator,
) -> impl Fn() -> std::future::Ready<std::io::Result<tokio::io::DuplexStream>> + '_ {
    move || std::future::ready(emu.connect())
}

async fn recorded_run(d: &Path) -> (PathBuf, Run) {
    let path = d.join("run.csv");
    record(&path).await;
    let run = read(&path).unwrap();
    (path, run)
}

#[tokio::test(start_paused = true)]
async fn replay_against_the_emulator_matches_and_finds_an_injected_divergence() {
    let d = dir();
    let (path, run) = recorded_run(d.path()).await;

    // Same emulator, same timing (virtual): every reply matches, joints exactly.
    let emu = Emulator::new(ControllerConfig::default());
    let opts = ReplayOptions {
        tolerance_deg: 0.01,
        ..ReplayOptions::default()
    };
    let report = replay(&run, emulator_connect(&emu), &opts).await.unwrap();
    assert_eq!(report.sessions, 1);
    assert_eq!(report.requests, run.exchanges.len());
    assert_eq!(report.compared, run.exchanges.len());
    assert!(report.matches(), "{:#?}", report.divergences);
    assert!(report.max_joint_diff_deg.iter().all(|d| *d < 0.01));
    assert!(
        emu.with(|c| c.counters().motions) >= 1,
        "the replay moved the emulator"
    );

    // Inject: one reply in the middle of the stream says JT2 was 5 degrees off, and another
    // says the controller had an error. Replay finds both, and only them.
    let text = std::fs::read_to_string(&path).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_owned).collect();
    let rx: Vec<usize> = lines
        .iter()
        .enumerate()
        .filter(|(_, l)| l.contains(",rx,motion,"))
        .map(|(i, _)| i)
        .collect();
    let target = rx[rx.len() / 2];
    let (head, reply) = lines[target].rsplit_once(",\"").unwrap();
    let mut status = fs020n_proto::Status::decode(reply.trim_end_matches('"')).unwrap();
    status.joints.0[1] += 5.0;
    lines[target] = format!("{head},\"{}\"", status.encode());
    let other = rx[rx.len() / 4];
    let (head, reply) = lines[other].rsplit_once(",\"").unwrap();
    let mut status = fs020n_proto::Status::decode(reply.trim_end_matches('"')).unwrap();
    status.error = fs020n_proto::ErrorCode::DESTINATION_OUT_OF_RANGE;
    lines[other] = format!("{head},\"{}\"", status.encode());
    std::fs::write(&path, lines.join("\n") + "\n").unwrap();
    let injected = read(&path).unwrap();

    let emu = Emulator::new(ControllerConfig::default());
    let report = replay(&injected, emulator_connect(&emu), &opts)
        .await
        .unwrap();
    assert_eq!(report.divergent, 2, "{:#?}", report.divergences);
    assert_eq!(report.by_field.get("joint 2"), Some(&1));
    assert_eq!(report.by_field.get("error"), Some(&1));
    let d = &report.divergences;
    assert!(d[0]
        .fields
        .iter()
        .any(|f| f.field == "error" && f.recorded == "E1088"));
    let jt2 = &d[1].fields[0];
    assert_eq!(jt2.field, "joint 2");
    let (rec, rep): (f64, f64) = (jt2.recorded.parse().unwrap(), jt2.replayed.parse().unwrap());
    assert!((rec - rep - 5.0).abs() < 0.01, "{jt2:?}");
    assert!(d[1].request.starts_with("1040 7 21 "));
}

#[tokio::test(start_paused = true)]
async fn replay_refuses_what_it_cannot_replay() {
    let emu = Emulator::new(ControllerConfig::default());
    let d = dir();
    let path = d.path().join("status.csv");
    std::fs::write(
        &path,
        "time_s,timer_s,error_code,error,run,repeat,teach_lock,power,task_running,j1,j2,j3,j4,j5,j6\n\
         0.1000,0.105,0,,1,1,0,1,0,0.000,0.000,-90.000,0.000,-90.000,0.000\n",
    )
    .unwrap();
    let run = read(&path).unwrap();
    assert_eq!(run.format, SourceFormat::StatusCsv);
    assert_eq!(run.states.len(), 1);
    let e = replay(&run, emulator_connect(&emu), &ReplayOptions::default())
        .await
        .unwrap_err();
    assert!(e.to_string().contains("no requests"), "{e}");
}
