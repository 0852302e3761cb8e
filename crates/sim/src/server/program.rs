//! The emulator serving an AS program's clients: a background task that advances the program
//! at its own events, the served port (listening exactly while the program does) and the pump
//! that moves a connection's bytes to and from the program's socket.

use std::time::Duration;

use super::{Emulator, TcpServer, WeakEmulator};
use crate::controller::Controller;
use crate::machine::ControllerConfig;
use crate::program::{ClientId, ServerProgram};

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
        Emulator::driven(Controller::bare(config))
    }

    /// An emulator of `controller` whose AS programs a background task advances at their own
    /// events (see [`Emulator::with_program`]).
    pub fn driven(controller: Controller) -> Emulator {
        let emu = Emulator::from_controller(controller);
        if let Ok(rt) = tokio::runtime::Handle::try_current() {
            rt.spawn(drive(emu.downgrade()));
        }
        emu
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
        let listener = self.with(|c| c.program_listening(None)).then_some(listener);
        let this = self.clone();
        let task = tokio::spawn(async move { this.program_accept_loop(local, listener).await });
        Ok(TcpServer::new(local, task))
    }

    /// Connects an in-memory client to the program's served port (refused while the program
    /// does not listen).
    pub fn connect_program(&self) -> std::io::Result<tokio::io::DuplexStream> {
        let id = self
            .with(|c| c.program_connect(None, [127, 0, 0, 1]))
            .map_err(|e| std::io::Error::new(std::io::ErrorKind::ConnectionRefused, e))?;
        let (client, server) = tokio::io::duplex(super::PIPE_CAPACITY);
        tokio::spawn(pump(self.clone(), id, server));
        Ok(client)
    }

    async fn program_accept_loop(
        self,
        addr: std::net::SocketAddr,
        mut listener: Option<tokio::net::TcpListener>,
    ) {
        let mut changes = self.changes();
        loop {
            if !self.with(|c| c.program_listening(None)) {
                // Not listening: connections are refused.
                listener = None;
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
                        tracing::warn!(%addr, error = %e, "cannot listen; retrying");
                        tokio::time::sleep(Duration::from_millis(100)).await;
                        continue;
                    }
                },
            };
            tokio::select! {
                accepted = l.accept() => {
                    if let Ok((stream, peer)) = accepted {
                        let ip = match peer.ip() {
                            std::net::IpAddr::V4(v4) => v4.octets(),
                            std::net::IpAddr::V6(v6) => v6.to_ipv4_mapped().map_or([0; 4], |v| v.octets()),
                        };
                        match self.with(|c| c.program_connect(None, ip)) {
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
        let next = emu.with(|c| c.next_program_event());
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
                        emu.with(|c| c.program_close(id));
                        return;
                    }
                    Ok(n) => {
                        if !emu.with(|c| c.program_send(id, &buf[..n])) {
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
            let r = emu.with(|c| c.program_recv(id));
            if !r.bytes.is_empty() {
                let sent = async {
                    wr.write_all(&r.bytes).await?;
                    wr.flush().await
                };
                if sent.await.is_err() {
                    emu.with(|c| c.program_close(id));
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
