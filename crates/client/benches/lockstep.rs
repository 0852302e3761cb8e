//! Lock-step requests per second over loopback TCP.
//!
//! * `raw/echo` — the physical limit: a blocking socket writing the 5-byte poll `0 0 0` and
//!   reading a fixed 94-byte reply from a minimal echo server (one thread per connection).
//! * `client/echo` — the async client (`Robot::poll`, current-thread runtime) against the same
//!   echo server: the client's own overhead.
//! * `client/emulator` — the async client against the emulator's TCP server.
//! * `raw/emulator` — the raw socket against the emulator: the emulator's share.
//! * `blocking/echo` — the blocking client (one-worker runtime: a thread hop per request).
//!
//! After the criterion groups a summary prints requests per second and the ratios.
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

use std::io::{Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::time::{Duration, Instant};

use criterion::{Criterion, Throughput};
use fs020n_client::{blocking, ClientConfig, Robot};
use fs020n_sim::{ControllerConfig, Emulator};

const POLL: &[u8] = b"0 0 0";
const REPLY_LEN: usize = 94;

/// A valid reply padded with leading blanks to exactly 94 bytes.
fn reply() -> Vec<u8> {
    let body = " 1040 0 -1 -1 0 -1 0     0.000     0.000     0.000   -90.000     0.000   -90.000     0.000 ";
    let mut r = " ".repeat(REPLY_LEN - body.len());
    r.push_str(body);
    assert_eq!(r.len(), REPLY_LEN);
    r.into_bytes()
}

fn echo_server() -> SocketAddr {
    let listener = TcpListener::bind("127.0.0.1:0").expect("bind");
    let addr = listener.local_addr().expect("addr");
    std::thread::spawn(move || {
        let reply = reply();
        for stream in listener.incoming() {
            let Ok(mut s) = stream else { continue };
            let reply = reply.clone();
            std::thread::spawn(move || {
                let _ = s.set_nodelay(true);
                let mut buf = [0u8; 512];
                while let Ok(n) = s.read(&mut buf) {
                    if n == 0 || s.write_all(&reply).is_err() {
                        break;
                    }
                }
            });
        }
    });
    addr
}

struct RawClient {
    s: TcpStream,
    buf: [u8; 512],
}

impl RawClient {
    fn connect(addr: SocketAddr) -> RawClient {
        let deadline = Instant::now() + Duration::from_secs(10);
        loop {
            if let Ok(s) = TcpStream::connect(addr) {
                s.set_nodelay(true).expect("nodelay");
                let mut c = RawClient { s, buf: [0; 512] };
                if c.try_round_trip().is_ok() {
                    return c;
                }
            }
            assert!(Instant::now() < deadline, "cannot connect to {addr}");
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    fn try_round_trip(&mut self) -> std::io::Result<()> {
        self.s.write_all(POLL)?;
        // A reply ends with its 14th field; count the bytes of one reply of this peer: the
        // echo's is 94, the emulator's 91 or 92. Read until the final blank after 14 fields.
        let mut got = 0;
        let mut fields = 0;
        let mut in_field = false;
        loop {
            let n = self.s.read(&mut self.buf[got..])?;
            if n == 0 {
                return Err(std::io::ErrorKind::UnexpectedEof.into());
            }
            for &b in &self.buf[got..got + n] {
                if b == b' ' {
                    if in_field {
                        fields += 1;
                    }
                    in_field = false;
                } else {
                    in_field = true;
                }
            }
            got += n;
            if fields >= 14 {
                return Ok(());
            }
        }
    }

    fn round_trip(&mut self) {
        self.try_round_trip().expect("round trip");
    }
}

fn emulator_server() -> (Emulator, SocketAddr) {
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let rt = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .expect("runtime");
        rt.block_on(async move {
            let emu = Emulator::new(ControllerConfig::default());
            let server = emu
                .serve_tcp("127.0.0.1:0".parse().expect("addr"))
                .await
                .expect("serve");
            tx.send((emu, server.local_addr())).expect("send");
            std::future::pending::<()>().await;
        });
    });
    rx.recv().expect("emulator up")
}

fn current_thread() -> tokio::runtime::Runtime {
    tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .expect("runtime")
}

/// Round trips per second of `f` run `n` times.
fn rate(n: u32, mut f: impl FnMut()) -> f64 {
    for _ in 0..n / 10 {
        f();
    }
    let t = Instant::now();
    for _ in 0..n {
        f();
    }
    f64::from(n) / t.elapsed().as_secs_f64()
}

fn main() {
    let echo = echo_server();
    let (_emu, emu_addr) = emulator_server();
    let mut c = Criterion::default()
        .measurement_time(Duration::from_secs(3))
        .warm_up_time(Duration::from_secs(1))
        .configure_from_args();
    let mut g = c.benchmark_group("lockstep");
    g.throughput(Throughput::Elements(1));

    let mut raw = RawClient::connect(echo);
    g.bench_function("raw/echo", |b| b.iter(|| raw.round_trip()));

    let rt = current_thread();
    let robot = rt
        .block_on(Robot::connect(&echo.to_string(), ClientConfig::default()))
        .expect("client to echo");
    g.bench_function("client/echo", |b| {
        b.iter_custom(|iters| {
            rt.block_on(async {
                let t = Instant::now();
                for _ in 0..iters {
                    robot.poll().await.expect("poll");
                }
                t.elapsed()
            })
        })
    });

    let emu_robot = rt
        .block_on(Robot::connect(
            &emu_addr.to_string(),
            ClientConfig::default(),
        ))
        .expect("client to emulator");
    g.bench_function("client/emulator", |b| {
        b.iter_custom(|iters| {
            rt.block_on(async {
                let t = Instant::now();
                for _ in 0..iters {
                    emu_robot.poll().await.expect("poll");
                }
                t.elapsed()
            })
        })
    });
    rt.block_on(emu_robot.close()).expect("close");

    let mut raw_emu = RawClient::connect(emu_addr);
    g.bench_function("raw/emulator", |b| b.iter(|| raw_emu.round_trip()));
    drop(raw_emu);

    let blocking_robot =
        blocking::Robot::connect(&echo.to_string(), ClientConfig::default()).expect("blocking");
    g.bench_function("blocking/echo", |b| {
        b.iter(|| blocking_robot.poll().expect("poll"))
    });
    g.finish();

    // Summary: the same measurements as plain rates, in alternating rounds (the median of
    // each is printed), so that a load change on the machine hits all of them alike.
    let n = if std::env::args().any(|a| a == "--test") {
        100
    } else {
        20_000
    };
    let rounds = if n == 100 { 1 } else { 5 };
    let async_rate = |r: &Robot| {
        rt.block_on(async {
            for _ in 0..n / 10 {
                r.poll().await.expect("poll");
            }
            let t = Instant::now();
            for _ in 0..n {
                r.poll().await.expect("poll");
            }
            f64::from(n) / t.elapsed().as_secs_f64()
        })
    };
    let mut raw_echo = Vec::new();
    let mut client_echo = Vec::new();
    let mut blocking_echo = Vec::new();
    let mut decode = Vec::new();
    let mut status_decode = Vec::new();
    let mut tokio_echo = Vec::new();
    let bytes = reply();
    let text = String::from_utf8(bytes.clone()).expect("ascii");
    let mut tokio_raw = rt.block_on(async {
        let s = tokio::net::TcpStream::connect(echo).await.expect("connect");
        s.set_nodelay(true).expect("nodelay");
        s
    });
    let tokio_rate = |s: &mut tokio::net::TcpStream| {
        use tokio::io::{AsyncReadExt, AsyncWriteExt};
        rt.block_on(async {
            let mut buf = [0u8; 512];
            let t = Instant::now();
            for _ in 0..n {
                s.write_all(POLL).await.expect("write");
                let mut got = 0;
                while got < REPLY_LEN {
                    got += s.read(&mut buf[got..]).await.expect("read");
                }
            }
            f64::from(n) / t.elapsed().as_secs_f64()
        })
    };
    for _ in 0..rounds {
        raw_echo.push(rate(n, || raw.round_trip()));
        client_echo.push(async_rate(&robot));
        blocking_echo.push(rate(n, || {
            blocking_robot.poll().expect("poll");
        }));
        decode.push(rate(n, || {
            let mut d = fs020n_proto::ReplyDecoder::new();
            d.push(&bytes).expect("push");
            criterion::black_box(d.next_reply().expect("decode"));
        }));
        status_decode.push(rate(n, || {
            criterion::black_box(fs020n_proto::Status::decode(&text).expect("decode"));
        }));
        tokio_echo.push(tokio_rate(&mut tokio_raw));
    }
    // The emulator: one session at a time, so the async client first, then the raw one.
    let emu_robot = rt
        .block_on(Robot::connect(
            &emu_addr.to_string(),
            ClientConfig::default(),
        ))
        .expect("client to emulator");
    let mut client_emu = Vec::new();
    let mut raw_emu_rates = Vec::new();
    for _ in 0..rounds {
        client_emu.push(async_rate(&emu_robot));
    }
    rt.block_on(emu_robot.close()).expect("close");
    let mut raw_emu = RawClient::connect(emu_addr);
    for _ in 0..rounds {
        raw_emu_rates.push(rate(n, || raw_emu.round_trip()));
    }
    let med = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let (te, sd) = (med(&mut tokio_echo), med(&mut status_decode));
    let (re, ce, be, cm, rm, de) = (
        med(&mut raw_echo),
        med(&mut client_echo),
        med(&mut blocking_echo),
        med(&mut client_emu),
        med(&mut raw_emu_rates),
        med(&mut decode),
    );
    println!("\nsummary (round trips per second, median of {rounds} rounds of {n}):");
    println!("  raw/echo         {re:10.0}   (physical limit)");
    println!(
        "  raw-tokio/echo   {te:10.0}   ratio to raw/echo {:.3} (minimal tokio loop)",
        te / re
    );
    println!(
        "  client/echo      {ce:10.0}   ratio to raw/echo {:.3}, to raw-tokio/echo {:.3}",
        ce / re,
        ce / te
    );
    println!(
        "  blocking/echo    {be:10.0}   ratio to raw/echo {:.3}",
        be / re
    );
    println!(
        "  raw/emulator     {rm:10.0}   ratio to raw/echo {:.3}",
        rm / re
    );
    println!(
        "  client/emulator  {cm:10.0}   ratio to raw/emulator {:.3}",
        cm / rm
    );
    println!(
        "  decoding one 94-byte reply: ReplyDecoder {:.2} us, Status::decode {:.2} us",
        1e6 / de,
        1e6 / sd
    );
}
