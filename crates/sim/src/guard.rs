//! The HTTP guard in front of the emulator's pendant API and of the web faces built on it:
//! what a page in the user's browser from another site, or a DNS-rebinding attack, must not be
//! able to do, and the bearer token. One set of rules; each server words its own refusals
//! ([`GuardRefusal`]).
//!
//! - **Host** must name the address the server is bound to ([`PendantAccess`]); a request
//!   without a readable `Host` is refused.
//! - **Origin**, when the browser sends one, must be the server's own origin.
//! - **POST** must carry `Content-Type: application/json` (a cross-site form cannot send it
//!   without a CORS preflight, which these servers never grant).
//! - **Token**: when the server has one, a request that needs it must carry
//!   `Authorization: Bearer <token>` (the scheme name is case-insensitive, RFC 9110 §11.1),
//!   compared in constant time.

use std::net::SocketAddr;
use std::sync::Arc;

use axum::http::{header, HeaderMap, Method};

/// Who may call a server bound to an address: the `Host` names and the origin the browser
/// checks accept.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PendantAccess {
    /// Accepted `host:port` authorities (lower case). Empty: any `Host` (only for a server bound
    /// to an unspecified address, which requires a token anyway).
    hosts: Vec<String>,
}

impl PendantAccess {
    /// The authorities under which a server bound to `addr` is reached: the address itself,
    /// and on loopback also `localhost` and both loopback literals. Bound to `0.0.0.0`/`::`,
    /// the machine's addresses are not known, so any `Host` is accepted (a token is then
    /// mandatory).
    pub fn bound_to(addr: SocketAddr) -> PendantAccess {
        let port = addr.port();
        if addr.ip().is_unspecified() {
            return PendantAccess { hosts: Vec::new() };
        }
        let mut hosts = vec![match addr {
            SocketAddr::V4(a) => format!("{}:{port}", a.ip()),
            SocketAddr::V6(a) => format!("[{}]:{port}", a.ip()),
        }];
        if addr.ip().is_loopback() {
            for h in ["localhost", "127.0.0.1", "[::1]"] {
                let h = format!("{h}:{port}");
                if !hosts.contains(&h) {
                    hosts.push(h);
                }
            }
        }
        PendantAccess { hosts }
    }

    /// `true` when `host` (a `Host` header value) names this server. A missing port means 80.
    pub fn host_allowed(&self, host: &str) -> bool {
        if self.hosts.is_empty() {
            return true;
        }
        let host = host.trim().to_ascii_lowercase();
        let with_port = if host.ends_with(']') || !host.contains(':') {
            format!("{host}:80")
        } else {
            host
        };
        self.hosts.contains(&with_port)
    }

    /// `true` when `origin` (an `Origin` header value) is this server's own origin.
    pub fn origin_allowed(&self, origin: &str) -> bool {
        match origin.trim().strip_prefix("http://") {
            Some(authority) if !authority.contains('/') => self.host_allowed(authority),
            _ => false,
        }
    }
}

/// Why the guard refused a request (the server words it, with its remedy).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum GuardRefusal {
    /// The `Host` header does not name this server (DNS rebinding); `None`: no readable `Host`.
    ForeignHost(Option<String>),
    /// The `Origin` header is another site's (the header's text).
    ForeignOrigin(String),
    /// A POST without `Content-Type: application/json`.
    NotJson,
    /// The server has a token and the request carries none.
    NoToken,
    /// The request carries a token that is not the server's.
    WrongToken,
}

/// The rules of one HTTP server: the address it is bound to and its token.
#[derive(Debug, Clone)]
pub struct RequestGuard {
    access: PendantAccess,
    token: Option<Arc<str>>,
}

impl RequestGuard {
    /// The rules for a server bound to `bound`, with `token` (when given, even empty, a
    /// request that needs it must carry it; filter empty tokens out first to mean none).
    pub fn new(bound: SocketAddr, token: Option<String>) -> RequestGuard {
        RequestGuard {
            access: PendantAccess::bound_to(bound),
            token: token.map(Arc::from),
        }
    }

    /// The `Host` and `Origin` rules.
    pub fn access(&self) -> &PendantAccess {
        &self.access
    }

