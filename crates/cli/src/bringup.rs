//! What `deploy` and `doctor` share: the terminal's address, the steps they print (a line each,
//! or one JSON object each with `--json`), and the transcript file.

use std::io::Write as _;
use std::path::Path;
use std::time::Duration;

use fs020n_term::connection::{ConnectionError, Direction, TerminalConnection};
use fs020n_term::text::TERMINAL_PORT;
use fs020n_term::ClientConfig;
use serde_json::json;

use crate::error::{CliError, CliResult, Exit};

/// The terminal's address: `--terminal`, else the robot's host on port 23.
pub(crate) fn terminal_addr(terminal: Option<&str>, robot: &str) -> String {
    if let Some(t) = terminal {
        return t.to_owned();
    }
    let host = match robot.rsplit_once(':') {
        Some((host, _)) => host,
        None => robot,
    };
    format!("{host}:{TERMINAL_PORT}")
}

/// How long one terminal command may take.
pub(crate) const TERMINAL_TIMEOUT: Duration = Duration::from_secs(15);

/// Connects and logs in to the terminal.
pub(crate) async fn open_terminal(
    addr: &str,
    block_bytes: usize,
    connect_timeout: Duration,
) -> Result<TerminalConnection, ConnectionError> {
    let config = ClientConfig {
        block_bytes,
        timeout: TERMINAL_TIMEOUT,
        ..ClientConfig::default()
    };
    TerminalConnection::connect(addr, config, connect_timeout).await
}

/// The steps of a walk, printed as they happen.
#[derive(Debug)]
pub(crate) struct Steps {
    json: bool,
    count: usize,
}

impl Steps {
    pub(crate) fn new(json: bool) -> Steps {
        Steps { json, count: 0 }
    }

    /// A step that went well.
    pub(crate) fn ok(&mut self, step: &str, detail: impl Into<String>) {
        self.print(step, "ok", &detail.into(), None);
    }

    /// A step that was only shown (a dry run) or skipped.
    pub(crate) fn note(&mut self, step: &str, status: &str, detail: impl Into<String>) {
        self.print(step, status, &detail.into(), None);
    }

    /// A step that failed: printed, then returned as the command's error.
    pub(crate) fn fail(
        &mut self,
        step: &str,
        exit: Exit,
        detail: impl Into<String>,
        remedy: impl Into<String>,
    ) -> CliError {
        let (detail, remedy) = (detail.into(), remedy.into());
        self.print(step, "failed", &detail, Some(&remedy));
        CliError::new(exit, format!("{step}: {detail}")).with_remedy(remedy)
    }

    fn print(&mut self, step: &str, status: &str, detail: &str, remedy: Option<&str>) {
        self.count += 1;
        if self.json {
            println!(
                "{}",
                json!({"step": step, "status": status, "detail": detail, "remedy": remedy})
            );
        } else {
            let mark = match status {
                "ok" => "ok  ",
                "failed" => "FAIL",
                _ => "--  ",
            };
            println!("{mark} {step}: {detail}");
            if let Some(r) = remedy {
                println!("     what to do: {r}");
            }
        }
    }
}

/// Writes the terminal conversation to `path`: one line per piece, `>>` for what was sent
/// and `<<` for what came, with the time since the connection opened; bytes outside printable
/// ASCII as `\xNN`.
pub(crate) fn write_transcript(path: &Path, t: &TerminalConnection) -> CliResult {
    let mut out = String::new();
    for e in t.transcript() {
        let dir = match e.direction {
            Direction::Sent => ">>",
            Direction::Received => "<<",
        };
        out.push_str(&format!("{:9.3} {dir} ", e.at.as_secs_f64()));
        for &b in &e.bytes {
            match b {
                b'\r' => out.push_str("\\r"),
                b'\n' => out.push_str("\\n"),
                0x20..=0x7E => out.push(char::from(b)),
                _ => out.push_str(&format!("\\x{b:02X}")),
            }
        }
        out.push('\n');
    }
    std::fs::File::create(path)
        .and_then(|mut f| f.write_all(out.as_bytes()))
        .map_err(|e| {
            CliError::failure(format!(
                "cannot write the transcript {}: {e}",
                path.display()
            ))
        })
}

/// The remedy for a terminal that cannot be used.
pub(crate) fn terminal_remedy(e: &ConnectionError) -> &'static str {
    match e {
        ConnectionError::Connect { .. } => {
            "check the controller's address (--terminal HOST:PORT), that it is on the network, \
             and that its terminal (telnet, port 23) is not blocked by a firewall"
        }
        ConnectionError::Io(_) => {
            "the controller closed the terminal: it serves three terminal sessions at once — \
             close other terminals (KIDE, a telnet window) and try again"
        }
        _ => "check the controller's terminal by hand (telnet HOST 23, log in as `as`)",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_terminal_defaults_to_the_robots_host_on_port_23() {
        assert_eq!(terminal_addr(None, "192.168.0.2:10050"), "192.168.0.2:23");
        assert_eq!(terminal_addr(None, "robot"), "robot:23");
        assert_eq!(
            terminal_addr(Some("127.0.0.1:2323"), "192.168.0.2:10050"),
            "127.0.0.1:2323"
        );
    }
}
