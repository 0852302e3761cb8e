//! What the hub costs a client: one request's round trip through the hub's protocol face
//! against the same request sent to the controller directly (an in-memory emulator on the
//! runtime's real clock), and a watcher's poll answered from the latest status.
//!
//! `cargo bench -p fs020n-web --bench hub`; figures in docs/HUB.md ("What the hub costs").
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion};
use fs020n_client::{BoxedStream, ConnectFuture, Connector};
use fs020n_proto::ReplyDecoder;
use fs020n_sim::{ControllerConfig, Emulator};
use fs020n_web::{Hub, HubConfig};
use tokio::io::{AsyncReadExt, AsyncWriteExt, DuplexStream};
use tokio::runtime::Runtime;

struct EmuConnector(Emulator);

impl Connector for EmuConnector {
    fn connect(&self) -> ConnectFuture<'_> {
        let emu = self.0.clone();
        Box::pin(async move { Ok(Box::new(emu.connect()?) as BoxedStream) })
    }

    fn describe(&self) -> String {
        "in-memory emulator".into()
    }
}

/// One lock-step round trip on a raw stream.
async fn round_trip(stream: &mut DuplexStream, decoder: &mut ReplyDecoder, text: &[u8]) {
    stream.write_all(text).await.expect("write");
    let mut buf = [0u8; 256];
    loop {
        if decoder.next_reply().expect("decodable").is_some() {
            return;
        }
        let n = stream.read(&mut buf).await.expect("read");
        assert!(n > 0, "closed");
        decoder.push(&buf[..n]).expect("reply");
    }
}

fn bench(c: &mut Criterion) {
    let rt = Runtime::new().expect("runtime");
    let mut group = c.benchmark_group("hub");
    group.measurement_time(Duration::from_secs(5));

    // Direct: a raw client of the emulator. Command 4 acts (it becomes the newest command)
    // without moving anything.
    let (mut direct, mut d_dec) = rt.block_on(async {
        let emu = Emulator::new(ControllerConfig::default());
        (emu.connect().expect("connect"), ReplyDecoder::new())
    });
    group.bench_function("direct: 1040 4 0 to the emulator", |b| {
        b.iter(|| rt.block_on(round_trip(&mut direct, &mut d_dec, b"1040 4 0")))
    });

    // Through the hub: the controlling client's request is checked and forwarded in lock-step.
    let hub = rt.block_on(async {
        let emu = Emulator::new(ControllerConfig::default());
        Hub::connect_with(EmuConnector(emu), HubConfig::default())
            .await
            .expect("hub")
    });
    // A client of the face, connected just before its benchmark (a silent client is closed).
    let client = |name: &'static str| {
        let h = hub.clone();
        rt.block_on(async move {
            let (client, server) = tokio::io::duplex(4096);
            tokio::spawn(async move { h.serve_client(server, name.into()).await });
            (client, ReplyDecoder::new())
        })
    };
    let (mut ctl, mut c_dec) = client("ctl");
    group.bench_function("hub: 1040 4 0 forwarded for the controlling client", |b| {
        b.iter(|| rt.block_on(round_trip(&mut ctl, &mut c_dec, b"1040 4 0")))
    });
    let (mut watcher, mut w_dec) = client("watcher");
    group.bench_function("hub: 0 0 0 from a watcher, answered locally", |b| {
        b.iter(|| rt.block_on(round_trip(&mut watcher, &mut w_dec, b"0 0 0")))
    });
    group.finish();
    drop(hub);
}

criterion_group!(benches, bench);
criterion_main!(benches);
