//! `sim --robots N --threads N`: several emulated robots from one `--listen` (and `--pendant`)
//! address, on consecutive ports, served by one or more threads.

use std::net::SocketAddr;

use crate::error::{CliError, CliResult};

/// The robot (and pendant) addresses of `robots` robots: with one robot, the given addresses;
/// with more, each given address is the first of `robots` consecutive ports (port 0: every
/// robot picks a free port of its own).
pub(crate) fn expand(
    listen: &[SocketAddr],
    pendant: &[SocketAddr],
    robots: u16,
) -> CliResult<Vec<(SocketAddr, Option<SocketAddr>)>> {
    if robots == 0 {
        return Err(CliError::input("--robots must be at least 1"));
    }
    if robots == 1 {
        return Ok(listen
            .iter()
            .enumerate()
            .map(|(i, &l)| (l, pendant.get(i).copied()))
            .collect());
    }
    if listen.len() != 1 || pendant.len() > 1 {
        return Err(CliError::input(
            "--robots N takes one --listen address (and at most one --pendant address): the \
             first of N consecutive ports",
        ));
    }
    let consecutive = |first: SocketAddr, what: &str| -> CliResult<Vec<SocketAddr>> {
        (0..robots)
            .map(|i| {
                if first.port() == 0 {
                    return Ok(first);
                }
                first
                    .port()
                    .checked_add(i)
                    .map(|port| SocketAddr::new(first.ip(), port))
                    .ok_or_else(|| {
                        CliError::input(format!(
                            "{what} {first} + {robots} robots goes beyond port 65535"
                        ))
                    })
            })
            .collect()
    };
    let robot_ports = consecutive(listen[0], "--listen")?;
    let pendant_ports = match pendant.first() {
        Some(&p) => consecutive(p, "--pendant")?.into_iter().map(Some).collect(),
        None => vec![None; usize::from(robots)],
    };
    Ok(robot_ports.into_iter().zip(pendant_ports).collect())
}

/// The runtime of `sim`: `threads` workers (2 by default), or one thread doing everything.
pub(crate) fn runtime(threads: u16) -> CliResult<tokio::runtime::Runtime> {
    let built = match threads {
        0 => return Err(CliError::input("--threads must be at least 1")),
        1 => tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build(),
        n => tokio::runtime::Builder::new_multi_thread()
            .worker_threads(usize::from(n))
            .enable_all()
            .build(),
    };
    built.map_err(|e| CliError::failure(format!("cannot start the async runtime: {e}")))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn a(s: &str) -> SocketAddr {
        s.parse().unwrap()
    }

    #[test]
    fn consecutive_ports_or_port_zero_each() {
        let r = expand(&[a("127.0.0.1:20000")], &[], 3).unwrap();
        assert_eq!(
            r,
            [
                (a("127.0.0.1:20000"), None),
                (a("127.0.0.1:20001"), None),
                (a("127.0.0.1:20002"), None)
            ]
        );
        let r = expand(&[a("127.0.0.1:0")], &[a("127.0.0.1:30000")], 2).unwrap();
        assert_eq!(
            r,
            [
                (a("127.0.0.1:0"), Some(a("127.0.0.1:30000"))),
                (a("127.0.0.1:0"), Some(a("127.0.0.1:30001")))
            ]
        );
        // One robot: the addresses as given, several --listen allowed.
        let r = expand(&[a("127.0.0.1:1"), a("127.0.0.1:5")], &[], 1).unwrap();
        assert_eq!(r.len(), 2);
    }

    #[test]
    fn refusals_name_the_fix() {
        assert!(expand(&[a("127.0.0.1:65535")], &[], 2)
            .unwrap_err()
            .to_string()
            .contains("beyond port 65535"));
        assert!(expand(&[a("127.0.0.1:1"), a("127.0.0.1:2")], &[], 2)
            .unwrap_err()
            .to_string()
            .contains("one --listen"));
        assert!(expand(&[a("127.0.0.1:1")], &[], 0).is_err());
    }
}
