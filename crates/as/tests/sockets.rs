//! TCP instructions: results, timeouts and AS codes, element splitting, two tasks talking.
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

mod common;

use std::time::Duration;

use common::*;
use fs020n_proto::ErrorCode;

const SERVER: &str = "  TCP_LISTEN lret, 9000\n\
  TCP_ACCEPT sock, 9000, 2, ip[0]\n\
  TCP_END_LISTEN eret, 9000\n\
  TCP_RECV rret, sock, $buf[1], n, 1, 10\n\
  IF rret < 0 GOTO fin\n\
  $out[1] = \"got \"\n\
  $out[2] = $buf[1]\n\
  TCP_SEND sret, sock, $out[1], 2, 1\n\
  TCP_RECV rret2, sock, $buf[1], n2, 1\n\
  TCP_CLOSE cret, sock\n\
  TCP_CLOSE cret2, sock\n\
fin:\n\
  done = TIMER(0)";

#[test]
fn listen_accept_receive_send_close() {
    let (mut i, mut s) = start(&pc(SERVER));
    i.run_until(&mut s, ms(10));
    assert!(s.listening(9000));
    assert_eq!(i.real("lret"), Some(0.0));
    let c = s.connect(9000).unwrap();
    s.send(c, b"abcdefghijklmnopqrstuvwxyz");
    i.run_until(&mut s, ms(20));
    assert!(i.real("sock").unwrap() >= 0.0);
    assert_eq!(i.real_at("ip", &[0]), Some(127.0));
    assert_eq!(i.real_at("ip", &[3]), Some(1.0));
    assert_eq!(i.real("eret"), Some(0.0));
    assert!(!s.listening(9000));
    // Split into elements of at most 10 bytes.
    assert_eq!(i.real("rret"), Some(0.0));
    assert_eq!(i.real("n"), Some(3.0));
    assert_eq!(i.string_at("buf", &[1]), Some(b"abcdefghij".to_vec()));
    assert_eq!(i.string_at("buf", &[3]), Some(b"uvwxyz".to_vec()));
    assert_eq!(s.recv(c), b"got abcdefghij");
    assert_eq!(i.real("sret"), Some(0.0));
    // The client closes: the second receive reports the broken connection.
    s.close(c);
    i.run_until(&mut s, ms(30));
    assert_eq!(i.real("rret2"), Some(-34025.0));
    assert_eq!(i.real("n2"), Some(0.0));
    assert_eq!(i.real("cret"), Some(0.0));
    assert_eq!(
        i.real("cret2"),
        Some(-34057.0),
        "a second close of the same socket"
    );
    assert!(s.raised.is_empty());
}

#[test]
fn timeouts_return_minus_34024_and_the_program_goes_on() {
    let (mut i, mut s) = start(&pc(SERVER));
    i.run_until(&mut s, ms(1999));
    assert_eq!(i.real("sock"), None, "still accepting");
    i.run_until(&mut s, ms(2001));
    assert_eq!(
        i.real("sock"),
        Some(-34024.0),
        "TCP_ACCEPT timed out after 2 s"
    );
    // The receive on the failed socket id reports an illegal socket.
    assert_eq!(i.real("rret"), Some(-34057.0));
    assert!(
        s.raised.is_empty(),
        "communication errors do not stop the program"
    );

    let (mut i, mut s) = start(&pc(SERVER));
    i.run_until(&mut s, ms(10));
    let _c = s.connect(9000).unwrap();
    i.run_until(&mut s, ms(20));
    let t0 = i.now();
    i.run_until(&mut s, t0 + Duration::from_millis(990));
    assert_eq!(i.real("rret"), None);
    i.run_until(&mut s, t0 + Duration::from_millis(1010));
    assert_eq!(
        i.real("rret"),
        Some(-34024.0),
        "TCP_RECV timed out after 1 s"
    );
}

#[test]
fn a_send_that_the_peer_does_not_take_times_out() {
    let body = "  TCP_LISTEN r, 9001\n  TCP_ACCEPT sock, 9001, 5\n  $m[0] = \"0123456789\"\n  TCP_SEND s1, sock, $m[0], 1, 2\n  TCP_SEND s2, sock, $m[0], 1, 2\n  at = TIMER(0)";
    let (mut i, mut s) = start(&pc(body));
    s.socket_capacity = 15;
    i.run_until(&mut s, ms(10));
    let c = s.connect(9001).unwrap();
    i.run_until(&mut s, ms(1000));
    assert_eq!(i.real("s1"), Some(0.0));
    assert_eq!(i.real("s2"), None, "waiting: the peer's buffer is full");
    i.run_until(&mut s, ms(3000));
    assert_eq!(i.real("s2"), Some(-34024.0));
    assert!((2.0..2.1).contains(&i.real("at").unwrap()));
    assert_eq!(s.recv(c), b"0123456789");
}

