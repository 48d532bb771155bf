//! The OPC UA server around a run: bound before the run, started with the address space when
//! the run starts, stopped after it.

use super::address_space::{self, Nodes};
use super::endpoint::Endpoint;
use super::error::ServeError;
use super::shared::Shared;
use opcua::server::diagnostics::NamespaceMetadata;
use opcua::server::node_manager::memory::{simple_node_manager, SimpleNodeManager};
use opcua::server::{ServerBuilder, ServerEndpoint, ServerHandle, ANONYMOUS_USER_TOKEN_ID};
use std::sync::Arc;
use std::time::Duration;
use tokio::runtime::Runtime;
use twin::SignalLayout;

/// The server's pieces: its runtime, the socket bound early, and once started its handle.
pub struct OpcUaServer {
    runtime: Runtime,
    endpoint: Endpoint,
    listener: Option<std::net::TcpListener>,
    /// The PKI folder the server insists on (no certificates are made); removed with it.
    pki: tempfile::TempDir,
    running: Option<(ServerHandle, tokio::task::JoinHandle<Result<(), String>>)>,
}

/// What the run publishes through: the node manager and the subscriptions behind it.
pub struct Published {
    /// The machine's nodes.
    pub manager: Arc<SimpleNodeManager>,
    /// Who is told of value changes.
    pub subscriptions: Arc<opcua::server::SubscriptionCache>,
    /// The ids of the published variables.
    pub nodes: Nodes,
}

impl OpcUaServer {
    /// Binds `endpoint` now, so that a busy port fails before the run.
    pub fn bind(endpoint: Endpoint) -> Result<Self, ServeError> {
        let runtime = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(2)
            .enable_all()
            .build()
            .map_err(ServeError::Runtime)?;
        let listener =
            std::net::TcpListener::bind(endpoint.addr).map_err(|source| ServeError::Bind {
                addr: endpoint.addr,
                source,
            })?;
        let pki = tempfile::Builder::new()
            .prefix("twin-opcua-pki-")
            .tempdir()
            .map_err(|e| ServeError::Server(format!("cannot make its PKI folder: {e}")))?;
        Ok(Self {
            runtime,
            endpoint,
            listener: Some(listener),
            pki,
            running: None,
        })
    }

    /// Builds the address space of `machine` and starts serving it.
    pub fn start(
        &mut self,
        machine: &str,
        layout: &SignalLayout,
        shared: &Arc<Shared>,
    ) -> Result<Published, ServeError> {
        let listener = self
            .listener
            .take()
            .ok_or_else(|| ServeError::Server("started twice".into()))?;
        // The server spawns its tasks as it is built.
        let _entered = self.runtime.enter();
        let namespace = format!("urn:twin:{machine}");
        let url = format!(
            "opc.tcp://{}:{}/",
            self.endpoint.host,
            self.endpoint.addr.port()
        );
        let (server, handle) = ServerBuilder::new()
            .application_name("twin")
            .application_uri("urn:twin")
            .product_uri("urn:twin")
            .host(self.endpoint.host.clone())
            .port(self.endpoint.addr.port())
            .pki_dir(self.pki.path())
            .discovery_urls(vec![url])
            .add_endpoint(
                "none",
                ServerEndpoint::new_none("/", &[ANONYMOUS_USER_TOKEN_ID.to_string()]),
            )
            .with_node_manager(simple_node_manager(
                NamespaceMetadata {
                    namespace_uri: namespace.clone(),
                    ..Default::default()
                },
                "twin",
            ))
            .build()
            .map_err(ServeError::Server)?;
        let manager = handle
            .node_managers()
            .get_of_type::<SimpleNodeManager>()
            .ok_or_else(|| ServeError::Server("no node manager".into()))?;
        let ns = handle
            .get_namespace_index(&namespace)
            .ok_or_else(|| ServeError::Server(format!("no namespace {namespace}")))?;
        let nodes = address_space::build(&manager, ns, machine, layout, shared);
        let subscriptions = handle.subscriptions().clone();
        listener
            .set_nonblocking(true)
            .map_err(|e| ServeError::Server(e.to_string()))?;
        let listener = tokio::net::TcpListener::from_std(listener)
            .map_err(|e| ServeError::Server(e.to_string()))?;
        let task = self.runtime.spawn(server.run_with(listener));
        self.running = Some((handle, task));
        Ok(Published {
            manager,
            subscriptions,
            nodes,
        })
    }

    /// Stops serving after `linger` (so that a client's last call gets its answer) and waits
    /// for the server to close its sessions.
    pub fn stop(mut self, linger: Duration) -> Result<(), ServeError> {
        let Some((handle, task)) = self.running.take() else {
            return Ok(());
        };
        std::thread::sleep(linger);
        handle.cancel();
        let ended = self
            .runtime
            .block_on(async { tokio::time::timeout(Duration::from_secs(5), task).await });
        match ended {
            Ok(Ok(Err(reason))) => Err(ServeError::Server(reason)),
            _ => Ok(()),
        }
    }
}
