//! `ik`: every joint solution of a pose within the ranges, and the nearest to a seed.

use fs020n_kin::{IkError, Pose, RobotModel, Xyzoat};
use fs020n_proto::JointsDeg;
use serde_json::json;

use crate::cmd::joints_from;
use crate::error::{CliError, CliResult};
use crate::output::joints_json;

/// `ik`.
pub(crate) fn ik(
    model: &RobotModel,
    pose: &[f64],
    near: Option<&[f64]>,
    as_json: bool,
) -> CliResult {
    let p: [f64; 6] = pose
        .try_into()
        .map_err(|_| CliError::input("pose: expected X Y Z O A T"))?;
    if p.iter().any(|v| !v.is_finite()) {
        return Err(CliError::input("pose: values must be finite numbers"));
    }
    let seed = match near {
        Some(n) => joints_from(n, "--near")?,
        None => model.home,
    };
    let target = Pose::from_xyzoat(Xyzoat::new(p[0], p[1], p[2], p[3], p[4], p[5]));
    let unreachable = |e: IkError| CliError::input(format!("unreachable: {e}"));
    let all = model.inverse_all(&target).map_err(unreachable)?;
    let nearest = model
        .inverse_nearest(&target, &seed.to_rad())
        .map_err(unreachable)?
        .to_deg();
    let solutions: Vec<JointsDeg> = all.iter().map(|q| q.to_deg()).collect();
    if as_json {
        println!(
            "{}",
            json!({
                "solutions": solutions.iter().map(joints_json).collect::<Vec<_>>(),
                "nearest": joints_json(&nearest),
            })
        );
    } else {
        println!("{} solution(s) within the joint ranges:", solutions.len());
        for s in &solutions {
            let mark = if s.max_abs_diff(&nearest) < 1e-9 {
                "  <- nearest"
            } else {
                ""
            };
            println!("  {s}{mark}");
        }
        println!("nearest to {seed}: {nearest}");
    }
    Ok(())
}
