//! `speed`: the speed of the motion program.

use fs020n_client::Robot;
use serde_json::json;

use crate::cmd::with_robot;
use crate::context::{check_speed, Ctx, Interrupt};
use crate::error::{client_error, CliResult};

/// `speed`.
pub(crate) fn speed(ctx: &Ctx, percent: f64) -> CliResult {
    let percent = check_speed(percent)?;
    with_robot(ctx, async |robot: &Robot, _stop: &Interrupt| {
        robot.set_speed(percent).await.map_err(client_error)?;
        if ctx.json {
            println!("{}", json!({ "speed_percent": percent }));
        } else {
            println!("monitor speed set to {percent} % (it stays set in the controller)");
        }
        Ok(())
    })
}
