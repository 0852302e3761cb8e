//! The emulator's `UDP_SENDTO`/`UDP_RECVFROM` on real UDP sockets bound to 127.0.0.1: a
//! loopback peer sends a datagram the program receives, the program answers it, and a
//! receive with no datagram times out with −34024 on the controller's (virtual) clock.
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

use std::net::UdpSocket;
use std::time::Duration;

use fs020n_sim::{Controller, ControllerConfig, ServerProgram};

/// A port free on loopback now (bound, then released for the program to take).
fn free_port() -> u16 {
    let s = UdpSocket::bind("127.0.0.1:0").expect("bind");
    s.local_addr().expect("addr").port()
}

fn controller(text: &str) -> Controller {
    let program = match ServerProgram::from_source("udp.as", text) {
        Ok(p) => p,
        Err(e) => panic!("load failed:\n{e}"),
    };
    Controller::with_program(ControllerConfig::default(), program)
}

#[test]
fn a_loopback_peer_and_the_program_exchange_datagrams() {
    let peer = UdpSocket::bind("127.0.0.1:0").expect("bind the peer");
    peer.set_read_timeout(Some(Duration::from_secs(5)))
        .expect("timeout");
    let peer_port = peer.local_addr().expect("addr").port();
    let port = free_port();
    let text = format!(
        ".PROGRAM autostart.pc()\n\
  UDP_RECVFROM ret, {port}, $in[1], n, 10, ip[1], 4\n\
  $out[1] = \"got \"\n\
  $out[2] = $in[1]\n\
  UDP_SENDTO sret, ip[1], {peer_port}, $out[1], 2, 1\n\
  done = 1\n\
.END\n"
    );
    let mut c = controller(&text);
    c.advance_by(Duration::from_millis(20));
    assert_eq!(
        c.program().udp_address(),
        Some(std::net::Ipv4Addr::LOCALHOST)
    );
    peer.send_to(b"hello", ("127.0.0.1", port)).expect("send");
    // The datagram is on the loopback interface: the program's next poll reads it.
    let mut waited = 0;
    while c.program().real("done").is_none() && waited < 200 {
        c.advance_by(Duration::from_millis(10));
        waited += 1;
        std::thread::sleep(Duration::from_millis(1));
    }
    assert_eq!(c.program().real("ret"), Some(0.0));
    assert_eq!(
        c.program().real("n"),
        Some(2.0),
        "hello in elements of 4 bytes"
    );
    assert_eq!(c.program().real("sret"), Some(0.0));
    assert_eq!(c.program().real("done"), Some(1.0));
    let mut buf = [0u8; 64];
    let (n, from) = peer.recv_from(&mut buf).expect("the answer");
    assert_eq!(&buf[..n], b"got hell");
    assert!(from.ip().is_loopback());
}

#[test]
fn udp_recvfrom_with_no_datagram_times_out_on_the_controller_clock() {
    let port = free_port();
    let text = format!(
        ".PROGRAM autostart.pc()\n\
  UDP_RECVFROM ret, {port}, $in[0], n, 2\n\
  at = TIMER(0)\n\
.END\n"
    );
    let mut c = controller(&text);
    c.advance_by(Duration::from_millis(1900));
    assert_eq!(c.program().real("ret"), None, "still waiting");
    // The port is really open on the host while it waits.
    assert!(
        UdpSocket::bind(("127.0.0.1", port)).is_err(),
        "the program holds the port"
    );
    c.advance_by(Duration::from_millis(200));
    assert_eq!(c.program().real("ret"), Some(-34024.0));
    let at = c.program().real("at").expect("went on");
    assert!((2.0..2.01).contains(&at), "timed out at {at} s");
    // …and closed when the instruction ended.
    assert!(UdpSocket::bind(("127.0.0.1", port)).is_ok(), "released");
}

#[test]
fn garbage_datagrams_do_not_disturb_the_program() {
    let peer = UdpSocket::bind("127.0.0.1:0").expect("bind the peer");
    let port = free_port();
    let text = format!(
        ".PROGRAM autostart.pc()\n\
  count = 0\n\
  WHILE TRUE DO\n\
    UDP_RECVFROM ret, {port}, $in[0], n, 1, ip[0], 255\n\
    IF ret == 0 THEN\n\
      count = count + 1\n\
    END\n\
  END\n\
.END\n"
    );
    let mut c = controller(&text);
    c.advance_by(Duration::from_millis(20));
    let big = vec![0xFFu8; 9000];
    for d in [&b""[..], &[0, 0xFF, b'\n', 0x80][..], &big[..]] {
        peer.send_to(d, ("127.0.0.1", port)).expect("send");
        std::thread::sleep(Duration::from_millis(5));
        c.advance_by(Duration::from_millis(20));
    }
    assert_eq!(c.program().real("count"), Some(3.0));
    assert_eq!(
        c.program().real("n"),
        Some(17.0),
        "4096 bytes kept, in 255-byte elements"
    );
}
