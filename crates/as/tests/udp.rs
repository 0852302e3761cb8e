//! `UDP_SENDTO` and `UDP_RECVFROM` on the controller's socket table, with scripted datagrams on
//! virtual time: what is sent, what is received and split into elements, the sender's address,
//! the timeout code, and datagrams lost while no `UDP_RECVFROM` waits.
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

mod common;

use common::{ms, pc, start};
use fs020n_as::Datagram;

fn datagram(ip: [u8; 4], port: u16, bytes: &[u8]) -> Datagram {
    Datagram {
        ip,
        port,
        bytes: bytes.to_vec(),
    }
}

#[test]
fn udp_sendto_sends_the_elements_as_one_datagram_to_the_address_and_port() {
    let (mut i, mut s) = start(&pc("  ip[1] = 192\n\
  ip[2] = 168\n\
  ip[3] = 0\n\
  ip[4] = 10\n\
  $out[0] = \"hello \"\n\
  $out[1] = \"world\"\n\
  UDP_SENDTO ret, ip[1], 10010, $out[0], 2, 3\n\
  done = 1"));
    i.run_until(&mut s, ms(10));
    assert_eq!(i.real("done"), Some(1.0));
    assert_eq!(i.real("ret"), Some(0.0));
    assert_eq!(
        s.sent_datagrams(),
        vec![datagram([192, 168, 0, 10], 10010, b"hello world")]
    );
    assert!(s.sent_datagrams().is_empty(), "taken once");
}

#[test]
fn udp_recvfrom_fills_the_elements_the_count_and_the_senders_address() {
    let (mut i, mut s) = start(&pc(
        "  UDP_RECVFROM ret, 10010, $in[1], n, 5, ip[1], 10\n  done = 1",
    ));
    i.run_until(&mut s, ms(10));
    assert!(s.udp_receiving(10010), "the port opens while it waits");
    assert_eq!(i.real("done"), None);
    assert!(s.deliver_datagram(
        10010,
        datagram([127, 0, 0, 1], 40000, b"abcdefghijklmnopqrstuvwxyz")
    ));
    i.run_until(&mut s, ms(20));
    assert_eq!(i.real("done"), Some(1.0));
    assert_eq!(i.real("ret"), Some(0.0));
    // Split as TCP_RECV splits: elements of at most max bytes.
    assert_eq!(i.real("n"), Some(3.0));
    assert_eq!(i.string_at("in", &[1]), Some(b"abcdefghij".to_vec()));
    assert_eq!(i.string_at("in", &[2]), Some(b"klmnopqrst".to_vec()));
    assert_eq!(i.string_at("in", &[3]), Some(b"uvwxyz".to_vec()));
    for (k, b) in [127.0, 0.0, 0.0, 1.0].into_iter().enumerate() {
        assert_eq!(i.real_at("ip", &[k as i32 + 1]), Some(b));
    }
    assert!(!s.udp_receiving(10010), "the port closes when it ends");
}

#[test]
fn a_scripted_datagram_arrives_on_virtual_time_and_ends_the_wait_then() {
    let (mut i, mut s) = start(&pc(
        "  UDP_RECVFROM ret, 10010, $in[0], n, 5\n  at = TIMER(0)",
    ));
    s.script_datagram(ms(1500), 10010, datagram([10, 0, 0, 2], 9, b"go"));
    i.run_until(&mut s, ms(1400));
    assert_eq!(i.real("at"), None, "still waiting");
    i.run_until(&mut s, ms(2000));
    assert_eq!(i.real("ret"), Some(0.0));
    assert_eq!(i.string_at("in", &[0]), Some(b"go".to_vec()));
    let at = i.real("at").expect("went on");
    assert!((1.5..1.51).contains(&at), "went on at {at} s");
}

#[test]
fn udp_recvfrom_times_out_with_34024_and_the_task_keeps_running() {
    let (mut i, mut s) = start(&pc("  n = 7\n\
  UDP_RECVFROM ret, 10010, $in[0], n, 2\n\
  at = TIMER(0)\n\
  after = 1"));
    i.run_until(&mut s, ms(1990));
    assert_eq!(i.real("ret"), None);
    i.run_until(&mut s, ms(2100));
    assert_eq!(i.real("ret"), Some(-34024.0));
    assert_eq!(i.real("n"), Some(0.0));
    assert_eq!(i.real("after"), Some(1.0));
    let at = i.real("at").expect("went on");
    assert!((2.0..2.01).contains(&at), "timed out at {at} s");
    assert!(
        s.raised.is_empty(),
        "a timeout raises no error: {:?}",
        s.raised
    );
    assert!(!s.udp_receiving(10010));
}

