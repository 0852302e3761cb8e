//! Formatting of statuses and numbers for people and for `--json`.

use std::time::Duration;

use fs020n_client::RttStats;
use fs020n_kin::{RobotModel, Xyzoat};
use fs020n_proto::{JointsDeg, Status, Timer, TIMER_WIRE_STEP_S};
use serde_json::{json, Value};

/// Joint angles as a JSON array.
pub(crate) fn joints_json(j: &JointsDeg) -> Value {
    json!(j.values())
}

/// A reply as JSON with exactly the documented keys.
pub(crate) fn status_json(s: &Status) -> Value {
    json!({
        "version": s.version,
        "error_code": s.error.raw(),
        "error": if s.error.is_none() { Value::Null } else { json!(s.error.to_string()) },
        "run": s.run,
        "repeat": s.repeat,
        "teach_lock": s.teach_lock,
        "power": s.power,
        "task_running": s.task_running,
        "timer_s": match s.timer { Timer::Seconds(t) => json!(t), Timer::Overflow => Value::Null },
        // The step of TIMER(1) at this session's age, and of command 7's time stamps.
        "timer_step_s": s.timer.step_s(),
        "joints_deg": joints_json(&s.joints),
    })
}

/// The flange pose of `joints` (forward kinematics).
pub(crate) fn flange_pose(model: &RobotModel, joints: &JointsDeg) -> Xyzoat {
    model.forward(&joints.to_rad()).to_xyzoat()
}

/// A pose as JSON: `{"x", "y", "z"}` in mm, `{"o", "a", "t"}` in degrees.
pub(crate) fn pose_json(p: &Xyzoat) -> Value {
    json!({ "x": p.x_mm, "y": p.y_mm, "z": p.z_mm, "o": p.o_deg, "a": p.a_deg, "t": p.t_deg })
}

/// A pose for people.
pub(crate) fn pose_line(p: &Xyzoat) -> String {
    format!(
        "X={:.3} Y={:.3} Z={:.3} mm  O={:.3} A={:.3} T={:.3} deg",
        p.x_mm, p.y_mm, p.z_mm, p.o_deg, p.a_deg, p.t_deg
    )
}

/// A robot's status as JSON: the reply's keys ([`status_json`]) and `pose`, the flange pose
/// computed from the joints with the robot model.
pub(crate) fn robot_status_json(s: &Status, model: &RobotModel) -> Value {
    let mut v = status_json(s);
    v["pose"] = pose_json(&flange_pose(model, &s.joints));
    v
}

/// A robot's status for people: the reply's table and the flange pose.
pub(crate) fn robot_status_table(s: &Status, model: &RobotModel) -> String {
    let mut t = status_table(s);
    t.push_str(&format!(
        "  flange pose    {}\n",
        pose_line(&flange_pose(model, &s.joints))
    ));
    t
}

/// A reply as a table for people.
pub(crate) fn status_table(s: &Status) -> String {
    let yes = |b: bool, on: &str, off: &str| if b { on.to_owned() } else { off.to_owned() };
    let error = if s.error.is_none() {
        "none".to_owned()
    } else {
        match s.error.message() {
            Some(m) => format!("{} ({}) — {m}", s.error, s.error.raw()),
            None => format!("{} ({})", s.error, s.error.raw()),
        }
    };
    let timer = match (s.timer, s.timer.step_s()) {
        (Timer::Seconds(t), Some(step)) if step > TIMER_WIRE_STEP_S => format!(
            "{t:.3} s — a long session: TIMER(1) steps by {:.1} ms, and so do command 7's time \
             stamps (reconnect to start anew)",
            step * 1e3
        ),
        (Timer::Seconds(t), _) => format!("{t:.3} s"),
        (Timer::Overflow, _) => "overflow (**********)".to_owned(),
    };
    let mut out = String::new();
    out.push_str(&format!("  version        {}\n", s.version));
    out.push_str(&format!("  error          {error}\n"));
    out.push_str(&format!("  RUN/HOLD       {}\n", yes(s.run, "RUN", "HOLD")));
    out.push_str(&format!(
        "  TEACH/REPEAT   {}\n",
        yes(s.repeat, "REPEAT", "TEACH")
    ));
    out.push_str(&format!(
        "  TEACH LOCK     {}\n",
        yes(s.teach_lock, "ON", "OFF")
    ));
    out.push_str(&format!("  motor power    {}\n", yes(s.power, "ON", "OFF")));
    out.push_str(&format!(
        "  program        {}\n",
        yes(s.task_running, "running", "not running")
    ));
    out.push_str(&format!("  timer          {timer}\n"));
    out.push_str("  joints (deg)  ");
    for (i, v) in s.joints.iter().enumerate() {
        out.push_str(&format!(" JT{}={:.3}", i + 1, v));
    }
    out.push('\n');
    out
}

/// Round-trip figures for people: `min … µs, mean … µs, p99 … µs, max … µs`.
pub(crate) fn rtt_line(r: &RttStats) -> String {
    let us = |d: std::time::Duration| d.as_secs_f64() * 1e6;
    format!(
        "min {:.0} µs, mean {:.0} µs, p99 {:.0} µs, max {:.0} µs",
        us(r.min),
        us(r.mean),
        us(r.p99),
        us(r.max)
    )
}

/// A duration for people: `"250 ms"`, `"10.0 s"`.
pub(crate) fn rounded(d: Duration) -> String {
    let s = d.as_secs_f64();
    if s < 1.0 {
        format!("{:.0} ms", s * 1e3)
    } else {
        format!("{s:.1} s")
    }
}
