//! The differential test: every behaviour of spec §2–§4 as a scenario of timed requests and
//! panel operations, run against the native emulator and against the AS server text
//! (`crates/as/programs/server1040.as`) interpreted on the same controller, comparing every
//! reply.
//!
//! Two interpreter configurations:
//!
//! * **matched timing** — a cost model that takes the native server's own timing assumptions
//!   (the communication task answers within microseconds, the motion program's loop overhead
//!   is the native 4 ms). Requests are sent half a millisecond into a TIMER millisecond, so
//!   the processing time never crosses a TIMER tick. Then fields 1–8 must match **byte for
//!   byte** in every reply, and the joints (fields 9–14) byte for byte whenever the arm stands
//!   still; while it moves they may differ slightly because the interpreted program issues its
//!   motions at its own instants between the 2 ms motion ticks (the native passes run on
//!   them) and computes command 7's point in 32-bit reals (the native in 64-bit).
//! * **default costs** — the interpreter's documented cost model (20 µs per step, a terminal
//!   line ≈ 0.5 ms + 20 µs per byte): the server answers 1–3 ms later than the native one, so
//!   TIMER(1) may be later by that much and the joints differ by the motion in that time.
//!   Fields 1–7 must still match; where a HOLD or brake stops the arm differs by the motion
//!   in those milliseconds. Command 7 streams are compared by how well each run tracks the
//!   trajectory (which sample a pass reads depends on the pass phase).
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

use std::time::Duration;

use fs020n_as::{Config, CostModel};
use fs020n_proto::Status;
use fs020n_sim::{ClientId, Controller, ControllerConfig, ServerProgram, SessionId};

/// One side of the comparison.
trait Server {
    fn controller(&mut self) -> &mut Controller;
    fn connect(&mut self) -> bool;
    /// Sends a request now; the reply and when it was sent.
    fn request(&mut self, bytes: &[u8]) -> Option<(String, Duration)>;
    fn close(&mut self);
}

struct Native {
    c: Controller,
    id: Option<SessionId>,
}

impl Server for Native {
    fn controller(&mut self) -> &mut Controller {
        &mut self.c
    }

    fn connect(&mut self) -> bool {
        self.id = self.c.try_accept().ok();
        self.id.is_some()
    }

    fn request(&mut self, bytes: &[u8]) -> Option<(String, Duration)> {
        let id = self.id?;
        let h = self.c.handle_request(id, bytes).ok()?;
        self.c.reply_sent(id);
        if h.close {
            self.id = None;
        }
        Some((String::from_utf8(h.reply).ok()?, self.c.now()))
    }

    fn close(&mut self) {
        if let Some(id) = self.id.take() {
            self.c
                .end_session_of(id, fs020n_sim::SessionEnd::Disconnected);
        }
    }
}

struct Program {
    c: Controller,
    id: Option<ClientId>,
}

impl Server for Program {
    fn controller(&mut self) -> &mut Controller {
        &mut self.c
    }

    fn connect(&mut self) -> bool {
        self.id = self.c.program_mut().connect(None, [127, 0, 0, 1]).ok();
        // The program's TCP_ACCEPT takes it at once.
        let now = self.c.now();
        self.c.advance_to(now);
        self.id.is_some()
    }

    fn request(&mut self, bytes: &[u8]) -> Option<(String, Duration)> {
        let id = self.id?;
        if !self.c.program_mut().send(id, bytes) {
            return None;
        }
        let step = Duration::from_micros(25);
        let now = self.c.now();
        self.c.advance_to(now);
        for _ in 0..2000 {
            let r = self.c.program_mut().recv(id);
            if !r.bytes.is_empty() {
                return Some((String::from_utf8(r.bytes).ok()?, self.c.now()));
            }
            if r.closed {
                return None;
            }
            self.c.advance_by(step);
        }
        None
    }

    fn close(&mut self) {
        if let Some(id) = self.id.take() {
            self.c.program_mut().close(id);
        }
    }
}

