//! The emulator serving an AS program's network: a background task that advances the program
//! at its own events, the served port (listening exactly while the program does), every other
//! port it listens on (through the port map), its connections to other hosts (`TCP_CONNECT`
//! through the host map: the dialer) and the pump that moves a connection's bytes to and from
//! the program's socket.

use std::collections::{BTreeMap, BTreeSet};
use std::net::{IpAddr, SocketAddr};
use std::time::Duration;

use fs020n_as::sockets::TcpCode;
use tokio::task::JoinHandle;

use super::{Emulator, TcpServer, WeakEmulator};
use crate::controller::Controller;
use crate::machine::ControllerConfig;
use crate::network::PortMap;
use crate::program::{ClientId, ProgramDial, ServerProgram};

/// How long the prompt waits at most after a command made a program listen (`PCEXECUTE`)
/// for the host sockets of its ports to listen: each binds in a task of its own, and a client
/// that connects as soon as the prompt is back must not be refused. They are bound within
/// microseconds; the bound only keeps a stuck host from holding the terminal.
pub(crate) const LISTENERS_WAIT: Duration = Duration::from_secs(2);

/// The program's ports served on the host ([`Emulator::serve_program_ports`]). Dropping it
/// does not stop them; call [`ProgramPorts::stop`].
#[derive(Debug)]
pub struct ProgramPorts {
    task: JoinHandle<()>,
}

impl ProgramPorts {
    /// Stops serving every port (open connections are dropped).
    pub fn stop(self) {
        self.task.abort();
    }
}

/// Which of the program's ports have a host socket listening now, so that a monitor command
/// that makes the program listen (`PCEXECUTE`) returns its prompt only once a client can
/// connect ([`Emulator::program_listeners_ready`]).
#[derive(Debug, Default)]
pub(super) struct Listeners {
    /// Every port the program listens on is served ([`Emulator::serve_program_ports`]).
    every_port: bool,
    /// The program's served port is served ([`Emulator::serve_program_tcp`]).
    served_port: bool,
    /// Program ports with a host socket listening now.
    bound: BTreeSet<u16>,
    /// Program ports the host cannot serve now (taken, or left to an address that does not
    /// serve them): nobody waits for them.
    unservable: BTreeSet<u16>,
}

/// What became of a program port's host socket.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Listener {
    /// Listening: a client can connect.
    Bound,
    /// Closed (the program stopped listening, or its server stopped).
    Closed,
    /// The host cannot listen on it.
    Unservable,
}

/// Marks its port closed when the accept loop that holds it ends (aborted with its server).
struct BoundMark {
    emu: Emulator,
    port: Option<u16>,
}

impl BoundMark {
    fn set(&mut self, port: u16, state: Listener) {
        if let Some(old) = self.port.filter(|&old| old != port) {
            self.emu.mark_listener(old, Listener::Closed);
        }
        self.port = Some(port);
        self.emu.mark_listener(port, state);
    }
}

impl Drop for BoundMark {
    fn drop(&mut self) {
        if let Some(port) = self.port {
            self.emu.mark_listener(port, Listener::Closed);
        }
    }
}

/// Tasks aborted with their owner.
#[derive(Default)]
struct Children(Vec<JoinHandle<()>>);

impl Drop for Children {
    fn drop(&mut self) {
        for t in &self.0 {
            t.abort();
        }
    }
}

impl Emulator {
    /// An emulator whose controller runs `program` (see [`Controller::with_program`]), started
    /// now. Create it inside a tokio runtime: a background task advances the program at its
    /// own events (timeouts, polls, steps) even when nobody observes the controller.
    pub fn with_program(config: ControllerConfig, program: ServerProgram) -> Emulator {
        Emulator::driven(Controller::with_program(config, program))
    }

