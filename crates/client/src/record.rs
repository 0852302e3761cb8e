//! Recording of every request and reply, one line each, written and flushed as it happens.

use std::fs::File;
use std::io::{self, Write};
use std::time::Duration;

use tokio::time::Instant;

use crate::config::{RecordFormat, Recording};
use crate::error::ClientError;

/// Direction of a recorded line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Dir {
    /// Request written.
    Tx,
    /// Reply received.
    Rx,
    /// Something that happened (connect, link lost, close).
    Event,
}

impl Dir {
    fn as_str(self) -> &'static str {
        match self {
            Dir::Tx => "tx",
            Dir::Rx => "rx",
            Dir::Event => "event",
        }
    }
}

/// One open recording file.
#[derive(Debug)]
pub(crate) struct Recorder {
    file: File,
    format: RecordFormat,
    epoch: Instant,
}

impl Recorder {
    pub(crate) fn open(rec: &Recording) -> Result<Recorder, ClientError> {
        let err = |e: io::Error| ClientError::Recording {
            path: rec.path.display().to_string(),
            message: e.to_string(),
        };
        let mut file = File::create(&rec.path).map_err(err)?;
        if rec.format == RecordFormat::Csv {
            file.write_all(b"t_s,session,dir,kind,rtt_ms,text\n")
                .map_err(err)?;
        }
        Ok(Recorder {
            file,
            format: rec.format,
            epoch: Instant::now(),
        })
    }

    /// Writes one line with a single `write` call (the file is unbuffered, so a line is in the
    /// kernel as soon as this returns: nothing is lost if the process dies).
    pub(crate) fn line(
        &mut self,
        at: Instant,
        session: u64,
        dir: Dir,
        kind: &str,
        rtt: Option<Duration>,
        text: &str,
    ) -> io::Result<()> {
        let t = at.saturating_duration_since(self.epoch).as_secs_f64();
        let rtt_ms = rtt.map(|d| d.as_secs_f64() * 1e3);
        let line = match self.format {
            RecordFormat::Csv => format!(
                "{t:.6},{session},{},{kind},{},{}\n",
                dir.as_str(),
                rtt_ms.map(|r| format!("{r:.3}")).unwrap_or_default(),
                csv_quote(text)
            ),
            RecordFormat::JsonLines => {
                let v = serde_json::json!({
                    "t_s": (t * 1e6).round() / 1e6,
                    "session": session,
                    "dir": dir.as_str(),
                    "kind": kind,
                    "rtt_ms": rtt_ms.map(|r| (r * 1e3).round() / 1e3),
                    "text": text,
                });
                format!("{v}\n")
            }
        };
        self.file.write_all(line.as_bytes())
    }
}

fn csv_quote(s: &str) -> String {
    format!("\"{}\"", s.replace('"', "\"\""))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[tokio::test]
    async fn csv_and_jsonl_lines() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("r.csv");
        let mut r = Recorder::open(&Recording {
            path: path.clone(),
            format: RecordFormat::Csv,
        })
        .unwrap();
        let t = Instant::now();
        r.line(t, 1, Dir::Tx, "poll", None, "0 0 0").unwrap();
        r.line(
            t,
            1,
            Dir::Rx,
            "poll",
            Some(Duration::from_micros(1500)),
            " 1040 \"x\"",
        )
        .unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines[0], "t_s,session,dir,kind,rtt_ms,text");
        assert!(lines[1].ends_with(",1,tx,poll,,\"0 0 0\""), "{}", lines[1]);
        assert!(
            lines[2].ends_with(",1,rx,poll,1.500,\" 1040 \"\"x\"\"\""),
            "{}",
            lines[2]
        );

        let path = dir.path().join("r.jsonl");
        let mut r = Recorder::open(&Recording {
            path: path.clone(),
            format: RecordFormat::JsonLines,
        })
        .unwrap();
        r.line(t, 2, Dir::Event, "connect", None, "x").unwrap();
        let v: serde_json::Value =
            serde_json::from_str(std::fs::read_to_string(&path).unwrap().trim()).unwrap();
        assert_eq!(v["dir"], "event");
        assert_eq!(v["session"], 2);
        assert!(v["rtt_ms"].is_null());
    }
}
