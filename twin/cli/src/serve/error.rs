//! What `twin serve` fails with around its run: the endpoint, the server, the address space.

use thiserror::Error;

/// Why `twin serve` could not serve; each is one line naming what to change.
#[derive(Debug, Error)]
pub enum ServeError {
    /// The `--opcua` URL is not `opc.tcp://HOST:PORT`.
    #[error("--opcua {url}: {reason}")]
    Endpoint {
        /// The URL as given.
        url: String,
        /// What is wrong with it.
        reason: String,
    },
    /// The host is not a loopback address; security policy None is only served on loopback.
    #[error(
        "--opcua {url}: {host} is not a loopback address; `twin serve` has no certificates yet, \
         and serves security policy None only on 127.0.0.1, ::1 or localhost"
    )]
    NotLoopback {
        /// The URL as given.
        url: String,
        /// Its host.
        host: String,
    },
    /// The OPC UA runtime (tokio) could not start.
    #[error("cannot start the OPC UA runtime: {0}")]
    Runtime(std::io::Error),
    /// The port could not be bound.
    #[error("cannot listen on {addr}: {source}")]
    Bind {
        /// The socket address.
        addr: std::net::SocketAddr,
        /// Why.
        source: std::io::Error,
    },
    /// The server could not be configured or built.
    #[error("cannot build the OPC UA server: {0}")]
    Server(String),
}