    /// An emulator of a new controller with nothing loaded ([`Controller::bare`]), started
    /// now: no protocol port answers until a program is loaded through the terminal
    /// ([`Emulator::serve_terminal`]) and started. Create it inside a tokio runtime.
    pub fn bare(config: ControllerConfig) -> Emulator {
        Emulator::driven(Controller::bare(config, fs020n_as::LoadOptions::new()))
    }

    /// An emulator of `controller` whose AS programs a background task advances at their own
    /// events (see [`Emulator::with_program`]).
    pub fn driven(controller: Controller) -> Emulator {
        let emu = Emulator::from_controller(controller);
        if let Ok(rt) = tokio::runtime::Handle::try_current() {
            rt.spawn(drive(emu.downgrade()));
            rt.spawn(dialer(emu.downgrade()));
        }
        emu
    }

    /// Serves every port the program listens on at `bind` (127.0.0.1 by default), each at the
    /// host port `map` gives (the same number unless mapped; 0: a free one), until
    /// [`ProgramPorts::stop`]. Each listens exactly while the program does; a port whose host
    /// address is `except` (the robot address [`Emulator::serve_program_tcp`] serves) is left
    /// to it. Where each is served: [`Emulator::program_ports`].
    pub fn serve_program_ports(
        &self,
        bind: IpAddr,
        map: PortMap,
        except: Option<SocketAddr>,
    ) -> ProgramPorts {
        if let Ok(mut m) = self.inner.port_map.lock() {
            *m = Some(map.clone());
        }
        self.serve_listeners(true);
        let this = self.clone();
        ProgramPorts {
            task: tokio::spawn(async move { this.ports_loop(bind, map, except).await }),
        }
    }

    /// Where each port the program has listened on is served on the host (program port →
    /// host address), for the ports [`Emulator::serve_program_ports`] serves.
    pub fn program_ports(&self) -> BTreeMap<u16, SocketAddr> {
        self.inner
            .ports
            .lock()
            .map(|p| p.clone())
            .unwrap_or_else(|poisoned| poisoned.into_inner().clone())
    }

    /// The port map the program's ports are served through ([`Emulator::serve_program_ports`]),
    /// `None` until they are served.
    pub fn port_map(&self) -> Option<PortMap> {
        self.inner
            .port_map
            .lock()
            .map(|m| m.clone())
            .unwrap_or_else(|poisoned| poisoned.into_inner().clone())
    }

    /// Waits until the program's `port` is served on the host (at most `timeout`): its host
    /// address, `None` when it is not served by then (the program does not listen on it, or
    /// its host port cannot be bound: see the log).
    pub async fn wait_program_port(&self, port: u16, timeout: Duration) -> Option<SocketAddr> {
        let mut changes = self.changes();
        let until = tokio::time::Instant::now() + timeout;
        loop {
            if let Some(a) = self.program_ports().get(&port) {
                return Some(*a);
            }
            tokio::select! {
                r = changes.changed() => if r.is_err() { return None },
                _ = tokio::time::sleep_until(until) => return self.program_ports().get(&port).copied(),
            }
        }
    }

