//! The interpreted protocol-1040 server (`fs020n_as::SERVER_1040` run by
//! `Controller::with_program`) streaming command 7 at 100 Hz on virtual time (results in
//! docs/PERFORMANCE.md, "AS interpreter").
//!
//! One simulated second = 100 × (the client sends a command 7, the controller advances 10 ms
//! with the interpreter running both tasks, the client reads the reply). Goal ≥ 500 simulated
//! seconds per wall second.

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::{criterion_group, criterion_main, Criterion};
use fs020n_as::Config;
use fs020n_proto::JointsDeg;
use fs020n_sim::{ClientId, ServerProgram};
use fs020n_sim::{Controller, ControllerConfig};

struct Streamer {
    c: Controller,
    id: ClientId,
    t: f64,
    timer0: f64,
}

/// The bytes a client sends (3 decimals, trailing zeros trimmed), digit by digit (the
/// client's side is not what this benchmark measures: `format!` here cost a tenth of the run).
fn push_num(out: &mut String, v: f64) {
    let m = (v * 1000.0).round() as i64;
    out.push(' ');
    if m < 0 {
        out.push('-');
    }
    let m = m.unsigned_abs();
    let (int, mut frac) = (m / 1000, m % 1000);
    let mut digits = [0u8; 20];
    let (mut n, mut rest) = (0, int);
    loop {
        digits[n] = b'0' + (rest % 10) as u8;
        n += 1;
        rest /= 10;
        if rest == 0 {
            break;
        }
    }
    for &d in digits[..n].iter().rev() {
        out.push(char::from(d));
    }
    if frac != 0 {
        out.push('.');
        let mut div = 100;
        while frac != 0 {
            out.push(char::from(b'0' + (frac / div) as u8));
            frac %= div;
            div /= 10;
        }
    }
}

impl Streamer {
    fn new(monitor_percent: f64) -> Streamer {
        let program = ServerProgram::from_source_with(
            "server1040.as",
            fs020n_as::SERVER_1040,
            Config::default(),
        )
        .unwrap();
        let mut c = Controller::with_program(
            ControllerConfig {
                joints: JointsDeg::new([0.0, 10.0, -80.0, 0.0, -80.0, 0.0]),
                ..ControllerConfig::default()
            },
            program,
        );
        c.advance_by(Duration::from_millis(10));
        let id = c.program_mut().connect(None, [127, 0, 0, 1]).unwrap();
        let mut s = Streamer {
            c,
            id,
            t: 0.0,
            timer0: 0.0,
        };
        s.request("1040 1 0");
        s.request(&format!("1040 3 1 {monitor_percent}"));
        s.timer0 = s.c.now().as_secs_f64() - 0.01;
        s
    }

    fn request(&mut self, text: &str) {
        assert!(self.c.program_mut().send(self.id, text.as_bytes()));
        for _ in 0..20 {
            self.c.advance_by(Duration::from_millis(1));
            if !self.c.program_mut().recv(self.id).bytes.is_empty() {
                return;
            }
        }
        panic!("no reply");
    }

    /// One simulated second: 100 command-7 samples of a smooth multi-joint trajectory, one
    /// every 10 ms, each reply read.
    fn second(&mut self) {
        for _ in 0..100 {
            let t = self.t;
            let w = 0.8;
            let amp = [30.0, 10.0, 10.0, 20.0, 15.0, 40.0];
            let base = [0.0, 10.0, -80.0, 0.0, -80.0, 0.0];
            let mut req = String::with_capacity(200);
            req.push_str("1040 7 21");
            push_num(&mut req, self.c.now().as_secs_f64() - self.timer0);
            push_num(&mut req, 1.0);
            push_num(&mut req, 0.0);
            for k in 0..3 {
                for j in 0..6 {
                    let ph = w * t + j as f64;
                    let v = match k {
                        0 => base[j] + amp[j] * ph.sin() - amp[j] * (j as f64).sin(),
                        1 => amp[j] * w * ph.cos(),
                        _ => -amp[j] * w * w * ph.sin(),
                    };
                    push_num(&mut req, v);
                }
            }
            assert!(self.c.program_mut().send(self.id, req.as_bytes()));
            self.c.advance_by(Duration::from_millis(10));
            black_box(self.c.program_mut().recv(self.id));
            self.t += 0.01;
        }
        assert!(self.c.error().is_none(), "{}", self.c.error());
    }
}

/// CPU time of this thread (Linux `/proc/thread-self/schedstat`, nanoseconds), so that the
/// figure is not skewed by other processes on a shared machine; `None` elsewhere.
fn thread_cpu() -> Option<Duration> {
    let text = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    Some(Duration::from_nanos(
        text.split_whitespace().next()?.parse().ok()?,
    ))
}

fn stream(c: &mut Criterion) {
    let mut g = c.benchmark_group("as_stream_100hz");
    g.sample_size(20);
    for monitor in [100.0, 10.0] {
        let name = format!("sim_second_monitor_{monitor}");
        let mut s = Streamer::new(monitor);
        g.bench_function(&name, |b| b.iter(|| s.second()));
        // The headline figure, printed plainly.
        let mut s = Streamer::new(monitor);
        let (t, cpu) = (Instant::now(), thread_cpu());
        for _ in 0..60 {
            s.second();
        }
        let factor = 60.0 / t.elapsed().as_secs_f64();
        let cpu_factor = match (cpu, thread_cpu()) {
            (Some(a), Some(b)) if b > a => format!("{:.0}", 60.0 / (b - a).as_secs_f64()),
            _ => "?".into(),
        };
        let tasks = s.c.program().tasks().unwrap();
        let steps: u64 = tasks.iter().map(|t| t.steps).sum();
        // The deterministic counts, with each task's share (the robot task runs `ros_move`,
        // pc1 the communication task).
        let per_task: Vec<String> = tasks
            .iter()
            .filter(|t| t.steps > 0)
            .map(|t| format!("{} {}", t.task, t.steps))
            .collect();
        println!(
            "{name}: {factor:.0} simulated s per wall s, {cpu_factor} per CPU s ({} motions, {steps} AS steps in 60 s: {})",
            s.c.counters().motions,
            per_task.join(", "),
        );
    }
    g.finish();
}

criterion_group!(benches, stream);
criterion_main!(benches);
