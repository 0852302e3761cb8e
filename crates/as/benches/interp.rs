//! Interpreter speed (docs/PERFORMANCE.md, "AS interpreter"): steps per second of a busy
//! arithmetic loop and of the protocol-1040 server's request parsing, on the test system.

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use fs020n_as::testing::VirtualSystem;
use fs020n_as::{Config, Interpreter};

fn busy_loop(c: &mut Criterion) {
    let src = ".PROGRAM autostart.pc()\n  n = 0\n  x[1] = 0\n  WHILE TRUE DO\n    n = n + 1\n    x[1] = x[1] + n * 0.5\n  END\n.END\n";
    let mut g = c.benchmark_group("interp");
    // 100 ms of virtual time: 4 steps per pass at 20 µs each = 1250 passes, 5000 steps.
    g.throughput(Throughput::Elements(5000));
    g.bench_function("busy_loop_5000_steps", |b| {
        b.iter_custom(|iters| {
            let mut total = Duration::ZERO;
            for _ in 0..iters {
                let mut i = Interpreter::from_source("b.as", src, Config::default()).unwrap();
                let mut s = VirtualSystem::new();
                i.start(&mut s);
                let t = Instant::now();
                i.run_until(&mut s, Duration::from_millis(100));
                total += t.elapsed();
                black_box(i.real("n"));
            }
            total
        })
    });
    g.finish();
}

fn server_requests(c: &mut Criterion) {
    let mut g = c.benchmark_group("server1040");
    g.throughput(Throughput::Elements(1));
    let mut i =
        Interpreter::from_source("s.as", fs020n_as::SERVER_1040, Config::default()).unwrap();
    let mut s = VirtualSystem::new();
    i.start(&mut s);
    i.run_until(&mut s, Duration::from_millis(10));
    let client = s.connect(10050).unwrap();
    i.run_until(&mut s, Duration::from_millis(20));
    let req = b"1040 7 21 1.5 1 0 10.123 20.5 -80.25 5.5 -70.125 15 1.5 -2.25 3 0.5 -0.75 1 0.1 -0.2 0.3 0.05 -0.075 0.1";
    g.bench_function("command_7_request_and_reply", |b| {
        b.iter(|| {
            s.send(client, req);
            let t = i.now() + Duration::from_millis(10);
            i.run_until(&mut s, t);
            black_box(s.recv(client))
        })
    });
    g.finish();
}

criterion_group!(benches, busy_loop, server_requests);
criterion_main!(benches);
