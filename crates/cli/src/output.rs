//! Formatting of statuses and numbers for people and for `--json`.

use fs020n_client::RttStats;
use fs020n_proto::{JointsDeg, Status, Timer};
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
        "joints_deg": joints_json(&s.joints),
    })
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
    let timer = match s.timer {
        Timer::Seconds(t) => format!("{t:.3} s"),
        Timer::Overflow => "overflow (**********)".to_owned(),
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
