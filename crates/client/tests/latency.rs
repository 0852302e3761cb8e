//! The client through a link with latency (a delaying proxy in front of the in-memory
//! emulator, on virtual time): the server-clock estimate corrects for half the round trip, and
//! streams still track.

mod common;

use std::time::Duration;

use common::*;
use fs020n_client::{
    BoxedStream, ClientConfig, ConnectFuture, Connector, Robot, StreamOptions, StreamOutcome,
    Trajectory, TrajectoryPoint,
};
use fs020n_sim::Emulator;
use tokio::io::{AsyncRead, AsyncReadExt, AsyncWrite, AsyncWriteExt};

/// Every chunk is delivered `one_way` after it was read, in each direction.
struct Delayed {
    emu: Emulator,
    one_way: Duration,
}

async fn pump<R, W>(mut r: R, mut w: W, d: Duration)
where
    R: AsyncRead + Unpin,
    W: AsyncWrite + Unpin,
{
    let mut buf = [0u8; 1024];
    loop {
        match r.read(&mut buf).await {
            Ok(0) | Err(_) => {
                let _ = w.shutdown().await;
                return;
            }
            Ok(n) => {
                tokio::time::sleep(d).await;
                if w.write_all(&buf[..n]).await.is_err() {
                    return;
                }
            }
        }
    }
}

impl Connector for Delayed {
    fn connect(&self) -> ConnectFuture<'_> {
        Box::pin(async move {
            let server = self.emu.connect()?;
            let (client, proxy) = tokio::io::duplex(4096);
            let (pr, pw) = tokio::io::split(proxy);
            let (sr, sw) = tokio::io::split(server);
            tokio::spawn(pump(pr, sw, self.one_way));
            tokio::spawn(pump(sr, pw, self.one_way));
            Ok(Box::new(client) as BoxedStream)
        })
    }

    fn describe(&self) -> String {
        "delayed emulator".into()
    }
}

async fn connect_delayed(emu: &Emulator, one_way_ms: u64) -> Robot {
    Robot::connect_with(
        Delayed {
            emu: emu.clone(),
            one_way: Duration::from_millis(one_way_ms),
        },
        ClientConfig::default(),
    )
    .await
    .unwrap()
}

#[tokio::test(start_paused = true)]
async fn the_server_clock_estimate_corrects_for_half_the_round_trip() {
    let emu = emulator();
    let robot = connect_delayed(&emu, 4).await;
    sleep_ms(3000).await;
    let st = robot.stats();
    assert!(st.rtt.min >= Duration::from_millis(8), "{st:?}");
    let estimate = robot.server_time_now().unwrap();
    let actual = emu.with(|c| c.native().timer1_s());
    // Without the RTT/2 correction the estimate would lag by 4 ms.
    assert!(
        (estimate - actual).abs() <= 0.0015,
        "estimate {estimate} vs TIMER(1) {actual}"
    );
    let fit = robot.server_clock().unwrap();
    assert!((fit.rate - 1.0).abs() < 1e-3, "{fit:?}");
    assert!(fit.pairs >= 20, "{fit:?}");
}

#[tokio::test(start_paused = true)]
async fn a_stream_over_a_slow_link_still_tracks() {
    let emu = emulator();
    let robot = connect_delayed(&emu, 5).await;
    robot.set_speed(100.0).await.unwrap();
    robot.start().await.unwrap();
    let n = 40;
    let points = (0..=n)
        .map(|k| {
            let t = k as f64 * 0.05;
            let s = 0.5 - 0.5 * (std::f64::consts::PI * t / 2.0).cos();
            TrajectoryPoint::new(t, with_jt1(-20.0 * s))
        })
        .collect();
    let report = robot
        .stream(Trajectory::new(points).unwrap(), StreamOptions::default())
        .await
        .unwrap()
        .wait()
        .await
        .unwrap();
    assert_eq!(report.outcome, StreamOutcome::Completed);
    assert!(report.rtt_mean >= Duration::from_millis(10), "{report:?}");
    assert_eq!(report.late_replies, 0, "{report:?}");
    assert_eq!(report.underruns, 0, "{report:?}");
    assert!(report.tracking_error_max_deg < 1.5, "{report:?}");
    assert!(report.settled, "{report:?}");
    assert!((emu.with(|c| c.joints())[0] + 20.0).abs() < 0.5);
}
