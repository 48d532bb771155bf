//! The OPC UA server around a run: bound before the run, started with the address space when
//! the run starts, stopped after it. Secured (`--security sign|sign-encrypt`) it offers one
//! Basic256Sha256 endpoint, trusts the clients' certificates in its PKI folder's `trusted/`, and
//! prints one line for each client refused (an untrusted certificate, a wrong password, an
//! anonymous session when a user is required).

use super::address_space::{self, Commanding, Nodes};
use super::error::ServeError;
use super::sampling;
use super::shared::Shared;
use crate::opcua::endpoint::Endpoint;
use crate::opcua::security::{self, Pki, Refusal, Security};
use opcua::server::authenticator::{
    AuthManager, CoreServerPermissions, DefaultAuthenticator, Password, UserToken,
};
use opcua::server::diagnostics::NamespaceMetadata;
use opcua::server::node_manager::memory::{simple_node_manager, SimpleNodeManager};
use opcua::server::{
    ServerBuilder, ServerEndpoint, ServerHandle, ServerUserToken, ANONYMOUS_USER_TOKEN_ID,
};
use opcua::types::{Error, UserTokenPolicy};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;
use tokio::runtime::Runtime;
use twin::SignalLayout;

/// The server's user token id for `--user`.
const USER_TOKEN_ID: &str = "twin-user";

/// How the server is secured.
#[derive(Debug, Clone, Default)]
pub struct ServerSecurity {
    /// The endpoint's security.
    pub security: Security,
    /// The PKI folder, used with Sign or SignAndEncrypt (default: [`security::default_pki`]
    /// of `serve`); security None needs none (a temporary, empty one is used).
    pub pki: Option<PathBuf>,
    /// The user name and password every session must give; None: anonymous sessions.
    pub user: Option<(String, String)>,
}

/// The server's PKI folder.
enum PkiFolder {
    /// A temporary, empty one for security None (async-opcua insists on one); removed with it.
    Temporary(tempfile::TempDir),
    /// The server's own, with its certificate.
    Kept(Pki),
}

impl PkiFolder {
    fn path(&self) -> &Path {
        match self {
            PkiFolder::Temporary(dir) => dir.path(),
            PkiFolder::Kept(pki) => pki.dir(),
        }
    }
}

/// The server's pieces: its runtime, the socket bound early, and once started its handle.
pub struct OpcUaServer {
    runtime: Runtime,
    endpoint: Endpoint,
    listener: Option<std::net::TcpListener>,
    security: ServerSecurity,
    pki: PkiFolder,
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
    /// Binds `endpoint` now, so that a busy port fails before the run; with Sign or
    /// SignAndEncrypt opens the PKI folder (making the server's certificate on first use).
    pub fn bind(endpoint: Endpoint, security: ServerSecurity) -> Result<Self, ServeError> {
        let listener =
            std::net::TcpListener::bind(endpoint.addr).map_err(|source| ServeError::Bind {
                addr: endpoint.addr,
                source,
            })?;
        let pki = if security.security.is_secure() {
            let dir = match &security.pki {
                Some(dir) => dir.clone(),
                None => security::default_pki("serve")?,
            };
            let host = advertised_host(&endpoint);
            PkiFolder::Kept(Pki::open(&dir, "twin serve", APPLICATION_URI, &[host])?)
        } else {
            PkiFolder::Temporary(
                tempfile::Builder::new()
                    .prefix("twin-opcua-pki-")
                    .tempdir()
                    .map_err(|e| ServeError::Server(format!("cannot make its PKI folder: {e}")))?,
            )
        };
        let mut builder = tokio::runtime::Builder::new_multi_thread();
        builder.worker_threads(2).enable_all();
        if let PkiFolder::Kept(pki) = &pki {
            let pki = pki.clone();
            security::on_runtime_threads(
                &mut builder,
                security::refusal_watch(move |refusal| eprintln!("{}", refused(&pki, &refusal))),
            );
        }
        let runtime = builder.build().map_err(ServeError::Runtime)?;
        Ok(Self {
            runtime,
            endpoint,
            listener: Some(listener),
            security,
            pki,
            running: None,
        })
    }

    /// One line on how the server is secured, for the operator; None for security None.
    pub fn describe(&self) -> Option<String> {
        let PkiFolder::Kept(pki) = &self.pki else {
            return None;
        };
        Some(format!(
            "twin serve: Basic256Sha256 {:?} at {}; its certificate is {}; a client refused as \
             untrusted is trusted by moving its certificate from {}/ into {}/",
            self.security.security.mode(),
            self.endpoint.url,
            pki.own_certificate().display(),
            pki.rejected().display(),
            pki.trusted().display()
        ))
    }

