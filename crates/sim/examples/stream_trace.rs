//! A trace of the emulator's behaviour under a long command-7 stream, to check that a change
//! meant to be a pure optimization computes the same motion: every reply's bytes, and at every
//! 2 ms tick the controller time, the pass and motion counters, the motions in progress, the
//! phase and the joints (as exact bit patterns and as decimals).
//!
//! ```text
//! cargo run --release -p fs020n-sim --example stream_trace -- [SECONDS] > trace.txt
//! ```
//!
//! The stream is the `stream_speed` trajectory at monitor 100 %, interrupted by the other
//! commands and panel operations that change the motion: command 6 (a joint move), 5 (cancel:
//! BRAKE with a motion planned by look-ahead), 2 and 1 (stop and restart the program), 3 (the
//! monitor speed down to 10 % and back), HOLD and RUN. Two builds compute the same motion when
//! their traces are the same except for the last bits of the joints (compare the reply lines
//! and the tick lines' counters exactly, the joints within a tolerance).

use std::fmt::Write as _;
use std::io::Write as _;
use std::time::Duration;

use fs020n_proto::{Command, JointsDeg, Request};
use fs020n_sim::{Controller, ControllerConfig};

// The trajectory of the `stream_speed` example and the `emulator` bench (the rest of that
// module is not used here).
#[path = "../benches/streamer/mod.rs"]
#[allow(dead_code)]
mod streamer;
use streamer::sample;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let seconds: u32 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(60);
    let mut c = Controller::new(ControllerConfig {
        joints: JointsDeg::new([0.0, 10.0, -80.0, 0.0, -80.0, 0.0]),
        ..ControllerConfig::default()
    });
    let id = c.try_accept()?;
    let mut out = String::new();
    let send = |c: &mut Controller, out: &mut String, bytes: &[u8]| {
        let h = c.handle_request(id, bytes)?;
        let _ = writeln!(
            out,
            "reply {:.6} {}",
            c.now().as_secs_f64(),
            String::from_utf8_lossy(&h.reply).replace('\n', "|")
        );
        Ok::<(), fs020n_sim::SessionGone>(())
    };
    send(&mut c, &mut out, b"1040 1 0")?;
    send(&mut c, &mut out, b"1040 3 1 100")?;
    let mut t = 0.0;
    let steps = seconds * 100;
    for k in 0..steps {
        // Every 10 simulated seconds, a different interruption.
        let phase = k % 1000;
        let round = (k / 1000) % 5;
        let request = match (round, phase) {
            (1, 300) => Some("1040 5 0".to_owned()),
            (2, 300) => Some("1040 2 0".to_owned()),
            (2, 400) => Some("1040 1 0".to_owned()),
            (3, 200) => Some("1040 3 1 10".to_owned()),
            (3, 600) => Some("1040 3 1 100".to_owned()),
            (4, 300) => Some("1040 6 9 0 0 0 5 12 -75 10 -70 20".to_owned()),
            _ => None,
        };
        if round == 1 && phase == 500 {
            c.set_run(false);
        }
        if round == 1 && phase == 700 {
            c.set_run(true);
        }
        let request = match request {
            Some(r) => r,
            None => {
                Request::new(Command::StreamedMove(sample(t, c.native().timer1_s()))).encode()?
            }
        };
        send(&mut c, &mut out, request.as_bytes())?;
        for _ in 0..5 {
            c.advance_by(Duration::from_millis(2));
            let n = c.counters();
            let q = c.joints();
            let bits: Vec<String> = q.iter().map(|v| format!("{:016x}", v.to_bits())).collect();
            let dec: Vec<String> = q.iter().map(|v| format!("{v:.12}")).collect();
            let _ = writeln!(
                out,
                "tick {:.6} passes {} motions {} active {} planned {} {:?} err {} joints {} bits {}",
                c.now().as_secs_f64(),
                n.passes,
                n.motions,
                c.arm().active_count(),
                c.arm().has_planned(),
                c.motion_phase(),
                c.error(),
                dec.join(" "),
                bits.join(" ")
            );
        }
        t += 0.01;
    }
    std::io::stdout().write_all(out.as_bytes())?;
    Ok(())
}
