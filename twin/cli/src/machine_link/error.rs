//! What the machine link fails with: the map file, the machine's server, the nodes, and the
//! shadow's own server. Each message is one line naming the file, key, node or endpoint and
//! what to change.

use std::path::PathBuf;
use std::time::Duration;
use thiserror::Error;

/// Why the machine map, the link to the machine or the shadow's server failed.
#[derive(Debug, Error)]
pub enum LinkError {
    /// The machine map file is unreadable or wrong.
    #[error("{}: {reason}", path.display())]
    Map {
        /// The map file.
        path: PathBuf,
        /// What is wrong and what to change.
        reason: String,
    },
    /// The endpoint URL is not one the link can use.
    #[error("{url}: {reason}")]
    Endpoint {
        /// The URL as given.
        url: String,
        /// What is wrong with it.
        reason: String,
    },
    /// The machine's server did not answer in time.
    #[error(
        "{url}: no answer within {} s; is the machine's server running and reachable?",
        timeout.as_secs_f64()
    )]
    NoAnswer {
        /// The endpoint URL.
        url: String,
        /// How long the link waited.
        timeout: Duration,
    },
    /// The server answered but refused the session or a request.
    #[error("{url}: the server refused the link: {reason}")]
    Refused {
        /// The endpoint URL.
        url: String,
        /// Its status and what was asked.
        reason: String,
    },
    /// A mapped node is not on the server.
    #[error(
        "nodes.\"{column}\": {node} is not on the server ({status}); check the node id in the map"
    )]
    UnknownNode {
        /// The map's column.
        column: String,
        /// The node id as the map gives it.
        node: String,
        /// The server's status for it.
        status: String,
    },
    /// A mapped node's namespace URI is not in the server's NamespaceArray.
    #[error(
        "nodes.\"{column}\": {node}: namespace {uri} is not on the server (it has: {known}); \
         check the nsu= part of the node id"
    )]
    UnknownNamespace {
        /// The map's column.
        column: String,
        /// The node id as the map gives it.
        node: String,
        /// The namespace URI.
        uri: String,
        /// The server's namespace URIs.
        known: String,
    },
    /// A mapped node id does not parse.
    #[error("nodes.\"{column}\": node \"{node}\": {reason}")]
    NodeId {
        /// The map's column.
        column: String,
        /// The node id as given.
        node: String,
        /// What is wrong with it.
        reason: String,
    },
    /// The tokio runtime or the link's thread could not start.
    #[error("cannot start the OPC UA runtime: {0}")]
    Runtime(std::io::Error),
    /// The shadow's server could not be built or started.
    #[error("the shadow's OPC UA server: {0}")]
    Server(String),
    /// A value given to the shadow's server does not fit its variable.
    #[error("published variable {index}: {reason}")]
    Value {
        /// The variable's index in the list given to start.
        index: usize,
        /// What does not fit.
        reason: String,
    },
}
