//! The emulator on a tokio runtime: the controller advanced by the runtime's clock, served over
//! TCP (with the controller's listen windows) or over in-memory streams; an AS program's
//! clients, every port it listens on and its connections to other hosts are served by
//! `server/program.rs`.
//!
//! Under `tokio::time::pause()` (or `#[tokio::test(start_paused = true)]`) the runtime's clock is
//! virtual: the emulator and a client on in-memory streams then run thousands of times faster
//! than real time and reproducibly, with every timeout behaving as on the real controller.

use std::io;
use std::net::SocketAddr;
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

use fs020n_proto::SEND_TIMEOUT;
use tokio::io::{AsyncRead, AsyncReadExt, AsyncWrite, AsyncWriteExt, DuplexStream};
use tokio::net::TcpListener;
use tokio::sync::watch;
use tokio::task::JoinHandle;
use tokio::time::Instant;

use crate::controller::Controller;
use crate::fault::ReplyFault;
use crate::machine::ControllerConfig;
use crate::native::SessionId;
use crate::snapshot::{SessionEnd, Snapshot};

mod fleet;
mod program;

pub use fleet::{FleetServer, FleetStop};
pub use program::ProgramPorts;
pub(crate) use program::LISTENERS_WAIT;

/// Size of the in-memory pipe of [`Emulator::connect`] in each direction, bytes (small, like a
/// socket buffer that fills when the peer stops reading).
pub const PIPE_CAPACITY: usize = 4096;

/// Bytes read by one receive call of the communication task: `TCP_RECV` fills up to sixteen
/// 255-byte string elements (4080 bytes; 4096 here). Whatever one receive returns is one
/// request: only its first 255 bytes are parsed, the rest of that read is discarded.
pub const RECEIVE_BUFFER: usize = 4096;

/// The robot port's socket send buffer, bytes (`SO_SNDBUF`; Linux doubles it for its own
/// bookkeeping). The controller's TCP stack buffers little: with a small fixed buffer a client
/// that stops reading fills it (and its own receive buffer) within seconds, and the 2 s send
/// timeout then ends the session as on the controller. The kernel's default would grow to
/// megabytes and keep such a session alive for minutes.
pub const SEND_BUFFER: u32 = 4096;

struct Inner {
    controller: Mutex<Controller>,
    epoch: Instant,
    /// Bumped whenever a `with` call changes the session or the reading pause.
    changed: watch::Sender<u64>,
    /// Where each port a program listens on is served on the host (`server/program.rs`).
    ports: Mutex<std::collections::BTreeMap<u16, SocketAddr>>,
    /// The port map those ports are served through, once they are (`server/program.rs`).
    port_map: Mutex<Option<crate::network::PortMap>>,
    /// Which of the program's ports have a host socket listening now (`server/program.rs`).
    listeners: Mutex<program::Listeners>,
}

/// A running emulated controller, shared by its network tasks and its observers. Cheap to
/// clone. Create it inside a tokio runtime: its clock is the runtime's.
#[derive(Clone)]
pub struct Emulator {
    inner: Arc<Inner>,
}

impl std::fmt::Debug for Emulator {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Emulator")
            .field("elapsed", &self.elapsed())
            .finish()
    }
}

impl Emulator {
    /// A controller started now.
    pub fn new(config: ControllerConfig) -> Emulator {
        let (changed, _) = watch::channel(0);
        Emulator {
            inner: Arc::new(Inner {
                controller: Mutex::new(Controller::new(config)),
                epoch: Instant::now(),
                changed,
                ports: Mutex::default(),
                port_map: Mutex::default(),
                listeners: Mutex::default(),
            }),
        }
    }

    /// An emulator of an existing controller (e.g. one running an AS program:
    /// [`Controller::with_program`]), started now.
    pub fn from_controller(controller: Controller) -> Emulator {
        let (changed, _) = watch::channel(0);
        Emulator {
            inner: Arc::new(Inner {
                controller: Mutex::new(controller),
                epoch: Instant::now(),
                changed,
                ports: Mutex::default(),
                port_map: Mutex::default(),
                listeners: Mutex::default(),
            }),
        }
    }

    /// A handle that does not keep the emulator alive.
    pub(crate) fn downgrade(&self) -> WeakEmulator {
        WeakEmulator(Arc::downgrade(&self.inner))
    }

    /// Notified whenever a session, the reading pause or a program's client-visible socket
    /// state changes.
    pub(crate) fn changes(&self) -> watch::Receiver<u64> {
        self.inner.changed.subscribe()
    }

