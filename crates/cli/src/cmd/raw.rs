//! `raw`: one request as typed, with its reply.

use fs020n_client::Robot;
use serde_json::json;

use crate::cmd::with_robot;
use crate::context::{Ctx, Interrupt};
use crate::error::{describe, CliResult, Place};
use crate::output::{robot_status_json, status_table};

/// `raw`.
pub(crate) fn raw(ctx: &Ctx, text: &str, yes: bool) -> CliResult {
    with_robot(ctx, async |robot: &Robot, _stop: &Interrupt| {
        let frame = robot
            .send_raw(text, yes)
            .await
            .map_err(|e| describe(e, Place::Command))?;
        if ctx.json {
            println!(
                "{}",
                json!({ "request": text, "reply": frame.text, "decoded": robot_status_json(&frame.status, &ctx.model) })
            );
        } else {
            println!("request  {text:?}");
            println!("reply    {:?}", frame.text);
            print!("{}", status_table(&frame.status));
        }
        Ok(())
    })
}