#[test]
fn listen_errors() {
    let body = "  TCP_LISTEN a, 9002\n  TCP_LISTEN b, 9002\n  TCP_END_LISTEN c, 9002\n  TCP_END_LISTEN d, 9002\n  TCP_ACCEPT e, 9002, 0\n  $x[0] = \"\"\n  TCP_SEND f, 77, $x[0], 1\n  TCP_CLOSE g, 77";
    let (i, s) = run_pc(body, 0.1);
    assert_eq!(i.real("a"), Some(0.0));
    assert_eq!(i.real("b"), Some(-34055.0));
    assert_eq!(i.real("c"), Some(0.0));
    assert_eq!(i.real("d"), Some(-34056.0));
    assert_eq!(i.real("e"), Some(-34056.0));
    assert_eq!(i.real("f"), Some(-34057.0));
    assert_eq!(i.real("g"), Some(-34057.0));
    assert!(s.raised.is_empty());
    // Parameter errors stop the program.
    let (_, s) = run_pc("  TCP_ACCEPT a, 9002, 61", 0.1);
    assert_eq!(s.raised, vec![ErrorCode(-30106)]);
    let (_, s) = run_pc("  TCP_RECV a, 1, $b[0], n, 1, 256", 0.1);
    assert_eq!(s.raised, vec![ErrorCode(-30106)]);
    let (_, s) = run_pc("  TCP_SEND a, 1, $b[0], 1, 1", 0.1);
    assert_eq!(
        s.raised,
        vec![ErrorCode(-30104)],
        "sending a string element never assigned"
    );
}

#[test]
fn two_tasks_talk_over_a_socket_and_receives_are_at_most_4096_bytes() {
    let src = ".PROGRAM autostart.pc()\n\
                 TCP_LISTEN r, 9100\n\
                 TCP_ACCEPT sock, 9100, 5\n\
                 TWAIT 0.05\n\
                 TCP_RECV rr, sock, $in[1], n, 5\n\
                 TCP_RECV rr2, sock, $in2[1], n2, 5\n\
                 $reply[0] = $in[1]\n\
                 $reply[1] = \"!\"\n\
                 TCP_SEND sr, sock, $reply[0], 2, 5\n\
               .END\n\
               .PROGRAM autostart2.pc()\n\
                 ip[1] = 127\n\
                 ip[2] = 0\n\
                 ip[3] = 0\n\
                 ip[4] = 1\n\
                 TWAIT 0.01\n\
                 TCP_CONNECT c, 9100, ip[1], 5\n\
                 $s = \"0123456789\"\n\
                 FOR .k = 0 TO 409\n\
                   $big[.k] = $s\n\
                 END\n\
                 TCP_SEND s1, c, $big[0], 409, 5\n\
                 TCP_SEND s2, c, $big[0], 1, 5\n\
                 TCP_SEND s3, c, $big[0], 410, 5\n\
                 TCP_RECV rc, c, $back[0], m, 5\n\
                 TCP_CLOSE cc, c\n\
               .END\n";
    let (mut i, mut s) = start(src);
    i.run_until(&mut s, ms(500));
    assert!(s.raised.is_empty(), "{:?}", s.terminal);
    assert!(i.real("c").unwrap() >= 0.0);
    assert_eq!(i.real("s1"), Some(0.0));
    assert_eq!(
        i.real("s3"),
        Some(-34022.0),
        "4100 bytes are more than one TCP_SEND moves"
    );
    // 4090 + 10 bytes were waiting: one receive takes 4096 (17 elements), the next the rest.
    assert_eq!(i.real("n"), Some(17.0));
    assert_eq!(
        i.string_at("in", &[17]).map(|v| v.len()),
        Some(4096 - 16 * 255)
    );
    assert_eq!(i.real("n2"), Some(1.0));
    assert_eq!(i.string_at("in2", &[1]).map(|v| v.len()), Some(4));
    assert_eq!(i.real("m"), Some(2.0));
    assert_eq!(i.string_at("back", &[0]).map(|v| v.len()), Some(255));
    assert_eq!(i.string_at("back", &[1]), Some(b"!".to_vec()));
}

#[test]
fn tcp_connect_to_a_port_below_8192_is_tried_and_fails_as_a_connection_not_as_an_illegal_port() {
    // A vision system on port 3000: no listener there in the test system, so the connection
    // fails with its code and the program goes on; port 70000 is an illegal value.
    let src = ".PROGRAM autostart.pc()\n\
                 ip[1] = 192\n\
                 ip[2] = 168\n\
                 ip[3] = 0\n\
                 ip[4] = 20\n\
                 TCP_CONNECT c, 3000, ip[1], 1\n\
                 tried = 1\n\
                 TCP_CONNECT c2, 70000, ip[1], 1\n\
                 after = 1\n\
               .END\n";
    let (mut i, mut s) = start(src);
    i.run_until(&mut s, ms(3000));
    assert_eq!(i.real("tried"), Some(1.0));
    assert!(i.real("c").is_some_and(|c| c < 0.0), "{:?}", i.real("c"));
    assert_eq!(i.real("after"), None, "port 70000 stops the task");
}
