//! The hub's web page and its JSON API.
//!
//! | method and path | body | does |
//! |---|---|---|
//! | `GET /` | – | the page (switches shown, not switchable; guarded Cancel and Stop) |
//! | `GET /api` | – | lists the endpoints |
//! | `GET /state` | – | [`HubState`] |
//! | `GET /model` | – | the robot model (the page draws the arm from it) |
//! | `GET /urdf` | – | the URDF generated from the model |
//! | `GET /live` | – | server-sent events: `{"kind":"hub","hub":HubState}` 25 times a second |
//! | `POST /cancel` | `{"confirm": true}` | command 5 (brake; the program keeps running) |
//! | `POST /stop` | `{"confirm": true}` | command 2 (stop at once; the program ends) |
//!
//! Every route is behind the [`Guard`] (Host, Origin, JSON POSTs, token).

use std::io;
use std::net::SocketAddr;

use axum::extract::rejection::JsonRejection;
use axum::extract::State;
use axum::http::{header, StatusCode, Uri};
use axum::middleware;
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use axum::{Json, Router};
use serde::Deserialize;
use serde_json::{json, Value};

use super::{Hub, HubState};
use crate::guard::{guard_layer, Guard, WebError};
use crate::page::{live_feed, page_routes};
use crate::WebServer;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Confirm {
    confirm: bool,
}

fn confirmed(body: Result<Json<Confirm>, JsonRejection>, what: &str) -> Result<(), WebError> {
    let remedy = format!("send {{\"confirm\": true}} to {what}");
    match body {
        Ok(Json(Confirm { confirm: true })) => Ok(()),
        Ok(_) => Err(WebError::new(
            StatusCode::UNPROCESSABLE_ENTITY,
            "not confirmed",
            remedy,
        )),
        Err(e) => Err(WebError::new(
            e.status(),
            format!("bad request body: {}", e.body_text()),
            remedy,
        )),
    }
}

fn failed(e: fs020n_client::ClientError) -> WebError {
    WebError::new(
        StatusCode::BAD_GATEWAY,
        e.to_string(),
        "check the session with the controller (the page's link line)",
    )
}

async fn state(State(hub): State<Hub>) -> Json<HubState> {
    Json(hub.state())
}

async fn stop(
    State(hub): State<Hub>,
    body: Result<Json<Confirm>, JsonRejection>,
) -> Result<Json<HubState>, WebError> {
    confirmed(body, "stop the robot (command 2)")?;
    hub.count_page_action();
    hub.stop_robot("page").await.map_err(failed)?;
    Ok(Json(hub.state()))
}

async fn cancel(
    State(hub): State<Hub>,
    body: Result<Json<Confirm>, JsonRejection>,
) -> Result<Json<HubState>, WebError> {
    confirmed(body, "cancel the motion (command 5)")?;
    hub.count_page_action();
    hub.cancel_motion("page").await.map_err(failed)?;
    Ok(Json(hub.state()))
}

async fn model(State(hub): State<Hub>) -> Json<Value> {
    Json(serde_json::to_value(hub.model()).unwrap_or(Value::Null))
}

async fn urdf(State(hub): State<Hub>) -> Response {
    (
        [(header::CONTENT_TYPE, "application/xml; charset=utf-8")],
        hub.model().to_urdf(),
    )
        .into_response()
}

async fn live(State(hub): State<Hub>) -> Response {
    live_feed(move || json!({"kind": "hub", "hub": hub.state()}).to_string()).into_response()
}

async fn index() -> Json<Value> {
    Json(json!({
        "service": "fs020n hub",
        "endpoints": [
            "GET /", "GET /api", "GET /state", "GET /model", "GET /urdf", "GET /live",
            "POST /cancel {\"confirm\": true}", "POST /stop {\"confirm\": true}"
        ],
        "docs": "docs/HUB.md"
    }))
}

async fn not_found(uri: Uri) -> WebError {
    WebError::new(
        StatusCode::NOT_FOUND,
        format!("no such endpoint: {}", uri.path()),
        "GET /api lists the endpoints; docs/HUB.md describes them",
    )
}

/// The hub's web app for a server bound to `bound`, with an optional token (mandatory off
/// loopback: [`serve_hub_page`] refuses to start without one).
pub fn hub_app(hub: Hub, bound: SocketAddr, token: Option<String>) -> Router {
    Router::new()
        .merge(page_routes())
        .route("/api", get(index))
        .route("/state", get(state))
        .route("/model", get(model))
        .route("/urdf", get(urdf))
        .route("/live", get(live))
        .route("/stop", post(stop))
        .route("/cancel", post(cancel))
        .fallback(not_found)
        .with_state(hub)
        .layer(middleware::from_fn_with_state(
            Guard::new(bound, token),
            guard_layer,
        ))
}

/// Serves the hub's page on `addr`. Off loopback a token is mandatory (`InvalidInput`).
pub async fn serve_hub_page(
    hub: Hub,
    addr: SocketAddr,
    token: Option<String>,
) -> io::Result<WebServer> {
    Guard::require_token_off_loopback(addr, token.as_deref(), "the hub's page")?;
    WebServer::serve(addr, |bound| hub_app(hub, bound, token), "hub page").await
}