/// A reply as recorded.
#[derive(Debug, Clone)]
struct Reply {
    label: String,
    text: String,
    at: Duration,
}

struct Driver {
    s: Box<dyn Server>,
    replies: Vec<Reply>,
}

impl Driver {
    /// Advances to `secs` plus half a millisecond (mid-millisecond of TIMER(1): a few
    /// microseconds of processing never cross a TIMER tick).
    fn at(&mut self, secs: f64) {
        let t = Duration::from_secs_f64(secs) + Duration::from_micros(500);
        self.s.controller().advance_to(t);
    }

    fn req(&mut self, text: &str) {
        let got = self.s.request(text.as_bytes());
        let (text_out, at) =
            got.unwrap_or_else(|| ("<no reply>".into(), self.s.controller().now()));
        self.replies.push(Reply {
            label: text.to_owned(),
            text: text_out,
            at,
        });
    }

    fn poll(&mut self) {
        self.req("0 0 0");
    }

    fn panel(&mut self, f: impl FnOnce(&mut Controller)) {
        f(self.s.controller());
    }
}

fn matched_costs() -> Config {
    Config {
        cost: CostModel {
            statement: Duration::from_micros(1),
            // The loop overhead from `.last_tm = TIMER(2)` to the next `.tm = TIMER(2)`: the
            // assignment, the `IF ros_print` test, the PRINT, the END and the WHILE test =
            // the native 4 ms pass.
            print: Duration::from_micros(4000 - 4),
            print_per_byte: Duration::ZERO,
        },
        ..Config::default()
    }
}

fn native() -> Box<dyn Server> {
    Box::new(Native {
        c: Controller::new(config()),
        id: None,
    })
}

fn program(cfg: Config) -> Box<dyn Server> {
    // The per-pass PRINT on (the server ships with it off): its cost stands for the native
    // pass's loop overhead (see `matched_costs`).
    let source = fs020n_as::SERVER_1040.replace("ros_print = 0", "ros_print = 1");
    let p = ServerProgram::from_source_with("server1040.as", &source, cfg).unwrap();
    Box::new(Program {
        c: Controller::with_program(config(), p),
        id: None,
    })
}

fn config() -> ControllerConfig {
    ControllerConfig::default()
}

/// Fields of a reply: the seven status fields as text, TIMER(1) and the joints as numbers.
fn fields(r: &str) -> Option<(Vec<String>, Status)> {
    let st = Status::decode(r).ok()?;
    let head: Vec<String> = r.split_whitespace().take(7).map(str::to_owned).collect();
    Some((head, st))
}

/// How two runs of a scenario compare.
#[derive(Debug, Default)]
struct Diff {
    replies: usize,
    identical: usize,
    status_mismatches: Vec<String>,
    timer_max_ms: f64,
    /// TIMER(1) differences beyond the program's own lag (its reply later than the native
    /// one, rounded up to the TIMER millisecond), ms.
    timer_beyond_lag_ms: f64,
    /// The program's longest lag behind the native reply, ms.
    lag_max_ms: f64,
    joints_max_deg: f64,
    joints_still_max_deg: f64,
}