    /// Time since the emulator started, by the runtime's clock.
    pub fn elapsed(&self) -> Duration {
        self.inner.epoch.elapsed()
    }

    fn lock(&self) -> MutexGuard<'_, Controller> {
        // A panic while holding the lock cannot leave the controller half-updated in a way that
        // matters more than stopping; keep serving.
        self.inner
            .controller
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
    }

    /// Brings the controller up to the current time, then runs `f` on it (pendant operations,
    /// observations, fault injection).
    pub fn with<R>(&self, f: impl FnOnce(&mut Controller) -> R) -> R {
        let now = self.elapsed();
        let (r, changed) = {
            let mut c = self.lock();
            // Taken before advancing: a session that times out while advancing is a change.
            let before = (
                c.native().session(),
                c.reading_paused_until(),
                c.program().io_generation(),
                c.monitor_generation(),
            );
            c.advance_to(now);
            let r = f(&mut c);
            let after = (
                c.native().session(),
                c.reading_paused_until(),
                c.program().io_generation(),
                c.monitor_generation(),
            );
            (r, before != after)
        };
        if changed {
            self.inner.changed.send_modify(|g| *g = g.wrapping_add(1));
        }
        r
    }

    /// A serializable picture of the controller now.
    pub fn snapshot(&self) -> Snapshot {
        self.with(|c| c.snapshot())
    }

    pub(crate) fn instant_of(&self, t: Duration) -> Instant {
        self.inner.epoch + t
    }

    /// Connects an in-memory client, as a TCP connect would: refused during a listen gap and
    /// while a session is open.
    pub fn connect(&self) -> io::Result<DuplexStream> {
        let id = self
            .with(|c| c.try_accept())
            .map_err(|e| io::Error::new(io::ErrorKind::ConnectionRefused, e))?;
        let (client, server) = tokio::io::duplex(PIPE_CAPACITY);
        let this = self.clone();
        tokio::spawn(async move { this.run_session(id, server).await });
        Ok(client)
    }

    /// Serves the robot port on `addr` (e.g. `127.0.0.1:10050`; port 0 picks one) until the
    /// returned task is aborted. Like the AS program, it listens in 3-second windows with a short
    /// gap between them and not at all while a session is open, so connecting then is refused.
    pub async fn serve_tcp(&self, addr: SocketAddr) -> io::Result<TcpServer> {
        let listener = bind_robot_port(addr)?;
        let local = listener.local_addr()?;
        let this = self.clone();
        let task = tokio::spawn(async move { this.accept_loop(local, Some(listener)).await });
        Ok(TcpServer { addr: local, task })
    }

    async fn accept_loop(self, addr: SocketAddr, mut listener: Option<TcpListener>) {
        let mut changes = self.inner.changed.subscribe();
        loop {
            let (listening, next_change) =
                self.with(|c| (c.native().is_listening(), c.native().next_listen_change()));
            if !listening {
                listener = None;
                match next_change {
                    Some(t) => tokio::time::sleep_until(self.instant_of(t)).await,
                    // A session is open: wait until it ends.
                    None => {
                        if changes.changed().await.is_err() {
                            return;
                        }
                    }
                }
                continue;
            }
            let l = match listener.take() {
                Some(l) => l,
                None => match bind_robot_port(addr) {
                    Ok(l) => l,
                    Err(e) => {
                        tracing::warn!(%addr, error = %e, "cannot listen; retrying");
                        tokio::time::sleep(Duration::from_millis(100)).await;
                        continue;
                    }
                },
            };
            let window_end = next_change.map(|t| self.instant_of(t));
            tokio::select! {
                accepted = l.accept() => {
                    let Ok((stream, peer)) = accepted else { continue };
                    match self.with(|c| c.try_accept()) {
                        Ok(id) => {
                            drop(l);
                            let _ = stream.set_nodelay(true);
                            tracing::info!(%peer, session = id.0, "client connected");
                            self.run_session(id, stream).await;
                        }
                        Err(e) => {
                            tracing::info!(%peer, "{e}");
                            listener = Some(l);
                        }
                    }
                }
                _ = sleep_until_opt(window_end) => {
                    drop(l);
                }
            }
        }
    }

    /// Runs the communication task's session loop on `stream` until the session ends.
    pub async fn run_session<S>(&self, id: SessionId, stream: S)
    where
        S: AsyncRead + AsyncWrite + Unpin,
    {
        // The loop never reads and writes at the same time: one stream, no split halves.
        let mut stream = stream;
        // Kept pending across requests, so that a waiter is not registered and dropped per
        // request; re-armed after each change.
        let mut changes = Box::pin(next_change(self.inner.changed.subscribe()));
        let mut buf = vec![0u8; RECEIVE_BUFFER];
        let mut state = self.with(|c| SessionState::of(c, id));
        // One timer for the receive timeout, armed at a deadline the session has had and moved
        // only when it fires: the deadline moves later with every request, so re-arming it per
        // request would cost a timer-wheel update each time. When it fires early, the state is
        // read again (the controller ends the session itself once the real deadline passes).
        let timer = tokio::time::sleep_until(self.instant_of(state.deadline.unwrap_or_default()));
        tokio::pin!(timer);
        while let (true, Some(deadline)) = (state.open, state.deadline) {
            if let Some(until) = state.paused {
                tokio::select! {
                    _ = tokio::time::sleep_until(self.instant_of(until.min(deadline))) => {}
                    rx = &mut changes => changes = Box::pin(next_change(rx)),
                }
                state = self.with(|c| SessionState::of(c, id));
                continue;
            }
            let armed = self.instant_of(deadline);
            if timer.is_elapsed() || timer.deadline() > armed {
                timer.as_mut().reset(armed);
            }
            // Biased: the request first (the common wake-up), so that a wake-up by a request
            // does not also poll the timer and the change watcher.
            let n = tokio::select! {
                biased;
                r = stream.read(&mut buf) => r,
                _ = &mut timer => {
                    state = self.with(|c| SessionState::of(c, id));
                    continue;
                }
                rx = &mut changes => {
                    changes = Box::pin(next_change(rx));
                    state = self.with(|c| SessionState::of(c, id));
                    continue;
                }
            };
            let n = match n {
                Ok(0) | Err(_) => {
                    self.with(|c| c.end_session_of(id, SessionEnd::Disconnected));
                    break;
                }
                Ok(n) => n,
            };
            let Ok(handled) = self.with(|c| c.handle_request(id, &buf[..n])) else {
                break;
            };
            // Only a reply without a fault can go out in the instant it was built.
            let plain = handled.fault.is_none();
            let sent = match handled.fault {
                None => send(&mut stream, &handled.reply).await,
                Some(ReplyFault::Withhold) => Ok(Sent::Later),
                Some(ReplyFault::Delay(d)) => {
                    if !self.pause(id, d).await {
                        break;
                    }
                    send(&mut stream, &handled.reply).await
                }
                Some(ReplyFault::Garbage(bytes)) => send(&mut stream, &bytes).await,
                Some(ReplyFault::Split { parts, gap }) => {
                    let size = handled.reply.len().div_ceil(parts.max(1)).max(1);
                    let mut sent = Ok(Sent::Later);
                    for (k, chunk) in handled.reply.chunks(size).enumerate() {
                        if k > 0 && !self.pause(id, gap).await {
                            break;
                        }
                        sent = send(&mut stream, chunk).await;
                        if sent.is_err() {
                            break;
                        }
                    }
                    sent
                }
            };
            let sent = match sent {
                Ok(sent) if plain => sent,
                Ok(_) => Sent::Later,
                Err(why) => {
                    self.with(|c| c.end_session_of(id, why));
                    break;
                }
            };
            // The communication task receives again only now (its 5 s timeout starts here).
            let received_again = |c: &mut Controller| {
                c.reply_sent(id);
                SessionState::of(c, id)
            };
            state = match sent {
                // The reply went out without waiting: the controller stays at the instant it
                // handled the request (microseconds ago on a real clock, the same instant on
                // virtual time), and `reply_sent` changes nothing an observer waits for.
                Sent::AtOnce => received_again(&mut self.lock()),
                Sent::Later => self.with(received_again),
            };
            if handled.close {
                break;
            }
        }
        let _ = stream.shutdown().await;
    }
}

