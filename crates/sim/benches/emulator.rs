//! Emulator benchmarks (results in docs/PERFORMANCE.md, "## Emulator"):
//!
//! 1. `stream_100hz/sim_second`: one simulated second of a robot streaming command 7 at 100 Hz,
//!    on the `Controller` directly (virtual time). Simulated seconds per wall second = 1 / time.
//! 2. `tcp_poll/reply`: one lock-step `0 0 0` poll round trip over loopback TCP.

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use fs020n_proto::{Command, JointsDeg, ReplyDecoder, Request, StreamSample};
use fs020n_sim::{Controller, ControllerConfig, SessionId};
use tokio::io::{AsyncReadExt, AsyncWriteExt};

struct Streamer {
    c: Controller,
    id: SessionId,
    t: f64,
    /// Encode requests with the client library's exact encoder (float formatting) instead of
    /// the bench's integer-based one; the emulator's own cost is the same either way.
    client_encoder: bool,
}

/// The same bytes as the client encoder (3 decimals, trailing zeros trimmed), built with integer
/// formatting so that the benchmark measures the emulator, not the client's float formatting.
fn fast_encode(s: &StreamSample) -> String {
    use std::fmt::Write;
    let mut out = String::with_capacity(200);
    out.push_str("1040 7 21");
    let mut num = |v: f64| {
        let m = (v * 1000.0).round() as i64;
        let (sign, m) = if m < 0 { ("-", -m) } else { ("", m) };
        let (int, frac) = (m / 1000, m % 1000);
        if frac == 0 {
            let _ = write!(out, " {sign}{int}");
        } else {
            let f = format!("{frac:03}");
            let _ = write!(out, " {sign}{int}.{}", f.trim_end_matches('0'));
        }
    };
    num(s.t0_s);
    num(s.lookahead_passes);
    num(0.0);
    for v in s
        .position
        .iter()
        .chain(s.velocity.iter())
        .chain(s.acceleration.iter())
    {
        num(v);
    }
    out
}

impl Streamer {
    fn new(monitor_percent: f64, client_encoder: bool) -> Streamer {
        let mut c = Controller::new(ControllerConfig {
            joints: JointsDeg::new([0.0, 10.0, -80.0, 0.0, -80.0, 0.0]),
            ..ControllerConfig::default()
        });
        let id = c.try_accept().unwrap();
        c.handle_request(id, b"1040 1 0").unwrap();
        c.handle_request(id, format!("1040 3 1 {monitor_percent}").as_bytes())
            .unwrap();
        Streamer {
            c,
            id,
            t: 0.0,
            client_encoder,
        }
    }

    /// One simulated second: 100 command-7 samples of a smooth multi-joint trajectory.
    fn second(&mut self) {
        for _ in 0..100 {
            let t = self.t;
            let w = 0.8;
            let amp = [30.0, 10.0, 10.0, 20.0, 15.0, 40.0];
            let base = [0.0, 10.0, -80.0, 0.0, -80.0, 0.0];
            let mut p = [0.0; 6];
            let mut v = [0.0; 6];
            let mut a = [0.0; 6];
            for j in 0..6 {
                let ph = w * t + j as f64;
                p[j] = base[j] + amp[j] * ph.sin() - amp[j] * (j as f64).sin();
                v[j] = amp[j] * w * ph.cos();
                a[j] = -amp[j] * w * w * ph.sin();
            }
            let s = StreamSample {
                t0_s: self.c.timer1_s(),
                lookahead_passes: 1.0,
                position: JointsDeg::new(p),
                velocity: JointsDeg::new(v),
                acceleration: JointsDeg::new(a),
            };
            let req = if self.client_encoder {
                Request::new(Command::StreamedMove(s)).encode().unwrap()
            } else {
                fast_encode(&s)
            };
            black_box(self.c.handle_request(self.id, req.as_bytes()).unwrap());
            self.c.advance_by(Duration::from_millis(10));
            self.t += 0.01;
        }
        assert!(self.c.error().is_none(), "{}", self.c.error());
    }
}

fn stream(c: &mut Criterion) {
    let mut g = c.benchmark_group("stream_100hz");
    g.sample_size(20);
    for (monitor, client_encoder) in [(100.0, false), (10.0, false), (100.0, true)] {
        let name = format!(
            "sim_second_monitor_{monitor}{}",
            if client_encoder {
                "_client_encoder"
            } else {
                ""
            }
        );
        let mut s = Streamer::new(monitor, client_encoder);
        g.bench_function(&name, |b| b.iter(|| s.second()));
        // the headline figure, printed plainly
        let mut s = Streamer::new(monitor, client_encoder);
        let t = Instant::now();
        for _ in 0..50 {
            s.second();
        }
        let factor = 50.0 / t.elapsed().as_secs_f64();
        println!(
            "{name}: {factor:.0} simulated s per wall s ({} motions, {} passes in 50 s)",
            s.c.counters().motions,
            s.c.counters().passes
        );
    }
    g.finish();
}

fn tcp_poll(c: &mut Criterion) {
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .unwrap();
    let (emu, mut stream) = rt.block_on(async {
        let emu = fs020n_sim::Emulator::new(ControllerConfig::default());
        let server = emu.serve_tcp("127.0.0.1:0".parse().unwrap()).await.unwrap();
        let s = tokio::net::TcpStream::connect(server.local_addr())
            .await
            .unwrap();
        s.set_nodelay(true).unwrap();
        std::mem::forget(server);
        (emu, s)
    });
    let mut g = c.benchmark_group("tcp_poll");
    g.throughput(Throughput::Elements(1));
    g.bench_function("reply", |b| {
        b.iter_custom(|iters| {
            rt.block_on(async {
                let mut buf = [0u8; 256];
                let mut decoder = ReplyDecoder::new();
                let start = Instant::now();
                for _ in 0..iters {
                    stream.write_all(b"0 0 0").await.unwrap();
                    loop {
                        let n = stream.read(&mut buf).await.unwrap();
                        assert!(n > 0, "connection closed");
                        decoder.push(&buf[..n]).unwrap();
                        if let Some(r) = decoder.next_reply().unwrap() {
                            black_box(r);
                            break;
                        }
                    }
                }
                start.elapsed()
            })
        })
    });
    g.finish();
    let n = emu.with(|c| c.counters().requests);
    println!("tcp_poll: {n} requests served in one session");
}

criterion_group!(benches, stream, tcp_poll);
criterion_main!(benches);