fn compare(name: &str, a: &[Reply], b: &[Reply], still: &[bool]) -> Diff {
    assert_eq!(a.len(), b.len(), "{name}: both runs send the same requests");
    let mut d = Diff {
        replies: a.len(),
        ..Diff::default()
    };
    for (k, (x, y)) in a.iter().zip(b).enumerate() {
        if x.text == y.text {
            d.identical += 1;
            continue;
        }
        let (Some((hx, sx)), Some((hy, sy))) = (fields(&x.text), fields(&y.text)) else {
            d.status_mismatches
                .push(format!("#{k} {:?}: {:?} vs {:?}", x.label, x.text, y.text));
            continue;
        };
        if hx != hy {
            d.status_mismatches.push(format!(
                "#{k} {:?} at {:.4}/{:.4} s: {} vs {}",
                x.label,
                x.at.as_secs_f64(),
                y.at.as_secs_f64(),
                hx.join(" "),
                hy.join(" ")
            ));
        }
        let tx = sx.timer.seconds().unwrap_or(f64::NAN);
        let ty = sy.timer.seconds().unwrap_or(f64::NAN);
        let dt_ms = (tx - ty).abs() * 1000.0;
        d.timer_max_ms = d.timer_max_ms.max(dt_ms);
        let lag_ms = y.at.saturating_sub(x.at).as_secs_f64() * 1000.0;
        d.lag_max_ms = d.lag_max_ms.max(lag_ms);
        d.timer_beyond_lag_ms = d.timer_beyond_lag_ms.max(dt_ms - (lag_ms.ceil() + 1.0));
        let dj = sx.joints.max_abs_diff(&sy.joints);
        d.joints_max_deg = d.joints_max_deg.max(dj);
        if still.get(k).copied().unwrap_or(false) {
            d.joints_still_max_deg = d.joints_still_max_deg.max(dj);
        }
    }
    eprintln!(
        "{name}: {} replies, {} byte-identical, status mismatches {}, TIMER(1) max diff {:.0} ms (program lag up to {:.2} ms), joints max diff {:.4}° ({:.4}° at rest)",
        d.replies,
        d.identical,
        d.status_mismatches.len(),
        d.timer_max_ms,
        d.lag_max_ms,
        d.joints_max_deg,
        d.joints_still_max_deg
    );
    d
}

type Scenario = fn(&mut Driver);

/// Runs `scenario` on both servers; `still[k]` says the arm stands still at reply k in the
/// native run (from its own snapshot).
fn run_both(name: &str, scenario: Scenario, cfg: Config) -> Diff {
    let mut n = Driver {
        s: native(),
        replies: Vec::new(),
    };
    scenario(&mut n);
    let mut p = Driver {
        s: program(cfg),
        replies: Vec::new(),
    };
    scenario(&mut p);
    // "Still" = the joints of consecutive replies agree in the native run and the next one
    // too (no motion around the reply).
    let joints: Vec<_> = n
        .replies
        .iter()
        .map(|r| Status::decode(&r.text).map(|s| s.joints).ok())
        .collect();
    let still: Vec<bool> = (0..joints.len())
        .map(|k| {
            let same = |a: usize, b: usize| match (joints.get(a), joints.get(b)) {
                (Some(Some(x)), Some(Some(y))) => x.max_abs_diff(y) == 0.0,
                _ => true,
            };
            k > 0 && same(k - 1, k) && same(k, k + 1)
        })
        .collect();
    compare(name, &n.replies, &p.replies, &still)
}

// ------------------------------------------------------------------------------- scenarios

/// §2, §3: polls, version mismatch, leading blank, runs of blanks, numbers as reals, COUNT
/// trusted, the 255-byte cut, unknown commands, the reply format.
fn requests_and_reply(d: &mut Driver) {
    d.at(0.05);
    assert!(d.s.connect());
    d.at(0.1);
    d.poll();
    d.req("1040 0 0");
    d.at(0.2);
    d.req("1041 3 1 50");
    d.req(" 1040 3 1 50");
    d.req("1040  3   1 40");
    d.req("1040 6.5 0");
    d.req("1040 99 2 1 2");
    d.req("1040 4 0");
    d.req("1040 3 1 30abc");
    let mut long = String::from("1040 3 1 ");
    long.push_str(&" ".repeat(255 - long.len()));
    long.push_str("77");
    d.req(&long);
    // One receive takes at most 4096 bytes; only the first 255 are parsed.
    d.req(&format!("1040 3 1 60{}", "9".repeat(3000)));
    d.at(1.0);
    d.poll();
}

