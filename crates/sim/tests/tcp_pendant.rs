//! End-to-end over real loopback TCP: the robot port (listen windows, one client, 255) and the
//! pendant HTTP API, and `run_robot`. Fast: no test waits for a 3-second window in real time.
#![cfg(feature = "pendant")]

use std::net::SocketAddr;
use std::time::Duration;

use fs020n_proto::{ReplyDecoder, Status};
use fs020n_sim::Timing;
use fs020n_sim::{
    run_robot, serve_pendant, ControllerConfig, Emulator, MotionTaskState, Panel, SimOptions,
};
use serde_json::Value;
use tokio::io::{AsyncRead, AsyncReadExt, AsyncWrite, AsyncWriteExt};
use tokio::net::TcpStream;

async fn roundtrip<S: AsyncRead + AsyncWrite + Unpin>(s: &mut S, req: &str) -> Status {
    s.write_all(req.as_bytes()).await.unwrap();
    let mut d = ReplyDecoder::new();
    let mut buf = [0u8; 256];
    loop {
        let n = s.read(&mut buf).await.unwrap();
        assert!(n > 0, "eof");
        d.push(&buf[..n]).unwrap();
        if let Some(f) = d.next_reply().unwrap() {
            return f.status;
        }
    }
}

/// A minimal HTTP/1.1 client: returns (status, JSON body).
async fn http(
    addr: SocketAddr,
    method: &str,
    path: &str,
    body: Option<&str>,
    token: Option<&str>,
) -> (u16, Value) {
    http_with(
        addr,
        method,
        path,
        body,
        token,
        &[("Host", &addr.to_string())],
    )
    .await
}

/// Like [`http`] with the given extra headers (a `Host` among them replaces the default).
async fn http_with(
    addr: SocketAddr,
    method: &str,
    path: &str,
    body: Option<&str>,
    token: Option<&str>,
    headers: &[(&str, &str)],
) -> (u16, Value) {
    let mut s = TcpStream::connect(addr).await.unwrap();
    let mut req = format!("{method} {path} HTTP/1.1\r\nConnection: close\r\n");
    for (k, v) in headers {
        req.push_str(&format!("{k}: {v}\r\n"));
    }
    if let Some(t) = token {
        req.push_str(&format!("Authorization: Bearer {t}\r\n"));
    }
    if let Some(b) = body {
        if !headers
            .iter()
            .any(|(k, _)| k.eq_ignore_ascii_case("content-type"))
        {
            req.push_str("Content-Type: application/json\r\n");
        }
        req.push_str(&format!("Content-Length: {}\r\n\r\n{b}", b.len()));
    } else if method == "POST"
        && !headers
            .iter()
            .any(|(k, _)| k.eq_ignore_ascii_case("content-type"))
    {
        req.push_str("Content-Type: application/json\r\nContent-Length: 0\r\n\r\n");
    } else {
        req.push_str("Content-Length: 0\r\n\r\n");
    }
    s.write_all(req.as_bytes()).await.unwrap();
    let mut out = Vec::new();
    s.read_to_end(&mut out).await.unwrap();
    let text = String::from_utf8(out).unwrap();
    let status: u16 = text[9..12].parse().unwrap();
    let (head, body) = text.split_once("\r\n\r\n").unwrap();
    let body = if head
        .to_ascii_lowercase()
        .contains("transfer-encoding: chunked")
    {
        dechunk(body)
    } else {
        body.to_owned()
    };
    let v = if body.is_empty() {
        Value::Null
    } else {
        serde_json::from_str(&body).unwrap()
    };
    (status, v)
}

fn dechunk(mut s: &str) -> String {
    let mut out = String::new();
    loop {
        let (len, rest) = s.split_once("\r\n").unwrap();
        let n = usize::from_str_radix(len.trim(), 16).unwrap();
        if n == 0 {
            return out;
        }
        out.push_str(&rest[..n]);
        s = &rest[n + 2..];
    }
}

fn local() -> SocketAddr {
    "127.0.0.1:0".parse().unwrap()
}

