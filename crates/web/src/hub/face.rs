//! The hub's protocol-1040 face: a TCP port that speaks to clients as the controller does (one
//! read = one request, one reply each, no terminator), in front of the one real session.
//!
//! Rules (docs/HUB.md):
//! - The first client to send an **acting** request (version 1040) while nobody holds control
//!   takes control. Its requests are forwarded in lock-step, polls included (so that its
//!   replies, and their TIMER(1), are the controller's own).
//! - Polls (a version other than 1040) from the other clients are answered from the latest
//!   status, without reaching the controller.
//! - Acting requests from a client without control are answered with the latest status,
//!   never forwarded, and logged.
//! - Commands 6 and 7 must carry their full argument count (9 and 21): the controller would
//!   otherwise use stale arguments. Then the fence, then the client library's checks
//!   (`Robot::send_raw`): a refused request is answered with the latest status and logged with
//!   the reason.
//! - 255 from the controlling client is not forwarded (it would end the hub's session): the
//!   hub sends 2 — what the controller does on 255 — replies, and closes the connection.
//! - When the controlling client disconnects, does not read its reply within 2 s, or sends
//!   nothing for [`HubConfig::silence_timeout`](super::HubConfig::silence_timeout), the hub
//!   sends 2 at once and releases control. Other clients get the controller's 5 s receive
//!   timeout.
//! - When the session with the controller is lost, every client's connection is closed.

use std::io;
use std::net::SocketAddr;

use fs020n_client::ErrorKind;
use fs020n_proto::Command;
use fs020n_proto::ServerRequest;
use fs020n_proto::{MAX_REQUEST_BYTES, RECEIVE_TIMEOUT, SEND_TIMEOUT};
use tokio::io::{AsyncRead, AsyncReadExt, AsyncWrite, AsyncWriteExt};
use tokio::net::TcpListener;
use tokio::task::JoinHandle;
use tokio::time::{timeout, Instant};

use super::{lock, ClientEnd, ClientEntry, Hub, Refusal};

/// Bytes read by one receive call (as the controller's `TCP_RECV`, spec §2).
pub const FACE_RECEIVE_BUFFER: usize = 4096;

/// The poll the hub forwards for a controlling client's poll.
const POLL: &str = "0 0 0";

/// What to send back for one request.
struct Outcome {
    /// The reply bytes (empty: send nothing).
    reply: Vec<u8>,
    /// Close the connection after the reply.
    close: Option<ClientEnd>,
}

impl Hub {
    /// Serves one client of the protocol face on `stream` until it ends (any byte stream: a
    /// TCP connection, or an in-memory pipe in tests). `peer` names it in the log.
    pub async fn serve_client<S>(&self, stream: S, peer: String)
    where
        S: AsyncRead + AsyncWrite + Unpin,
    {
        let id = self.next_client_id();
        self.serve_numbered(stream, peer, id).await;
    }

    /// The next client number (in the order clients connect).
    fn next_client_id(&self) -> u64 {
        self.inner
            .next_client
            .fetch_add(1, std::sync::atomic::Ordering::Relaxed)
    }