/// §2.1 command 1: the server's own switch test; TASK(1) in field 7.
fn command_1_conditions(d: &mut Driver) {
    d.at(0.05);
    d.s.connect();
    d.at(0.1);
    d.panel(|c| c.set_run(false));
    d.req("1040 1 0");
    d.panel(|c| c.set_run(true));
    d.panel(|c| c.set_teach_lock(true));
    d.at(0.2);
    d.req("1040 1 0");
    d.panel(|c| c.set_teach_lock(false));
    d.panel(|c| c.set_repeat(false));
    d.at(0.3);
    d.req("1040 1 0");
    d.panel(|c| c.set_repeat(true));
    d.panel(|c| {
        let _ = c.set_power(false);
    });
    d.at(0.4);
    d.req("1040 1 0");
    d.panel(|c| {
        let _ = c.set_power(true);
    });
    d.panel(|c| {
        c.inject(fs020n_sim::Fault::RaiseError {
            code: fs020n_proto::ErrorCode(-31130),
        })
    });
    d.at(0.5);
    d.req("1040 1 0");
    d.panel(|c| {
        let _ = c.reset_error();
    });
    d.at(0.6);
    d.req("1040 1 0");
    d.at(0.7);
    d.poll();
    d.req("1040 1 0");
    d.at(0.8);
    d.poll();
}

/// §2.1 command 6, §2.2 newest-only and re-issue, §4 joint move timing, §2 stale arguments.
fn joint_moves_and_stale_arguments(d: &mut Driver) {
    d.at(0.05);
    d.s.connect();
    d.at(0.1);
    d.req("1040 3 1 50");
    d.req("1040 1 0");
    d.at(0.2);
    d.req("1040 6 9 0 0 0 20 10 -80 10 -70 30");
    for k in 0..40 {
        d.at(0.3 + 0.1 * f64::from(k));
        d.poll();
    }
    // COUNT 6: JT4..JT6 stale from the previous 6.
    d.req("1040 6 6 0 0 0 -10 0 -90");
    for k in 0..40 {
        d.at(4.5 + 0.1 * f64::from(k));
        d.poll();
    }
    // A status poll with version 1040 becomes the newest command: the robot finishes its
    // motion, then stands.
    d.req("1040 6 9 0 0 0 0 0 -90 0 -90 0");
    d.at(8.7);
    d.req("1040 0 0");
    for k in 0..30 {
        d.at(9.0 + 0.1 * f64::from(k));
        d.poll();
    }
}

/// §2 an argument never assigned: E0102 stops the motion program; the error stays; 1 refused.
fn undefined_argument(d: &mut Driver) {
    d.at(0.05);
    d.s.connect();
    d.at(0.1);
    d.req("1040 1 0");
    d.at(0.2);
    d.req("1040 6 3 0 0 0");
    d.at(0.3);
    d.poll();
    d.req("1040 1 0");
    d.at(0.4);
    d.poll();
}

/// §2.1 command 3 and ABS.SPEED: the 30 % branch runs at min(30, monitor).
fn speed_and_abs_speed(d: &mut Driver) {
    d.at(0.05);
    d.s.connect();
    d.at(0.1);
    d.req("1040 1 0");
    d.at(0.15);
    d.req("1040 6 9 0 0 0 30 0 -90 0 -90 0");
    for k in 0..20 {
        d.at(0.2 + 0.1 * f64::from(k));
        d.poll();
    }
    d.req("1040 3 1 100");
    d.req("1040 6 9 0 0 0 -30 20 -60 0 -60 0");
    for k in 0..20 {
        d.at(2.5 + 0.1 * f64::from(k));
        d.poll();
    }
    d.req("1040 3 1 0");
    d.req("1040 3 1 150");
    d.at(5.0);
    d.poll();
}

