//! `fk`: the flange pose of joint angles.

use fs020n_kin::RobotModel;

use crate::cmd::joints_from;
use crate::error::CliResult;

/// `fk`.
pub(crate) fn fk(model: &RobotModel, joints: &[f64], as_json: bool) -> CliResult {
    let q = joints_from(joints, "joints")?;
    if let Err(e) = model.check_limits(&q) {
        eprintln!("warning: {e}");
    }
    let p = model.forward(&q.to_rad()).to_xyzoat();
    if as_json {
        println!("{}", serde_json::to_string(&p).unwrap_or_default());
    } else {
        println!("flange of {q}");
        println!(
            "  X {:.3}  Y {:.3}  Z {:.3} mm   O {:.3}  A {:.3}  T {:.3} deg",
            p.x_mm, p.y_mm, p.z_mm, p.o_deg, p.a_deg, p.t_deg
        );
    }
    Ok(())
}
