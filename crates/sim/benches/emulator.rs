//! Emulator benchmarks (results in docs/PERFORMANCE.md, "## Emulator"):
//!
//! 1. `stream_100hz/sim_second_*`: one simulated second of a robot streaming command 7 at
//!    100 Hz, on the `Controller` directly (virtual time). Simulated seconds per wall second =
//!    1 / time. `…_emulator_alone` times only the emulator (the requests recorded beforehand,
//!    untimed); the others include the bench building each request.
//! 2. `tcp_poll/reply`: one lock-step `0 0 0` poll round trip over loopback TCP.

use std::hint::black_box;
use std::time::Instant;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use fs020n_proto::ReplyDecoder;
use fs020n_sim::ControllerConfig;
use tokio::io::{AsyncReadExt, AsyncWriteExt};

mod streamer;
use streamer::{Replay, Streamer};

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
    // The emulator alone: each measurement replays freshly recorded requests on a fresh
    // controller (the recording is not timed).
    g.bench_function("sim_second_monitor_100_emulator_alone", |b| {
        b.iter_custom(|iters| {
            let seconds = u32::try_from(iters).unwrap();
            let requests = streamer::record(100.0, seconds);
            let mut r = Replay::new(100.0);
            let t = Instant::now();
            r.run(&requests);
            t.elapsed()
        })
    });
    let requests = streamer::record(100.0, 50);
    let mut r = Replay::new(100.0);
    let t = Instant::now();
    r.run(&requests);
    let factor = 50.0 / t.elapsed().as_secs_f64();
    println!("sim_second_monitor_100_emulator_alone: {factor:.0} simulated s per wall s");
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