    /// Checks one request: the browser checks (`Host`, `Origin`, a JSON POST), then, when
    /// `token_needed`, the token.
    pub fn check(
        &self,
        method: &Method,
        headers: &HeaderMap,
        token_needed: bool,
    ) -> Result<(), GuardRefusal> {
        let host = headers.get(header::HOST).and_then(|v| v.to_str().ok());
        if !host.is_some_and(|h| self.access.host_allowed(h)) {
            return Err(GuardRefusal::ForeignHost(host.map(str::to_owned)));
        }
        if let Some(origin) = headers.get(header::ORIGIN) {
            let origin = origin.to_str().unwrap_or("");
            if !self.access.origin_allowed(origin) {
                return Err(GuardRefusal::ForeignOrigin(origin.to_owned()));
            }
        }
        if method == Method::POST {
            let json = headers
                .get(header::CONTENT_TYPE)
                .and_then(|v| v.to_str().ok())
                .and_then(|v| v.split(';').next())
                .is_some_and(|v| v.trim().eq_ignore_ascii_case("application/json"));
            if !json {
                return Err(GuardRefusal::NotJson);
            }
        }
        match (&self.token, token_needed) {
            (Some(token), true) => {
                let given = headers
                    .get(header::AUTHORIZATION)
                    .and_then(|v| v.to_str().ok())
                    .and_then(|v| {
                        let (scheme, rest) = v.split_once(' ')?;
                        scheme
                            .eq_ignore_ascii_case("bearer")
                            .then_some(rest.trim_start())
                    });
                match given {
                    None => Err(GuardRefusal::NoToken),
                    Some(g) if constant_time_eq(g.as_bytes(), token.as_bytes()) => Ok(()),
                    Some(_) => Err(GuardRefusal::WrongToken),
                }
            }
            _ => Ok(()),
        }
    }
}

/// Compares two byte strings in a time that depends on their length only.
fn constant_time_eq(a: &[u8], b: &[u8]) -> bool {
    if a.len() != b.len() {
        return false;
    }
    a.iter().zip(b).fold(0u8, |acc, (x, y)| acc | (x ^ y)) == 0
}

#[cfg(test)]
mod tests {
    use super::*;
    use axum::http::HeaderValue;

    /// A GET's headers: `Host` and `Authorization`, each when given.
    fn get(host: Option<&'static str>, authorization: Option<&'static str>) -> HeaderMap {
        [(header::HOST, host), (header::AUTHORIZATION, authorization)]
            .into_iter()
            .filter_map(|(name, value)| Some((name, HeaderValue::from_static(value?))))
            .collect()
    }

    #[test]
    fn a_request_without_a_host_is_refused_even_when_any_host_is_accepted() {
        let g = RequestGuard::new("0.0.0.0:80".parse().unwrap(), Some("t".into()));
        assert_eq!(
            g.check(&Method::GET, &get(None, None), false),
            Err(GuardRefusal::ForeignHost(None))
        );
        assert!(g
            .check(&Method::GET, &get(Some("robot.lan"), None), false)
            .is_ok());
    }

    #[test]
    fn the_token_is_checked_only_when_needed_and_tells_missing_from_wrong() {
        let g = RequestGuard::new("127.0.0.1:8080".parse().unwrap(), Some("s3cret".into()));
        let host = Some("127.0.0.1:8080");
        assert!(g.check(&Method::GET, &get(host, None), false).is_ok());
        assert_eq!(
            g.check(&Method::GET, &get(host, None), true),
            Err(GuardRefusal::NoToken)
        );
        assert_eq!(
            g.check(&Method::GET, &get(host, Some("Bearer s3cre")), true),
            Err(GuardRefusal::WrongToken)
        );
        assert!(g
            .check(&Method::GET, &get(host, Some("BEARER   s3cret")), true)
            .is_ok());
    }

    #[test]
    fn constant_time_eq_compares_length_and_every_byte() {
        assert!(constant_time_eq(b"abc", b"abc"));
        assert!(!constant_time_eq(b"abc", b"abd"));
        assert!(!constant_time_eq(b"abc", b"ab"));
        assert!(constant_time_eq(b"", b""));
    }
}