/// §2.1 command 5 (BRAKE, 5 after 5) and 2 (stop within the 50 ms signal edge), 1 right after
/// 2.
fn brake_and_stop(d: &mut Driver) {
    d.at(0.05);
    d.s.connect();
    d.at(0.1);
    d.req("1040 3 1 100");
    d.req("1040 1 0");
    d.at(0.2);
    d.req("1040 6 9 0 0 0 90 0 -90 0 -90 0");
    d.at(0.5);
    d.req("1040 5 0");
    d.req("1040 5 0");
    for k in 0..10 {
        d.at(0.6 + 0.05 * f64::from(k));
        d.poll();
    }
    d.req("1040 6 9 0 0 0 -60 0 -90 0 -90 0");
    d.at(1.5);
    d.req("1040 2 0");
    d.at(1.52);
    d.poll();
    d.at(1.53);
    d.req("1040 1 0");
    for k in 0..10 {
        d.at(1.6 + 0.05 * f64::from(k));
        d.poll();
    }
    d.req("1040 1 0");
    d.at(2.3);
    d.poll();
}

/// §4 a 1 while the arm brakes after the `ONI 2007` stop (command 2, 255 and a new session,
/// the receive timeout): the program has ended but its last motion — the brake — still runs
/// (TASK(1) = 3), so the server's own test passes and `MC EXECUTE` refuses it (P1009); a 1
/// once the arm stands starts the program.
fn start_while_the_stop_brakes(d: &mut Driver) {
    d.at(0.05);
    d.s.connect();
    d.at(0.1);
    d.req("1040 3 1 50");
    d.req("1040 1 0");
    d.at(0.2);
    d.req("1040 6 9 0 0 0 90 0 -90 0 -90 0");
    // Command 2 while the arm moves fast: the ONI fires 50 ms later and the arm brakes.
    d.at(0.6);
    d.req("1040 2 0");
    d.at(0.7);
    d.req("1040 1 0");
    for k in 0..8 {
        d.at(0.75 + 0.05 * f64::from(k));
        d.poll();
    }
    d.at(1.3);
    d.req("1040 1 0");
    d.at(1.35);
    d.poll();
    // 255 while the arm moves; a new session sends a 1 during the brake.
    d.req("1040 6 9 0 0 0 -60 0 -90 0 -90 0");
    d.at(1.7);
    d.req("1040 255 0");
    d.at(1.76);
    d.s.connect();
    d.at(1.8);
    d.req("1040 1 0");
    for k in 0..8 {
        d.at(1.85 + 0.05 * f64::from(k));
        d.poll();
    }
    d.at(2.4);
    d.req("1040 1 0");
    d.at(2.45);
    d.poll();
    // The receive timeout while the arm moves: a slow monitor speed keeps a long joint move
    // going past the 5 s; a new session's 1 arrives during the brake.
    d.req("1040 3 1 15");
    d.req("1040 6 9 0 0 0 -150 0 -90 0 -90 0");
    d.at(7.5);
    d.s.close();
    d.at(7.51);
    d.s.connect();
    d.at(7.52);
    d.req("1040 1 0");
    for k in 0..4 {
        d.at(7.55 + 0.05 * f64::from(k));
        d.poll();
    }
    d.at(8.0);
    d.req("1040 1 0");
    d.at(8.05);
    d.poll();
}

/// The streamed trajectory at server time `t`: position, velocity, acceleration of joint `i`.
fn trajectory(i: usize, t: f64) -> (f64, f64, f64) {
    let w = 0.8;
    let amp = [20.0, 10.0, 10.0, 20.0, 15.0, 30.0];
    let base = [0.0, 10.0, -80.0, 0.0, -80.0, 0.0];
    let ph = w * t + i as f64;
    (
        base[i] + amp[i] * ph.sin(),
        amp[i] * w * ph.cos(),
        -amp[i] * w * w * ph.sin(),
    )
}

