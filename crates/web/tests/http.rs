//! The web apps through their routers (no sockets): the page, the live feed, the guard, the
//! pendant API under `/api`, the hub's guarded buttons.
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

mod common;

use axum::body::Body;
use axum::http::{header, Method, Request, StatusCode};
use axum::Router;
use common::*;
use fs020n_sim::MotionTaskState;
use fs020n_web::hub::hub_app;
use fs020n_web::{emulator_app, HubConfig};
use futures_util::StreamExt;
use serde_json::Value;
use tower::ServiceExt;

const HOST: &str = "127.0.0.1:8080";

fn req(method: Method, path: &str, body: Option<&str>) -> axum::http::request::Builder {
    let mut b = Request::builder()
        .method(method)
        .uri(path)
        .header(header::HOST, HOST);
    if body.is_some() {
        b = b.header(header::CONTENT_TYPE, "application/json");
    }
    b
}

async fn call(app: &Router, r: Request<Body>) -> (StatusCode, axum::http::HeaderMap, Vec<u8>) {
    let resp = app.clone().oneshot(r).await.unwrap();
    let status = resp.status();
    let headers = resp.headers().clone();
    let body = axum::body::to_bytes(resp.into_body(), 1 << 20)
        .await
        .unwrap();
    (status, headers, body.to_vec())
}

async fn json(app: &Router, method: Method, path: &str, body: Option<&str>) -> (StatusCode, Value) {
    let r = req(method, path, body)
        .body(Body::from(body.unwrap_or("").to_owned()))
        .unwrap();
    let (s, _, b) = call(app, r).await;
    (s, serde_json::from_slice(&b).unwrap_or(Value::Null))
}

/// The first event of a live feed, as JSON.
async fn first_event(app: &Router, token: Option<&str>) -> Value {
    let mut b = req(Method::GET, "/live", None);
    if let Some(t) = token {
        b = b.header(header::AUTHORIZATION, format!("Bearer {t}"));
    }
    let resp = app
        .clone()
        .oneshot(b.body(Body::empty()).unwrap())
        .await
        .unwrap();
    assert_eq!(resp.status(), StatusCode::OK);
    assert_eq!(
        resp.headers()[header::CONTENT_TYPE].to_str().unwrap(),
        "text/event-stream"
    );
    let mut stream = resp.into_body().into_data_stream();
    let mut text = String::new();
    while !text.contains("\n\n") {
        let chunk = stream.next().await.unwrap().unwrap();
        text.push_str(std::str::from_utf8(&chunk).unwrap());
    }
    let data = text
        .lines()
        .find_map(|l| l.strip_prefix("data:"))
        .unwrap()
        .trim();
    serde_json::from_str(data).unwrap()
}

