//! The link to a running machine: one OPC UA subscription on the machine's server, one
//! monitored item per mapped node, and the samples handed to the caller as [`LinkEvent`]s.
//!
//! A background thread runs a tokio runtime with the async-opcua client: security None and
//! anonymous by default; with [`LinkOptions::security`] Sign or SignAndEncrypt, Basic256Sha256
//! with the link's certificate from its PKI folder ([`LinkOptions::pki`]), the machine's
//! server's certificate checked against that folder's `trusted/`, and a user name and password
//! if [`LinkOptions::user`] is set. The client's own reconnect is not used: it retries a session on the same
//! secure-channel settings and re-creates subscriptions silently (a failure there is only
//! logged), while a machine's server that restarts as a new process knows nothing of the old
//! session. So each connection here is a fresh session; when it drops the link reports
//! [`LinkEvent::Lost`], retries with exponential back-off (0.1 s doubling up to
//! [`LinkOptions::max_backoff`]), re-creates the subscription and its items on a fresh session
//! and reports [`LinkEvent::Restored`]. A closed connection is seen at once; a server that
//! hangs, after three failed keep-alive reads (1 s apart, each waiting up to the connect
//! timeout). After a restore each node's first sample is the server's current value, which a
//! server that survived a network drop has delivered already: the caller drops samples not
//! newer than the last it has.
//!
//! Every data change is asked for (trigger StatusValueTimestamp: a repeated value with a new
//! source timestamp is a sample too; servers that refuse the filter get none), queued on the
//! server up to [`QUEUE_SIZE`] per node, published every [`PUBLISHING_INTERVAL`]. Samples with
//! a Bad status carry no number and are skipped. The channel to [`MachineLink::recv`] is
//! bounded ([`CHANNEL_CAPACITY`]); a caller that falls that far behind holds back the client,
//! and the server's queues then drop their oldest samples.

use super::error::LinkError;
use super::map::{parse_node_id, Identifier, MappedNode, Namespace, NodeAddress};
pub use crate::opcua::security::Security;
use crate::opcua::security::{self, Pki, Refusal};
use opcua::client::{ClientBuilder, IdentityToken, MonitoredItem, Session, SubscriptionCallbacks};
use opcua::types::{
    AttributeId, DataChangeFilter, DataChangeTrigger, DataValue, DateTime, ExtensionObject,
    MessageSecurityMode, MonitoredItemCreateRequest, MonitoringMode, MonitoringParameters, NodeId,
    ReadValueId, StatusCode, TimestampsToReturn, UserTokenPolicy, VariableId, Variant,
};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError, SyncSender};
use std::sync::{Arc, Mutex};
use std::time::{Duration, SystemTime, UNIX_EPOCH};
use tokio::sync::watch;

/// How often the server sends the queued notifications.
pub const PUBLISHING_INTERVAL: Duration = Duration::from_millis(20);
/// Samples the server queues per node between publishes (1 s at 1 kHz).
pub const QUEUE_SIZE: u32 = 1000;
/// Events held for a caller that has not called `recv` yet.
pub const CHANNEL_CAPACITY: usize = 1_000_000;
/// The first pause between reconnection attempts; it doubles up to `max_backoff`.
const FIRST_BACKOFF: Duration = Duration::from_millis(100);
/// OPC UA ticks (100 ns since 1601-01-01) at the UNIX epoch.
const UNIX_EPOCH_TICKS: i64 = 116_444_736_000_000_000;

/// How the link connects and samples.
#[derive(Clone, PartialEq)]
pub struct LinkOptions {
    /// How long `connect` (and each reconnection attempt) waits for the server.
    pub connect_timeout: Duration,
    /// The longest pause between reconnection attempts.
    pub max_backoff: Duration,
    /// The sampling interval asked of the server; zero is as fast as it samples.
    pub sampling_interval: Duration,
    /// The connection's security: None, or Basic256Sha256 Sign or SignAndEncrypt.
    pub security: Security,
    /// The link's PKI folder with Sign or SignAndEncrypt: its certificate (`own/cert.der`, made
    /// on first use; the machine's server must trust it), key, and the machine servers'
    /// certificates it trusts (`trusted/`; a new one is put in `rejected/`). None: the default,
    /// `$XDG_DATA_HOME/twin/pki/shadow` (else `~/.local/share/twin/pki/shadow`).
    pub pki: Option<PathBuf>,
    /// The user name and password to give the server; None: an anonymous session.
    pub user: Option<(String, String)>,
}

