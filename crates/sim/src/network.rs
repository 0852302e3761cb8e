//! The emulated controller's place on a network: its own address, the hosts of the cell behind
//! the addresses its programs send to (the host map), and the host ports its programs'
//! listening ports are served on (the port map).
//!
//! A program written for a cell hard-codes the cell's addresses (`192.168.0.10` for the PC,
//! its own `192.168.0.2`). The emulator runs on one machine: the host map says which real host
//! each cell address is (`192.168.0.10 → 127.0.0.1`), so the program runs unchanged. An
//! address the map does not name is not reached — never silently some other host: the
//! program's `TCP_CONNECT`/`UDP_SENDTO` gets E4023 "Cannot reach the Host" and the log names
//! the address and the flag that maps it.

use std::collections::BTreeMap;
use std::net::{IpAddr, Ipv4Addr};

use serde::{Deserialize, Serialize};

/// The controller's address when none is given: the usual address of a robot controller in a
/// cell (set yours with `--address`).
pub const DEFAULT_ADDRESS: Ipv4Addr = Ipv4Addr::new(192, 168, 0, 2);

/// The controller's network settings (a part of [`crate::ControllerConfig`]).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Network {
    /// The controller's own address: what its programs see as its IP, and where a
    /// `TCP_CONNECT`/`UDP_SENDTO` to it goes (its own ports). 127.0.0.1 is its own too.
    pub address: Ipv4Addr,
    /// The hosts of the cell: an address a program sends to → the real host that answers for
    /// it. A client from a mapped real host appears to the program at its cell address.
    pub hosts: BTreeMap<Ipv4Addr, IpAddr>,
}

impl Default for Network {
    fn default() -> Self {
        Network {
            address: DEFAULT_ADDRESS,
            hosts: BTreeMap::new(),
        }
    }
}

/// Where a program's connection or datagram to an address goes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Route {
    /// The controller itself (its own address, or loopback): its own listening ports.
    Own,
    /// A real host, through the host map.
    Host(IpAddr),
    /// An address the host map does not name: not reached (E4023).
    Unmapped,
}

impl Network {
    /// Adds a host to the map: programs reach `real` at `cell`.
    pub fn host(mut self, cell: Ipv4Addr, real: IpAddr) -> Self {
        self.hosts.insert(cell, real);
        self
    }

    /// Sets the controller's own address.
    pub fn address(mut self, address: Ipv4Addr) -> Self {
        self.address = address;
        self
    }

    /// Where a program's connection to `ip` goes: the host map first (a mapped address is
    /// that host, even the controller's own), then the controller itself, else unmapped.
    pub fn route(&self, ip: [u8; 4]) -> Route {
        let ip = Ipv4Addr::from(ip);
        if let Some(real) = self.hosts.get(&ip) {
            Route::Host(*real)
        } else if ip == self.address || ip.is_loopback() {
            Route::Own
        } else {
            Route::Unmapped
        }
    }

    /// The address a program sees for a peer at the real address `real`: the cell address
    /// mapped to it (the lowest, when several are), else the real IPv4 address itself
    /// (0.0.0.0 for an IPv6 peer).
    pub fn cell_address_of(&self, real: IpAddr) -> [u8; 4] {
        let real = match real {
            IpAddr::V6(v6) => v6.to_ipv4_mapped().map_or(real, IpAddr::V4),
            v4 => v4,
        };
        if let Some((cell, _)) = self.hosts.iter().find(|(_, r)| **r == real) {
            return cell.octets();
        }
        match real {
            IpAddr::V4(v4) => v4.octets(),
            IpAddr::V6(_) => [0; 4],
        }
    }

    /// Parses one host-map entry, `CELL=REAL` (e.g. `192.168.0.10=127.0.0.1`): the cell
    /// address is IPv4, the real host IPv4 or IPv6.
    pub fn parse_host(text: &str) -> Result<(Ipv4Addr, IpAddr), String> {
        let (cell, real) = text.split_once('=').ok_or_else(|| {
            format!("host entry {text:?}: expected CELL=REAL, e.g. 192.168.0.10=127.0.0.1")
        })?;
        let cell = cell.trim().parse::<Ipv4Addr>().map_err(|e| {
            format!("host entry {text:?}: the cell address {cell:?} is not an IPv4 address ({e})")
        })?;
        let real = real.trim().parse::<IpAddr>().map_err(|e| {
            format!("host entry {text:?}: the real host {real:?} is not an IP address ({e})")
        })?;
        Ok((cell, real))
    }
}

/// What the host serves a listening port the port map does not name on.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum UnlistedPorts {
    /// The same port number (a program's 9111 is the host's 9111).
    #[default]
    Same,
    /// A free port the system picks (tests that run in parallel); read it from
    /// [`crate::Emulator::program_ports`].
    Free,
}

