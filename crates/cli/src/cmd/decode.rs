//! `decode`: a reply (or a request with `--request`) read as the controller and the client read it.

use fs020n_proto::ServerRequest;
use fs020n_proto::{Command, DecodeError, Status};
use serde_json::{json, Value};

use crate::args::DecodeArgs;
use crate::error::{CliError, CliResult};
use crate::output::{joints_json, status_json, status_table};

/// `decode`.
pub(crate) fn decode(args: &DecodeArgs, as_json: bool) -> CliResult {
    let text = args.text.as_str();
    let as_reply = if args.reply {
        true
    } else if args.request {
        false
    } else {
        // A reply: it decodes, or it has a reply's 14 fields with a bad value (asterisks in a
        // joint, a non-integer flag), or it starts with a blank as replies do and requests
        // must not (use --request to read such a request as the controller would).
        match Status::decode(text) {
            Ok(_) => true,
            Err(DecodeError::JointOverflow { .. } | DecodeError::NotInteger { .. }) => true,
            Err(_) => text.starts_with(' '),
        }
    };
    if as_reply {
        let status =
            Status::decode(text).map_err(|e| CliError::input(format!("not a valid reply: {e}")))?;
        if as_json {
            println!("{}", status_json(&status));
        } else {
            println!("reply");
            print!("{}", status_table(&status));
        }
        return Ok(());
    }
    let (request, warnings) = decode_request(text)?;
    let command = request.command();
    if as_json {
        let v = json!({
            "kind": "request",
            "version": request.version,
            "effective": request.version_matches(),
            "command_number": request.command_number,
            "command": command_name(&command),
            "count": request.count,
            "args": request.args,
            "detail": command_json(&command),
            "warnings": warnings,
        });
        println!("{v}");
    } else {
        println!("request (as the controller reads it)");
        println!(
            "  version   {} ({})",
            request.version,
            if request.version_matches() {
                "1040: the server acts on it"
            } else {
                "not 1040: a status poll, no effect"
            }
        );
        println!(
            "  command   {} = {}",
            request.command_number,
            command_name(&command)
        );
        println!("  count     {}", request.count);
        println!("  args      {:?}", request.args);
        if let Some(d) = command_detail(&command) {
            println!("  {d}");
        }
        for w in warnings {
            println!("  warning: {w}");
        }
    }
    Ok(())
}

/// Parses a request strictly enough to point at mistakes, then as the controller would.
fn decode_request(text: &str) -> CliResult<(ServerRequest, Vec<String>)> {
    if text.trim().is_empty() {
        return Err(CliError::input(
            "empty text: expected a reply (14 fields) or a request (VERSION COMMAND COUNT ARGS…)",
        ));
    }
    let mut warnings = Vec::new();
    if text.starts_with(' ') {
        warnings.push("a leading blank makes the version token empty: the controller reads version 0 and ignores the request".to_owned());
    }
    if text.len() > fs020n_proto::MAX_REQUEST_BYTES {
        warnings.push(format!(
            "{} bytes: the controller reads only the first 255",
            text.len()
        ));
    }
    let mut col = 1;
    let mut tokens: usize = 0;
    for tok in text.split(' ') {
        if !tok.is_empty() {
            tokens += 1;
            if tok
                .trim()
                .parse::<f64>()
                .map(|v| !v.is_finite())
                .unwrap_or(true)
            {
                return Err(CliError::input(format!(
                    "not a valid request or reply: column {col}: {tok:?} is not a number (the controller would read it as {})",
                    fs020n_proto::number::as_val(tok)
                )));
            }
        }
        col += tok.len() + 1;
    }
    if tokens < 3 {
        return Err(CliError::input(format!(
            "not a valid request or reply: {tokens} field(s); a request has at least VERSION COMMAND COUNT_OF_ARGS and a reply 14 fields"
        )));
    }
    let r = ServerRequest::parse(text.as_bytes());
    let given = tokens.saturating_sub(3);
    if given != r.count {
        warnings.push(format!(
            "COUNT_OF_ARGS is {} but {given} argument(s) follow: the controller {}",
            r.count,
            if given < r.count {
                "reads the missing ones as 0"
            } else {
                "ignores the extra ones"
            }
        ));
    }
    Ok((r, warnings))
}

fn command_name(c: &Command) -> &'static str {
    match c {
        Command::StartProgram => "start program",
        Command::StopProgram => "stop program",
        Command::SetSpeed { .. } => "set speed",
        Command::Reserved => "reserved",
        Command::CancelMotion => "cancel motion",
        Command::JointMove { .. } => "joint move",
        Command::StreamedMove(_) => "streamed move",
        Command::EndSession => "end session",
        Command::Other { .. } => "other (recorded, no effect)",
    }
}

fn command_detail(c: &Command) -> Option<String> {
    match c {
        Command::SetSpeed { percent } => Some(format!("speed     {percent} %")),
        Command::JointMove { target } => Some(format!("target    {target}")),
        Command::StreamedMove(s) => Some(format!(
            "t0 {} s, look-ahead {} passes\n  position  {}\n  velocity  {}/s\n  accel     {}/s²",
            s.t0_s, s.lookahead_passes, s.position, s.velocity, s.acceleration
        )),
        _ => None,
    }
}

fn command_json(c: &Command) -> Value {
    match c {
        Command::SetSpeed { percent } => json!({ "percent": percent }),
        Command::JointMove { target } => json!({ "target_deg": joints_json(target) }),
        Command::StreamedMove(s) => json!({
            "t0_s": s.t0_s,
            "lookahead_passes": s.lookahead_passes,
            "position_deg": joints_json(&s.position),
            "velocity_deg_s": joints_json(&s.velocity),
            "acceleration_deg_s2": joints_json(&s.acceleration),
        }),
        _ => Value::Null,
    }
}
