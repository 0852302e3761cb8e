//! The socket table's outgoing connections (`TCP_CONNECT` to another host): the dial the
//! driver makes, the program's poll that takes the socket or the error, and a dial the
//! program gave up on.

use std::time::Duration;

use fs020n_as::sockets::{Delivery, Dial, SocketLimits, SocketTable, TcpCode};
use fs020n_as::SockPoll;

const PC: [u8; 4] = [192, 168, 0, 10];

fn table() -> SocketTable {
    SocketTable::new(SocketLimits {
        local_buffer: 1024,
        client_buffer: 1024,
    })
}

#[test]
fn a_connect_to_another_host_waits_for_the_driver_then_carries_bytes_both_ways() {
    let mut net = table();
    assert_eq!(net.connect_remote(PC, 5000), SockPoll::Pending);
    // Polled again before the driver took it: still one dial.
    assert_eq!(net.connect_remote(PC, 5000), SockPoll::Pending);
    let dials = net.take_dials();
    assert_eq!(dials.len(), 1);
    let Dial { id, ip, port } = dials[0];
    assert_eq!((ip, port), (PC, 5000));
    assert!(net.take_dials().is_empty());
    // Not the program's yet: TCP_STATUS does not list it.
    assert!(net.status().is_empty());
    assert!(net.dial_done(id, Ok(())));
    assert_eq!(net.connect_remote(PC, 5000), SockPoll::Ready(Ok(id)));
    assert_eq!(net.status().len(), 1);
    assert_eq!(net.status()[0].ip, PC);
    // The program sends; the driver reads it as an outside client's bytes.
    assert_eq!(
        net.send(id, b"ready", Duration::ZERO, || Delivery::Now),
        SockPoll::Ready(Ok(()))
    );
    assert_eq!(net.client_read(id, Duration::ZERO).bytes, b"ready");
    // The host answers.
    assert!(net.client_send(id, b"go"));
    assert_eq!(net.recv(id, 255), SockPoll::Ready(Ok(b"go".to_vec())));
    // The host closes: the program's next receive reports it.
    net.client_close(id);
    assert_eq!(
        net.recv(id, 255),
        SockPoll::Ready(Err(TcpCode::Broken.code()))
    );
}

#[test]
fn a_refused_dial_gives_the_program_the_drivers_code_once() {
    let mut net = table();
    assert_eq!(net.connect_remote(PC, 5000), SockPoll::Pending);
    let id = net.take_dials()[0].id;
    assert!(net.dial_done(id, Err(TcpCode::Broken.code())));
    assert_eq!(
        net.connect_remote(PC, 5000),
        SockPoll::Ready(Err(TcpCode::Broken.code()))
    );
    // A new TCP_CONNECT dials again, with a new socket id.
    assert_eq!(net.connect_remote(PC, 5000), SockPoll::Pending);
    let again = net.take_dials();
    assert_eq!(again.len(), 1);
    assert_ne!(again[0].id, id);
}

#[test]
fn a_dial_the_program_gave_up_on_is_closed_when_it_connects() {
    let mut net = table();
    assert_eq!(net.connect_remote(PC, 5000), SockPoll::Pending);
    let id = net.take_dials()[0].id;
    net.abandon_connect(PC, 5000);
    // The driver's late success is refused: it closes the connection.
    assert!(!net.dial_done(id, Ok(())));
    assert!(net.client_read(id, Duration::ZERO).closed);
    assert!(net.status().is_empty());
}

#[test]
fn a_dial_abandoned_before_the_driver_took_it_is_never_made() {
    let mut net = table();
    assert_eq!(net.connect_remote(PC, 5000), SockPoll::Pending);
    net.abandon_connect(PC, 5000);
    assert!(net.take_dials().is_empty());
}

#[test]
fn a_restart_forgets_every_dial() {
    let mut net = table();
    assert_eq!(net.connect_remote(PC, 5000), SockPoll::Pending);
    let id = net.take_dials()[0].id;
    net.restart();
    assert!(!net.dial_done(id, Ok(())));
}
