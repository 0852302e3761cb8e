//! The controller's socket table (`fs020n_as::sockets`): the AS result codes, local peers and
//! outside clients with their deliveries, on passed-in times.

use std::time::Duration;

use fs020n_as::error::error_message;
use fs020n_as::sockets::{ClientRead, Delivery, SocketLimits, SocketTable, TcpCode};
use fs020n_as::SockPoll;

const MS: Duration = Duration::from_millis(1);

fn table() -> SocketTable {
    SocketTable::new(SocketLimits {
        local_buffer: 10,
        client_buffer: 8,
    })
}

fn ready<T>(p: SockPoll<T>) -> Result<T, i32> {
    match p {
        SockPoll::Ready(r) => r,
        SockPoll::Pending => panic!("expected a ready result"),
    }
}

/// A listening table with one outside client accepted: (table, socket id).
fn with_client() -> (SocketTable, i32) {
    let mut t = table();
    assert_eq!(t.listen(10050), 0);
    let Some(id) = t.client_connect(10050, [10, 0, 0, 7]) else {
        panic!("the port listens");
    };
    assert_eq!(ready(t.accept(10050)), Ok((id, [10, 0, 0, 7])));
    (t, id)
}

#[test]
fn the_result_codes_are_the_as_manual_numbers_with_their_messages() {
    let numbers: Vec<i32> = TcpCode::ALL.iter().map(|c| c.code()).collect();
    assert_eq!(
        numbers,
        [-34019, -34020, -34021, -34022, -34023, -34024, -34025, -34055, -34056, -34057]
    );
    for c in TcpCode::ALL {
        assert_eq!(TcpCode::from_code(c.code()), Some(c));
        assert_eq!(error_message(c.code()), Some(c.message()));
    }
    assert_eq!(TcpCode::from_code(-34026), None);
    assert_eq!(TcpCode::from_code(0), None);
}

#[test]
fn a_port_listens_once_and_ending_it_resets_the_connections_not_accepted() {
    let mut t = table();
    assert_eq!(t.listen(9000), 0);
    assert_eq!(t.listen(9000), TcpCode::PortInUse.code());
    assert_eq!(t.served_port(), Some(9000));
    assert_eq!(t.listen(9001), 0);
    assert_eq!(
        t.served_port(),
        Some(9000),
        "the first port listened on stays served"
    );
    let client = t.connect_local(9000).expect("listening");
    assert_eq!(t.end_listen(9000), 0);
    assert!(t.peer_closed(client), "the waiting connection was reset");
    assert_eq!(t.end_listen(9000), TcpCode::NotListening.code());
    assert_eq!(ready(t.accept(9000)), Err(TcpCode::NotListening.code()));
    assert_eq!(t.connect_local(9000), None);
}

#[test]
fn local_connections_take_two_ids_and_accept_is_pending_until_one_waits() {
    let mut t = table();
    t.listen(9000);
    assert_eq!(t.accept(9000), SockPoll::Pending);
    assert_eq!(t.connect_local(9000), Some(1));
    assert_eq!(t.connect_local(9000), Some(3));
    assert_eq!(ready(t.accept(9000)), Ok((2, [127, 0, 0, 1])));
    assert_eq!(ready(t.accept(9000)), Ok((4, [127, 0, 0, 1])));
    assert_eq!(t.port_of(2), Some(9000));
    assert_eq!(t.port_of(1), Some(0));
}

#[test]
fn a_local_send_waits_while_the_peer_inbox_is_full_and_recv_takes_at_most_max() {
    let mut t = table();
    t.listen(9000);
    let a = t.connect_local(9000).unwrap();
    let (b, _) = ready(t.accept(9000)).unwrap();
    assert_eq!(
        ready(t.send(b, b"0123456789", MS, || Delivery::Now)),
        Ok(())
    );
    assert_eq!(t.send(b, b"x", MS, || Delivery::Now), SockPoll::Pending);
    assert_eq!(t.take_inbox(a), b"0123456789");
    assert!(t.peer_send(a, b"hello"));
    assert_eq!(ready(t.recv(b, 3)), Ok(b"hel".to_vec()));
    assert_eq!(ready(t.recv(b, 255)), Ok(b"lo".to_vec()));
    assert_eq!(t.recv(b, 255), SockPoll::Pending);
}

#[test]
fn after_a_close_the_peer_reads_the_rest_then_broken_and_a_second_close_is_unknown() {
    let mut t = table();
    t.listen(9000);
    let a = t.connect_local(9000).unwrap();
    let (b, _) = ready(t.accept(9000)).unwrap();
    assert!(t.peer_send(a, b"bye"));
    assert_eq!(t.close(a), 0);
    assert_eq!(t.close(a), TcpCode::UnknownSocket.code());
    assert_eq!(ready(t.recv(b, 255)), Ok(b"bye".to_vec()));
    assert_eq!(ready(t.recv(b, 255)), Err(TcpCode::Broken.code()));
    assert_eq!(
        ready(t.send(b, b"x", MS, || Delivery::Now)),
        Err(TcpCode::Broken.code())
    );
    assert!(!t.peer_send(b, b"x"), "the other end is gone");
    assert_eq!(ready(t.recv(a, 255)), Err(TcpCode::UnknownSocket.code()));
}