impl Default for LinkOptions {
    fn default() -> Self {
        Self {
            connect_timeout: Duration::from_secs(5),
            max_backoff: Duration::from_secs(5),
            sampling_interval: Duration::ZERO,
            security: Security::None,
            pki: None,
            user: None,
        }
    }
}

impl std::fmt::Debug for LinkOptions {
    /// As derived, with the password left out.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LinkOptions")
            .field("connect_timeout", &self.connect_timeout)
            .field("max_backoff", &self.max_backoff)
            .field("sampling_interval", &self.sampling_interval)
            .field("security", &self.security)
            .field("pki", &self.pki)
            .field("user", &self.user.as_ref().map(|(user, _)| (user, "*****")))
            .finish()
    }
}

/// The link's PKI folder.
enum LinkPki {
    /// Security None: a temporary, empty folder (the client insists on one); removed with it.
    Temporary(tempfile::TempDir),
    /// Sign or SignAndEncrypt: the link's own, with its certificate.
    Kept(Pki),
}

impl LinkPki {
    /// Security None: a temporary folder; otherwise `options.pki` (or the default) opened,
    /// the link's certificate made on first use.
    fn open(url: &str, options: &LinkOptions) -> Result<LinkPki, LinkError> {
        let bad = |e: security::SecurityError| LinkError::Endpoint {
            url: url.to_string(),
            reason: e.to_string(),
        };
        if !options.security.is_secure() {
            let dir = tempfile::Builder::new()
                .prefix("twin-opcua-client-pki-")
                .tempdir()
                .map_err(LinkError::Runtime)?;
            return Ok(LinkPki::Temporary(dir));
        }
        let dir = match &options.pki {
            Some(dir) => dir.clone(),
            None => security::default_pki("shadow").map_err(bad)?,
        };
        Pki::open(&dir, "twin shadow", APPLICATION_URI, &[])
            .map(LinkPki::Kept)
            .map_err(bad)
    }

    fn path(&self) -> &std::path::Path {
        match self {
            LinkPki::Temporary(dir) => dir.path(),
            LinkPki::Kept(pki) => pki.dir(),
        }
    }
}

/// The link's application URI (also in its certificate).
const APPLICATION_URI: &str = "urn:twin:shadow";

/// What the link reports.
#[derive(Debug, Clone, PartialEq)]
pub enum LinkEvent {
    /// One value of node `node` (index into the map's nodes), with its source timestamp (s
    /// since the UNIX epoch; the server timestamp if the source one is missing) and the value
    /// as f64 (any numeric variant; a non-numeric one gives [`LinkEvent::Refused`] once per
    /// node).
    Sample {
        /// Index into the nodes given to `connect`.
        node: usize,
        /// Source timestamp, s since the UNIX epoch.
        source_time: f64,
        /// The value.
        value: f64,
    },
    /// The connection dropped at `at` (wall clock, s since epoch), with why.
    Lost {
        /// Wall clock, s since the UNIX epoch.
        at: f64,
        /// Why, as the client saw it.
        reason: String,
    },
    /// Connected again (subscriptions restored) at `at`, after `attempts` tries.
    Restored {
        /// Wall clock, s since the UNIX epoch.
        at: f64,
        /// Connection attempts it took.
        attempts: u32,
    },
    /// Node `node` gives what the link cannot use (a non-numeric value, or gone after a
    /// reconnection).
    Refused {
        /// Index into the nodes given to `connect`.
        node: usize,
        /// Why.
        reason: String,
    },
}

/// A live link to a machine's OPC UA server; see the module's documentation.
pub struct MachineLink {
    events: Option<Receiver<LinkEvent>>,
    /// Per node: the sampling interval the server granted at the last (re)connection, s.
    sampling: Arc<Mutex<Vec<Option<f64>>>>,
    stop: watch::Sender<bool>,
    thread: Option<std::thread::JoinHandle<()>>,
}

/// A mapped node with its parsed address.
#[derive(Debug, Clone)]
struct Target {
    column: String,
    text: String,
    address: NodeAddress,
}

