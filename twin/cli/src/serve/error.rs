//! What `twin serve` fails with around its run: the endpoint, the server, the address space.

use thiserror::Error;

/// Why `twin serve` could not serve; each is one line naming what to change.
#[derive(Debug, Error)]
pub enum ServeError {
    /// The `--opcua` URL cannot be served.
    #[error(transparent)]
    Endpoint(#[from] crate::opcua::EndpointError),
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
    Security(#[from] crate::opcua::SecurityError),
    /// The server could not be configured or built.
    #[error("cannot build the OPC UA server: {0}")]
    Server(String),
}
