//! # fs020n-web
//!
//! Seeing the arm, and sharing it:
//!
//! - **The web pendant of the emulator** ([`emulator`]): a page served at `/` next to the
//!   pendant API, with a 3D view of the arm drawn from the robot model, live joints and flange
//!   pose, the operator's controls, fault injection and a strip chart. `fs020n sim --pendant`.
//! - **The hub** ([`hub`]): one session with a real (or emulated) controller, shared — a
//!   protocol-1040 face for existing clients (one controlling client, lock-step; the others
//!   watch), a safety [`Fence`](hub::Fence), the same page for a real robot, and a Foxglove
//!   live bridge (feature `foxglove`). `fs020n hub`.
//!
//! The page is HTML, JavaScript and CSS written for this project and embedded in the binary
//! ([`page`]): no third-party code, works offline. Every HTTP route is behind a
//! [`Guard`](guard::Guard): the Host must be the server's own (DNS rebinding), a cross-origin
//! request is refused, POSTs carry JSON, and a token (mandatory off loopback) is required for
//! everything but the page itself. docs/WEB.md and docs/HUB.md describe them.
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod emulator;
pub mod guard;
pub mod hub;
pub mod page;

use std::io;
use std::net::SocketAddr;

use axum::Router;
use tokio::task::JoinHandle;

pub use emulator::{emulator_app, run_robot, serve_emulator_page, RobotWithPage};
pub use hub::{Hub, HubConfig, HubState};

/// A running web server. Dropping it does not stop it; call [`WebServer::stop`].
#[derive(Debug)]
pub struct WebServer {
    addr: SocketAddr,
    task: JoinHandle<()>,
}

impl WebServer {
    /// Binds `addr` and serves the router `app` builds for the bound address (the guard needs
    /// it: port 0 picks a free port).
    pub async fn serve(
        addr: SocketAddr,
        app: impl FnOnce(SocketAddr) -> Router,
        what: &'static str,
    ) -> io::Result<WebServer> {
        let listener = tokio::net::TcpListener::bind(addr).await?;
        let local = listener.local_addr()?;
        let app = app(local);
        tracing::info!(addr = %local, "{what} listening");
        let task = tokio::spawn(async move {
            if let Err(e) = axum::serve(listener, app).await {
                tracing::warn!(error = %e, "{what} stopped");
            }
        });
        Ok(WebServer { addr: local, task })
    }

    /// The bound address.
    pub fn local_addr(&self) -> SocketAddr {
        self.addr
    }

    /// Stops serving.
    pub fn stop(self) {
        self.task.abort();
    }
}