/// What every connection attempt needs.
struct Context {
    url: String,
    targets: Vec<Target>,
    options: LinkOptions,
    events: SyncSender<LinkEvent>,
    /// Per node: a Refused has been sent (non-numeric values are refused once).
    refused: Arc<Vec<AtomicBool>>,
    /// The client's PKI folder.
    pki: LinkPki,
    /// The machine's server's certificate last refused as untrusted by the client, if any.
    refusal: Arc<Mutex<Option<Refusal>>>,
    /// Makes the refusals of certificates seen (see [`security::refusal_watch`]).
    watch: tracing::Dispatch,
    /// Per node: the sampling interval the server granted, s.
    sampling: Arc<Mutex<Vec<Option<f64>>>>,
}

/// One live session: the session and the task driving it, which ends with why it ended.
/// Dropping it stops the task (and so the session's connection).
struct Connection {
    session: Arc<Session>,
    driver: tokio::task::JoinHandle<String>,
}

impl Drop for Connection {
    fn drop(&mut self) {
        self.driver.abort();
    }
}

/// Why one connection attempt failed.
enum Failure {
    /// The server did not answer, or the connection broke: worth retrying.
    Transient,
    /// The server answered but the map does not fit it, or it refused the session.
    Fatal(LinkError),
}

impl MachineLink {
    /// Connects to `endpoint`, checks every node is on the server, subscribes to them all and
    /// starts delivering [`LinkEvent`]s; fails with one line if the server does not answer
    /// within the connect timeout, or a node or namespace is not on it.
    pub fn connect(
        endpoint: &str,
        nodes: &[MappedNode],
        options: LinkOptions,
    ) -> Result<MachineLink, LinkError> {
        if !endpoint.starts_with("opc.tcp://") {
            return Err(LinkError::Endpoint {
                url: endpoint.to_string(),
                reason: "must start with opc.tcp://".into(),
            });
        }
        let targets = nodes
            .iter()
            .map(|n| {
                parse_node_id(&n.node)
                    .map(|address| Target {
                        column: n.column.clone(),
                        text: n.node.clone(),
                        address,
                    })
                    .map_err(|reason| LinkError::NodeId {
                        column: n.column.clone(),
                        node: n.node.clone(),
                        reason,
                    })
            })
            .collect::<Result<Vec<_>, _>>()?;
        let pki = LinkPki::open(endpoint, &options)?;
        let refusal = Arc::new(Mutex::new(None));
        let seen = refusal.clone();
        let watch = security::refusal_watch(move |r| {
            if let Ok(mut last) = seen.lock() {
                *last = Some(r);
            }
        });
        let runtime = security::on_runtime_threads(
            tokio::runtime::Builder::new_multi_thread()
                .worker_threads(1)
                .thread_name("twin-machine-link")
                .enable_all(),
            watch.clone(),
        )
        .build()
        .map_err(LinkError::Runtime)?;
        let (events_tx, events_rx) = std::sync::mpsc::sync_channel(CHANNEL_CAPACITY);
        let sampling = Arc::new(Mutex::new(vec![None; targets.len()]));
        let context = Arc::new(Context {
            url: endpoint.to_string(),
            sampling: sampling.clone(),
            refused: Arc::new(targets.iter().map(|_| AtomicBool::new(false)).collect()),
            targets,
            options,
            events: events_tx,
            pki,
            refusal,
            watch,
        });
        let connection = tracing::dispatcher::with_default(&context.watch, || {
            runtime.block_on(first_connection(&context))
        })?;
        let (stop, stop_rx) = watch::channel(false);
        let thread = std::thread::Builder::new()
            .name("twin-machine-link".into())
            .spawn(move || {
                let watch = context.watch.clone();
                tracing::dispatcher::with_default(&watch, || {
                    runtime.block_on(supervise(context, connection, stop_rx));
                    runtime.shutdown_timeout(Duration::from_secs(1));
                });
            })
            .map_err(LinkError::Runtime)?;
        Ok(MachineLink {
            events: Some(events_rx),
            sampling,
            stop,
            thread: Some(thread),
        })
    }

    /// Per node (in the order given to `connect`): the sampling interval the server granted
    /// at the last (re)connection, s (None before it answered). A server may revise what the
    /// link asks for (every change) to its own fastest rate, silently.
    pub fn granted_sampling(&self) -> Vec<Option<f64>> {
        self.sampling.lock().map(|s| s.clone()).unwrap_or_default()
    }

