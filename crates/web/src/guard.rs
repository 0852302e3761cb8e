//! The HTTP guard in front of every web route: what a page in the user's browser from another
//! site, or a DNS-rebinding attack, must not be able to do.
//!
//! - **Host** must name the address the server is bound to (`127.0.0.1:8080`, or
//!   `localhost:8080` / `[::1]:8080` on loopback; any host when bound to `0.0.0.0`/`::`, where a
//!   token is mandatory; a request without a `Host` is refused). A rebinding attack sends its
//!   own host name.
//! - **Origin**, when the browser sends one, must be this server's own origin.
//! - **POST** must carry `Content-Type: application/json` (a cross-site form cannot).
//! - **Token**: when the server has one, every request except the page itself (`/` and
//!   `/assets/…`, which hold no data) needs `Authorization: Bearer <token>`. The page reads the
//!   token from its own URL fragment (`http://host:port/#token=…`, never sent to the server)
//!   and sends it with every request.
//!
//! The rules are the emulator pendant's, one guard for both ([`RequestGuard`]); this module
//! words its refusals as JSON `{"error": …, "remedy": …}` like the pendant API's.

use std::net::SocketAddr;
use std::sync::Arc;

use axum::extract::{Request, State};
use axum::http::{header, HeaderMap, Method, StatusCode};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use axum::Json;
use fs020n_sim::{GuardRefusal, RequestGuard};
use serde::Serialize;

/// An HTTP error: status, what went wrong, and what to do about it.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct WebError {
    /// HTTP status.
    #[serde(skip)]
    pub status: StatusCode,
    /// What went wrong.
    pub error: String,
    /// How to fix it.
    pub remedy: String,
}

impl WebError {
    /// A new error.
    pub fn new(status: StatusCode, error: impl Into<String>, remedy: impl Into<String>) -> Self {
        WebError {
            status,
            error: error.into(),
            remedy: remedy.into(),
        }
    }
}

impl IntoResponse for WebError {
    fn into_response(self) -> Response {
        let status = self.status;
        let mut r = (status, Json(&self)).into_response();
        if status == StatusCode::UNAUTHORIZED {
            r.headers_mut().insert(
                header::WWW_AUTHENTICATE,
                header::HeaderValue::from_static("Bearer"),
            );
        }
        r
    }
}

/// The rules of one server: its bound address and its token, checked by the emulator
/// pendant's own guard ([`RequestGuard`]).
#[derive(Debug, Clone)]
pub struct Guard {
    bound: SocketAddr,
    rules: Arc<RequestGuard>,
}

impl Guard {
    /// The rules for a server bound to `bound`, with an optional token (an empty token counts
    /// as none).
    pub fn new(bound: SocketAddr, token: Option<String>) -> Guard {
        Guard {
            bound,
            rules: Arc::new(RequestGuard::new(bound, token.filter(|t| !t.is_empty()))),
        }
    }

    /// Refuses a server bound off loopback without a token (it could move the robot).
    pub fn require_token_off_loopback(
        addr: SocketAddr,
        token: Option<&str>,
        what: &str,
    ) -> std::io::Result<()> {
        if !addr.ip().is_loopback() && token.is_none_or(str::is_empty) {
            return Err(std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                format!(
                    "refusing to serve {what} on {addr} without a token: bind it to 127.0.0.1 or \
                     give a token"
                ),
            ));
        }
        Ok(())
    }

    /// `true` when `host` (a Host header value) names this server.
    pub fn host_allowed(&self, host: &str) -> bool {
        self.rules.access().host_allowed(host)
    }

    /// Checks one request; `Err` is the refusal to send. The page itself (`/` and
    /// `/assets/…`) needs no token.
    pub fn check(&self, method: &Method, path: &str, headers: &HeaderMap) -> Result<(), WebError> {
        let public = path == "/" || path.starts_with("/assets/");
        self.rules
            .check(method, headers, !public)
            .map_err(|refusal| self.refused(refusal))
    }

    /// A refusal of the guard, in this server's words.
    fn refused(&self, refusal: GuardRefusal) -> WebError {
        match refusal {
            GuardRefusal::ForeignHost(host) => WebError::new(
                StatusCode::MISDIRECTED_REQUEST,
                format!(
                    "Host {:?} is not this server ({})",
                    host.as_deref().unwrap_or(""),
                    self.bound
                ),
                format!(
                    "open the page by its address, http://{}/ (a different host name is refused \
                     against DNS rebinding)",
                    self.bound
                ),
            ),
            GuardRefusal::ForeignOrigin(origin) => WebError::new(
                StatusCode::FORBIDDEN,
                format!("cross-origin request from {origin:?} refused"),
                format!(
                    "only the page served by this server (http://{}) may use it",
                    self.bound
                ),
            ),
            GuardRefusal::NotJson => WebError::new(
                StatusCode::UNSUPPORTED_MEDIA_TYPE,
                "a POST needs Content-Type: application/json",
                "send a JSON body with the header Content-Type: application/json (e.g. {})",
            ),
            GuardRefusal::NoToken | GuardRefusal::WrongToken => WebError::new(
                StatusCode::UNAUTHORIZED,
                if refusal == GuardRefusal::WrongToken {
                    "wrong token"
                } else {
                    "this server requires a token"
                },
                "send `Authorization: Bearer <token>`; in a browser open \
                 http://HOST:PORT/#token=<token>",
            ),
        }
    }
}

