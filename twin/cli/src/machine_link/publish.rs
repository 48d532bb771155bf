//! The shadow's own OPC UA server: publishes what the shadow makes of the machine (estimates,
//! residuals, alarms) for other clients to read or subscribe to.
//!
//! The address space, in namespace `namespace_uri` (index `ns`, the server's first own
//! namespace):
//!
//! - the object `ns=<ns>;s=<object>`, under the Objects folder;
//! - a folder `ns=<ns>;s=<object>/<folder>` per distinct folder, organized by the object;
//! - each variable `ns=<ns>;s=<folder>/<name>`, organized by its folder, read-only, of data
//!   type Double, String or Boolean; Bad (waiting for initial data) until first set;
//! - for a unit with a UNECE code (m, rad, N, N·m, m/s, rad/s, s, kg, A, 1), the variable's
//!   `EngineeringUnits` property (`ns=<ns>;s=<folder>/<name>/EngineeringUnits`, an
//!   EUInformation of the UNECE namespace); other units are only in the description.
//!
//! The server is set up as `twin serve`'s is: loopback only, security policy None, anonymous.

use super::error::LinkError;
use super::link::date_time;
use crate::opcua::endpoint::{self, Endpoint, EndpointError};
use crate::opcua::units::add_engineering_units;
use opcua::server::address_space::{AddressSpace, ObjectBuilder, VariableBuilder};
use opcua::server::diagnostics::NamespaceMetadata;
use opcua::server::node_manager::memory::{simple_node_manager, SimpleNodeManager};
use opcua::server::{
    ServerBuilder, ServerEndpoint, ServerHandle, SubscriptionCache, ANONYMOUS_USER_TOKEN_ID,
};
use opcua::types::{
    DataTypeId, DataValue, DateTime, NodeId, ObjectId, QualifiedName, StatusCode, Variant,
};
use std::collections::BTreeSet;
use std::sync::Arc;
use std::time::Duration;
use tokio::runtime::Runtime;

/// A published variable's data type.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VariableKind {
    /// A number (OPC UA Double).
    Double,
    /// Text (OPC UA String).
    Text,
    /// A flag (OPC UA Boolean).
    Boolean,
}

/// A variable the shadow publishes.
#[derive(Debug, Clone, PartialEq)]
pub struct PublishedVariable {
    /// The folder under the object (`Estimates`, `Residuals`, `Alarms`).
    pub folder: String,
    /// The variable's name, unique in its folder.
    pub name: String,
    /// Its unit (`m`, `N·m`, `1`; empty for text and flags).
    pub unit: String,
    /// What it is, for a person browsing the server.
    pub description: String,
    /// Its data type.
    pub kind: VariableKind,
}

/// A value to publish.
#[derive(Debug, Clone, PartialEq)]
pub enum PublishedValue {
    /// For a [`VariableKind::Double`] variable.
    Double(f64),
    /// For a [`VariableKind::Text`] variable.
    Text(String),
    /// For a [`VariableKind::Boolean`] variable.
    Boolean(bool),
}

/// The shadow's running OPC UA server.
pub struct ShadowServer {
    runtime: Runtime,
    handle: ServerHandle,
    task: tokio::task::JoinHandle<Result<(), String>>,
    manager: Arc<SimpleNodeManager>,
    subscriptions: Arc<SubscriptionCache>,
    /// The variables' node ids and kinds, in the order given to start.
    variables: Vec<(NodeId, VariableKind)>,
    /// The PKI folder the server insists on (no certificates are made); removed with it.
    _pki: tempfile::TempDir,
}

