//! The terminal client over TCP with tokio (feature `tokio`): the driver of
//! [`TerminalClient`], keeping a transcript of every byte both ways.
//!
//! Each call runs one operation to its end in the caller's task. Time is tokio's, so a test
//! on a paused runtime runs on virtual time.

use std::time::Duration;

use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::TcpStream;
use tokio::time::{sleep_until, timeout, Instant};

use crate::client::{ClientConfig, Event, TerminalClient, TerminalError};

/// Who sent a piece of the transcript.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Direction {
    /// The client typed it.
    Sent,
    /// The controller printed it.
    Received,
}

/// One piece of the conversation, when it happened since the connection opened.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TranscriptEntry {
    /// Time since the connection opened.
    pub at: Duration,
    /// Who sent it.
    pub direction: Direction,
    /// The bytes as they went.
    pub bytes: Vec<u8>,
}

/// Why a terminal operation over TCP failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ConnectionError {
    /// The terminal port did not accept a connection.
    #[error("cannot connect to the controller's terminal at {addr}: {message}; check the address, that the controller is on and on the network, and that its terminal port (23) is open (a firewall between the PC and the controller?)")]
    Connect {
        /// The address.
        addr: String,
        /// The error.
        message: String,
    },
    /// The connection broke or closed.
    #[error("the terminal connection ended: {0}; the controller ends a command it was running when the link drops — connect again and check the state (PCSTATUS) before going on")]
    Io(String),
    /// The operation failed on the terminal.
    #[error(transparent)]
    Terminal(#[from] TerminalError),
}

/// What a `LOAD` did.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LoadReport {
    /// Errors the controller counted.
    pub errors: usize,
    /// The syntax error the load was aborted on, if any.
    pub syntax_error: Option<String>,
    /// The programs the controller said it loaded (`Program name()`), lower case.
    pub programs: Vec<String>,
    /// The load's last line (`File load completed. (0 errors)`, `Loading done.`), if any.
    pub ending: Option<String>,
    /// The text of the load.
    pub output: String,
}

/// A logged-in terminal over TCP.
#[derive(Debug)]
pub struct TerminalConnection {
    stream: TcpStream,
    client: TerminalClient,
    opened: Instant,
    transcript: Vec<TranscriptEntry>,
    terminal: Option<String>,
    answered: Vec<Event>,
}

impl TerminalConnection {
    /// Connects to `addr` (`host:port`) within `connect_timeout` and logs in.
    pub async fn connect(
        addr: &str,
        config: ClientConfig,
        connect_timeout: Duration,
    ) -> Result<TerminalConnection, ConnectionError> {
        let failed = |message: String| ConnectionError::Connect {
            addr: addr.to_owned(),
            message,
        };
        let stream = match timeout(connect_timeout, TcpStream::connect(addr)).await {
            Ok(Ok(s)) => s,
            Ok(Err(e)) => return Err(failed(e.to_string())),
            Err(_) => return Err(failed(format!("no answer within {connect_timeout:?}"))),
        };
        let _ = stream.set_nodelay(true);
        let mut c = TerminalConnection {
            stream,
            client: TerminalClient::new(config),
            opened: Instant::now(),
            transcript: Vec::new(),
            terminal: None,
            answered: Vec::new(),
        };
        c.client.login(c.now())?;
        match c.drive().await? {
            Event::LoggedIn { terminal } => c.terminal = terminal,
            other => return Err(unexpected(other)),
        }
        Ok(c)
    }

    /// The terminal's name from the greeting (`AUX1`).
    pub fn terminal(&self) -> Option<&str> {
        self.terminal.as_deref()
    }

    /// Every byte both ways so far.
    pub fn transcript(&self) -> &[TranscriptEntry] {
        &self.transcript
    }

    /// The questions answered so far (`Event::Answered`), in order.
    pub fn answered(&self) -> &[Event] {
        &self.answered
    }

    /// Runs one monitor command; its output without the echo and the prompt. With `confirm`,
    /// `Are you sure ?` is answered yes.
    pub async fn command(&mut self, line: &str, confirm: bool) -> Result<String, ConnectionError> {
        self.client.command(self.now(), line, confirm)?;
        match self.drive().await? {
            Event::Reply { output, .. } => Ok(output),
            other => Err(unexpected(other)),
        }
    }

    /// Loads `data` as file `name`.
    pub async fn load(&mut self, name: &str, data: &[u8]) -> Result<LoadReport, ConnectionError> {
        self.client.load(self.now(), name, data)?;
        match self.drive().await? {
            Event::Loaded {
                errors,
                syntax_error,
                programs,
                ending,
                output,
            } => Ok(LoadReport {
                errors,
                syntax_error,
                programs,
                ending,
                output,
            }),
            other => Err(unexpected(other)),
        }
    }

    /// Saves with `spec` (`/P backup.as=name`); the file's bytes.
    pub async fn save(&mut self, spec: &str) -> Result<Vec<u8>, ConnectionError> {
        self.client.save(self.now(), spec)?;
        match self.drive().await? {
            Event::Saved { file, .. } => Ok(file),
            other => Err(unexpected(other)),
        }
    }

    fn now(&self) -> Duration {
        self.opened.elapsed()
    }

    /// Runs the client until its operation ends; the final event.
    async fn drive(&mut self) -> Result<Event, ConnectionError> {
        let mut buf = vec![0u8; 4096];
        loop {
            while let Some(bytes) = self.client.poll_transmit() {
                self.stream
                    .write_all(&bytes)
                    .await
                    .map_err(|e| ConnectionError::Io(e.to_string()))?;
                self.transcript.push(TranscriptEntry {
                    at: self.now(),
                    direction: Direction::Sent,
                    bytes,
                });
            }
            while let Some(event) = self.client.poll_event() {
                match event {
                    Event::Answered { .. } => self.answered.push(event),
                    Event::Failed(e) => return Err(e.into()),
                    done => return Ok(done),
                }
            }
            let deadline = self
                .client
                .poll_timeout()
                .map(|t| self.opened + t)
                .unwrap_or_else(|| Instant::now() + Duration::from_secs(3600));
            tokio::select! {
                read = self.stream.read(&mut buf) => {
                    let n = read.map_err(|e| ConnectionError::Io(e.to_string()))?;
                    if n == 0 {
                        return Err(ConnectionError::Io("the controller closed the connection".into()));
                    }
                    let now = self.now();
                    self.transcript.push(TranscriptEntry {
                        at: now,
                        direction: Direction::Received,
                        bytes: buf[..n].to_vec(),
                    });
                    self.client.handle_input(now, &buf[..n]);
                }
                () = sleep_until(deadline) => {
                    let now = self.now();
                    self.client.handle_timeout(now);
                }
            }
        }
    }
}

fn unexpected(event: Event) -> ConnectionError {
    ConnectionError::Io(format!("unexpected terminal event {event:?}"))
}