    /// Builds the address space of `machine` (its commands as `commanding` has them) and starts
    /// serving it, sampling at every control update (`control_period`, s); prints one line on
    /// stderr with the URL once connections are accepted.
    pub fn start(
        &mut self,
        machine: &str,
        layout: &SignalLayout,
        shared: &Arc<Shared>,
        commanding: Commanding,
        control_period: f64,
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
            advertised_host(&self.endpoint),
            self.endpoint.addr.port()
        );
        let builder = sampling::limits(ServerBuilder::new(), control_period);
        let (server, handle) = self
            .configure(builder)
            .discovery_urls(vec![url.clone()])
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
        let nodes = address_space::build(&manager, ns, machine, layout, shared, commanding);
        let subscriptions = handle.subscriptions().clone();
        listener
            .set_nonblocking(true)
            .map_err(|e| ServeError::Server(e.to_string()))?;
        let listener = tokio::net::TcpListener::from_std(listener)
            .map_err(|e| ServeError::Server(e.to_string()))?;
        let task = self.runtime.spawn(server.run_with(listener));
        self.running = Some((handle, task));
        eprintln!("listening on {url} (machine nsu={namespace};s={machine})");
        Ok(Published {
            manager,
            subscriptions,
            nodes,
        })
    }

    /// The builder with the application, the PKI folder, the endpoint and its users.
    fn configure(&self, builder: ServerBuilder) -> ServerBuilder {
        let security = self.security.security;
        let mut users = BTreeMap::new();
        let token_ids = match &self.security.user {
            Some((user, password)) => {
                users.insert(
                    USER_TOKEN_ID.to_string(),
                    ServerUserToken::user_pass(user.as_str(), password.as_str()),
                );
                vec![USER_TOKEN_ID.to_string()]
            }
            None => vec![ANONYMOUS_USER_TOKEN_ID.to_string()],
        };
        let mut builder = builder
            .application_name("twin")
            .application_uri(APPLICATION_URI)
            .product_uri("urn:twin")
            .host(advertised_host(&self.endpoint))
            .port(self.endpoint.addr.port())
            .pki_dir(self.pki.path())
            .create_sample_keypair(false)
            .trust_client_certs(false)
            .add_endpoint(
                security.flag(),
                ServerEndpoint::new("/", security.policy(), security.mode(), &token_ids),
            )
            .with_authenticator(Arc::new(Authenticator {
                inner: DefaultAuthenticator::new(users.clone()),
                user: self.security.user.as_ref().map(|(user, _)| user.clone()),
            }));
        for (id, token) in users {
            builder = builder.add_user_token(id, token);
        }
        builder
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

/// The server's application URI (also in its certificate).
const APPLICATION_URI: &str = "urn:twin";

/// The host the endpoints advertise: the one bound, or this computer's name when bound to all
/// addresses (0.0.0.0, ::).
fn advertised_host(endpoint: &Endpoint) -> String {
    if endpoint.addr.ip().is_unspecified() {
        if let Some(name) = opcua::crypto::X509Data::computer_hostnames()
            .into_iter()
            .next()
        {
            return name;
        }
    }
    endpoint.host.clone()
}

/// The line printed when a client's certificate is refused as untrusted.
fn refused(pki: &Pki, refusal: &Refusal) -> String {
    let again = if refusal.already_rejected {
        " (refused before)"
    } else {
        ""
    };
    format!(
        "twin serve: refused a client: its certificate {} is not trusted{again}; to trust it, \
         move it into {}/",
        pki.rejected().join(&refusal.file_name).display(),
        pki.trusted().display()
    )
}

/// async-opcua's authenticator for the user tokens given, printing one line for each session
/// refused.
struct Authenticator {
    inner: DefaultAuthenticator,
    /// The user required, if any.
    user: Option<String>,
}

#[async_trait::async_trait]
impl AuthManager for Authenticator {
    async fn authenticate_anonymous_token(&self, endpoint: &ServerEndpoint) -> Result<(), Error> {
        let result = self.inner.authenticate_anonymous_token(endpoint).await;
        if result.is_err() {
            eprintln!(
                "twin serve: refused an anonymous session; sessions must give user \"{}\" and \
                 its password",
                self.user.as_deref().unwrap_or("")
            );
        }
        result
    }

    async fn authenticate_username_identity_token(
        &self,
        endpoint: &ServerEndpoint,
        username: &str,
        password: &Password,
    ) -> Result<UserToken, Error> {
        let result = self
            .inner
            .authenticate_username_identity_token(endpoint, username, password)
            .await;
        if result.is_err() {
            eprintln!(
                "twin serve: refused a session of user \"{username}\": wrong user name or password"
            );
        }
        result
    }

    fn user_token_policies(&self, endpoint: &ServerEndpoint) -> Vec<UserTokenPolicy> {
        self.inner.user_token_policies(endpoint)
    }

    fn core_permissions(&self, token: &UserToken) -> CoreServerPermissions {
        self.inner.core_permissions(token)
    }
}