#[test]
fn an_outside_clients_bytes_reach_the_program_and_its_reply_is_due_at_once() {
    let (mut t, id) = with_client();
    assert!(t.is_client(id));
    let g = t.generation();
    assert!(t.client_send(id, b"1040 0 0"));
    assert!(t.generation() > g);
    assert_eq!(ready(t.recv(id, 255)), Ok(b"1040 0 0".to_vec()));
    assert_eq!(
        ready(t.send(id, b"reply", 5 * MS, || Delivery::Now)),
        Ok(())
    );
    let read = t.client_read(id, 5 * MS);
    assert_eq!(
        read,
        ClientRead {
            bytes: b"reply".to_vec(),
            closed: false,
            next_at: None
        }
    );
}

#[test]
fn deliveries_delay_split_replace_or_withhold_a_reply() {
    let (mut t, id) = with_client();
    let now = 10 * MS;
    t.send(id, b"late", now, || Delivery::Delay(3 * MS));
    let early = t.client_read(id, now);
    assert_eq!((early.bytes.len(), early.next_at), (0, Some(13 * MS)));
    assert_eq!(t.client_read(id, 13 * MS).bytes, b"late");

    t.send(id, b"abcdef", now, || Delivery::Split { parts: 3, gap: MS });
    assert_eq!(t.client_read(id, now).bytes, b"ab");
    assert_eq!(t.client_read(id, now + 2 * MS).bytes, b"cdef");

    t.send(id, b"good", now, || Delivery::Replace(b"junk".to_vec()));
    assert_eq!(t.client_read(id, now).bytes, b"junk");

    assert_eq!(
        ready(t.send(id, b"lost", now, || Delivery::Withhold)),
        Ok(())
    );
    assert_eq!(t.client_read(id, now + Duration::from_secs(1)).bytes, b"");
}

#[test]
fn the_delivery_is_asked_only_when_a_client_send_is_taken() {
    let (mut t, id) = with_client();
    // The first send into an empty outbox is taken even beyond the buffer (8 bytes).
    assert_eq!(
        ready(t.send(id, b"0123456789", MS, || Delivery::Delay(MS))),
        Ok(())
    );
    let mut asked = false;
    let p = t.send(id, b"x", MS, || {
        asked = true;
        Delivery::Now
    });
    assert_eq!(p, SockPoll::Pending);
    assert!(!asked, "a pending send consumes no delivery (no fault)");
}

#[test]
fn a_closed_client_connection_reads_the_rest_then_the_end() {
    let (mut t, id) = with_client();
    t.send(id, b"last", MS, || Delivery::Delay(MS));
    assert_eq!(t.close(id), 0);
    assert!(!t.is_client(id), "the program no longer holds it");
    assert!(!t.client_send(id, b"x"), "closed by the program");
    let r = t.client_read(id, MS);
    assert!(!r.closed, "unread bytes remain");
    let r = t.client_read(id, 2 * MS);
    assert_eq!((r.bytes.as_slice(), r.closed), (&b"last"[..], true));
    t.client_close(id);
    assert!(t.client_read(id, 3 * MS).closed, "gone");
}

#[test]
fn a_client_that_closes_is_seen_broken_by_the_program() {
    let (mut t, id) = with_client();
    t.client_send(id, b"x");
    t.client_close(id);
    assert_eq!(ready(t.recv(id, 255)), Ok(b"x".to_vec()));
    assert_eq!(ready(t.recv(id, 255)), Err(TcpCode::Broken.code()));
    assert_eq!(
        ready(t.send(id, b"y", MS, || Delivery::Now)),
        Err(TcpCode::Broken.code())
    );
    assert_eq!(t.close(id), 0);
    assert_eq!(t.close(id), TcpCode::UnknownSocket.code());
}

#[test]
fn breaking_the_clients_ends_their_streams_and_hides_the_sockets_from_the_program() {
    let (mut t, id) = with_client();
    t.send(id, b"unread", MS, || Delivery::Now);
    let g = t.generation();
    t.break_clients();
    assert!(t.generation() > g);
    let r = t.client_read(id, MS);
    assert_eq!((r.bytes.len(), r.closed), (0, true));
    assert_eq!(
        ready(t.recv(id, 255)),
        Err(TcpCode::UnknownSocket.code()),
        "the program's socket is closed"
    );
}

#[test]
fn the_generation_counts_only_changes_a_client_can_see() {
    let mut t = table();
    let mut g = t.generation();
    let mut changed = |t: &SocketTable| {
        let c = t.generation() != g;
        g = t.generation();
        c
    };
    t.listen(9000);
    assert!(changed(&t));
    let a = t.connect_local(9000).unwrap();
    assert!(!changed(&t));
    let (b, _) = ready(t.accept(9000)).unwrap();
    t.send(b, b"x", MS, || Delivery::Now);
    t.recv(a, 1);
    assert!(!changed(&t), "local traffic is not seen outside");
    t.close(b);
    assert!(changed(&t));
    t.client_connect(9000, [1, 2, 3, 4]);
    assert!(changed(&t));
}