/// Which host port serves each port a program listens on.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct PortMap {
    /// A program's port → the host port serving it (0: a free port the system picks).
    pub ports: BTreeMap<u16, u16>,
    /// Ports not in [`PortMap::ports`].
    pub unlisted: UnlistedPorts,
}

impl PortMap {
    /// Every port at the same number (the default).
    pub fn same() -> PortMap {
        PortMap::default()
    }

    /// Every port not mapped at a free port.
    pub fn free() -> PortMap {
        PortMap {
            ports: BTreeMap::new(),
            unlisted: UnlistedPorts::Free,
        }
    }

    /// Serves the program's `port` at host port `host` (0: a free one).
    pub fn map(mut self, port: u16, host: u16) -> Self {
        self.ports.insert(port, host);
        self
    }

    /// The host port serving the program's `port` (0: a free one).
    pub fn host_port(&self, port: u16) -> u16 {
        match (self.ports.get(&port), self.unlisted) {
            (Some(h), _) => *h,
            (None, UnlistedPorts::Same) => port,
            (None, UnlistedPorts::Free) => 0,
        }
    }

    /// Parses one port-map entry, `PROGRAM=HOST` (e.g. `9111=19111`; `HOST` 0 picks a free
    /// port).
    pub fn parse_entry(text: &str) -> Result<(u16, u16), String> {
        let (p, h) = text.split_once('=').ok_or_else(|| {
            format!("port entry {text:?}: expected PROGRAM=HOST, e.g. 9111=19111")
        })?;
        let p = p
            .trim()
            .parse::<u16>()
            .ok()
            .filter(|p| *p > 0)
            .ok_or_else(|| {
                format!("port entry {text:?}: the program's port {p:?} is not a port (1 to 65535)")
            })?;
        let h = h.trim().parse::<u16>().map_err(|_| {
            format!("port entry {text:?}: the host port {h:?} is not a port (0 to 65535)")
        })?;
        Ok((p, h))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_host_map_wins_then_the_controller_itself_then_nothing() {
        let net = Network::default()
            .host(Ipv4Addr::new(192, 168, 0, 10), IpAddr::from([127, 0, 0, 1]))
            .host(Ipv4Addr::new(127, 0, 0, 5), IpAddr::from([10, 0, 0, 5]));
        assert_eq!(
            net.route([192, 168, 0, 10]),
            Route::Host(IpAddr::from([127, 0, 0, 1]))
        );
        assert_eq!(net.route([192, 168, 0, 2]), Route::Own);
        assert_eq!(net.route([127, 0, 0, 1]), Route::Own);
        assert_eq!(
            net.route([127, 0, 0, 5]),
            Route::Host(IpAddr::from([10, 0, 0, 5]))
        );
        assert_eq!(net.route([192, 168, 0, 11]), Route::Unmapped);
    }

    #[test]
    fn a_peer_from_a_mapped_host_appears_at_its_cell_address() {
        let net = Network::default().host(Ipv4Addr::new(192, 168, 0, 10), [127, 0, 0, 1].into());
        assert_eq!(
            net.cell_address_of([127, 0, 0, 1].into()),
            [192, 168, 0, 10]
        );
        assert_eq!(net.cell_address_of([10, 1, 2, 3].into()), [10, 1, 2, 3]);
        let mapped_v6 = IpAddr::V6(Ipv4Addr::new(127, 0, 0, 1).to_ipv6_mapped());
        assert_eq!(net.cell_address_of(mapped_v6), [192, 168, 0, 10]);
    }

    #[test]
    fn entries_parse_or_say_what_is_expected() {
        assert_eq!(
            Network::parse_host("192.168.0.10=127.0.0.1"),
            Ok((Ipv4Addr::new(192, 168, 0, 10), IpAddr::from([127, 0, 0, 1])))
        );
        assert!(Network::parse_host("192.168.0.10")
            .unwrap_err()
            .contains("CELL=REAL"));
        assert!(Network::parse_host("pc=127.0.0.1")
            .unwrap_err()
            .contains("not an IPv4"));
        assert_eq!(PortMap::parse_entry("9111=19111"), Ok((9111, 19111)));
        assert_eq!(PortMap::parse_entry("9111=0"), Ok((9111, 0)));
        assert!(PortMap::parse_entry("0=5").is_err());
        assert!(PortMap::parse_entry("9111")
            .unwrap_err()
            .contains("PROGRAM=HOST"));
    }

    #[test]
    fn unlisted_ports_keep_their_number_unless_free_is_asked() {
        let same = PortMap::same().map(9111, 19111);
        assert_eq!((same.host_port(9111), same.host_port(9112)), (19111, 9112));
        let free = PortMap::free().map(9111, 19111);
        assert_eq!((free.host_port(9111), free.host_port(9112)), (19111, 0));
    }
}
