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
    /// The host is not a loopback address, and the server is not secured: security policy None
    /// and anonymous sessions are only served on loopback.
    #[error(
        "--opcua {url}: {host} is not a loopback address; serving beyond 127.0.0.1, ::1 or \
         localhost needs --security sign-encrypt (or sign) and --user NAME with its password \
         (--password-file FILE or TWIN_OPCUA_PASSWORD)"
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
    /// The security settings or the PKI folder are unusable.
    #[error(transparent)]
    Security(#[from] super::security::SecurityError),
    /// The server could not be configured or built.
    #[error("cannot build the OPC UA server: {0}")]
    Server(String),
}