#[tokio::test]
async fn tcp_session_one_client_255_and_relisten() {
    let emu = Emulator::new(ControllerConfig::default());
    let server = emu.serve_tcp(local()).await.unwrap();
    let mut s = TcpStream::connect(server.local_addr()).await.unwrap();
    s.set_nodelay(true).unwrap();
    let st = roundtrip(&mut s, "1040 1 0").await;
    assert!(st.task_running);
    // one client: the port does not even listen during a session
    tokio::time::sleep(Duration::from_millis(20)).await;
    assert!(TcpStream::connect(server.local_addr()).await.is_err());
    let st = roundtrip(&mut s, "1040 6 9 0 0 0 5 0 -90 0 -90 0").await;
    assert_eq!(st.version, 1040);
    let st = roundtrip(&mut s, "1040 255 0").await;
    assert!(st.task_running, "reply to 255 is still sent");
    let mut buf = [0u8; 16];
    assert_eq!(s.read(&mut buf).await.unwrap(), 0, "then the socket closes");
    // then signal 2007 ends the program once stable for 50 ms
    assert!(emu.with(|c| c.native().stop_signal()));
    let mut waited = 0;
    while emu.with(|c| c.task()) != MotionTaskState::NotRunning {
        assert!(waited < 200, "the program did not end");
        tokio::time::sleep(Duration::from_millis(10)).await;
        waited += 1;
    }
    let mut again = None;
    for _ in 0..100 {
        if let Ok(c) = TcpStream::connect(server.local_addr()).await {
            again = Some(c);
            break;
        }
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    let mut s2 = again.expect("listening again");
    let st = roundtrip(&mut s2, "0 0 0").await;
    assert!(st.timer.seconds().unwrap() < 0.5);
    server.stop();
}

#[tokio::test]
async fn tcp_listen_gap_refuses_connections() {
    // Shortened windows (a test-only knob) to see a gap over real TCP quickly.
    let cfg = ControllerConfig {
        timing: Timing {
            accept_window: Duration::from_millis(150),
            listen_gap: Duration::from_millis(300),
            ..Timing::default()
        },
        ..ControllerConfig::default()
    };
    let emu = Emulator::new(cfg);
    let server = emu.serve_tcp(local()).await.unwrap();
    // wait for the gap, and a little more for the accept loop to close the port
    let mut waited = 0;
    while emu.with(|c| c.native().is_listening()) {
        tokio::time::sleep(Duration::from_millis(5)).await;
        waited += 1;
        assert!(waited < 200);
    }
    tokio::time::sleep(Duration::from_millis(50)).await;
    assert!(!emu.with(|c| c.native().is_listening()));
    let refused = TcpStream::connect(server.local_addr()).await;
    assert!(refused.is_err(), "refused during the gap");
    // a client that retries gets in with the next window
    let mut ok = None;
    for _ in 0..200 {
        if let Ok(s) = TcpStream::connect(server.local_addr()).await {
            ok = Some(s);
            break;
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    let mut s = ok.expect("connected in the next window");
    roundtrip(&mut s, "0 0 0").await;
    assert!(emu.with(|c| c.counters().sessions) == 1);
    server.stop();
}

#[tokio::test]
async fn pendant_api_end_to_end() {
    let emu = Emulator::new(ControllerConfig::default());
    let robot = emu.serve_tcp(local()).await.unwrap();
    let pendant = serve_pendant(emu.clone(), local(), None).await.unwrap();
    let p = pendant.local_addr();
    let mut s = TcpStream::connect(robot.local_addr()).await.unwrap();
    roundtrip(&mut s, "1040 1 0").await;

    let (code, v) = http(p, "GET", "/state", None, None).await;
    assert_eq!(code, 200);
    assert_eq!(v["panel"]["power"], true);
    assert_eq!(v["task"], "running");
    assert_eq!(v["monitor_speed_percent"], 10.0);
    assert_eq!(v["session"]["open"], true);
    assert_eq!(v["session"]["newest_command"]["number"], 1.0);
    assert_eq!(v["session"]["newest_index"], 1);
    assert_eq!(v["error"]["code"], 0);
    assert_eq!(v["joints_deg"][2], -90.0);
    assert!((v["tool"]["x_mm"].as_f64().unwrap() - 850.0).abs() < 1e-6);
    assert!((v["tool"]["z_mm"].as_f64().unwrap() - 1153.5).abs() < 1e-6);
    assert!((v["tool"]["a_deg"].as_f64().unwrap() - 180.0).abs() < 1e-6);
    assert_eq!(v["motion"], "idle");

    let (code, v) = http(p, "GET", "/model", None, None).await;
    assert_eq!(code, 200);
    assert_eq!(v["joints"][0]["max_deg"], 160.0);

    // HOLD from the pendant shows in the protocol reply
    let (code, v) = http(p, "POST", "/panel", Some(r#"{"run": false}"#), None).await;
    assert_eq!(code, 200);
    assert_eq!(v["task"], "paused");
    let st = roundtrip(&mut s, "0 0 0").await;
    assert!(!st.run && !st.task_running);
    http(p, "POST", "/panel", Some(r#"{"run": true}"#), None).await;

    let (code, v) = http(p, "POST", "/speed", Some(r#"{"percent": 55}"#), None).await;
    assert_eq!(code, 200);
    assert_eq!(v["monitor_speed_percent"], 55.0);
    let (code, v) = http(p, "POST", "/speed", Some(r#"{"percent": 0}"#), None).await;
    assert_eq!(code, 422);
    assert!(v["error"].as_str().unwrap().contains("monitor speed"));
    assert!(v["remedy"].is_string());

    // e-stop: power cut, E3808; power on and reset refused while pressed
    let (_, v) = http(p, "POST", "/estop/press", None, None).await;
    assert_eq!(v["error"]["name"], "E3808");
    assert_eq!(v["panel"]["power"], false);
    assert_eq!(v["task"], "not_running");
    let (code, v) = http(p, "POST", "/panel", Some(r#"{"power": true}"#), None).await;
    assert_eq!(code, 409);
    assert!(v["remedy"].as_str().unwrap().contains("/estop/release"));
    let (code, _) = http(p, "POST", "/reset", None, None).await;
    assert_eq!(code, 409);
    http(p, "POST", "/estop/release", None, None).await;
    let (code, v) = http(p, "POST", "/reset", None, None).await;
    assert_eq!(code, 200);
    assert_eq!(v["error"]["code"], 0);
    let (_, v) = http(p, "POST", "/panel", Some(r#"{"power": true}"#), None).await;
    assert_eq!(v["panel"]["power"], true);
    let st = roundtrip(&mut s, "0 0 0").await;
    assert!(st.power && st.error.is_none());

    // faults: by name, and JSON errors
    let (code, v) = http(
        p,
        "POST",
        "/faults",
        Some(r#"{"kind": "raise_error", "code": "E1130"}"#),
        None,
    )
    .await;
    assert_eq!(code, 200);
    assert_eq!(v["error"]["code"], -31130);
    http(p, "POST", "/reset", None, None).await;
    let (code, v) = http(
        p,
        "POST",
        "/faults",
        Some(r#"{"kind": "garbage_reply", "text": "xx"}"#),
        None,
    )
    .await;
    assert_eq!(code, 200);
    assert_eq!(v["pending_faults"], 1);
    let (_, v) = http(p, "DELETE", "/faults", None, None).await;
    assert_eq!(v["pending_faults"], 0);
    let (code, v) = http(p, "POST", "/faults", Some(r#"{"kind": "explode"}"#), None).await;
    assert_eq!(code, 422);
    assert!(v["remedy"].as_str().unwrap().contains("delay_replies"));
    let (code, v) = http(p, "POST", "/faults", Some("{not json"), None).await;
    assert_eq!(code, 400);
    assert!(v["error"].is_string());
    let (code, v) = http(p, "POST", "/panel", Some(r#"{"runn": true}"#), None).await;
    assert_eq!(code, 422, "unknown switch: {v}");
    let (code, v) = http(p, "GET", "/nope", None, None).await;
    assert_eq!(code, 404);
    assert!(v["remedy"].is_string());
    let (code, v) = http(p, "DELETE", "/state", None, None).await;
    assert_eq!(code, 405);
    assert!(v["error"].is_string());
    let (code, v) = http(
        p,
        "POST",
        "/faults",
        Some(r#"{"kind": "close_connection"}"#),
        None,
    )
    .await;
    assert_eq!(code, 200);
    assert_eq!(v["session"]["last_end"]["reason"], "fault");
    let mut buf = [0u8; 8];
    assert_eq!(s.read(&mut buf).await.unwrap(), 0);
    pendant.stop();
    robot.stop();
}

#[tokio::test]
async fn pendant_token_rules() {
    let emu = Emulator::new(ControllerConfig::default());
    let e = serve_pendant(emu.clone(), "0.0.0.0:0".parse().unwrap(), None)
        .await
        .unwrap_err();
    assert_eq!(e.kind(), std::io::ErrorKind::InvalidInput);
    let e = serve_pendant(
        emu.clone(),
        "0.0.0.0:0".parse().unwrap(),
        Some(String::new()),
    )
    .await
    .unwrap_err();
    assert_eq!(
        e.kind(),
        std::io::ErrorKind::InvalidInput,
        "an empty token is no token"
    );
    // off loopback with a token (we talk to it through loopback)
    let server = serve_pendant(
        emu.clone(),
        "0.0.0.0:0".parse().unwrap(),
        Some("s3cret".into()),
    )
    .await
    .unwrap();
    let addr = SocketAddr::from(([127, 0, 0, 1], server.local_addr().port()));
    let (code, v) = http(addr, "GET", "/state", None, None).await;
    assert_eq!(code, 401);
    assert!(v["remedy"]
        .as_str()
        .unwrap()
        .contains("Authorization: Bearer"));
    let (code, _) = http(addr, "GET", "/state", None, Some("wrong")).await;
    assert_eq!(code, 401);
    let (code, v) = http(addr, "GET", "/state", None, Some("s3cret")).await;
    assert_eq!(code, 200);
    assert_eq!(v["task"], "not_running");
    server.stop();
}

#[tokio::test]
async fn run_robot_starts_both_servers_and_several_robots_coexist() {
    let a = run_robot(
        SimOptions::default()
            .listen(local())
            .pendant(local())
            .monitor_speed(40.0)
            .panel(Panel {
                teach_lock: true,
                ..Panel::default()
            }),
    )
    .await
    .unwrap();
    let b = run_robot(SimOptions::default().listen(local()))
        .await
        .unwrap();
    assert_ne!(a.robot_addr(), b.robot_addr());
    assert!(b.pendant_addr().is_none());
    let mut sa = TcpStream::connect(a.robot_addr()).await.unwrap();
    let mut sb = TcpStream::connect(b.robot_addr()).await.unwrap();
    let st = roundtrip(&mut sa, "1040 1 0").await;
    assert!(
        st.teach_lock && !st.task_running,
        "lock ON: command 1 ignored"
    );
    let st = roundtrip(&mut sb, "1040 1 0").await;
    assert!(!st.teach_lock && st.task_running);
    let (code, v) = http(a.pendant_addr().unwrap(), "GET", "/state", None, None).await;
    assert_eq!(code, 200);
    assert_eq!(v["monitor_speed_percent"], 40.0);
    assert_eq!(a.emulator().snapshot().monitor_speed_percent, 40.0);
    a.stop();
    b.stop();
    // bad options are refused with a message
    let e = run_robot(SimOptions::default().listen(local()).monitor_speed(0.0))
        .await
        .unwrap_err();
    assert!(e.to_string().contains("monitor speed"));
    let e = run_robot(
        SimOptions::default()
            .listen(local())
            .joints(fs020n_proto::JointsDeg::new([
                0.0, 0.0, -90.0, 0.0, -170.0, 0.0,
            ])),
    )
    .await
    .unwrap_err();
    assert!(e.to_string().contains("JT5"), "{e}");
    let e = run_robot(
        SimOptions::default()
            .listen(local())
            .model_file("/nonexistent/model.toml"),
    )
    .await
    .unwrap_err();
    assert_eq!(e.kind(), std::io::ErrorKind::NotFound);
    let e = run_robot(
        SimOptions::default()
            .listen(local())
            .pendant("0.0.0.0:0".parse().unwrap()),
    )
    .await
    .unwrap_err();
    assert!(e.to_string().contains("token"));
}

#[tokio::test]
async fn pendant_refuses_what_a_foreign_web_page_can_send() {
    let emu = Emulator::new(ControllerConfig::default());
    let pendant = serve_pendant(emu.clone(), local(), None).await.unwrap();
    let addr = pendant.local_addr();
    let own = format!("http://{addr}");
    let port = addr.port();
    // DNS rebinding: a page of evil.example resolved to 127.0.0.1 sends its own Host
    let (st, v) = http_with(
        addr,
        "POST",
        "/estop/press",
        None,
        None,
        &[("Host", &format!("evil.example:{port}"))],
    )
    .await;
    assert_eq!(st, 421, "{v}");
    assert!(v["remedy"]
        .as_str()
        .unwrap()
        .contains("address it listens on"));
    let (st, _) = http_with(addr, "GET", "/state", None, None, &[]).await;
    assert_eq!(st, 421, "no Host at all");
    // a cross-site fetch from another origin
    let (st, v) = http_with(
        addr,
        "POST",
        "/estop/press",
        None,
        None,
        &[
            ("Host", &addr.to_string()),
            ("Origin", "http://evil.example"),
        ],
    )
    .await;
    assert_eq!(st, 403, "{v}");
    let (st, _) = http_with(
        addr,
        "POST",
        "/estop/press",
        None,
        None,
        &[("Host", &addr.to_string()), ("Origin", "null")],
    )
    .await;
    assert_eq!(st, 403);
    // a form post (text/plain or urlencoded) — the kind a page can send without a preflight
    for ct in [
        "text/plain",
        "application/x-www-form-urlencoded",
        "multipart/form-data; boundary=x",
    ] {
        let (st, v) = http_with(
            addr,
            "POST",
            "/estop/press",
            Some("{}"),
            None,
            &[("Host", &addr.to_string()), ("Content-Type", ct)],
        )
        .await;
        assert_eq!(st, 415, "{ct}: {v}");
    }
    assert!(
        !emu.with(|c| c.panel().estop),
        "nothing above pressed the E-stop"
    );
    // the pendant's own page (same origin, JSON) and curl (no Origin) are served
    let (st, _) = http_with(
        addr,
        "POST",
        "/estop/press",
        None,
        None,
        &[
            ("Host", &format!("localhost:{port}")),
            ("Origin", &own),
            ("Content-Type", "application/json; charset=utf-8"),
        ],
    )
    .await;
    assert_eq!(st, 200);
    assert!(emu.with(|c| c.panel().estop));
    let (st, _) = http(addr, "POST", "/estop/release", None, None).await;
    assert_eq!(st, 200);
    pendant.stop();
}

#[tokio::test]
async fn pendant_validates_fault_parameters_and_switches_abs_speed_off() {
    let emu = Emulator::new(ControllerConfig::default());
    let pendant = serve_pendant(emu.clone(), local(), None).await.unwrap();
    let addr = pendant.local_addr();
    for bad in [
        r#"{"kind": "split_reply", "parts": 0, "gap_ms": 10}"#,
        r#"{"kind": "split_reply", "parts": 1, "gap_ms": 10}"#,
    ] {
        let (st, v) = http(addr, "POST", "/faults", Some(bad), None).await;
        assert_eq!(st, 422, "{bad}: {v}");
    }
    assert_eq!(emu.with(|c| c.pending_faults()), 0);
    // ABS.SPEED: on by a command 3, shown, and off only from the pendant
    emu.with(|c| {
        let id = c.try_accept().unwrap();
        c.handle_request(id, b"1040 3 1 40").unwrap();
        c.handle_request(id, b"1040 255 0").unwrap();
    });
    let (_, v) = http(addr, "GET", "/abs_speed", None, None).await;
    assert_eq!(v["on"], true);
    let (_, v) = http(addr, "GET", "/state", None, None).await;
    assert_eq!(v["abs_speed"], true, "survives the session");
    let (st, v) = http(addr, "POST", "/abs_speed", Some(r#"{"on": false}"#), None).await;
    assert_eq!(st, 200);
    assert_eq!(v["abs_speed"], false);
    pendant.stop();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn pendant_network_shows_the_address_host_map_and_served_ports_and_replaces_the_host_map() {
    let text = ".PROGRAM autostart.pc()\n\
  TCP_LISTEN lret, 9500\n\
  TCP_ACCEPT sock, 9500, 60\n\
.END\n";
    let program = fs020n_sim::ServerProgram::from_source("net.as", text).unwrap();
    let network = fs020n_sim::Network::default().address("10.0.0.7".parse().unwrap());
    let emu = Emulator::with_program(
        ControllerConfig {
            network,
            ..ControllerConfig::default()
        },
        program,
    );
    let ports = emu.serve_program_ports(
        "127.0.0.1".parse().unwrap(),
        fs020n_sim::PortMap::same().map(9500, 0),
        None,
    );
    let served = emu
        .wait_program_port(9500, Duration::from_secs(10))
        .await
        .expect("port 9500 served");
    let p = serve_pendant(emu.clone(), local(), None).await.unwrap();
    let addr = p.local_addr();

    let (code, v) = http(addr, "GET", "/network", None, None).await;
    assert_eq!(code, 200, "{v}");
    assert_eq!(v["address"], "10.0.0.7");
    assert_eq!(v["hosts"], serde_json::json!({}));
    assert_eq!(v["listening"], serde_json::json!([9500]));
    assert_eq!(v["served"]["9500"], served.to_string());
    assert_eq!(v["port_map"]["ports"]["9500"], 0);
    assert_eq!(v["port_map"]["unlisted"], "same");

    let body = r#"{"hosts": {"192.168.0.10": "127.0.0.1"}}"#;
    let (code, v) = http(addr, "POST", "/network/hosts", Some(body), None).await;
    assert_eq!(code, 200, "{v}");
    assert_eq!(v["hosts"]["192.168.0.10"], "127.0.0.1");
    assert_eq!(v["address"], "10.0.0.7", "the address stays");
    let cell = std::net::Ipv4Addr::new(192, 168, 0, 10);
    assert_eq!(
        emu.with(|c| c.network().hosts.get(&cell).copied()),
        Some("127.0.0.1".parse().unwrap()),
        "the controller routes through the new map"
    );

    let (code, v) = http(
        addr,
        "POST",
        "/network/hosts",
        Some(r#"{"hosts": {"pc": "127.0.0.1"}}"#),
        None,
    )
    .await;
    assert!(code == 400 || code == 422, "{code} {v}");
    assert!(
        v["remedy"].as_str().unwrap().contains("192.168.0.10"),
        "{v}"
    );
    let (_, v) = http(addr, "GET", "/network", None, None).await;
    assert_eq!(
        v["hosts"]["192.168.0.10"], "127.0.0.1",
        "a refused map changes nothing"
    );
    ports.stop();
    p.stop();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn pendant_shows_what_the_programs_interface_panel_shows() {
    let text = ".PROGRAM autostart.pc()\n\
  IFPWPRINT 2, 1, 1, 4, 10 = \"Ready\", \"cycle 7\"\n\
  IFPTITLE 1, \"Cell\"\n\
.END\n";
    let program = fs020n_sim::ServerProgram::from_source("panel.as", text).unwrap();
    let emu = Emulator::with_program(ControllerConfig::default(), program);
    let p = serve_pendant(emu.clone(), local(), None).await.unwrap();
    let addr = p.local_addr();
    let mut v = Value::Null;
    for _ in 0..200 {
        let (code, got) = http(addr, "GET", "/interface-panel", None, None).await;
        assert_eq!(code, 200, "{got}");
        v = got;
        if v["titles"]["1"] == "Cell" {
            break;
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    assert_eq!(
        v["windows"][1]["rows"],
        serde_json::json!(["Ready", "cycle 7", "", ""])
    );
    assert_eq!(v["windows"][1]["background"], 4);
    assert_eq!(v["titles"]["1"], "Cell");
    // The native server has no interface panel: 404 with what to do.
    let native = serve_pendant(Emulator::new(ControllerConfig::default()), local(), None)
        .await
        .unwrap();
    let (code, v) = http(native.local_addr(), "GET", "/interface-panel", None, None).await;
    assert_eq!(code, 404, "{v}");
}