/// The axum middleware applying a [`Guard`] (use with
/// `axum::middleware::from_fn_with_state(guard, guard_layer)`).
pub async fn guard_layer(State(guard): State<Guard>, req: Request, next: Next) -> Response {
    match guard.check(req.method(), req.uri().path(), req.headers()) {
        Ok(()) => next.run(req).await,
        Err(e) => {
            tracing::info!(path = %req.uri().path(), error = %e.error, "web request refused");
            e.into_response()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use axum::http::HeaderValue;

    fn headers(pairs: &[(header::HeaderName, &str)]) -> HeaderMap {
        let mut h = HeaderMap::new();
        for (k, v) in pairs {
            h.insert(k.clone(), HeaderValue::from_str(v).unwrap());
        }
        h
    }

    #[test]
    fn host_rules() {
        let g = Guard::new("127.0.0.1:8080".parse().unwrap(), None);
        assert!(g.host_allowed("127.0.0.1:8080"));
        assert!(g.host_allowed("localhost:8080"));
        assert!(g.host_allowed("LOCALHOST:8080"));
        assert!(!g.host_allowed("127.0.0.1:8081"));
        assert!(!g.host_allowed("evil.example:8080"));
        assert!(!g.host_allowed(""));
        let g = Guard::new("192.168.0.5:80".parse().unwrap(), Some("t".into()));
        assert!(g.host_allowed("192.168.0.5:80"));
        assert!(!g.host_allowed("localhost:80"));
    }

    #[test]
    fn origin_content_type_and_token() {
        let g = Guard::new("127.0.0.1:8080".parse().unwrap(), Some("s3cret".into()));
        let host = (header::HOST, "127.0.0.1:8080");
        // The page itself needs no token.
        assert!(g
            .check(&Method::GET, "/", &headers(std::slice::from_ref(&host)))
            .is_ok());
        assert!(g
            .check(
                &Method::GET,
                "/assets/app.js",
                &headers(std::slice::from_ref(&host))
            )
            .is_ok());
        // Data needs it.
        let e = g
            .check(
                &Method::GET,
                "/state",
                &headers(std::slice::from_ref(&host)),
            )
            .unwrap_err();
        assert_eq!(e.status, StatusCode::UNAUTHORIZED);
        let auth = (header::AUTHORIZATION, "bearer s3cret");
        assert!(g
            .check(
                &Method::GET,
                "/state",
                &headers(&[host.clone(), auth.clone()])
            )
            .is_ok());
        let wrong = (header::AUTHORIZATION, "Bearer nope");
        assert_eq!(
            g.check(&Method::GET, "/state", &headers(&[host.clone(), wrong]))
                .unwrap_err()
                .error,
            "wrong token"
        );
        // POST without JSON.
        let e = g
            .check(
                &Method::POST,
                "/stop",
                &headers(&[host.clone(), auth.clone()]),
            )
            .unwrap_err();
        assert_eq!(e.status, StatusCode::UNSUPPORTED_MEDIA_TYPE);
        let json = (header::CONTENT_TYPE, "application/json; charset=utf-8");
        assert!(g
            .check(
                &Method::POST,
                "/stop",
                &headers(&[host.clone(), auth.clone(), json.clone()])
            )
            .is_ok());
        // Another site's page.
        let foreign = (header::ORIGIN, "http://evil.example");
        let e = g
            .check(
                &Method::POST,
                "/stop",
                &headers(&[host.clone(), auth.clone(), json.clone(), foreign]),
            )
            .unwrap_err();
        assert_eq!(e.status, StatusCode::FORBIDDEN);
        let own = (header::ORIGIN, "http://127.0.0.1:8080");
        assert!(g
            .check(&Method::POST, "/stop", &headers(&[host, auth, json, own]))
            .is_ok());
        // Rebinding: a foreign Host.
        let e = g
            .check(
                &Method::GET,
                "/",
                &headers(&[(header::HOST, "evil.example:8080")]),
            )
            .unwrap_err();
        assert_eq!(e.status, StatusCode::MISDIRECTED_REQUEST);
    }

    #[test]
    fn off_loopback_needs_a_token() {
        let any: SocketAddr = "0.0.0.0:1".parse().unwrap();
        assert!(Guard::require_token_off_loopback(any, None, "x").is_err());
        assert!(Guard::require_token_off_loopback(any, Some(""), "x").is_err());
        assert!(Guard::require_token_off_loopback(any, Some("t"), "x").is_ok());
        let lo: SocketAddr = "127.0.0.1:1".parse().unwrap();
        assert!(Guard::require_token_off_loopback(lo, None, "x").is_ok());
    }
}
