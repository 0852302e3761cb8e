//! The streaming workload shared by the `emulator` bench and the `stream_speed` example: one
//! robot streaming command 7 at 100 Hz on the `Controller` directly (virtual time).

use std::hint::black_box;
use std::time::Duration;

use fs020n_proto::{Command, JointsDeg, Request, StreamSample};
use fs020n_sim::{Controller, ControllerConfig, SessionId};

/// A controller with a session, the program running, fed command 7 at 100 Hz.
pub(crate) struct Streamer {
    /// The controller.
    pub(crate) c: Controller,
    id: SessionId,
    t: f64,
    /// Encode requests with the client library's exact encoder (float formatting) instead of
    /// the bench's integer-based one; the emulator's own cost is the same either way.
    client_encoder: bool,
    request: Vec<u8>,
}

/// The same bytes as the client encoder (3 decimals, trailing zeros trimmed), written digit by
/// digit so that the benchmark measures the emulator, not the client's float formatting.
fn fast_encode(s: &StreamSample, out: &mut Vec<u8>) {
    out.clear();
    out.extend_from_slice(b"1040 7 21");
    let mut num = |v: f64| {
        let m = (v * 1000.0).round() as i64;
        // Built right to left in a buffer: " -123.456" at most 1 + 1 + 20 + 4 bytes.
        let mut buf = [0u8; 32];
        let mut i = buf.len();
        let m_abs = m.unsigned_abs();
        let (mut int, frac) = (m_abs / 1000, m_abs % 1000);
        if frac != 0 {
            // The fraction's digits without trailing zeros.
            let (mut f, mut width) = (frac, 3);
            while f % 10 == 0 {
                f /= 10;
                width -= 1;
            }
            for _ in 0..width {
                i -= 1;
                buf[i] = b'0' + (f % 10) as u8;
                f /= 10;
            }
            i -= 1;
            buf[i] = b'.';
        }
        loop {
            i -= 1;
            buf[i] = b'0' + (int % 10) as u8;
            int /= 10;
            if int == 0 {
                break;
            }
        }
        if m < 0 {
            i -= 1;
            buf[i] = b'-';
        }
        i -= 1;
        buf[i] = b' ';
        out.extend_from_slice(&buf[i..]);
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
}

/// The sample of the smooth six-joint trajectory at trajectory time `t`, stamped `t0_s`.
pub(crate) fn sample(t: f64, t0_s: f64) -> StreamSample {
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
    StreamSample {
        t0_s,
        lookahead_passes: 1.0,
        position: JointsDeg::new(p),
        velocity: JointsDeg::new(v),
        acceleration: JointsDeg::new(a),
    }
}

impl Streamer {
    /// A streamer at `monitor_percent`.
    pub(crate) fn new(monitor_percent: f64, client_encoder: bool) -> Streamer {
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
            request: Vec::with_capacity(256),
        }
    }

    /// One simulated second: 100 command-7 samples of a smooth multi-joint trajectory.
    pub(crate) fn second(&mut self) {
        for _ in 0..100 {
            let s = sample(self.t, self.c.timer1_s());
            if self.client_encoder {
                self.request = Request::new(Command::StreamedMove(s))
                    .encode()
                    .unwrap()
                    .into_bytes();
            } else {
                fast_encode(&s, &mut self.request);
            }
            black_box(self.c.handle_request(self.id, &self.request).unwrap());
            self.c.advance_by(Duration::from_millis(10));
            self.t += 0.01;
        }
        assert!(self.c.error().is_none(), "{}", self.c.error());
    }
}