    /// The next event, waiting at most `timeout`; None on timeout.
    pub fn recv(&mut self, timeout: Duration) -> Option<LinkEvent> {
        let events = self.events.as_ref()?;
        match events.recv_timeout(timeout) {
            Ok(event) => Some(event),
            Err(RecvTimeoutError::Timeout) => None,
            Err(RecvTimeoutError::Disconnected) => {
                // The runtime thread has ended (only on close): nothing more will come.
                std::thread::sleep(timeout);
                None
            }
        }
    }

    /// Closes the session and stops the link's thread.
    pub fn close(mut self) {
        self.shut_down();
    }

    fn shut_down(&mut self) {
        let _ = self.stop.send(true);
        // Dropping the receiver unblocks a callback waiting on a full channel.
        self.events = None;
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

impl Drop for MachineLink {
    fn drop(&mut self) {
        self.shut_down();
    }
}

/// Seconds since the UNIX epoch, now.
fn wall_clock() -> f64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map(|d| d.as_secs_f64())
        .unwrap_or(0.0)
}

/// An OPC UA DateTime as seconds since the UNIX epoch.
pub fn unix_seconds(time: &DateTime) -> f64 {
    (time.checked_ticks() - UNIX_EPOCH_TICKS) as f64 * 1e-7
}

/// Seconds since the UNIX epoch as an OPC UA DateTime (to 100 ns).
pub fn date_time(seconds: f64) -> DateTime {
    let ticks = (seconds * 1e7).round();
    let ticks = if ticks.is_finite() {
        (ticks as i64).saturating_add(UNIX_EPOCH_TICKS).max(0)
    } else {
        0
    };
    DateTime::from(ticks)
}

/// The first connection: retried while the server does not answer, up to the connect
/// timeout; a map that does not fit the server fails at once.
async fn first_connection(context: &Arc<Context>) -> Result<Connection, LinkError> {
    let timeout = context.options.connect_timeout;
    let deadline = tokio::time::Instant::now() + timeout;
    let mut backoff = FIRST_BACKOFF;
    let no_answer = || LinkError::NoAnswer {
        url: context.url.clone(),
        timeout,
    };
    loop {
        let left = deadline.saturating_duration_since(tokio::time::Instant::now());
        match tokio::time::timeout(left, open(context, true)).await {
            Ok(Ok(connection)) => return Ok(connection),
            Ok(Err(Failure::Fatal(error))) => return Err(error),
            Ok(Err(Failure::Transient)) => {}
            Err(_) => return Err(no_answer()),
        }
        let left = deadline.saturating_duration_since(tokio::time::Instant::now());
        if left.is_zero() {
            return Err(no_answer());
        }
        tokio::time::sleep(backoff.min(left)).await;
        backoff = (backoff * 2).min(context.options.max_backoff.max(FIRST_BACKOFF));
    }
}

/// Watches the connection; when it drops, reports Lost and reconnects until stopped.
async fn supervise(
    context: Arc<Context>,
    mut connection: Connection,
    mut stop: watch::Receiver<bool>,
) {
    loop {
        let reason = tokio::select! {
            ended = &mut connection.driver => ended.unwrap_or_else(|e| format!("the client stopped: {e}")),
            _ = stop.wait_for(|s| *s) => {
                close_session(&connection).await;
                return;
            }
        };
        if send(
            &context,
            LinkEvent::Lost {
                at: wall_clock(),
                reason,
            },
        )
        .is_err()
        {
            return;
        }
        let mut backoff = FIRST_BACKOFF;
        let mut attempts = 0u32;
        connection = loop {
            attempts += 1;
            let attempt =
                tokio::time::timeout(context.options.connect_timeout, open(&context, false));
            let outcome = tokio::select! {
                outcome = attempt => outcome,
                _ = stop.wait_for(|s| *s) => return,
            };
            if let Ok(Ok(connection)) = outcome {
                break connection;
            }
            tokio::select! {
                _ = tokio::time::sleep(backoff) => {}
                _ = stop.wait_for(|s| *s) => return,
            }
            backoff = (backoff * 2).min(context.options.max_backoff.max(FIRST_BACKOFF));
        };
        let restored = LinkEvent::Restored {
            at: wall_clock(),
            attempts,
        };
        if send(&context, restored).is_err() {
            close_session(&connection).await;
            return;
        }
    }
}

/// Closes a session politely, not waiting long for a server that is gone.
async fn close_session(connection: &Connection) {
    let _ = tokio::time::timeout(Duration::from_secs(1), connection.session.disconnect()).await;
}

/// Hands an event to the caller (waiting while the channel is full); Err once the caller has
/// closed the link.
fn send(context: &Context, event: LinkEvent) -> Result<(), ()> {
    context.events.send(event).map_err(|_| ())
}

/// One connection attempt: a fresh session, the nodes checked, the subscription made.
/// `first` says a node missing from the server fails the link (rather than being refused).
async fn open(context: &Arc<Context>, first: bool) -> Result<Connection, Failure> {
    let (session, driver) = start_session(context).await?;
    // Built at once, so that an attempt cut short by its timeout ends its session too.
    let mut connection = Connection { session, driver };
    let connected = tokio::select! {
        _ = connection.session.wait_for_connection() => Ok(()),
        ended = &mut connection.driver => Err(ended.unwrap_or_else(|e| e.to_string())),
    };
    if let Err(reason) = connected {
        return Err(classify(context, reason));
    }
    subscribe(context, &connection, first).await?;
    Ok(connection)
}

/// Builds a session on a fresh client and spawns the task that drives it; the task ends with
/// why the connection ended.
async fn start_session(
    context: &Context,
) -> Result<(Arc<Session>, tokio::task::JoinHandle<String>), Failure> {
    let refused = |reason: String| {
        Failure::Fatal(LinkError::Refused {
            url: context.url.clone(),
            reason,
        })
    };
    let security = context.options.security;
    let mut client = ClientBuilder::new()
        .application_name("twin shadow")
        .application_uri(APPLICATION_URI)
        .product_uri("urn:twin")
        .pki_dir(context.pki.path())
        .create_sample_keypair(false)
        // With security, the machine's server's certificate must be in our trusted/.
        .trust_server_certs(!security.is_secure())
        // Our reconnection, not the client's (see the module's documentation).
        .session_retry_limit(0)
        .keep_alive_interval(Duration::from_secs(1))
        .max_failed_keep_alive_count(3)
        .request_timeout(context.options.connect_timeout.max(Duration::from_secs(1)))
        .min_publish_interval(PUBLISHING_INTERVAL)
        .session_timeout(30_000)
        .client()
        .map_err(|errors| refused(format!("the client's settings: {}", errors.join("; "))))?;
    let identity = match &context.options.user {
        Some((user, password)) => IdentityToken::new_user_name(user.clone(), password.clone()),
        None => IdentityToken::Anonymous,
    };
    let (session, event_loop) = if security.is_secure() {
        let endpoint = (
            context.url.as_str(),
            security.policy().to_uri(),
            security.mode(),
        );
        client
            .connect_to_matching_endpoint(endpoint, identity)
            .await
            .map_err(|e| classify(context, e.to_string()))?
    } else {
        let endpoint = (
            context.url.as_str(),
            "http://opcfoundation.org/UA/SecurityPolicy#None",
            MessageSecurityMode::None,
            UserTokenPolicy::anonymous(),
        );
        client
            .connect_to_endpoint_directly(endpoint, identity)
            .map_err(|e| {
                Failure::Fatal(LinkError::Endpoint {
                    url: context.url.clone(),
                    reason: e.to_string(),
                })
            })?
    };
    // A dropped connection ends the event loop (we reconnect on a fresh session).
    session.disable_reconnects();
    let driver = tokio::spawn(async move {
        match event_loop.run().await {
            // The event loop reports no status for a dropped connection.
            StatusCode::Good => "the server closed the connection or stopped answering".into(),
            status => format!("no connection ({status})"),
        }
    });
    Ok((session, driver))
}

/// A failed connection: transient when the server is not there; fatal when it refused us
/// (with security, a certificate not trusted by either side is named).
fn classify(context: &Context, reason: String) -> Failure {
    if let Some(reason) =
        certificate_refusal(context, &reason).or_else(|| user_refusal(context, &reason))
    {
        return Failure::Fatal(LinkError::Refused {
            url: context.url.clone(),
            reason,
        });
    }
    let transient = [
        "BadCommunicationError",
        "BadNotConnected",
        "BadConnectionClosed",
        "BadTimeout",
        "BadTcpInternalError",
        "BadConnectionRejected",
        "BadServerNotConnected",
        "BadEndOfStream",
        "BadDisconnect",
        "BadSecureChannelClosed",
        "BadServerHalted",
        "BadShutdown",
        "BadTooManySessions",
        "BadTcpServerTooBusy",
    ];
    if transient.iter().any(|code| reason.contains(code)) {
        Failure::Transient
    } else {
        Failure::Fatal(LinkError::Refused {
            url: context.url.clone(),
            reason,
        })
    }
}

/// With security, why a certificate was refused and what to do: the machine's server's
/// certificate refused by us (seen by the refusal watch), or ours refused by the server.
fn certificate_refusal(context: &Context, reason: &str) -> Option<String> {
    let LinkPki::Kept(pki) = &context.pki else {
        return None;
    };
    let ours = context.refusal.lock().ok().and_then(|mut last| last.take());
    if let Some(refusal) = ours {
        return Some(format!(
            "its certificate {} is not trusted by the twin; if it is the machine's, trust it by \
             moving it into {}/",
            pki.rejected().join(&refusal.file_name).display(),
            pki.trusted().display()
        ));
    }
    let untrusted = [
        "BadCertificateUntrusted",
        "BadSecurityChecksFailed",
        "BadCertificateInvalid",
        "BadCertificateRevoked",
        "BadCertificateIssuerRevoked",
    ];
    untrusted.iter().any(|code| reason.contains(code)).then(|| {
        format!(
            "it does not trust the twin's certificate {} ({}); trust it on the machine's server \
             (on `twin serve`: move it from its PKI folder's rejected/ into trusted/)",
            pki.own_certificate().display(),
            untrusted
                .iter()
                .find(|code| reason.contains(*code))
                .unwrap_or(&"untrusted")
        )
    })
}

/// Why the server refused the session's identity, if it did.
fn user_refusal(context: &Context, reason: &str) -> Option<String> {
    let codes = [
        "BadIdentityTokenRejected",
        "BadIdentityTokenInvalid",
        "BadUserAccessDenied",
    ];
    let code = codes.iter().find(|code| reason.contains(*code))?;
    Some(match &context.options.user {
        Some((user, _)) => {
            format!("it refused user \"{user}\" ({code}); check the user name and password")
        }
        None => format!("it refused an anonymous session ({code}); give a user name and password"),
    })
}

/// Resolves the nodes on the server, checks each by reading its Value, and subscribes to
/// those there. On the first connection a node or namespace not on the server fails the link;
/// on a later one it is refused (once) and the others carry on.
async fn subscribe(
    context: &Arc<Context>,
    connection: &Connection,
    first: bool,
) -> Result<(), Failure> {
    let session = &connection.session;
    let ids = resolve(context, session).await?;
    let read: Vec<ReadValueId> = ids.iter().map(|id| ReadValueId::from(id.clone())).collect();
    let values = session
        .read(&read, TimestampsToReturn::Neither, 0.0)
        .await
        .map_err(|e| classify(context, e.status().to_string()))?;
    let mut items = Vec::new();
    for (index, (target, id)) in context.targets.iter().zip(&ids).enumerate() {
        let status = values
            .get(index)
            .and_then(|v| v.status)
            .unwrap_or(StatusCode::Good);
        if is_missing(status) {
            let error = LinkError::UnknownNode {
                column: target.column.clone(),
                node: target.text.clone(),
                status: format!("{status}"),
            };
            if first {
                return Err(Failure::Fatal(error));
            }
            let _ = send(
                context,
                LinkEvent::Refused {
                    node: index,
                    reason: error.to_string(),
                },
            );
            continue;
        }
        items.push(item(
            index,
            id.clone(),
            context.options.sampling_interval,
            true,
        ));
    }
    let subscription = session
        .create_subscription(
            PUBLISHING_INTERVAL,
            // Lifetime and keep-alive counts in publishing intervals: 30 s and 1 s.
            1500,
            50,
            0,
            0,
            true,
            callbacks(context),
        )
        .await
        .map_err(|e| classify(context, e.status().to_string()))?;
    create_items(context, session, subscription, items, first).await
}

/// Creates the monitored items; an item whose filter the server refuses is made again
/// without it (every value change is then reported, not a repeated value).
async fn create_items(
    context: &Arc<Context>,
    session: &Session,
    subscription: u32,
    items: Vec<MonitoredItemCreateRequest>,
    first: bool,
) -> Result<(), Failure> {
    let mut again = Vec::new();
    for (with_filter, batch) in [(true, items), (false, Vec::new())] {
        let batch = if with_filter {
            batch
        } else {
            std::mem::take(&mut again)
        };
        if batch.is_empty() {
            continue;
        }
        let results = session
            .create_monitored_items(subscription, TimestampsToReturn::Both, batch.clone())
            .await
            .map_err(|e| classify(context, e.status().to_string()))?;
        for (request, created) in batch.iter().zip(&results) {
            let status = created.result.status_code;
            let index = request.requested_parameters.client_handle as usize - 1;
            if status.is_good() {
                let granted = created.result.revised_sampling_interval / 1e3;
                if let Ok(mut sampling) = context.sampling.lock() {
                    if let Some(slot) = sampling.get_mut(index) {
                        *slot = Some(granted);
                    }
                }
                continue;
            }
            if with_filter && filter_refused(status) {
                let id = request.item_to_monitor.node_id.clone();
                again.push(item(index, id, context.options.sampling_interval, false));
                continue;
            }
            let target = &context.targets[index];
            let reason = format!(
                "nodes.\"{}\": {} cannot be monitored ({status})",
                target.column, target.text
            );
            if first {
                let url = context.url.clone();
                return Err(Failure::Fatal(LinkError::Refused { url, reason }));
            }
            let _ = send(
                context,
                LinkEvent::Refused {
                    node: index,
                    reason,
                },
            );
        }
    }
    Ok(())
}

/// A monitored item's status that says the server does not take its data-change filter.
fn filter_refused(status: StatusCode) -> bool {
    matches!(
        status,
        StatusCode::BadMonitoredItemFilterUnsupported
            | StatusCode::BadMonitoredItemFilterInvalid
            | StatusCode::BadFilterNotAllowed
    )
}

/// A node id's status on reading it that says it is not there (or not a variable).
fn is_missing(status: StatusCode) -> bool {
    matches!(
        status,
        StatusCode::BadNodeIdUnknown
            | StatusCode::BadNodeIdInvalid
            | StatusCode::BadAttributeIdInvalid
            | StatusCode::BadNotReadable
    )
}

/// The monitored item for node `index` (its client handle is `index + 1`).
fn item(index: usize, id: NodeId, sampling: Duration, filter: bool) -> MonitoredItemCreateRequest {
    let filter = if filter {
        ExtensionObject::from_message(DataChangeFilter {
            trigger: DataChangeTrigger::StatusValueTimestamp,
            deadband_type: 0,
            deadband_value: 0.0,
        })
    } else {
        ExtensionObject::null()
    };
    MonitoredItemCreateRequest {
        item_to_monitor: ReadValueId {
            node_id: id,
            attribute_id: AttributeId::Value as u32,
            ..Default::default()
        },
        monitoring_mode: MonitoringMode::Reporting,
        requested_parameters: MonitoringParameters {
            client_handle: index as u32 + 1,
            sampling_interval: sampling.as_secs_f64() * 1e3,
            filter,
            queue_size: QUEUE_SIZE,
            // A live shadow wants the newest samples if the queue ever overflows.
            discard_oldest: true,
        },
    }
}

/// The node ids on this server: `nsu=` resolved through its NamespaceArray.
async fn resolve(context: &Context, session: &Session) -> Result<Vec<NodeId>, Failure> {
    let namespaces = if context
        .targets
        .iter()
        .any(|t| matches!(t.address.namespace, Namespace::Uri(_)))
    {
        namespace_array(context, session).await?
    } else {
        Vec::new()
    };
    context
        .targets
        .iter()
        .map(|target| {
            let namespace = match &target.address.namespace {
                Namespace::Index(index) => *index,
                Namespace::Uri(uri) => namespaces
                    .iter()
                    .position(|known| known == uri)
                    .and_then(|i| u16::try_from(i).ok())
                    .ok_or_else(|| {
                        Failure::Fatal(LinkError::UnknownNamespace {
                            column: target.column.clone(),
                            node: target.text.clone(),
                            uri: uri.clone(),
                            known: namespaces.join(", "),
                        })
                    })?,
            };
            Ok(match &target.address.identifier {
                Identifier::String(name) => NodeId::new(namespace, name.clone()),
                Identifier::Numeric(number) => NodeId::new(namespace, *number),
            })
        })
        .collect()
}

/// The server's NamespaceArray.
async fn namespace_array(context: &Context, session: &Session) -> Result<Vec<String>, Failure> {
    let id: NodeId = VariableId::Server_NamespaceArray.into();
    let values = session
        .read(&[ReadValueId::from(id)], TimestampsToReturn::Neither, 0.0)
        .await
        .map_err(|e| classify(context, e.status().to_string()))?;
    match values.into_iter().next().and_then(|v| v.value) {
        Some(Variant::Array(array)) => Ok(array
            .values
            .iter()
            .map(|v| match v {
                Variant::String(s) => s.as_ref().to_string(),
                _ => String::new(),
            })
            .collect()),
        _ => Err(Failure::Fatal(LinkError::Refused {
            url: context.url.clone(),
            reason: "its NamespaceArray has no list of URIs".into(),
        })),
    }
}

/// The subscription's callbacks: data changes become samples (or one refusal per node); a
/// status change (the server ended the subscription) is logged by the client and ends the
/// connection through its keep-alive.
fn callbacks(context: &Arc<Context>) -> SubscriptionCallbacks {
    let events = context.events.clone();
    let refused = context.refused.clone();
    SubscriptionCallbacks::new(
        |_status| {},
        move |value: DataValue, item: &MonitoredItem| {
            let index = item.client_handle() as usize;
            let Some(node) = index.checked_sub(1).filter(|n| *n < refused.len()) else {
                return;
            };
            if let Some(event) = sample(node, value, &refused[node]) {
                // Blocks while the caller lags CHANNEL_CAPACITY events behind; fails once the
                // caller has closed the link.
                let _ = events.send(event);
            }
        },
        |_fields, _item| {},
    )
}

/// A data change as an event: a sample, a refusal (the first non-numeric value of a node), or
/// nothing (a Bad status, or a node refused already).
fn sample(node: usize, value: DataValue, refused: &AtomicBool) -> Option<LinkEvent> {
    if value.status.is_some_and(|s| s.is_bad()) {
        return None;
    }
    let time = value
        .source_timestamp
        .or(value.server_timestamp)
        .map(|t| unix_seconds(&t))
        .unwrap_or_else(wall_clock);
    match value.value.as_ref().and_then(Variant::as_f64) {
        Some(number) => Some(LinkEvent::Sample {
            node,
            source_time: time,
            value: number,
        }),
        None if !refused.swap(true, Ordering::Relaxed) => Some(LinkEvent::Refused {
            node,
            reason: format!(
                "a non-numeric value ({}); the twin reads numbers only",
                value
                    .value
                    .as_ref()
                    .map(|v| format!("{:?}", v.type_id()))
                    .unwrap_or_else(|| "empty".into())
            ),
        }),
        None => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn times_convert_both_ways_to_100_ns() {
        let t = 1_700_000_000.123_456_7;
        let back = unix_seconds(&date_time(t));
        assert!((back - t).abs() < 2e-7, "{back} vs {t}");
        assert_eq!(unix_seconds(&date_time(0.0)), 0.0);
    }

    #[test]
    fn numeric_values_are_samples_and_others_refused_once() {
        let flag = AtomicBool::new(false);
        let value = |v: Variant| DataValue {
            value: Some(v),
            source_timestamp: Some(date_time(10.5)),
            ..Default::default()
        };
        assert_eq!(
            sample(1, value(Variant::Int32(3)), &flag),
            Some(LinkEvent::Sample {
                node: 1,
                source_time: 10.5,
                value: 3.0
            })
        );
        assert!(matches!(
            sample(1, value(Variant::from("x")), &flag),
            Some(LinkEvent::Refused { node: 1, .. })
        ));
        assert_eq!(sample(1, value(Variant::from("y")), &flag), None);
        let bad = DataValue {
            status: Some(StatusCode::BadSensorFailure),
            ..value(Variant::Double(1.0))
        };
        assert_eq!(sample(1, bad, &flag), None);
    }
}