    /// Whether every port the program listens on that this emulator serves on the host has a
    /// host socket listening now, so that a client can connect to each at once (ports the
    /// host cannot serve are not waited for; see the log).
    pub fn program_listeners_ready(&self) -> bool {
        let (listening, served) =
            self.with(|c| (c.program().listening_ports(), c.program().served_port()));
        // Taken before the listeners' lock: the two locks are never held together.
        let recorded = self.program_ports();
        let l = self
            .inner
            .listeners
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner());
        listening.into_iter().all(|p| {
            if l.unservable.contains(&p) {
                return true;
            }
            let bound = l.bound.contains(&p);
            if l.every_port {
                // Served at its own host port too: listening there (the first port also
                // listens at the robot address, which alone is not enough).
                bound && recorded.contains_key(&p)
            } else {
                !(l.served_port && Some(p) == served) || bound
            }
        })
    }

    /// Waits until [`Emulator::program_listeners_ready`], at most `timeout`; `false` when
    /// they are not ready by then.
    pub async fn wait_program_listeners(&self, timeout: Duration) -> bool {
        let mut changes = self.changes();
        let until = tokio::time::Instant::now() + timeout;
        loop {
            if self.program_listeners_ready() {
                return true;
            }
            tokio::select! {
                r = changes.changed() => if r.is_err() { return false },
                _ = tokio::time::sleep_until(until) => return self.program_listeners_ready(),
            }
        }
    }

    fn serve_listeners(&self, every_port: bool) {
        if let Ok(mut l) = self.inner.listeners.lock() {
            if every_port {
                l.every_port = true;
            } else {
                l.served_port = true;
            }
        }
    }

    fn mark_listener(&self, port: u16, state: Listener) {
        let changed = match self.inner.listeners.lock() {
            Ok(mut l) => {
                let bound = match state {
                    Listener::Bound => l.bound.insert(port),
                    Listener::Closed | Listener::Unservable => l.bound.remove(&port),
                };
                let unservable = match state {
                    Listener::Unservable => l.unservable.insert(port),
                    Listener::Bound | Listener::Closed => l.unservable.remove(&port),
                };
                bound || unservable
            }
            Err(_) => false,
        };
        if changed {
            self.inner.changed.send_modify(|g| *g = g.wrapping_add(1));
        }
    }

    fn record_port(&self, port: u16, addr: SocketAddr) {
        if let Ok(mut p) = self.inner.ports.lock() {
            p.insert(port, addr);
        }
        self.inner.changed.send_modify(|g| *g = g.wrapping_add(1));
    }

    async fn ports_loop(self, bind: IpAddr, map: PortMap, except: Option<SocketAddr>) {
        let mut changes = self.changes();
        let mut seen = std::collections::BTreeSet::new();
        let mut children = Children::default();
        loop {
            let (listening, served) =
                self.with(|c| (c.program().listening_ports(), c.program().served_port()));
            for port in listening {
                if !seen.insert(port) {
                    continue;
                }
                let addr = SocketAddr::new(bind, map.host_port(port));
                if Some(addr) == except {
                    if served == Some(port) {
                        // The robot address serves it already.
                        self.record_port(port, addr);
                    } else {
                        self.mark_listener(port, Listener::Unservable);
                        tracing::warn!(
                            port,
                            host = %addr,
                            "the AS program listens on port {port} but {addr} serves its first \
                             port; map it to another: --port-map {port}=PORT"
                        );
                    }
                    continue;
                }
                match super::bind_robot_port(addr).and_then(|l| Ok((l.local_addr()?, l))) {
                    Ok((local, listener)) => {
                        tracing::info!(port, host = %local, "the AS program's port is served");
                        self.record_port(port, local);
                        let this = self.clone();
                        children.0.push(tokio::spawn(async move {
                            this.program_accept_loop(local, Some(listener), Some(port))
                                .await;
                        }));
                    }
                    Err(e) => {
                        self.mark_listener(port, Listener::Unservable);
                        tracing::warn!(
                            port,
                            host = %addr,
                            error = %e,
                            "the AS program listens on port {port} but the host cannot serve it \
                             at {addr} (is it taken?); map it to another port: --port-map \
                             {port}=PORT (Python: port_map={{{port}: PORT}}; 0 picks a free one)"
                        )
                    }
                }
            }
            if changes.changed().await.is_err() {
                return;
            }
        }
    }

    /// Serves the program's port on `addr` (e.g. `127.0.0.1:10050`; port 0 picks one): the
    /// first port the program listens on. The real port listens exactly while the program
    /// does (between its `TCP_LISTEN` and `TCP_END_LISTEN`); a connection then waits for its
    /// `TCP_ACCEPT`.
    pub async fn serve_program_tcp(
        &self,
        addr: std::net::SocketAddr,
    ) -> std::io::Result<TcpServer> {
        let listener = super::bind_robot_port(addr)?;
        let local = listener.local_addr()?;
        // Bound once to learn the port; kept only if the program listens already (a bare
        // controller refuses connections from the start).
        let listener = self
            .with(|c| c.program().listening(None))
            .then_some(listener);
        self.serve_listeners(false);
        let this = self.clone();
        let task =
            tokio::spawn(async move { this.program_accept_loop(local, listener, None).await });
        Ok(TcpServer::new(local, task))
    }

    /// Connects an in-memory client to the program's served port (refused while the program
    /// does not listen).
    pub fn connect_program(&self) -> std::io::Result<tokio::io::DuplexStream> {
        let id = self
            .with(|c| c.program_mut().connect(None, [127, 0, 0, 1]))
            .map_err(|e| std::io::Error::new(std::io::ErrorKind::ConnectionRefused, e))?;
        let (client, server) = tokio::io::duplex(super::PIPE_CAPACITY);
        tokio::spawn(pump(self.clone(), id, server));
        Ok(client)
    }

    /// Serves the program's `port` (`None`: the served port) at `addr` while it listens.
    async fn program_accept_loop(
        self,
        addr: std::net::SocketAddr,
        mut listener: Option<tokio::net::TcpListener>,
        port: Option<u16>,
    ) {
        let mut changes = self.changes();
        let mut mark = BoundMark {
            emu: self.clone(),
            port: None,
        };
        loop {
            let (listening, program_port) = self.with(|c| {
                let p = c.program();
                (p.listening(port), port.or_else(|| p.served_port()))
            });
            if !listening {
                // Not listening: connections are refused.
                listener = None;
                if let Some(p) = program_port {
                    mark.set(p, Listener::Closed);
                }
                if changes.changed().await.is_err() {
                    return;
                }
                continue;
            }
            let l = match listener.take() {
                Some(l) => l,
                None => match super::bind_robot_port(addr) {
                    Ok(l) => l,
                    Err(e) => {
                        if let Some(p) = program_port {
                            mark.set(p, Listener::Unservable);
                        }
                        tracing::warn!(%addr, error = %e, "cannot listen; retrying");
                        tokio::time::sleep(Duration::from_millis(100)).await;
                        continue;
                    }
                },
            };
            if let Some(p) = program_port {
                mark.set(p, Listener::Bound);
            }
            tokio::select! {
                accepted = l.accept() => {
                    if let Ok((stream, peer)) = accepted {
                        // A client from a mapped host appears at its cell address.
                        let connected = self.with(|c| {
                            let ip = c.network().cell_address_of(peer.ip());
                            c.program_mut().connect(port, ip)
                        });
                        match connected {
                            Ok(id) => {
                                let _ = stream.set_nodelay(true);
                                tracing::info!(%peer, client = id.0, "client connected to the AS program");
                                tokio::spawn(pump(self.clone(), id, stream));
                            }
                            Err(e) => tracing::info!(%peer, "{e}"),
                        }
                    }
                    listener = Some(l);
                }
                r = changes.changed() => {
                    if r.is_err() {
                        return;
                    }
                    listener = Some(l);
                }
            }
        }
    }
}

