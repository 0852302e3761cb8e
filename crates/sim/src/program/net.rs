//! The program's TCP/IP stack as the emulator uses it: the controller's socket table
//! ([`fs020n_as::sockets::SocketTable`], shared with the interpreter's test system) with the
//! emulator's buffer sizes, the id a client of the controller is known by, the mapping
//! from a reply fault to how the table delivers a reply, the real UDP sockets behind
//! `UDP_SENDTO`/`UDP_RECVFROM` ([`UdpPorts`]), and the program's view of the network
//! ([`Reach`]: where an address goes, and the log line of an address nothing answers for).

use std::collections::{BTreeMap, BTreeSet};
use std::net::{IpAddr, Ipv4Addr, SocketAddr, SocketAddrV4, UdpSocket};
use std::sync::Arc;

use fs020n_as::sockets::{Delivery, SocketLimits, SocketTable, TcpCode};
use fs020n_as::{Datagram, MAX_TRANSFER};
use serde::Serialize;

pub use fs020n_as::sockets::ClientRead;

use crate::fault::ReplyFault;
use crate::network::{Network, Route};

/// Bytes a client's outgoing queue holds before the program's `TCP_SEND` waits (like a socket
/// send buffer: a client that stops reading makes the program's send time out).
pub const CLIENT_BUFFER: usize = 4096;

/// A client of the program's TCP stack (a connection to the controller; its socket id in
/// the table).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
pub struct ClientId(pub i32);

/// An empty socket table with the emulator's buffers: a client's unread bytes up to
/// [`CLIENT_BUFFER`], a socket connected to the program's own listener up to 16 times that.
pub(crate) fn socket_table() -> SocketTable {
    SocketTable::new(SocketLimits {
        local_buffer: CLIENT_BUFFER * 16,
        client_buffer: CLIENT_BUFFER,
    })
}

/// How a reply reaches the client when `fault` is the next reply fault.
pub(crate) fn delivery_of(fault: Option<ReplyFault>) -> Delivery {
    match fault {
        None => Delivery::Now,
        Some(ReplyFault::Withhold) => Delivery::Withhold,
        Some(ReplyFault::Garbage(b)) => Delivery::Replace(b),
        Some(ReplyFault::Delay(d)) => Delivery::Delay(d),
        Some(ReplyFault::Split { parts, gap }) => Delivery::Split { parts, gap },
    }
}

/// The program's UDP sockets on the host: a real socket bound to `address:port` while a
/// `UDP_RECVFROM` has the port open (datagrams read from it are delivered to the socket
/// table), and one bound to `address:0` for each `UDP_SENDTO`. Loopback by default: the
/// emulator talks to programs on this machine unless told otherwise.
#[derive(Debug, Clone)]
pub(crate) struct UdpPorts {
    address: Ipv4Addr,
    /// The receiving sockets, by port (shared by clones of the controller: one host socket).
    open: BTreeMap<u16, Arc<UdpSocket>>,
}

impl Default for UdpPorts {
    fn default() -> Self {
        UdpPorts {
            address: Ipv4Addr::LOCALHOST,
            open: BTreeMap::new(),
        }
    }
}

impl UdpPorts {
    /// The address the sockets bind to (from the next open or send on).
    pub(crate) fn set_address(&mut self, address: Ipv4Addr) {
        self.address = address;
    }

    /// The address the sockets bind to.
    pub(crate) fn address(&self) -> Ipv4Addr {
        self.address
    }

    /// Where the controller's own UDP ports are on the host (its bind address; loopback when
    /// it binds every address).
    pub(crate) fn own(&self) -> IpAddr {
        if self.address.is_unspecified() {
            IpAddr::V4(Ipv4Addr::LOCALHOST)
        } else {
            IpAddr::V4(self.address)
        }
    }

    /// `UDP_RECVFROM` opens `port`: the table's port and a host socket on it; −34055 when the
    /// table has it open, −34019 when the host refuses the socket (the port is taken).
    pub(crate) fn open(&mut self, net: &mut SocketTable, port: u16) -> i32 {
        let r = net.udp_open(port);
        if r < 0 {
            return r;
        }
        let socket = UdpSocket::bind(SocketAddrV4::new(self.address, port))
            .and_then(|s| s.set_nonblocking(true).map(|()| s));
        match socket {
            Ok(s) => {
                self.open.insert(port, Arc::new(s));
                0
            }
            Err(e) => {
                tracing::warn!(port, error = %e, "UDP_RECVFROM: cannot open the port");
                net.udp_close(port);
                TcpCode::OpenFailed.code()
            }
        }
    }

