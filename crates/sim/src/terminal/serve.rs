//! The controller's terminal over TCP: one [`TerminalLink`] per connection, at most three
//! logged in at once (AUX1–AUX3; a fourth is told so and closed), program output pushed to
//! every session as it is printed.

use std::net::SocketAddr;
use std::time::Duration;

use fs020n_term::SessionConfig;
use tokio::io::{AsyncRead, AsyncReadExt, AsyncWrite, AsyncWriteExt};
use tokio::net::TcpListener;

use super::TerminalLink;
use crate::server::{Emulator, TcpServer, LISTENERS_WAIT};

/// How often a session looks for program output (not at every change of the controller: a
/// client streaming at the protocol port changes it hundreds of times a second).
const OUTPUT_POLL: Duration = Duration::from_millis(100);

impl Emulator {
    /// Serves the controller's AS monitor terminal on `addr` (the real controller's port is
    /// 23; port 0 picks one) until the returned task is aborted. `config` sets how the
    /// controller's output is cut in pieces (`max_piece`) and the `SAVE` chunk size.
    pub async fn serve_terminal(
        &self,
        addr: SocketAddr,
        config: SessionConfig,
    ) -> std::io::Result<TcpServer> {
        let listener = TcpListener::bind(addr).await?;
        let local = listener.local_addr()?;
        let this = self.clone();
        let task = tokio::spawn(async move {
            loop {
                let Ok((stream, peer)) = listener.accept().await else {
                    continue;
                };
                let _ = stream.set_nodelay(true);
                tracing::info!(%peer, "terminal connection");
                tokio::spawn(this.clone().run_terminal(stream, config.clone()));
            }
        });
        Ok(TcpServer::new(local, task))
    }

    /// Runs one terminal session on `stream` until either side ends it (an in-memory stream
    /// works as well as a TCP one).
    pub async fn run_terminal<S>(self, stream: S, config: SessionConfig)
    where
        S: AsyncRead + AsyncWrite + Unpin,
    {
        let (mut rd, mut wr) = tokio::io::split(stream);
        let mut link = self.with(|c| TerminalLink::open(c, config));
        let mut buf = vec![0u8; 4096];
        'session: loop {
            while let Some(piece) = link.poll_transmit() {
                let sent = async {
                    wr.write_all(&piece).await?;
                    wr.flush().await
                };
                if sent.await.is_err() {
                    self.with(|c| link.handle_close(c));
                    break 'session;
                }
            }
            if link.is_closed() {
                break;
            }
            tokio::select! {
                r = rd.read(&mut buf) => match r {
                    Ok(0) | Err(_) => {
                        self.with(|c| link.handle_close(c));
                        break;
                    }
                    Ok(n) => {
                        self.with(|c| link.handle_input(c, &buf[..n]));
                        if !self.program_listeners_ready()
                            && !self.wait_program_listeners(LISTENERS_WAIT).await
                        {
                            tracing::warn!(
                                "the AS program listens on a port whose host socket is not \
                                 listening after {LISTENERS_WAIT:?}; the prompt returns anyway"
                            );
                        }
                    }
                },
                _ = tokio::time::sleep(OUTPUT_POLL) => {}
            }
            self.with(|c| link.print_output(c));
        }
        let _ = wr.shutdown().await;
    }
}