/// §2.4 command 7: a 100 Hz stream of a smooth trajectory.
fn stream(d: &mut Driver) {
    d.at(0.05);
    d.s.connect();
    d.at(0.1);
    d.req("1040 3 1 100");
    d.req("1040 1 0");
    let t0 = 0.2;
    for k in 0..300 {
        let t = t0 + 0.01 * f64::from(k);
        d.at(t);
        let server_t = t - 0.05;
        let mut req = format!("1040 7 21 {:.3} 1 0", server_t);
        for part in 0..3 {
            for i in 0..6 {
                let (p, v, a) = trajectory(i, server_t);
                req.push_str(&format!(" {:.3}", [p, v, a][part]));
            }
        }
        if k == 0 {
            // The first sample from the home pose: the JMOVE branch is not singular here.
            d.req("1040 6 9 0 0 0 0 10 -80 0 -80 0");
            d.at(t + 0.005);
        }
        d.req(&req);
    }
    d.at(3.5);
    d.poll();
}

/// §2.3 255 and a new session; §4 listen again; the receive timeout.
fn sessions_and_timeouts(d: &mut Driver) {
    d.at(0.05);
    d.s.connect();
    d.at(0.1);
    d.req("1040 1 0");
    d.req("1040 255 0");
    d.at(0.2);
    d.s.connect();
    d.at(0.3);
    d.poll();
    // No request for 5 s: the session ends; a new client gets a fresh TIMER(1).
    d.at(6.0);
    d.s.close();
    d.at(6.05);
    d.s.connect();
    d.at(6.1);
    d.poll();
}

/// §4 E1088 out of range, HOLD pauses (field 7 = 0) and resumes, E-stop.
fn errors_and_hold(d: &mut Driver) {
    d.at(0.05);
    d.s.connect();
    d.at(0.1);
    d.req("1040 3 1 100");
    d.req("1040 1 0");
    d.at(0.2);
    d.req("1040 6 9 0 0 0 45 0 -90 0 -90 0");
    d.at(0.3);
    d.panel(|c| c.set_run(false));
    for k in 0..6 {
        d.at(0.35 + 0.1 * f64::from(k));
        d.poll();
    }
    d.panel(|c| c.set_run(true));
    for k in 0..10 {
        d.at(1.0 + 0.1 * f64::from(k));
        d.poll();
    }
    d.req("1040 6 9 0 0 0 175 0 -90 0 -90 0");
    d.at(2.2);
    d.poll();
    d.panel(|c| {
        let _ = c.reset_error();
    });
    d.at(2.3);
    d.req("1040 1 0");
    d.at(2.4);
    d.panel(|c| c.set_estop(true));
    d.at(2.5);
    d.poll();
}

const SCENARIOS: &[(&str, Scenario)] = &[
    ("requests and reply (§2, §3)", requests_and_reply),
    ("command 1 conditions (§2.1, §4)", command_1_conditions),
    (
        "joint moves, newest only, stale arguments (§2, §2.2)",
        joint_moves_and_stale_arguments,
    ),
    ("undefined argument E0102 (§2)", undefined_argument),
    ("speed and ABS.SPEED (§2.1)", speed_and_abs_speed),
    ("brake and stop (§2.1, §4)", brake_and_stop),
    (
        "a 1 while the stop brakes (§4)",
        start_while_the_stop_brakes,
    ),
    ("sessions and timeouts (§2.3)", sessions_and_timeouts),
    ("errors and HOLD (§4)", errors_and_hold),
];