    /// Moves the datagrams waiting on `port`'s host socket into the table (IPv4 senders only;
    /// at most [`MAX_TRANSFER`] bytes of each are kept); a sender from a mapped host appears
    /// at its cell address.
    pub(crate) fn pump(&mut self, net: &mut SocketTable, port: u16, network: &Network) {
        let Some(s) = self.open.get(&port) else {
            return;
        };
        let mut buf = vec![0u8; 65536];
        // Bounded: a flood cannot keep the controller here.
        for _ in 0..64 {
            match s.recv_from(&mut buf) {
                Ok((n, SocketAddr::V4(from))) => {
                    let bytes = buf[..n.min(MAX_TRANSFER).min(buf.len())].to_vec();
                    net.udp_deliver(
                        port,
                        Datagram {
                            ip: network.cell_address_of(IpAddr::V4(*from.ip())),
                            port: from.port(),
                            bytes,
                        },
                    );
                }
                Ok((_, SocketAddr::V6(_))) => {}
                Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => break,
                Err(e) => {
                    tracing::debug!(port, error = %e, "UDP receive error");
                    break;
                }
            }
        }
    }

    /// `UDP_RECVFROM` ends: the table's port and the host socket close.
    pub(crate) fn close(&mut self, net: &mut SocketTable, port: u16) {
        net.udp_close(port);
        self.open.remove(&port);
    }

    /// Every host socket closes (a controller restart).
    pub(crate) fn close_all(&mut self) {
        self.open.clear();
    }

    /// `UDP_SENDTO` to `to` (a real address; the controller's own ports are at
    /// [`Self::own`]): one datagram from a socket of its own; −34021 when the host refuses it.
    pub(crate) fn send(&self, to: SocketAddr, data: &[u8]) -> i32 {
        let from: SocketAddr = match to {
            SocketAddr::V4(_) => SocketAddrV4::new(self.address, 0).into(),
            SocketAddr::V6(_) => (std::net::Ipv6Addr::UNSPECIFIED, 0).into(),
        };
        let sent = UdpSocket::bind(from).and_then(|s| s.send_to(data, to));
        match sent {
            Ok(_) => 0,
            Err(e) => {
                tracing::warn!(%to, error = %e, "UDP_SENDTO: the host refused the datagram");
                TcpCode::Communication.code()
            }
        }
    }
}

/// The program's view of the network: where an address it sends to goes ([`Network::route`])
/// and, for an address the host map does not name, E4023 with a log line that says how to map
/// it (a warning the first time for each address, then at debug level: a program retrying
/// every second does not flood the log).
#[derive(Debug, Clone, Default)]
pub(crate) struct Reach {
    warned: BTreeSet<[u8; 4]>,
}

impl Reach {
    /// Where `what` (`TCP_CONNECT`, `UDP_SENDTO`) to `ip:port` goes; `Err` with the program's
    /// code (−34023, "Cannot reach the Host") when the address is unmapped.
    pub(crate) fn route(
        &mut self,
        network: &Network,
        what: &str,
        ip: [u8; 4],
        port: u16,
    ) -> Result<Route, i32> {
        let route = network.route(ip);
        if route != Route::Unmapped {
            return Ok(route);
        }
        let to = SocketAddrV4::new(Ipv4Addr::from(ip), port);
        let own = network.address;
        let cell = Ipv4Addr::from(ip);
        if self.warned.insert(ip) {
            tracing::warn!(
                %to,
                "{what} to {to}: no host is mapped at {cell} (the controller is {own}); the \
                 program gets E4023 (cannot reach the host). Map it to a real host, e.g. \
                 --host {cell}=127.0.0.1 (Python: hosts={{\"{cell}\": \"127.0.0.1\"}})"
            );
        } else {
            tracing::debug!(%to, "{what}: unmapped address, E4023");
        }
        Err(TcpCode::Unreachable.code())
    }
}