/// What the session loop needs to know about its session, read under one lock.
#[derive(Debug, Clone, Copy)]
struct SessionState {
    open: bool,
    deadline: Option<Duration>,
    paused: Option<Duration>,
}

impl SessionState {
    fn of(c: &Controller, id: SessionId) -> SessionState {
        SessionState {
            open: c.native().is_session_open(id),
            deadline: c.native().receive_deadline(),
            paused: c.reading_paused_until(),
        }
    }
}

impl Emulator {
    /// Waits `d` while session `id` stays open (a delayed or split reply); `false` when the
    /// session ended meanwhile (closed by fault injection, or the emulator stopped it).
    async fn pause(&self, id: SessionId, d: Duration) -> bool {
        let mut changes = self.inner.changed.subscribe();
        let until = Instant::now() + d;
        loop {
            if !self.with(|c| c.native().is_session_open(id)) {
                return false;
            }
            tokio::select! {
                _ = tokio::time::sleep_until(until) => return self.with(|c| c.native().is_session_open(id)),
                r = changes.changed() => if r.is_err() { return false },
            }
        }
    }
}

/// Waits for the next change of the session state, then hands the receiver back.
async fn next_change(mut rx: watch::Receiver<u64>) -> watch::Receiver<u64> {
    if rx.changed().await.is_err() {
        // The emulator is gone: no change will ever come.
        std::future::pending::<()>().await;
    }
    rx
}