/// Advances the program at its own events while the emulator lives.
async fn drive(weak: WeakEmulator) {
    loop {
        let Some(emu) = weak.upgrade() else { return };
        // Subscribe before reading the next event: a change between the two (a client
        // connecting, bytes arriving) must wake this loop, not wait for the program's next
        // timeout.
        let mut changes = emu.changes();
        let next = emu.with(|c| c.program().next_event());
        // Without an event of its own the program only waits for clients; look again now and
        // then to notice that the emulator is gone.
        let at = match next {
            Some(t) => emu.instant_of(t),
            None => tokio::time::Instant::now() + Duration::from_secs(1),
        };
        drop(emu);
        tokio::select! {
            _ = tokio::time::sleep_until(at) => {}
            _ = changes.changed() => {}
        }
    }
}

/// Makes the program's connections to other hosts (`TCP_CONNECT` through the host map) while
/// the emulator lives.
async fn dialer(weak: WeakEmulator) {
    loop {
        let Some(emu) = weak.upgrade() else { return };
        let mut changes = emu.changes();
        for d in emu.with(|c| c.program_mut().take_dials()) {
            tokio::spawn(dial(emu.clone(), d));
        }
        drop(emu);
        tokio::select! {
            r = changes.changed() => if r.is_err() { return },
            // Look again now and then to notice that the emulator is gone.
            _ = tokio::time::sleep(Duration::from_secs(1)) => {}
        }
    }
}