impl ShadowServer {
    /// Starts serving `variables` under `object` in namespace `namespace_uri` at `endpoint`
    /// (`opc.tcp://HOST:PORT`, HOST a loopback address).
    pub fn start(
        endpoint: &str,
        namespace_uri: &str,
        object: &str,
        variables: &[PublishedVariable],
    ) -> Result<ShadowServer, LinkError> {
        let endpoint = endpoint::parse(endpoint).map_err(endpoint_error)?;
        check_names(object, variables)?;
        let runtime = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(1)
            .thread_name("twin-shadow-server")
            .enable_all()
            .build()
            .map_err(LinkError::Runtime)?;
        let listener = std::net::TcpListener::bind(endpoint.addr).map_err(|e| {
            LinkError::Server(format!(
                "cannot listen on {}: {e}; choose another port",
                endpoint.addr
            ))
        })?;
        let pki = tempfile::Builder::new()
            .prefix("twin-opcua-pki-")
            .tempdir()
            .map_err(|e| LinkError::Server(format!("cannot make its PKI folder: {e}")))?;
        let _entered = runtime.enter();
        let (server, handle) = build(&endpoint, &pki, namespace_uri)?;
        let manager = handle
            .node_managers()
            .get_of_type::<SimpleNodeManager>()
            .ok_or_else(|| LinkError::Server("no node manager".into()))?;
        let ns = handle
            .get_namespace_index(namespace_uri)
            .ok_or_else(|| LinkError::Server(format!("no namespace {namespace_uri}")))?;
        let ids = add_nodes(&manager, ns, object, variables);
        let subscriptions = handle.subscriptions().clone();
        let waiting = DataValue {
            value: None,
            status: Some(StatusCode::BadWaitingForInitialData),
            source_timestamp: None,
            source_picoseconds: None,
            server_timestamp: Some(DateTime::now()),
            server_picoseconds: None,
        };
        let _ = manager.set_values(
            &subscriptions,
            ids.iter().map(|id| (id, None, waiting.clone())),
        );
        listener
            .set_nonblocking(true)
            .map_err(|e| LinkError::Server(e.to_string()))?;
        let listener = tokio::net::TcpListener::from_std(listener)
            .map_err(|e| LinkError::Server(e.to_string()))?;
        let task = runtime.spawn(server.run_with(listener));
        drop(_entered);
        Ok(ShadowServer {
            runtime,
            handle,
            task,
            manager,
            subscriptions,
            variables: ids
                .into_iter()
                .zip(variables.iter().map(|v| v.kind))
                .collect(),
            _pki: pki,
        })
    }

    /// Sets variables by index (into the list given to start), all with source timestamp
    /// `source_time` (s since the UNIX epoch); a value of the wrong kind or an index out of
    /// range sets nothing.
    pub fn set(
        &self,
        values: &[(usize, PublishedValue)],
        source_time: f64,
    ) -> Result<(), LinkError> {
        let source = date_time(source_time);
        let now = DateTime::now();
        let mut updates = Vec::with_capacity(values.len());
        for (index, value) in values {
            let (id, kind) = self.variables.get(*index).ok_or_else(|| LinkError::Value {
                index: *index,
                reason: format!("there are {} published variables", self.variables.len()),
            })?;
            let variant = match (kind, value) {
                (VariableKind::Double, PublishedValue::Double(v)) => Variant::Double(*v),
                (VariableKind::Text, PublishedValue::Text(v)) => Variant::from(v.as_str()),
                (VariableKind::Boolean, PublishedValue::Boolean(v)) => Variant::Boolean(*v),
                (kind, value) => {
                    return Err(LinkError::Value {
                        index: *index,
                        reason: format!("a {kind:?} variable cannot take {value:?}"),
                    })
                }
            };
            let data = DataValue {
                value: Some(variant),
                status: Some(StatusCode::Good),
                source_timestamp: Some(source),
                source_picoseconds: None,
                server_timestamp: Some(now),
                server_picoseconds: None,
            };
            updates.push((id, None, data));
        }
        self.manager
            .set_values(&self.subscriptions, updates.into_iter())
            .map_err(|status| LinkError::Server(format!("cannot publish the values: {status}")))
    }

    /// Stops serving after `linger` (so that a client's last call gets its answer) and waits
    /// a little for the server to close its sessions.
    pub fn stop(self, linger: Duration) {
        std::thread::sleep(linger);
        self.handle.cancel();
        let task = self.task;
        let _ = self
            .runtime
            .block_on(async { tokio::time::timeout(Duration::from_secs(5), task).await });
    }
}

/// The endpoint's refusal, without `twin serve`'s flag name.
fn endpoint_error(error: EndpointError) -> LinkError {
    match error {
        EndpointError::Malformed { url, reason } => LinkError::Endpoint { url, reason },
        EndpointError::NotLoopback { url, host } => LinkError::Endpoint {
            url,
            reason: format!(
                "{host} is not a loopback address; the shadow serves security policy None only \
                 on 127.0.0.1, ::1 or localhost"
            ),
        },
    }
}

