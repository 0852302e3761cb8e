//! The cost of recording on the request path: lock-step polls per second of the async client
//! against a minimal echo server on loopback, without a recording, recording CSV, recording
//! MCAP. The file is written by the recording's own thread; the session task only queues.
//!
//! After the criterion group a summary prints polls per second and the MCAP bytes per exchange.
#![allow(clippy::expect_used)] // bench code: a failed expectation is a failed run

use std::io::{Read, Write};
use std::net::{SocketAddr, TcpListener};
use std::time::Instant;

use criterion::{Criterion, Throughput};
use fs020n_client::{ClientConfig, RecordFormat, Recording, Robot};

fn echo_server() -> SocketAddr {
    let listener = TcpListener::bind("127.0.0.1:0").expect("bind");
    let addr = listener.local_addr().expect("addr");
    std::thread::spawn(move || {
        let reply = b" 1040 0 -1 -1 0 -1 0     0.000     0.000     0.000   -90.000     0.000   -90.000     0.000 ";
        for stream in listener.incoming() {
            let Ok(mut s) = stream else { continue };
            std::thread::spawn(move || {
                let _ = s.set_nodelay(true);
                let mut buf = [0u8; 512];
                while let Ok(n) = s.read(&mut buf) {
                    if n == 0 || s.write_all(reply).is_err() {
                        break;
                    }
                }
            });
        }
    });
    addr
}

fn robot(rt: &tokio::runtime::Runtime, addr: SocketAddr, record: Option<Recording>) -> Robot {
    rt.block_on(Robot::connect(
        &addr.to_string(),
        ClientConfig {
            record,
            ..ClientConfig::default()
        },
    ))
    .expect("connect to the echo server")
}

fn main() {
    let mut c = Criterion::default().configure_from_args();
    let addr = echo_server();
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .expect("runtime");
    let dir = tempfile::tempdir().expect("tempdir");
    let cases = [
        ("off", None),
        (
            "csv",
            Some(Recording {
                path: dir.path().join("bench.csv"),
                format: RecordFormat::Csv,
            }),
        ),
        (
            "mcap",
            Some(Recording {
                path: dir.path().join("bench.mcap"),
                format: RecordFormat::Mcap,
            }),
        ),
    ];
    let mut group = c.benchmark_group("recording");
    group.throughput(Throughput::Elements(1));
    let mut rates = Vec::new();
    for (name, record) in cases {
        let r = robot(&rt, addr, record.clone());
        group.bench_function(name, |b| b.iter(|| rt.block_on(r.poll()).expect("poll")));
        let n = 20_000;
        let t = Instant::now();
        for _ in 0..n {
            rt.block_on(r.poll()).expect("poll");
        }
        let rate = f64::from(n) / t.elapsed().as_secs_f64();
        let stats = r.stats();
        rt.block_on(r.close()).expect("close");
        drop(r);
        rates.push((name, rate, stats.requests, stats.record_errors, record));
    }
    group.finish();
    println!("\nsummary (lock-step polls per second, echo server on loopback):");
    for (name, rate, requests, lost, record) in rates {
        let size = record
            .and_then(|r| std::fs::metadata(r.path).ok())
            .map(|m| {
                format!(
                    ", file {:.0} bytes per exchange",
                    m.len() as f64 / requests as f64
                )
            })
            .unwrap_or_default();
        println!("  {name:<5} {rate:>8.0}/s{size}, lines lost {lost}");
    }
}
