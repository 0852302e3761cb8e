//! `TCP_STATUS` on the controller's socket table: how many sockets the program holds open and,
//! per socket, its port, id, error and the peer's address.
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

mod common;

use common::{ms, pc, start};

const PROGRAM: &str = "  gone = 0\n\
  TCP_STATUS n0, port[1], sock[1], err[1], sub[1], $ip[1]\n\
  TCP_LISTEN r, 9000\n\
  TCP_ACCEPT s1, 9000, 5\n\
  TCP_ACCEPT s2, 9000, 5\n\
  TCP_STATUS n2, port[1], sock[1], err[1], sub[1], $ip[1]\n\
  WAIT gone\n\
  TCP_STATUS n3, port[11], sock[11], err[11], sub[11], $ip[11]\n\
  TCP_CLOSE r, s1\n\
  TCP_STATUS n4, port[21], sock[21], err[21], sub[21], $ip[21]";

#[test]
fn tcp_status_lists_the_open_sockets_with_port_id_error_and_address() {
    let (mut i, mut s) = start(&pc(PROGRAM));
    i.run_until(&mut s, ms(10));
    assert_eq!(i.real("n0"), Some(0.0), "nothing open");
    let a = s.connect(9000).expect("listening");
    let b = s.connect(9000).expect("listening");
    i.run_until(&mut s, ms(20));
    assert_eq!(i.real("n2"), Some(2.0));
    let (s1, s2) = (
        i.real("s1").expect("accepted"),
        i.real("s2").expect("accepted"),
    );
    assert_eq!(i.real_at("sock", &[1]), Some(s1));
    assert_eq!(i.real_at("sock", &[2]), Some(s2));
    for k in [1, 2] {
        assert_eq!(i.real_at("port", &[k]), Some(9000.0));
        assert_eq!(i.real_at("err", &[k]), Some(0.0));
        assert_eq!(i.real_at("sub", &[k]), Some(0.0));
        assert_eq!(i.string_at("ip", &[k]), Some(b"127.0.0.1".to_vec()));
    }
    // The first client closes: its socket is still open (the program has not closed it) and
    // reports the broken connection.
    s.close(a);
    i.set_real("gone", -1.0);
    i.run_until(&mut s, ms(30));
    assert_eq!(i.real("n3"), Some(2.0));
    assert_eq!(i.real_at("err", &[11]), Some(-34025.0));
    assert_eq!(i.real_at("err", &[12]), Some(0.0));
    // The program closes it: one left.
    assert_eq!(i.real("n4"), Some(1.0));
    assert_eq!(i.real_at("sock", &[21]), Some(s2));
    assert!(!s.peer_closed(b));
    assert!(s.raised.is_empty(), "{:?}", s.raised);
}