/// Refuses empty names, a folder named as the object, and a variable twice in a folder.
fn check_names(object: &str, variables: &[PublishedVariable]) -> Result<(), LinkError> {
    if object.is_empty() {
        return Err(LinkError::Server("the object's name is empty".into()));
    }
    let mut seen = BTreeSet::new();
    for (index, variable) in variables.iter().enumerate() {
        let refuse = |reason: &str| LinkError::Value {
            index,
            reason: format!("{}/{}: {reason}", variable.folder, variable.name),
        };
        if variable.folder.is_empty() || variable.name.is_empty() {
            return Err(refuse("its folder and name must not be empty"));
        }
        if variable.folder == object {
            return Err(refuse("its folder has the object's name; rename one"));
        }
        if !seen.insert((variable.folder.as_str(), variable.name.as_str())) {
            return Err(refuse("published twice; give each variable its own name"));
        }
    }
    Ok(())
}

/// The server as `twin serve` builds its own, with one node manager for `namespace`.
fn build(
    endpoint: &Endpoint,
    pki: &tempfile::TempDir,
    namespace: &str,
) -> Result<(opcua::server::Server, ServerHandle), LinkError> {
    let url = format!("opc.tcp://{}:{}/", endpoint.host, endpoint.addr.port());
    ServerBuilder::new()
        .application_name("twin shadow")
        .application_uri("urn:twin:shadow")
        .product_uri("urn:twin")
        .host(endpoint.host.clone())
        .port(endpoint.addr.port())
        .pki_dir(pki.path())
        .discovery_urls(vec![url])
        .add_endpoint(
            "none",
            ServerEndpoint::new_none("/", &[ANONYMOUS_USER_TOKEN_ID.to_string()]),
        )
        .with_node_manager(simple_node_manager(
            NamespaceMetadata {
                namespace_uri: namespace.to_string(),
                ..Default::default()
            },
            "twin-shadow",
        ))
        .build()
        .map_err(LinkError::Server)
}

/// Adds the object, its folders and the variables; returns the variables' ids in order.
fn add_nodes(
    manager: &SimpleNodeManager,
    ns: u16,
    object: &str,
    variables: &[PublishedVariable],
) -> Vec<NodeId> {
    let root = NodeId::new(ns, object.to_string());
    let mut space = manager.address_space().write();
    ObjectBuilder::new(&root, QualifiedName::new(ns, object), object)
        .description(format!("the shadow's view of {object}"))
        .organized_by(ObjectId::ObjectsFolder)
        .insert(&mut *space);
    let mut folders = BTreeSet::new();
    variables
        .iter()
        .map(|variable| {
            let folder = NodeId::new(ns, format!("{object}/{}", variable.folder));
            if folders.insert(variable.folder.clone()) {
                let name = variable.folder.as_str();
                space.add_folder(&folder, QualifiedName::new(ns, name), name, &root);
            }
            add_variable(&mut space, ns, &folder, variable)
        })
        .collect()
}

/// One read-only variable under `folder`, with its EngineeringUnits property when its unit has
/// a UNECE code.
fn add_variable(
    space: &mut AddressSpace,
    ns: u16,
    folder: &NodeId,
    variable: &PublishedVariable,
) -> NodeId {
    let path = format!("{}/{}", variable.folder, variable.name);
    let id = NodeId::new(ns, path.clone());
    let (data_type, initial) = match variable.kind {
        VariableKind::Double => (DataTypeId::Double, Variant::Double(0.0)),
        VariableKind::Text => (DataTypeId::String, Variant::from("")),
        VariableKind::Boolean => (DataTypeId::Boolean, Variant::Boolean(false)),
    };
    let description = if variable.unit.is_empty() {
        variable.description.clone()
    } else {
        format!("{}, {}", variable.description, variable.unit)
    };
    let name = variable.name.as_str();
    VariableBuilder::new(&id, QualifiedName::new(ns, name), name)
        .description(description)
        .data_type(data_type)
        .value(initial)
        .organized_by(folder.clone())
        .insert(space);
    add_engineering_units(space, &id, &path, &variable.unit);
    id
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_checked() {
        let variable = |folder: &str, name: &str| PublishedVariable {
            folder: folder.into(),
            name: name.into(),
            unit: "m".into(),
            description: "x".into(),
            kind: VariableKind::Double,
        };
        assert!(check_names(
            "press",
            &[variable("Estimates", "a"), variable("Residuals", "a")]
        )
        .is_ok());
        assert!(check_names(
            "press",
            &[variable("Estimates", "a"), variable("Estimates", "a")]
        )
        .is_err());
        assert!(check_names("press", &[variable("press", "a")]).is_err());
        assert!(check_names("press", &[variable("", "a")]).is_err());
    }
}