#[test]
fn matched_timing_replies_match_byte_for_byte() {
    let mut failures = Vec::new();
    for (name, s) in SCENARIOS {
        let d = run_both(name, *s, matched_costs());
        for m in &d.status_mismatches {
            failures.push(format!("{name}: {m}"));
        }
        if d.timer_max_ms > 0.0 {
            failures.push(format!("{name}: TIMER(1) differs by {} ms", d.timer_max_ms));
        }
        if d.joints_still_max_deg > 0.0 {
            failures.push(format!(
                "{name}: joints at rest differ by {}°",
                d.joints_still_max_deg
            ));
        }
        assert!(
            d.joints_max_deg < 2.0,
            "{name}: joints while moving differ by {}°",
            d.joints_max_deg
        );
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The worst tracking error of a stream run after the first second, degrees.
fn tracking_error(replies: &[Reply]) -> f64 {
    replies
        .iter()
        .filter(|r| r.label.starts_with("1040 7 "))
        .filter_map(|r| {
            let st = Status::decode(&r.text).ok()?;
            let t = st.timer.seconds()?;
            (t > 1.0).then(|| {
                (0..6)
                    .map(|i| (st.joints[i] - trajectory(i, t).0).abs())
                    .fold(0.0, f64::max)
            })
        })
        .fold(0.0, f64::max)
}

/// Streaming is chaotic in the exact instants: which sample a pass reads depends on the pass
/// phase (the interpreted program's passes run at its own instants, the native ones on the
/// 2 ms ticks), so the joints are compared by how well each run tracks the trajectory, and the
/// status fields and TIMER(1) byte for byte.
#[test]
fn command_7_streams_track_the_same() {
    for cfg in [matched_costs(), Config::default()] {
        let mut n = Driver {
            s: native(),
            replies: Vec::new(),
        };
        stream(&mut n);
        let mut p = Driver {
            s: program(cfg.clone()),
            replies: Vec::new(),
        };
        stream(&mut p);
        let d = compare("command 7 stream (§2.4)", &n.replies, &p.replies, &[]);
        let (en, ep) = (tracking_error(&n.replies), tracking_error(&p.replies));
        eprintln!("command 7 stream: worst tracking error native {en:.3}°, program {ep:.3}°");
        assert!(d.status_mismatches.is_empty(), "{:?}", d.status_mismatches);
        assert!(en < 3.0 && ep < 3.0, "both track the trajectory: {en} {ep}");
        assert!((en - ep).abs() < 1.0, "and equally well: {en} {ep}");
        if cfg == matched_costs() {
            assert_eq!(d.timer_max_ms, 0.0);
        }
    }
}

#[test]
fn default_costs_answer_later_but_the_same() {
    for (name, s) in SCENARIOS {
        let d = run_both(name, *s, Config::default());
        // A burst of requests answered back to back queues up the program's few hundred
        // microseconds per request; TIMER(1) differs by no more than that lag.
        assert!(d.lag_max_ms <= 10.0, "{name}: {d:?}");
        assert!(d.timer_beyond_lag_ms <= 0.0, "{name}: {d:?}");
        // Where a HOLD or a brake stops the arm depends on when the motion began: the
        // program issues it a few milliseconds later than the native server (the server
        // text hardened for real controllers checks its results and its print switch: a
        // few statements more per request and per pass, 0.57° at most in these scenarios).
        assert!(d.joints_still_max_deg < 0.6, "{name}: {d:?}");
        assert!(d.joints_max_deg < 3.0, "{name}: {d:?}");
    }
}

/// The scenario above does what it says on both servers: each 1 sent while the arm brakes is
/// refused (field 7 stays 0 until the next 1, the native server counts a refused start), each
/// 1 once the arm stands starts the program.
#[test]
fn a_1_while_the_stop_brakes_is_refused_by_both() {
    for mut d in [
        Driver {
            s: native(),
            replies: Vec::new(),
        },
        Driver {
            s: program(matched_costs()),
            replies: Vec::new(),
        },
    ] {
        start_while_the_stop_brakes(&mut d);
        let running: Vec<(String, bool)> = d
            .replies
            .iter()
            .map(|r| {
                let f7 = r.text.split_whitespace().nth(6).unwrap_or("?");
                (r.label.clone(), f7 == "-1")
            })
            .collect();
        let after_starts: Vec<bool> = running
            .windows(2)
            .filter(|w| w[0].0 == "1040 1 0")
            .map(|w| w[1].1)
            .collect();
        // The first 1 starts; then, per stop path, a 1 during the brake (refused) and a 1
        // after it (started).
        assert_eq!(
            after_starts,
            [true, false, true, false, true, false, true],
            "{running:?}"
        );
    }
    let mut n = Driver {
        s: native(),
        replies: Vec::new(),
    };
    start_while_the_stop_brakes(&mut n);
    assert_eq!(n.s.controller().counters().starts_refused, 3);
}
