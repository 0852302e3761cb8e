//! Test helpers: the hub on an in-memory emulator, and raw protocol-1040 clients of its face.
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test
#![allow(dead_code)]

use std::time::Duration;

use fs020n_client::{BoxedStream, ConnectFuture, Connector};
use fs020n_proto::{JointsDeg, ReplyDecoder, ReplyFrame};
use fs020n_sim::{ControllerConfig, Emulator};
use fs020n_web::{Hub, HubConfig};
use tokio::io::{AsyncReadExt, AsyncWriteExt, DuplexStream};

/// Connects to an in-memory emulator.
#[derive(Clone)]
pub(crate) struct EmuConnector(pub(crate) Emulator);

impl Connector for EmuConnector {
    fn connect(&self) -> ConnectFuture<'_> {
        let emu = self.0.clone();
        Box::pin(async move { Ok(Box::new(emu.connect()?) as BoxedStream) })
    }

    fn describe(&self) -> String {
        "in-memory emulator".into()
    }
}

pub(crate) fn emulator() -> Emulator {
    Emulator::new(ControllerConfig::default())
}

pub(crate) async fn hub(emu: &Emulator, config: HubConfig) -> Hub {
    Hub::connect_with(EmuConnector(emu.clone()), config)
        .await
        .expect("the hub connects to the emulator")
}

/// A raw client of the hub's face (what an existing protocol-1040 client does).
pub(crate) struct Raw {
    pub(crate) stream: DuplexStream,
    decoder: ReplyDecoder,
}

impl Raw {
    pub(crate) fn connect(hub: &Hub, name: &str) -> Raw {
        let (client, server) = tokio::io::duplex(4096);
        let hub = hub.clone();
        let name = name.to_owned();
        tokio::spawn(async move { hub.serve_client(server, name).await });
        Raw {
            stream: client,
            decoder: ReplyDecoder::new(),
        }
    }

    /// One request, one reply (lock-step).
    pub(crate) async fn request(&mut self, text: &str) -> ReplyFrame {
        self.try_request(text)
            .await
            .unwrap_or_else(|| panic!("no reply to {text:?}"))
    }

    /// `None` when the hub closed the connection instead of replying.
    pub(crate) async fn try_request(&mut self, text: &str) -> Option<ReplyFrame> {
        self.stream.write_all(text.as_bytes()).await.ok()?;
        let mut buf = [0u8; 512];
        loop {
            if let Some(f) = self.decoder.next_reply().expect("a decodable reply") {
                return Some(f);
            }
            let n = tokio::time::timeout(Duration::from_secs(3), self.stream.read(&mut buf))
                .await
                .expect("a reply within 3 s")
                .ok()?;
            if n == 0 {
                return None;
            }
            self.decoder.push(&buf[..n]).expect("reply bytes");
        }
    }

    /// `true` once the hub has closed this connection.
    pub(crate) async fn closed(&mut self) -> bool {
        let mut buf = [0u8; 64];
        matches!(
            tokio::time::timeout(Duration::from_secs(10), self.stream.read(&mut buf)).await,
            Ok(Ok(0)) | Ok(Err(_))
        )
    }
}

pub(crate) fn home() -> JointsDeg {
    JointsDeg::new([0.0, 0.0, -90.0, 0.0, -90.0, 0.0])
}

pub(crate) fn joint_move(j: [f64; 6]) -> String {
    format!(
        "1040 6 9 0 0 0 {} {} {} {} {} {}",
        j[0], j[1], j[2], j[3], j[4], j[5]
    )
}

pub(crate) async fn sleep_ms(ms: u64) {
    tokio::time::sleep(Duration::from_millis(ms)).await;
}

pub(crate) fn speed_norm(v: &JointsDeg) -> f64 {
    v.iter().map(f64::abs).fold(0.0, f64::max)
}
