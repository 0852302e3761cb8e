//! Block-teaching steps: the fields of a `JOINT`/`LINEAR` line into a [`BlockStep`].
//!
//! A step is one line: the interpolation, then its settings as words (`SPEED9 ACCU1 TIMER0
//! TOOL1 WORK0`), the clamp data, the signals (`OX=1,-2 WX=5`), other `NAME=values` fields,
//! and the target (`#[j1,…]` joint angles or `[x,y,z,o,a,t]`). Fields the emulator does not
//! model are dropped here: `GROUPn`, `MATH…`, the `CLAMP…` data (spot-welding and gripper
//! clamps), `YO=`, `CL1=` and any other `NAME=…`, and target values beyond the sixth (external
//! axes, which do not move this arm). A step this reader does not take (another
//! interpolation, `JUMP` (a jump to an externally selected program), `WORKn` other than 0, a
//! word it does not know, a target of fewer than six values) gives `None`: it loads as not
//! emulated.

use crate::ast::{BlockSpeed, BlockStep, BlockTarget};

/// Highest `TOOLn` a step may name.
const MAX_TOOL: u8 = 15;

/// The step of a `JOINT` or `LINEAR` line (`word`, lower case) whose text after the word is
/// `after` (comment removed), `None` when the emulator does not run this form.
pub(super) fn block_step(word: &str, after: &[u8]) -> Option<BlockStep> {
    let linear = match word {
        "joint" => false,
        "linear" => true,
        _ => return None,
    };
    let text = std::str::from_utf8(after).ok()?;
    // The target is the last bracket of the line; nothing but blanks after it.
    let open = text.rfind('[')?;
    let close = open + text[open..].find(']')?;
    if !text[close + 1..].trim().is_empty() {
        return None;
    }
    let (fields, joints) = match text[..open].strip_suffix('#') {
        Some(f) => (f, true),
        None => (&text[..open], false),
    };
    let values = numbers(&text[open + 1..close])?;
    let six: [f64; 6] = values.get(..6)?.try_into().ok()?;
    let target = if joints {
        BlockTarget::Joints(six)
    } else {
        BlockTarget::Pose(six)
    };
    let mut words = fields.split_ascii_whitespace();
    let speed = match words.next()? {
        w if upper_prefix(w, "SPEED") => BlockSpeed::Number(number_after(w, 5, 9)?),
        w if linear => {
            let v: f64 = w.parse().ok()?;
            if !(v.is_finite() && v > 0.0) {
                return None;
            }
            BlockSpeed::MmPerS(v)
        }
        _ => return None,
    };
    let mut step = BlockStep {
        linear,
        speed,
        accuracy: 1,
        timer: 0,
        tool: 1,
        outputs: Vec::new(),
        inputs: Vec::new(),
        target,
        end: false,
    };
    let mut in_clamp = false;
    for w in words {
        if let Some(list) = strip_upper_prefix(w, "OX=") {
            step.outputs = signals(list)?;
            in_clamp = false;
        } else if let Some(list) = strip_upper_prefix(w, "WX=") {
            step.inputs = signals(list)?
                .into_iter()
                .map(|n| {
                    if n.abs() < 1000 {
                        n.signum() * (1000 + n.abs())
                    } else {
                        n
                    }
                })
                .collect();
            in_clamp = false;
        } else if in_clamp || w.contains('=') {
            // The clamp data (`1 (OFF,0,1,1) 2 (…)`), `YO=…`, `CL1=…`: not modelled.
        } else if upper_prefix(w, "CLAMP") {
            in_clamp = true;
        } else if upper_prefix(w, "ACCU") {
            step.accuracy = number_after(w, 4, 4)?;
        } else if upper_prefix(w, "TIMER") {
            step.timer = number_after(w, 5, 9)?;
        } else if upper_prefix(w, "TOOL") {
            step.tool = number_after(w, 4, MAX_TOOL)?;
        } else if upper_prefix(w, "WORK") {
            // Work compensation is not modelled: only WORK0 (none) runs.
            if number_after(w, 4, 9)? != 0 {
                return None;
            }
        } else if upper_prefix(w, "GROUP") {
            number_after(w, 5, u8::MAX)?;
        } else if upper_prefix(w, "MATH") {
            // `MATHN31`, `MATH11`: not modelled.
        } else if w.eq_ignore_ascii_case("END") {
            step.end = true;
        } else {
            return None;
        }
    }
    Some(step)
}