#[test]
fn a_datagram_sent_while_no_udp_recvfrom_waits_is_lost() {
    let (mut i, mut s) = start(&pc("  TWAIT 1\n  UDP_RECVFROM ret, 10010, $in[0], n, 1"));
    i.run_until(&mut s, ms(500));
    assert!(!s.deliver_datagram(10010, datagram([127, 0, 0, 1], 9, b"early")));
    i.run_until(&mut s, ms(2100));
    assert_eq!(
        i.real("ret"),
        Some(-34024.0),
        "the early datagram was not kept"
    );
}

#[test]
fn an_aborted_udp_recvfrom_closes_its_port() {
    let (mut i, mut s) = start(&pc("  UDP_RECVFROM ret, 10010, $in[0], n, 30"));
    i.run_until(&mut s, ms(10));
    assert!(s.udp_receiving(10010));
    i.abort(fs020n_as::TaskId::Pc(1));
    i.run_until(&mut s, ms(20));
    assert!(!s.udp_receiving(10010));
}

#[test]
fn udp_sendto_of_more_than_4096_bytes_is_refused_with_34022() {
    let (mut i, mut s) = run_big();
    i.run_until(&mut s, ms(100));
    assert_eq!(i.real("ret"), Some(-34022.0));
    assert!(s.sent_datagrams().is_empty());
}

fn run_big() -> (fs020n_as::Interpreter, fs020n_as::testing::VirtualSystem) {
    start(&pc("  ip[0] = 127\n\
  ip[1] = 0\n\
  ip[2] = 0\n\
  ip[3] = 1\n\
  $x = \"\"\n\
  FOR k = 1 TO 25\n\
    $x = $x + \"0123456789\"\n\
  END\n\
  FOR k = 0 TO 16\n\
    $b[k] = $x\n\
  END\n\
  UDP_SENDTO ret, ip[0], 10010, $b[0], 17"))
}

#[test]
fn udp_recvfrom_element_size_outside_1_to_255_stops_the_task() {
    let (mut i, mut s) = start(&pc("  UDP_RECVFROM ret, 10010, $in[0], n, 1, ip[0], 0"));
    i.run_until(&mut s, ms(10));
    assert_eq!(i.real("ret"), None);
    assert!(!s.raised.is_empty(), "a parameter error stops the program");
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]

    /// Any datagram (any bytes, empty, over 4096 bytes) is received as data: the elements
    /// hold its first 4096 bytes in order, each at most `max` bytes.
    #[test]
    fn any_datagram_is_received_as_data_split_into_elements(
        bytes in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..5000),
        max in 1u32..=255,
    ) {
        let (mut i, mut s) = start(&pc(&format!(
            "  UDP_RECVFROM ret, 10010, $in[0], n, 5, ip[0], {max}"
        )));
        i.run_until(&mut s, ms(10));
        proptest::prop_assert!(s.deliver_datagram(10010, datagram([1, 2, 3, 4], 5, &bytes)));
        i.run_until(&mut s, ms(20));
        proptest::prop_assert_eq!(i.real("ret"), Some(0.0));
        let kept = &bytes[..bytes.len().min(4096)];
        let n = i.real("n").expect("count") as i32;
        proptest::prop_assert_eq!(n as usize, kept.len().div_ceil(max as usize));
        let mut got = Vec::new();
        for k in 0..n {
            let e = i.string_at("in", &[k]).expect("element");
            proptest::prop_assert!(e.len() <= max as usize);
            got.extend(e);
        }
        proptest::prop_assert_eq!(&got[..], kept);
        proptest::prop_assert!(s.raised.is_empty());
    }
}

#[test]
fn udp_sendto_reaches_a_port_below_8192_of_another_host_and_refuses_port_0() {
    // A PC or a camera may listen on any port: the 8192–65535 rule is for the controller's own.
    let (mut i, mut s) = start(&pc("  ip[1] = 10\n\
  ip[2] = 0\n\
  ip[3] = 0\n\
  ip[4] = 7\n\
  $out[0] = \"trigger\"\n\
  UDP_SENDTO ret, ip[1], 2000, $out[0], 1\n\
  done = 1\n\
  UDP_SENDTO ret, ip[1], 0, $out[0], 1\n\
  after = 1"));
    i.run_until(&mut s, ms(10));
    assert_eq!(i.real("done"), Some(1.0));
    assert_eq!(
        s.sent_datagrams(),
        vec![datagram([10, 0, 0, 7], 2000, b"trigger")]
    );
    assert_eq!(
        i.real("after"),
        None,
        "port 0 is an illegal value: the task stops"
    );
    assert!(s.sent_datagrams().is_empty());
}