#[tokio::test]
async fn the_emulator_page_sits_beside_the_pendant_api() {
    let emu = emulator();
    let app = emulator_app(emu.clone(), HOST.parse().unwrap(), None);
    let (s, h, body) = call(
        &app,
        req(Method::GET, "/", None).body(Body::empty()).unwrap(),
    )
    .await;
    assert_eq!(s, StatusCode::OK);
    assert!(h[header::CONTENT_TYPE]
        .to_str()
        .unwrap()
        .starts_with("text/html"));
    assert!(h[header::CONTENT_SECURITY_POLICY]
        .to_str()
        .unwrap()
        .contains("frame-ancestors 'none'"));
    assert!(String::from_utf8(body)
        .unwrap()
        .contains("data-joint=\"6\""));
    let (s, h, _) = call(
        &app,
        req(Method::GET, "/assets/app.js", None)
            .body(Body::empty())
            .unwrap(),
    )
    .await;
    assert_eq!(s, StatusCode::OK);
    assert!(h[header::CONTENT_TYPE]
        .to_str()
        .unwrap()
        .starts_with("text/javascript"));
    // The JSON description moved to /api; the other routes stay.
    let (s, v) = json(&app, Method::GET, "/api", None).await;
    assert_eq!(s, StatusCode::OK);
    assert_eq!(v["service"], "fs020n emulator pendant API");
    let (s, v) = json(&app, Method::GET, "/state", None).await;
    assert_eq!(s, StatusCode::OK);
    assert_eq!(v["joints_deg"][2], -90.0);
    let (s, v) = json(&app, Method::GET, "/model", None).await;
    assert_eq!(s, StatusCode::OK);
    assert_eq!(v["geometry"]["upper_arm_m"], 0.8);
    let (s, v) = json(&app, Method::GET, "/nope", None).await;
    assert_eq!(s, StatusCode::NOT_FOUND);
    assert!(v["remedy"].as_str().unwrap().contains("/api"));
    // The live feed carries snapshots.
    let ev = first_event(&app, None).await;
    assert_eq!(ev["kind"], "emulator");
    assert_eq!(ev["snapshot"]["panel"]["run"], true);
    // A switch from the page: JSON POST, same origin.
    let r = req(Method::POST, "/panel", Some(""))
        .header(header::ORIGIN, format!("http://{HOST}"))
        .body(Body::from(r#"{"run": false}"#))
        .unwrap();
    let (s, _, _) = call(&app, r).await;
    assert_eq!(s, StatusCode::OK);
    assert!(!emu.with(|c| c.panel().run), "HOLD");
    // The URDF.
    let (s, h, body) = call(
        &app,
        req(Method::GET, "/urdf", None).body(Body::empty()).unwrap(),
    )
    .await;
    assert_eq!(s, StatusCode::OK);
    assert!(h[header::CONTENT_TYPE]
        .to_str()
        .unwrap()
        .starts_with("application/xml"));
    assert!(String::from_utf8(body).unwrap().contains("joint_6"));
}

#[tokio::test]
async fn the_guard_refuses_other_sites_rebinding_and_forms() {
    let emu = emulator();
    let app = emulator_app(emu.clone(), HOST.parse().unwrap(), Some("s3cret".into()));
    // The page needs no token; the data does.
    let (s, _, _) = call(
        &app,
        req(Method::GET, "/", None).body(Body::empty()).unwrap(),
    )
    .await;
    assert_eq!(s, StatusCode::OK);
    let (s, v) = json(&app, Method::GET, "/state", None).await;
    assert_eq!(s, StatusCode::UNAUTHORIZED);
    assert!(v["remedy"].as_str().unwrap().contains("#token="));
    let ev = first_event(&app, Some("s3cret")).await;
    assert_eq!(ev["kind"], "emulator");
    // Another site's page pressing the E-stop: refused, nothing pressed.
    let r = req(Method::POST, "/estop/press", Some(""))
        .header(header::AUTHORIZATION, "Bearer s3cret")
        .header(header::ORIGIN, "http://evil.example")
        .body(Body::from("{}"))
        .unwrap();
    assert_eq!(call(&app, r).await.0, StatusCode::FORBIDDEN);
    // A form post (no JSON content type).
    let r = Request::builder()
        .method(Method::POST)
        .uri("/estop/press")
        .header(header::HOST, HOST)
        .header(header::AUTHORIZATION, "Bearer s3cret")
        .header(header::CONTENT_TYPE, "application/x-www-form-urlencoded")
        .body(Body::from("a=b"))
        .unwrap();
    assert_eq!(call(&app, r).await.0, StatusCode::UNSUPPORTED_MEDIA_TYPE);
    // DNS rebinding: the attacker's host name.
    let r = Request::builder()
        .uri("/state")
        .header(header::HOST, "evil.example:8080")
        .header(header::AUTHORIZATION, "Bearer s3cret")
        .body(Body::empty())
        .unwrap();
    assert_eq!(call(&app, r).await.0, StatusCode::MISDIRECTED_REQUEST);
    assert!(!emu.with(|c| c.panel().estop));
    // The page's own request goes through.
    let r = req(Method::POST, "/estop/press", Some(""))
        .header(header::AUTHORIZATION, "Bearer s3cret")
        .header(header::ORIGIN, format!("http://{HOST}"))
        .body(Body::from("{}"))
        .unwrap();
    assert_eq!(call(&app, r).await.0, StatusCode::OK);
    assert!(emu.with(|c| c.panel().estop));
}

#[tokio::test(start_paused = true)]
async fn the_hub_page_shows_the_robot_and_guards_its_buttons() {
    let emu = emulator();
    let hub = hub(&emu, HubConfig::default()).await;
    let app = hub_app(hub.clone(), HOST.parse().unwrap(), None);
    let ev = first_event(&app, None).await;
    assert_eq!(ev["kind"], "hub");
    assert_eq!(ev["hub"]["status"]["joints_deg"][2], -90.0);
    assert_eq!(ev["hub"]["link"]["connected"], true);
    let (s, v) = json(&app, Method::GET, "/model", None).await;
    assert_eq!(s, StatusCode::OK);
    assert_eq!(v["joints"][0]["max_deg"], 160.0);
    // The robot is running a program (started by a client of the face).
    let mut a = Raw::connect(&hub, "a");
    a.request("1040 1 0").await;
    assert_eq!(emu.with(|c| c.task()), MotionTaskState::Running);
    // Stop without the confirmation: refused.
    let (s, _) = json(&app, Method::POST, "/stop", Some("{}")).await;
    assert_eq!(s, StatusCode::UNPROCESSABLE_ENTITY);
    let (s, _) = json(&app, Method::POST, "/stop", Some(r#"{"confirm": false}"#)).await;
    assert_eq!(s, StatusCode::UNPROCESSABLE_ENTITY);
    assert_eq!(emu.with(|c| c.task()), MotionTaskState::Running);
    // Confirmed: command 2.
    let (s, v) = json(&app, Method::POST, "/stop", Some(r#"{"confirm": true}"#)).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    // Signal 2007 ends the program once it has been stable for 50 ms.
    sleep_ms(100).await;
    assert_eq!(emu.with(|c| c.task()), MotionTaskState::NotRunning);
    assert_eq!(v["counters"]["page_actions"], 1);
    let (s, _) = json(&app, Method::POST, "/cancel", Some(r#"{"confirm": true}"#)).await;
    assert_eq!(s, StatusCode::OK);
    // The hub has no switches to flip.
    let (s, _) = json(&app, Method::POST, "/panel", Some(r#"{"run": false}"#)).await;
    assert_eq!(s, StatusCode::NOT_FOUND);
}
