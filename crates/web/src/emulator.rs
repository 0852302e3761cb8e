//! The emulator's web pendant: the page, its live feed and the pendant API of `fs020n-sim`
//! (switches, E-stop, reset, monitor speed, faults), on one port.
//!
//! | path | |
//! |---|---|
//! | `GET /` | the page |
//! | `GET /live` | server-sent events: `{"kind":"emulator","snapshot":Snapshot}` 25 times a second |
//! | `GET /urdf` | the URDF generated from the model |
//! | `GET /api` and the rest | the pendant API (docs/EMULATOR.md) |

use std::io;
use std::net::SocketAddr;

use axum::extract::State;
use axum::http::header;
use axum::middleware;
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use axum::Router;
use fs020n_sim::{pendant_router, Emulator, RunningRobot, SimOptions};
use serde_json::json;

use crate::guard::{guard_layer, Guard};
use crate::page::{live_feed, page_routes};
use crate::WebServer;

async fn live(State(emulator): State<Emulator>) -> Response {
    live_feed(move || json!({"kind": "emulator", "snapshot": emulator.snapshot()}).to_string())
        .into_response()
}

async fn urdf(State(emulator): State<Emulator>) -> Response {
    let text = emulator.with(|c| c.model().to_urdf());
    (
        [(header::CONTENT_TYPE, "application/xml; charset=utf-8")],
        text,
    )
        .into_response()
}

/// The emulator's web app (page + live feed + pendant API) for a server bound to `bound`.
/// `token`, when given, is required on every request but the page itself.
pub fn emulator_app(emulator: Emulator, bound: SocketAddr, token: Option<String>) -> Router {
    Router::new()
        .merge(page_routes())
        .route("/live", get(live))
        .route("/urdf", get(urdf))
        .with_state(emulator.clone())
        .merge(pendant_router(emulator, token.clone(), bound))
        .layer(middleware::from_fn_with_state(
            Guard::new(bound, token),
            guard_layer,
        ))
}

/// Serves the emulator's web pendant on `addr`. Off loopback a token is mandatory
/// (`InvalidInput`).
pub async fn serve_emulator_page(
    emulator: Emulator,
    addr: SocketAddr,
    token: Option<String>,
) -> io::Result<WebServer> {
    Guard::require_token_off_loopback(addr, token.as_deref(), "the pendant")?;
    WebServer::serve(
        addr,
        |bound| emulator_app(emulator, bound, token),
        "pendant page and API",
    )
    .await
}

/// One emulated robot whose pendant serves the page: its robot port and (optional) web
/// pendant.
#[derive(Debug)]
pub struct RobotWithPage {
    robot: RunningRobot,
    page: Option<WebServer>,
}

impl RobotWithPage {
    /// The emulator.
    pub fn emulator(&self) -> &Emulator {
        self.robot.emulator()
    }

    /// The bound robot (protocol) port address.
    pub fn robot_addr(&self) -> SocketAddr {
        self.robot.robot_addr()
    }

    /// The bound address of the controller's terminal, if served.
    pub fn terminal_addr(&self) -> Option<SocketAddr> {
        self.robot.terminal_addr()
    }

    /// The bound pendant (page and API) address, if served.
    pub fn pendant_addr(&self) -> Option<SocketAddr> {
        self.page.as_ref().map(WebServer::local_addr)
    }

    /// Stops the robot port and the pendant.
    pub fn stop(self) {
        self.robot.stop();
        if let Some(p) = self.page {
            p.stop();
        }
    }
}

/// [`fs020n_sim::run_robot`] with the web pendant: the robot port as there, and on
/// `opts.pendant` the page, its live feed and the pendant API together.
pub async fn run_robot(mut opts: SimOptions) -> io::Result<RobotWithPage> {
    let pendant = opts.pendant.take();
    if let Some(addr) = pendant {
        Guard::require_token_off_loopback(addr, opts.pendant_token.as_deref(), "the pendant")?;
    }
    let token = opts.pendant_token.clone();
    let robot = fs020n_sim::run_robot(opts).await?;
    let page = match pendant {
        Some(addr) => match serve_emulator_page(robot.emulator().clone(), addr, token).await {
            Ok(p) => Some(p),
            Err(e) => {
                robot.stop();
                return Err(io::Error::new(
                    e.kind(),
                    format!("cannot serve the pendant on {addr}: {e}"),
                ));
            }
        },
        None => None,
    };
    Ok(RobotWithPage { robot, page })
}
