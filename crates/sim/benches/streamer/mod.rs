//! The streaming workload shared by the `emulator` bench and the `stream_speed` example: one
//! robot streaming command 7 at 100 Hz on the `Controller` directly (virtual time).
//!
//! Two ways to run it: [`Streamer`] builds each request when it is due (the client's work and
//! the emulator's), and [`Replay`] feeds a fresh controller the requests a `Streamer` built
//! before (recorded with [`record`], untimed), so that only the emulator's work is timed. The
//! controller runs on virtual time and is deterministic: the replayed controller sees the same
//! bytes at the same virtual times and computes the same motion.

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
        // `(v * 1000.0).round() as i64` without the library call that `round` compiles to
        // on baseline x86-64: `x − trunc(x)` is exact below 2^52 (these numbers are far
        // below), so halves round away from zero as `round` does.
        let x = v * 1000.0;
        let t = x as i64;
        let frac = x - t as f64;
        let m = if frac >= 0.5 {
            t + 1
        } else if frac <= -0.5 {
            t - 1
        } else {
            t
        };
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

/// `true` when two joint vectors are the same bits.
#[allow(dead_code)] // used by the examples, not the bench
pub(crate) fn same_bits(a: &JointsDeg, b: &JointsDeg) -> bool {
    a.0.iter()
        .zip(b.0.iter())
        .all(|(x, y)| x.to_bits() == y.to_bits())
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

/// A controller at the streaming start position with a session, the program started and the
/// monitor speed set.
fn started_controller(monitor_percent: f64) -> (Controller, SessionId) {
    let mut c = Controller::new(ControllerConfig {
        joints: JointsDeg::new([0.0, 10.0, -80.0, 0.0, -80.0, 0.0]),
        ..ControllerConfig::default()
    });
    let id = c.try_accept().unwrap();
    c.handle_request(id, b"1040 1 0").unwrap();
    c.handle_request(id, format!("1040 3 1 {monitor_percent}").as_bytes())
        .unwrap();
    (c, id)
}

impl Streamer {
    /// A streamer at `monitor_percent`.
    pub(crate) fn new(monitor_percent: f64, client_encoder: bool) -> Streamer {
        let (c, id) = started_controller(monitor_percent);
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
        self.second_with(|_| {});
    }

    /// [`second`](Self::second), handing every request to `keep` after it was sent.
    fn second_with(&mut self, mut keep: impl FnMut(&[u8])) {
        for _ in 0..100 {
            let s = sample(self.t, self.c.native().timer1_s());
            if self.client_encoder {
                self.request = Request::new(Command::StreamedMove(s))
                    .encode()
                    .unwrap()
                    .into_bytes();
            } else {
                fast_encode(&s, &mut self.request);
            }
            black_box(self.c.handle_request(self.id, &self.request).unwrap());
            keep(&self.request);
            self.c.advance_by(Duration::from_millis(10));
            self.t += 0.01;
        }
        assert!(self.c.error().is_none(), "{}", self.c.error());
    }
}

/// The requests of `seconds` simulated seconds of a [`Streamer`] at `monitor_percent` (the
/// bench's own encoder), in order: 100 per second.
pub(crate) fn record(monitor_percent: f64, seconds: u32) -> Vec<Vec<u8>> {
    let mut s = Streamer::new(monitor_percent, false);
    let mut requests = Vec::with_capacity(seconds as usize * 100);
    for _ in 0..seconds {
        s.second_with(|r| requests.push(r.to_vec()));
    }
    requests
}

/// A fresh controller fed recorded requests (see [`record`]) on the streamer's schedule: only
/// the emulator's work (`handle_request` and `advance_by`).
pub(crate) struct Replay {
    /// The controller.
    pub(crate) c: Controller,
    id: SessionId,
}

impl Replay {
    /// A replay at `monitor_percent` (the one the requests were recorded at).
    pub(crate) fn new(monitor_percent: f64) -> Replay {
        let (c, id) = started_controller(monitor_percent);
        Replay { c, id }
    }

    /// Sends `requests` one per 10 ms of virtual time.
    pub(crate) fn run(&mut self, requests: &[Vec<u8>]) {
        for r in requests {
            black_box(self.c.handle_request(self.id, r).unwrap());
            self.c.advance_by(Duration::from_millis(10));
        }
        assert!(self.c.error().is_none(), "{}", self.c.error());
    }
}