/// The robot port, bound and listening, non-blocking, with the controller's small send buffer
/// (accepted sockets inherit it): the one place its socket options are set, for the tokio
/// server ([`bind_robot_port`]) and the fleet's loop (`server/fleet.rs`).
pub(crate) fn robot_port_socket(addr: SocketAddr) -> io::Result<std::net::TcpListener> {
    let socket = socket2::Socket::new(
        socket2::Domain::for_address(addr),
        socket2::Type::STREAM,
        None,
    )?;
    socket.set_reuse_address(true)?;
    socket.set_send_buffer_size(SEND_BUFFER as usize)?;
    socket.set_nonblocking(true)?;
    socket.bind(&addr.into())?;
    socket.listen(16)?;
    Ok(socket.into())
}

/// [`robot_port_socket`] on the tokio runtime.
pub(crate) fn bind_robot_port(addr: SocketAddr) -> io::Result<TcpListener> {
    TcpListener::from_std(robot_port_socket(addr)?)
}

pub(crate) async fn sleep_until_opt(t: Option<Instant>) {
    match t {
        Some(t) => tokio::time::sleep_until(t).await,
        None => std::future::pending().await,
    }
}

/// How a reply went out.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Sent {
    /// Without waiting: the first write took all of it.
    AtOnce,
    /// After waiting for the peer to read.
    Later,
}

async fn send<W: AsyncWrite + Unpin>(wr: &mut W, bytes: &[u8]) -> Result<Sent, SessionEnd> {
    // A reply nearly always fits the socket's free buffer: one write, polled once, without
    // arming the send timeout's timer (a timer per reply was a tenth of a polled robot's cost).
    // Whatever does not go out at once is sent under the timeout as before.
    use std::task::Poll;
    let first = std::future::poll_fn(|cx| {
        let written = match std::pin::Pin::new(&mut *wr).poll_write(cx, bytes) {
            Poll::Ready(Ok(n)) => n.min(bytes.len()),
            Poll::Ready(Err(_)) => return Poll::Ready(None),
            Poll::Pending => 0,
        };
        if written == bytes.len() && written > 0 {
            match std::pin::Pin::new(&mut *wr).poll_flush(cx) {
                Poll::Ready(Ok(())) => return Poll::Ready(Some((written, true))),
                Poll::Ready(Err(_)) => return Poll::Ready(None),
                Poll::Pending => {}
            }
        }
        Poll::Ready(Some((written, false)))
    })
    .await;
    let rest = match first {
        None => return Err(SessionEnd::Disconnected),
        Some((_, true)) => return Ok(Sent::AtOnce),
        Some((written, false)) => &bytes[written..],
    };
    match tokio::time::timeout(SEND_TIMEOUT, async {
        wr.write_all(rest).await?;
        wr.flush().await
    })
    .await
    {
        Ok(Ok(())) => Ok(Sent::Later),
        Ok(Err(_)) => Err(SessionEnd::Disconnected),
        Err(_) => Err(SessionEnd::SendTimeout),
    }
}

/// An [`Emulator`] that does not keep it alive (for its background tasks).
#[derive(Clone)]
pub(crate) struct WeakEmulator(std::sync::Weak<Inner>);

impl WeakEmulator {
    pub(crate) fn upgrade(&self) -> Option<Emulator> {
        self.0.upgrade().map(|inner| Emulator { inner })
    }
}

/// A running TCP robot port. Dropping it does not stop it; call [`TcpServer::stop`].
#[derive(Debug)]
pub struct TcpServer {
    addr: SocketAddr,
    task: JoinHandle<()>,
}

impl TcpServer {
    pub(crate) fn new(addr: SocketAddr, task: JoinHandle<()>) -> TcpServer {
        TcpServer { addr, task }
    }

    /// The bound address (useful with port 0).
    pub fn local_addr(&self) -> SocketAddr {
        self.addr
    }

    /// Stops serving (an open session is dropped with the task).
    pub fn stop(self) {
        self.task.abort();
    }
}