/// Whether `w` starts with `prefix` (upper case), in any case.
fn upper_prefix(w: &str, prefix: &str) -> bool {
    strip_upper_prefix(w, prefix).is_some()
}

/// `w` without `prefix` (upper case), in any case.
fn strip_upper_prefix<'a>(w: &'a str, prefix: &str) -> Option<&'a str> {
    let head = w.get(..prefix.len())?;
    head.eq_ignore_ascii_case(prefix)
        .then(|| &w[prefix.len()..])
}

/// The number after the first `skip` letters of `w` (`ACCU2` → 2), at most `max`.
fn number_after(w: &str, skip: usize, max: u8) -> Option<u8> {
    let digits = w.get(skip..)?;
    if digits.is_empty() || digits.len() > 3 || !digits.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    let n: u16 = digits.parse().ok()?;
    u8::try_from(n).ok().filter(|n| *n <= max)
}

/// A signal list (`1,-2,30`; empty for none): 0 stands for no signal and is dropped.
fn signals(list: &str) -> Option<Vec<i32>> {
    if list.is_empty() {
        return Some(Vec::new());
    }
    let mut out = Vec::new();
    for v in list.split(',') {
        let n: i32 = v.trim().parse().ok()?;
        if !(-9999..=9999).contains(&n) {
            return None;
        }
        if n != 0 {
            out.push(n);
        }
    }
    Some(out)
}

/// The comma-separated numbers of a target.
fn numbers(text: &str) -> Option<Vec<f64>> {
    text.split(',')
        .map(|v| v.trim().parse::<f64>().ok().filter(|x| x.is_finite()))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_joint_step_keeps_its_settings_and_drops_what_the_arm_does_not_use() {
        let s = block_step(
            "joint",
            b"SPEED7 ACCU2 TIMER3 TOOL2 WORK0 GROUP0  CLAMP1 (ON,0,1,1) 2 (OFF,0,0,O) OX=4,-5 WX=6  YO=^H0,^H0 #[1,2,3,4,5,6,-700] ",
        )
        .unwrap();
        assert!(!s.linear);
        assert_eq!(s.speed, BlockSpeed::Number(7));
        assert_eq!((s.accuracy, s.timer, s.tool), (2, 3, 2));
        assert_eq!(s.outputs, vec![4, -5]);
        assert_eq!(s.inputs, vec![1006]);
        assert_eq!(
            s.target,
            BlockTarget::Joints([1.0, 2.0, 3.0, 4.0, 5.0, 6.0])
        );
    }

    #[test]
    fn a_linear_step_may_give_its_speed_in_mm_per_s_and_a_transformation() {
        let s = block_step(
            "linear",
            b"75.5 ACCU1 TIMER0 TOOL1 WORK0 CLAMP OX= WX= [10,20,30,0,90,0]",
        )
        .unwrap();
        assert_eq!(s.speed, BlockSpeed::MmPerS(75.5));
        assert!(s.outputs.is_empty() && s.inputs.is_empty());
        assert_eq!(
            s.target,
            BlockTarget::Pose([10.0, 20.0, 30.0, 0.0, 90.0, 0.0])
        );
    }

    #[test]
    fn forms_the_emulator_does_not_model_are_refused() {
        for (w, t) in [
            (
                "joint",
                &b"SPEED9 ACCU1 TIMER0 TOOL1 WORK2 OX= WX= #[0,0,0,0,0,0]"[..],
            ),
            (
                "joint",
                b"SPEED9 ACCU1 TIMER0 TOOL1 WORK0 OX= WX= #[0,0,0,0,0]",
            ),
            ("joint", b"SPEED10 ACCU1 OX= WX= #[0,0,0,0,0,0]"),
            ("joint", b"50 ACCU1 OX= WX= #[0,0,0,0,0,0]"),
            ("joint", b"SPEED9 WELD_COND1 OX= WX= #[0,0,0,0,0,0]"),
            ("cir1", b"SPEED9 ACCU1 OX= WX= #[0,0,0,0,0,0]"),
            ("linear", b"SPEED9 ACCU1 OX=x WX= #[0,0,0,0,0,0]"),
        ] {
            assert_eq!(block_step(w, t), None, "{}", String::from_utf8_lossy(t));
        }
    }
}