    async fn serve_numbered<S>(&self, stream: S, peer: String, id: u64)
    where
        S: AsyncRead + AsyncWrite + Unpin,
    {
        let (mut rd, mut wr) = tokio::io::split(stream);
        let mut link = self.inner.link.subscribe();
        let start = *link.borrow_and_update();
        let refused = {
            let mut book = lock(&self.inner.book);
            book.counters.clients += 1;
            if !start.up {
                Some(format!(
                    "client {id} ({peer}) refused: the session with the controller is down"
                ))
            } else if book.clients.len() >= self.inner.config.max_clients {
                Some(format!(
                    "client {id} ({peer}) refused: {} clients already",
                    self.inner.config.max_clients
                ))
            } else {
                book.clients.insert(
                    id,
                    ClientEntry {
                        peer: peer.clone(),
                        requests: 0,
                        refused: 0,
                        since: Instant::now(),
                    },
                );
                None
            }
        };
        if let Some(why) = refused {
            self.log(Some(id), "client", None, None, why);
            let _ = wr.shutdown().await;
            return;
        }
        self.log(
            Some(id),
            "client",
            None,
            None,
            format!("client {id} connected from {peer}"),
        );
        let mut buf = vec![0u8; FACE_RECEIVE_BUFFER];
        let end = loop {
            let limit = if self.controller() == Some(id) {
                self.inner.config.silence_timeout
            } else {
                RECEIVE_TIMEOUT
            };
            let read = tokio::select! {
                r = timeout(limit, rd.read(&mut buf)) => r,
                _ = link_changed(&mut link, start.generation) => break ClientEnd::LinkLost,
            };
            let n = match read {
                Err(_) => break ClientEnd::Silent,
                Ok(Ok(0)) | Ok(Err(_)) => break ClientEnd::Disconnected,
                Ok(Ok(n)) => n,
            };
            let out = self.handle(id, &buf[..n]).await;
            if !out.reply.is_empty() {
                let sent = timeout(SEND_TIMEOUT, async {
                    wr.write_all(&out.reply).await?;
                    wr.flush().await
                })
                .await;
                match sent {
                    Ok(Ok(())) => {}
                    Ok(Err(_)) => break ClientEnd::Disconnected,
                    Err(_) => break ClientEnd::NotReading,
                }
            }
            if let Some(end) = out.close {
                break end;
            }
        };
        self.client_gone(id, &peer, end).await;
        let _ = wr.shutdown().await;
    }

    /// A client is no longer served: if it held control, stop the robot at once.
    async fn client_gone(&self, id: u64, peer: &str, end: ClientEnd) {
        let was_controller = {
            let mut book = lock(&self.inner.book);
            book.clients.remove(&id);
            let c = book.controller == Some(id);
            if c {
                book.controller = None;
            }
            c
        };
        let why = match end {
            ClientEnd::Disconnected => "disconnected".to_owned(),
            ClientEnd::Silent => format!(
                "sent nothing for {:?}",
                if was_controller {
                    self.inner.config.silence_timeout
                } else {
                    RECEIVE_TIMEOUT
                }
            ),
            ClientEnd::NotReading => "did not read its reply within 2 s".into(),
            ClientEnd::EndCommand => "ended its session (255)".into(),
            ClientEnd::LinkLost => "was closed: the session with the controller was lost".into(),
        };
        if was_controller && end != ClientEnd::LinkLost {
            lock(&self.inner.book).counters.stops_on_client_end += 1;
            self.log(
                Some(id),
                "stop",
                None,
                None,
                format!("controlling client {id} ({peer}) {why}: stopping the robot (command 2)"),
            );
            let r = self.inner.robot.read().await.stop_program().await;
            lock(&self.inner.book).target = None;
            if let Err(e) = r {
                self.log(
                    Some(id),
                    "stop",
                    None,
                    None,
                    format!("the stop failed: {e}"),
                );
            }
        } else {
            self.log(
                Some(id),
                "client",
                None,
                None,
                format!("client {id} ({peer}) {why}"),
            );
        }
    }

    /// The reply with the latest status, not from the controller.
    fn latest_reply(&self, robot: &fs020n_client::Robot) -> Vec<u8> {
        robot.status().status.encode().into_bytes()
    }

    fn refuse(
        &self,
        id: u64,
        robot: &fs020n_client::Robot,
        request: &str,
        refusal: Refusal,
        reason: String,
    ) -> Outcome {
        {
            let mut book = lock(&self.inner.book);
            if let Some(c) = book.clients.get_mut(&id) {
                c.refused += 1;
            }
            let k = &mut book.counters;
            match refusal {
                Refusal::NoControl => k.refused_no_control += 1,
                Refusal::Incomplete => k.refused_incomplete += 1,
                Refusal::Fence => k.refused_fence += 1,
                Refusal::Checks => k.refused_checks += 1,
            }
        }
        self.log(
            Some(id),
            "refused",
            Some(request),
            Some(refusal),
            format!("refused from client {id}: {reason}"),
        );
        Outcome {
            reply: self.latest_reply(robot),
            close: None,
        }
    }

