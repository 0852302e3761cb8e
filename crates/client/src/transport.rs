//! How the client reaches the controller: a [`Connector`] makes one connection per call. The
//! TCP implementation is [`TcpConnector`]; tests implement the trait around an in-memory
//! emulator.

use std::future::Future;
use std::io;
use std::net::{IpAddr, SocketAddr};
use std::pin::Pin;

use fs020n_proto::DEFAULT_PORT;
use tokio::io::{AsyncRead, AsyncWrite};
use tokio::net::TcpStream;

/// A byte stream to the controller.
pub trait AsyncReadWrite: AsyncRead + AsyncWrite + Unpin + Send + 'static {}

impl<T: AsyncRead + AsyncWrite + Unpin + Send + 'static> AsyncReadWrite for T {}

/// A boxed connection.
pub type BoxedStream = Box<dyn AsyncReadWrite>;

/// The future returned by [`Connector::connect`].
pub type ConnectFuture<'a> = Pin<Box<dyn Future<Output = io::Result<BoxedStream>> + Send + 'a>>;

/// Makes connections to a controller. One call = one connection attempt; the client retries
/// across the server's listen gaps itself. Return an error of kind
/// [`InvalidInput`](io::ErrorKind::InvalidInput) when retrying cannot help (the address does
/// not resolve, or is malformed): the client then stops at once with
/// [`ClientError::Address`](crate::ClientError::Address).
///
/// ```
/// use fs020n_client::{BoxedStream, ConnectFuture, Connector};
/// struct Loop;
/// impl Connector for Loop {
///     fn connect(&self) -> ConnectFuture<'_> {
///         Box::pin(async {
///             let (a, _b) = tokio::io::duplex(64);
///             Ok(Box::new(a) as BoxedStream)
///         })
///     }
///     fn describe(&self) -> String {
///         "in-memory".into()
///     }
/// }
/// ```
pub trait Connector: Send + Sync + 'static {
    /// One connection attempt.
    fn connect(&self) -> ConnectFuture<'_>;

    /// What this connects to, for messages (e.g. `"192.168.0.2:10050"`).
    fn describe(&self) -> String;
}

/// Connects over TCP to `host:port` (or `host`, port 10050), resolving the name on every attempt
/// and setting `TCP_NODELAY` (every request must leave in one segment, at once). A name that
/// does not resolve is an [`InvalidInput`](io::ErrorKind::InvalidInput) error (no retries).
#[derive(Debug, Clone)]
pub struct TcpConnector {
    target: String,
}

impl TcpConnector {
    /// A connector to `addr`: `"host:port"`, `"host"` (port 10050), `"1.2.3.4"`, `"[::1]:10050"`.
    pub fn new(addr: impl Into<String>) -> TcpConnector {
        TcpConnector {
            target: addr.into(),
        }
    }

    async fn resolve(&self) -> io::Result<Vec<SocketAddr>> {
        let t = self.target.trim();
        if let Ok(sa) = t.parse::<SocketAddr>() {
            return Ok(vec![sa]);
        }
        if let Ok(ip) = t
            .trim_start_matches('[')
            .trim_end_matches(']')
            .parse::<IpAddr>()
        {
            return Ok(vec![SocketAddr::new(ip, DEFAULT_PORT)]);
        }
        let unresolvable = |e: io::Error| {
            io::Error::new(
                io::ErrorKind::InvalidInput,
                format!("the name does not resolve ({e})"),
            )
        };
        let addrs: Vec<SocketAddr> = match t.rsplit_once(':') {
            Some((_, port)) if port.parse::<u16>().is_ok() => tokio::net::lookup_host(t)
                .await
                .map_err(unresolvable)?
                .collect(),
            _ => tokio::net::lookup_host((t, DEFAULT_PORT))
                .await
                .map_err(unresolvable)?
                .collect(),
        };
        if addrs.is_empty() {
            return Err(io::Error::new(
                io::ErrorKind::InvalidInput,
                "the name resolves to no address",
            ));
        }
        Ok(addrs)
    }
}

impl Connector for TcpConnector {
    fn connect(&self) -> ConnectFuture<'_> {
        Box::pin(async move {
            let mut last = io::Error::new(io::ErrorKind::NotFound, "no address");
            for addr in self.resolve().await? {
                match TcpStream::connect(addr).await {
                    Ok(s) => {
                        s.set_nodelay(true)?;
                        return Ok(Box::new(s) as BoxedStream);
                    }
                    Err(e) => last = e,
                }
            }
            Err(last)
        })
    }

    fn describe(&self) -> String {
        self.target.clone()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[tokio::test]
    async fn resolves_forms_of_addresses() {
        let c = TcpConnector::new("127.0.0.1:1234");
        assert_eq!(
            c.resolve().await.unwrap(),
            vec!["127.0.0.1:1234".parse().unwrap()]
        );
        let c = TcpConnector::new("127.0.0.1");
        assert_eq!(c.resolve().await.unwrap()[0].port(), DEFAULT_PORT);
        let c = TcpConnector::new("[::1]");
        assert_eq!(c.resolve().await.unwrap()[0].port(), DEFAULT_PORT);
        let c = TcpConnector::new("localhost:4321");
        assert!(c.resolve().await.unwrap().iter().all(|a| a.port() == 4321));
        assert_eq!(c.describe(), "localhost:4321");
        let c = TcpConnector::new("no-such-host.invalid:10050");
        assert_eq!(
            c.resolve().await.unwrap_err().kind(),
            io::ErrorKind::InvalidInput
        );
    }
}