/// Connects one dial to its real host, reports the outcome to the program and pumps its bytes.
/// Refused: −34025 (connection failed); any other failure: −34023 (cannot reach the host).
/// Bounded by the program's own timeout: a connection made after it gave up is closed.
async fn dial(emu: Emulator, d: ProgramDial) {
    tracing::info!(cell = %d.cell, host = %d.to, "TCP_CONNECT: connecting to the mapped host");
    match tokio::net::TcpStream::connect(d.to).await {
        Ok(stream) => {
            if emu.with(|c| c.program_mut().dialed(d.client, Ok(()))) {
                let _ = stream.set_nodelay(true);
                tracing::info!(cell = %d.cell, host = %d.to, socket = d.client.0, "TCP_CONNECT: connected");
                pump(emu, d.client, stream).await;
            } else {
                tracing::info!(cell = %d.cell, "TCP_CONNECT: connected after the program gave up; closed");
            }
        }
        Err(e) => {
            let code = if e.kind() == std::io::ErrorKind::ConnectionRefused {
                TcpCode::Broken
            } else {
                TcpCode::Unreachable
            };
            tracing::warn!(
                cell = %d.cell,
                host = %d.to,
                error = %e,
                "TCP_CONNECT: the mapped host does not accept the connection (is its server \
                 running?); the program gets {}",
                code.code()
            );
            emu.with(|c| c.program_mut().dialed(d.client, Err(code.code())));
        }
    }
}

/// Moves bytes between a client connection and the program's socket `id`.
async fn pump<S>(emu: Emulator, id: ClientId, stream: S)
where
    S: tokio::io::AsyncRead + tokio::io::AsyncWrite + Unpin,
{
    use tokio::io::{AsyncReadExt, AsyncWriteExt};
    let (mut rd, mut wr) = tokio::io::split(stream);
    let reader = {
        let emu = emu.clone();
        async move {
            let mut buf = vec![0u8; super::RECEIVE_BUFFER];
            loop {
                // Fault injection: the controller stops reading for a while.
                if let Some(until) = emu.with(|c| c.reading_paused_until()) {
                    tokio::time::sleep_until(emu.instant_of(until)).await;
                    continue;
                }
                match rd.read(&mut buf).await {
                    Ok(0) | Err(_) => {
                        emu.with(|c| c.program_mut().close(id));
                        return;
                    }
                    Ok(n) => {
                        if !emu.with(|c| c.program_mut().send(id, &buf[..n])) {
                            return;
                        }
                    }
                }
            }
        }
    };
    let writer = async move {
        let mut changes = emu.changes();
        loop {
            let r = emu.with(|c| c.program_mut().recv(id));
            if !r.bytes.is_empty() {
                let sent = async {
                    wr.write_all(&r.bytes).await?;
                    wr.flush().await
                };
                if sent.await.is_err() {
                    emu.with(|c| c.program_mut().close(id));
                    return;
                }
                continue;
            }
            if r.closed {
                let _ = wr.shutdown().await;
                return;
            }
            let at = r.next_at.map(|t| emu.instant_of(t));
            tokio::select! {
                c = changes.changed() => if c.is_err() { return },
                _ = super::sleep_until_opt(at) => {}
            }
        }
    };
    // The connection ends when either side does.
    tokio::select! {
        _ = reader => {}
        _ = writer => {}
    }
}