    /// Handles one request of client `id`.
    async fn handle(&self, id: u64, bytes: &[u8]) -> Outcome {
        let robot = self.inner.robot.read().await;
        let head = &bytes[..bytes.len().min(MAX_REQUEST_BYTES)];
        // Trailing blanks, line ends and NULs change nothing for the controller's parser
        // (VAL stops at them; tokens beyond COUNT are ignored): cut them so that the client
        // library accepts the text.
        let text = String::from_utf8_lossy(head)
            .trim_end_matches(|c: char| c.is_ascii_whitespace() || c == '\0')
            .to_owned();
        let req = ServerRequest::parse(head);
        let controlling = {
            let mut book = lock(&self.inner.book);
            book.counters.requests += 1;
            if let Some(c) = book.clients.get_mut(&id) {
                c.requests += 1;
            }
            if req.version_matches() && book.controller.is_none() {
                book.controller = Some(id);
                drop(book);
                self.log(
                    Some(id),
                    "control",
                    None,
                    None,
                    format!("client {id} takes control"),
                );
                true
            } else {
                book.controller == Some(id)
            }
        };
        if !req.version_matches() {
            if !controlling {
                lock(&self.inner.book).counters.answered_locally += 1;
                return Outcome {
                    reply: self.latest_reply(&robot),
                    close: None,
                };
            }
            return self.forward(id, &robot, POLL, None).await;
        }
        if !controlling {
            let holder = self.controller();
            return self.refuse(
                id,
                &robot,
                &text,
                Refusal::NoControl,
                match holder {
                    Some(h) => format!("client {h} holds control; only polls with another version (e.g. \"0 0 0\") are answered"),
                    None => "this client does not hold control".into(),
                },
            );
        }
        let command = req.command();
        match &command {
            Command::EndSession => {
                // What the controller does on 255: stop the program, reply, close.
                let r = robot.stop_program().await;
                let release = {
                    let mut book = lock(&self.inner.book);
                    book.target = None;
                    book.controller = None;
                    book.counters.forwarded += 1;
                    r.is_ok()
                };
                self.log(
                    Some(id),
                    "stop",
                    Some(&text),
                    None,
                    format!("client {id} ended its session (255): stop (command 2) sent instead, control released"),
                );
                return match r {
                    Ok(status) if release => Outcome {
                        reply: status.encode().into_bytes(),
                        close: Some(ClientEnd::EndCommand),
                    },
                    _ => Outcome {
                        reply: Vec::new(),
                        close: Some(ClientEnd::LinkLost),
                    },
                };
            }
            Command::JointMove { .. } if req.count < 9 => {
                return self.refuse(
                    id,
                    &robot,
                    &text,
                    Refusal::Incomplete,
                    format!("command 6 with {} arguments; send all 9 (the controller would take the missing ones from earlier requests)", req.count),
                );
            }
            Command::StreamedMove(_) if req.count < 21 => {
                return self.refuse(
                    id,
                    &robot,
                    &text,
                    Refusal::Incomplete,
                    format!("command 7 with {} arguments; send all 21 (the controller would take the missing ones from earlier requests)", req.count),
                );
            }
            _ => {}
        }
        if let Some(fence) = &self.inner.config.fence {
            let current = robot.status().status.joints;
            if let Err(v) = fence.check(&command, &current) {
                return self.refuse(id, &robot, &text, Refusal::Fence, v.to_string());
            }
        }
        self.forward(id, &robot, &text, Some(command)).await
    }

