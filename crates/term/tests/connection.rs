//! The TCP driver against a terminal session served on loopback, the controller's output sent
//! in 5-byte pieces: login, a command, a load and its transcript.
#![cfg(feature = "tokio")]

mod common;

use std::sync::{Arc, Mutex};
use std::time::Duration;

use common::Shelf;
use fs020n_term::connection::{ConnectionError, Direction, TerminalConnection};
use fs020n_term::{ClientConfig, SessionConfig, TerminalSession};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::TcpListener;

async fn serve(shelf: Arc<Mutex<Shelf>>) -> String {
    let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let addr = listener.local_addr().unwrap().to_string();
    tokio::spawn(async move {
        let (mut stream, _) = listener.accept().await.unwrap();
        let mut session = {
            let mut s = shelf.lock().unwrap();
            TerminalSession::open(
                &mut *s,
                SessionConfig {
                    max_piece: 5,
                    ..SessionConfig::default()
                },
            )
        };
        let mut buf = [0u8; 1024];
        loop {
            while let Some(piece) = session.poll_transmit() {
                if stream.write_all(&piece).await.is_err() {
                    return;
                }
            }
            match stream.read(&mut buf).await {
                Ok(0) | Err(_) => {
                    session.handle_close(&mut *shelf.lock().unwrap());
                    return;
                }
                Ok(n) => session.handle_input(&mut *shelf.lock().unwrap(), &buf[..n]),
            }
        }
    });
    addr
}

#[tokio::test]
async fn a_load_over_tcp_reaches_the_controller_and_the_transcript_holds_both_ways() {
    let shelf = Arc::new(Mutex::new(Shelf::default()));
    let addr = serve(shelf.clone()).await;
    let mut t = TerminalConnection::connect(&addr, ClientConfig::default(), Duration::from_secs(5))
        .await
        .unwrap();
    assert_eq!(t.terminal(), Some("AUX1"));
    let file = b".PROGRAM autostart.pc()\r\n  PRINT \"up\"\r\n.END\r\n";
    let report = t.load("deploy.as", file).await.unwrap();
    assert_eq!(report.errors, 0);
    assert_eq!(shelf.lock().unwrap().received, file);
    let listing = t.command("DIRECTORY/P", false).await.unwrap();
    assert!(listing.contains("autostart.pc"), "{listing}");
    let sent: Vec<u8> = t
        .transcript()
        .iter()
        .filter(|e| e.direction == Direction::Sent)
        .flat_map(|e| e.bytes.clone())
        .collect();
    // The terminal type answered to the controller's opening, then the login and the LOAD.
    let ttype = b"\xff\xfb\x18\xff\xfa\x18\x00VT100\xff\xf0";
    assert!(sent.starts_with(ttype), "{sent:?}");
    assert!(sent[ttype.len()..].starts_with(b"as\r\nLOAD deploy.as\r\n"));
    assert!(t
        .transcript()
        .iter()
        .any(|e| e.direction == Direction::Received && e.bytes.len() <= 5));
}

#[tokio::test]
async fn a_closed_port_is_a_connect_error_naming_the_terminal_port() {
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap().to_string();
    drop(listener);
    let e = TerminalConnection::connect(&addr, ClientConfig::default(), Duration::from_secs(2))
        .await
        .unwrap_err();
    assert!(matches!(e, ConnectionError::Connect { .. }), "{e}");
    assert!(e.to_string().contains("terminal port (23)"), "{e}");
}