    /// Forwards `text` for the controlling client `id` and returns the controller's reply.
    async fn forward(
        &self,
        id: u64,
        robot: &fs020n_client::Robot,
        text: &str,
        command: Option<Command>,
    ) -> Outcome {
        match robot.send_raw(text, true).await {
            Ok(frame) => {
                let log_it = {
                    let mut book = lock(&self.inner.book);
                    book.counters.forwarded += 1;
                    match &command {
                        Some(Command::JointMove { target }) => book.target = Some(*target),
                        Some(Command::StreamedMove(s)) => book.target = Some(s.position),
                        Some(Command::StopProgram | Command::CancelMotion) => book.target = None,
                        _ => {}
                    }
                    // Acting requests other than motions (clients send 6 and 7 at up to
                    // 100 Hz: they are counted, not logged one by one).
                    matches!(&command, Some(c) if !c.is_motion())
                };
                if log_it {
                    self.log(
                        Some(id),
                        "forwarded",
                        Some(text),
                        None,
                        format!("forwarded from client {id}"),
                    );
                }
                Outcome {
                    reply: frame.text.into_bytes(),
                    close: None,
                }
            }
            // One mapping, from the client's classification: a dead session closes the
            // client (only a reconnect of the hub helps); anything else — a check that refused
            // the text (range, sample, speed, encoding, raw text), a blocked robot, a busy
            // motion channel — is a refusal by the checks, answered with the latest reply.
            Err(e) if e.kind() == ErrorKind::LinkLost => {
                tracing::warn!(client = id, error = %e, "forwarding failed: the session with the controller is lost");
                Outcome {
                    reply: Vec::new(),
                    close: Some(ClientEnd::LinkLost),
                }
            }
            Err(e) => self.refuse(id, robot, text, Refusal::Checks, e.to_string()),
        }
    }
}

/// Completes when the link generation differs from `generation` (lost or replaced).
async fn link_changed(rx: &mut tokio::sync::watch::Receiver<super::LinkState>, generation: u64) {
    loop {
        if rx.borrow_and_update().generation != generation {
            return;
        }
        if rx.changed().await.is_err() {
            return;
        }
    }
}

/// A running protocol face. Dropping it does not stop it; call [`FaceServer::stop`].
#[derive(Debug)]
pub struct FaceServer {
    addr: SocketAddr,
    task: JoinHandle<()>,
}

impl FaceServer {
    /// The bound address (useful with port 0).
    pub fn local_addr(&self) -> SocketAddr {
        self.addr
    }

    /// Stops accepting (clients already connected are served until they leave).
    pub fn stop(self) {
        self.task.abort();
    }
}

/// Serves the hub's protocol-1040 face on `addr`. Off loopback it warns: the protocol has no
/// authentication, and this port can move the robot.
pub async fn serve_face(hub: Hub, addr: SocketAddr) -> io::Result<FaceServer> {
    let listener = TcpListener::bind(addr).await?;
    let local = listener.local_addr()?;
    if !local.ip().is_loopback() {
        tracing::warn!(addr = %local, "the hub's protocol-1040 face listens off loopback: the protocol has no authentication and this port can move the robot; keep it on an isolated network");
    }
    tracing::info!(addr = %local, "hub protocol-1040 face listening");
    let task = tokio::spawn(async move {
        loop {
            match listener.accept().await {
                Ok((stream, peer)) => {
                    let _ = stream.set_nodelay(true);
                    // Numbered here, so that numbers follow the order of connection.
                    let id = hub.next_client_id();
                    let hub = hub.clone();
                    tokio::spawn(
                        async move { hub.serve_numbered(stream, peer.to_string(), id).await },
                    );
                }
                Err(e) => {
                    tracing::warn!(error = %e, "accept failed");
                    tokio::time::sleep(std::time::Duration::from_millis(50)).await;
                }
            }
        }
    });
    Ok(FaceServer { addr: local, task })
}
