//! `twin shadow`'s OPC UA plumbing against a stack the twin did not write (Python asyncua, from
//! `scripts/test-tools`): the link's samples in order with their source timestamps, its
//! survival of the machine's server restarting on the same port, its one-line refusals (a node
//! or namespace not on the server, a server that never answers), and the shadow's own server
//! read by an asyncua client.

mod common;

use common::{free_port, tools_python};
use std::io::{BufRead, BufReader};
use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdout, Command, Stdio};
use std::time::{Duration, Instant};
use twin_cli::machine_link::{
    LinkEvent, LinkOptions, MachineLink, MappedNode, PublishedValue, PublishedVariable,
    ShadowServer, VariableKind,
};

const URI: &str = "urn:test:machine";
/// The machine's sample period, s.
const PERIOD: f64 = 0.01;
/// Longest wait for anything in these tests (a loaded 2-core machine).
const PATIENCE: Duration = Duration::from_secs(60);

fn script(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/machine_link")
        .join(name)
}

/// The machine's server (`machine.py`), killed when dropped.
struct Machine {
    child: Child,
    /// Held open: the script prints `done` later, and a closed pipe would end it.
    _stdout: BufReader<ChildStdout>,
    /// The source time of sample 0.
    base: f64,
}

impl Machine {
    /// Starts `machine.py` and waits for it to listen.
    fn start(port: u16, first: u64, count: u64, base: Option<f64>) -> Machine {
        let mut command = Command::new(tools_python());
        command
            .arg(script("machine.py"))
            .args([port.to_string(), URI.into(), first.to_string()])
            .arg(count.to_string());
        if let Some(base) = base {
            command.arg(base.to_string());
        }
        let mut child = command
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("python starts");
        let mut stdout = BufReader::new(child.stdout.take().unwrap());
        let mut line = String::new();
        stdout.read_line(&mut line).unwrap();
        let base = line
            .strip_prefix("ready ")
            .and_then(|b| b.trim().parse::<f64>().ok())
            .unwrap_or_else(|| {
                let _ = child.kill();
                panic!("the machine did not start: {line:?}")
            });
        Machine {
            child,
            _stdout: stdout,
            base,
        }
    }

    /// Kills the server process (as a machine's server crashing would stop).
    fn kill(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl Drop for Machine {
    fn drop(&mut self) {
        self.kill();
    }
}

fn mapped(column: &str, node: &str) -> MappedNode {
    MappedNode {
        column: column.into(),
        node: node.into(),
        unit: "1".into(),
    }
}

/// The three Double variables, one by index and two by namespace URI.
fn crank_nodes() -> Vec<MappedNode> {
    vec![
        mapped("crank.position", &format!("nsu={URI};s=Crank.Position")),
        mapped("crank.velocity", "ns=2;s=Crank.Velocity"),
        mapped("effort.crank", &format!("nsu={URI};s=Crank.Torque")),
    ]
}

fn options() -> LinkOptions {
    LinkOptions {
        connect_timeout: Duration::from_secs(10),
        max_backoff: Duration::from_millis(500),
        ..LinkOptions::default()
    }
}

/// Checks a sample against the machine's scheme (value j·1e6 + k at BASE + k·PERIOD) and
/// returns its k.
fn sample_index(node: usize, source_time: f64, value: f64, base: f64) -> u64 {
    let k = value - node as f64 * 1e6;
    assert!(k >= 0.0 && k.fract() == 0.0, "node {node}: value {value}");
    let expected = base + k * PERIOD;
    assert!(
        (source_time - expected).abs() < 2e-6,
        "node {node}, sample {k}: source time {source_time}, expected {expected}"
    );
    k as u64
}

#[test]
fn every_sample_arrives_in_order_with_its_source_timestamp() {
    const COUNT: u64 = 300;
    let port = free_port();
    let machine = Machine::start(port, 0, COUNT, None);
    let url = format!("opc.tcp://127.0.0.1:{port}");
    let mut nodes = crank_nodes();
    nodes.push(mapped("mode", "ns=2;s=Crank.Mode"));
    let mut link = MachineLink::connect(&url, &nodes, options()).unwrap();
    let mut next = [None::<u64>; 3];
    let mut refused = Vec::new();
    let start = Instant::now();
    while next.iter().any(|k| *k != Some(COUNT)) && start.elapsed() < PATIENCE {
        match link.recv(Duration::from_millis(200)) {
            Some(LinkEvent::Sample {
                node,
                source_time,
                value,
            }) => {
                let k = sample_index(node, source_time, value, machine.base);
                // The first is the value current when subscribed; then each in turn.
                if let Some(expected) = next[node] {
                    assert_eq!(k, expected, "node {node}: a sample missing or out of order");
                }
                next[node] = Some(k + 1);
            }
            Some(LinkEvent::Refused { node, reason }) => refused.push((node, reason)),
            Some(other) => panic!("unexpected {other:?}"),
            None => {}
        }
    }
    assert_eq!(next, [Some(COUNT); 3], "samples missing after {PATIENCE:?}");
    assert_eq!(refused.len(), 1, "{refused:?}");
    assert_eq!(refused[0].0, 3);
    assert!(refused[0].1.contains("non-numeric"), "{refused:?}");
    link.close();
}

/// The samples' k per node, as collected.
type Seen = [Vec<u64>; 3];

/// Collects samples into `seen` until `enough` holds (None) or an event that is not a sample
/// comes (returned); fails the test after [`PATIENCE`].
fn collect(
    link: &mut MachineLink,
    base: f64,
    seen: &mut Seen,
    enough: impl Fn(&Seen) -> bool,
) -> Option<LinkEvent> {
    let start = Instant::now();
    while !enough(seen) {
        assert!(start.elapsed() < PATIENCE, "waited {PATIENCE:?}: {seen:?}");
        match link.recv(Duration::from_millis(200)) {
            Some(LinkEvent::Sample {
                node,
                source_time,
                value,
            }) => seen[node].push(sample_index(node, source_time, value, base)),
            Some(event) => return Some(event),
            None => {}
        }
    }
    None
}

/// Never enough: collect until an event that is not a sample.
fn change(_: &Seen) -> bool {
    false
}

#[test]
fn the_link_survives_the_server_restarting_on_the_same_port() {
    let port = free_port();
    let mut machine = Machine::start(port, 0, 1_000_000, None);
    let base = machine.base;
    let url = format!("opc.tcp://127.0.0.1:{port}");
    let mut link = MachineLink::connect(&url, &crank_nodes(), options()).unwrap();
    let mut seen = Seen::default();
    let first = collect(&mut link, base, &mut seen, |s| {
        s.iter().all(|s| s.len() >= 50)
    });
    assert_eq!(first, None);
    machine.kill();
    let killed = Instant::now();
    let lost = collect(&mut link, base, &mut seen, change);
    assert!(matches!(lost, Some(LinkEvent::Lost { .. })), "{lost:?}");
    let detected = killed.elapsed();
    // Down for a while: the link must keep retrying, not give up.
    std::thread::sleep(Duration::from_secs(2));
    const SECOND_RUN: u64 = 100_000;
    let _machine = Machine::start(port, SECOND_RUN, 1_000_000, Some(base));
    let listening = Instant::now();
    let restored = collect(&mut link, base, &mut seen, change);
    let Some(LinkEvent::Restored { attempts, .. }) = restored else {
        panic!("not restored: {restored:?}");
    };
    let restore = listening.elapsed();
    let before: Vec<usize> = seen.iter().map(Vec::len).collect();
    let resumed = |s: &Seen| {
        s.iter()
            .all(|s| s.last().is_some_and(|k| *k >= SECOND_RUN + 50))
    };
    let unexpected = collect(&mut link, base, &mut seen, resumed);
    assert_eq!(unexpected, None, "after the restore");
    for (node, samples) in seen.iter().enumerate() {
        assert!(
            samples.windows(2).all(|w| w[0] < w[1]),
            "node {node}: samples out of order"
        );
        let after = &samples[before[node]..];
        assert!(
            after.windows(2).all(|w| w[1] == w[0] + 1),
            "node {node}: samples missing after the restore"
        );
        assert!(
            after.last().is_some_and(|k| *k >= SECOND_RUN + 50),
            "node {node}"
        );
    }
    eprintln!(
        "loss seen {:.0} ms after the kill; restored {:.0} ms after the new server listened, \
         {attempts} attempts",
        detected.as_secs_f64() * 1e3,
        restore.as_secs_f64() * 1e3
    );
    link.close();
}

#[test]
fn a_node_or_namespace_not_on_the_server_is_refused_in_one_line() {
    let port = free_port();
    let _machine = Machine::start(port, 0, 10, None);
    let url = format!("opc.tcp://127.0.0.1:{port}");
    let mut nodes = crank_nodes();
    nodes.push(mapped("crank.torque", "ns=2;s=Crank.Nope"));
    let message = MachineLink::connect(&url, &nodes, options())
        .err()
        .expect("refused")
        .to_string();
    assert_eq!(
        message,
        "nodes.\"crank.torque\": ns=2;s=Crank.Nope is not on the server (BadNodeIdUnknown); \
         check the node id in the map"
    );
    let nodes = vec![mapped("ram.position", "nsu=urn:nowhere;s=Ram")];
    let message = MachineLink::connect(&url, &nodes, options())
        .err()
        .expect("refused")
        .to_string();
    assert!(
        message.starts_with(
            "nodes.\"ram.position\": nsu=urn:nowhere;s=Ram: namespace urn:nowhere is not on \
             the server (it has: http://opcfoundation.org/UA/, "
        ) && message.contains(URI)
            && !message.contains('\n'),
        "{message}"
    );
}

#[test]
fn a_server_that_never_answers_is_refused_in_one_line() {
    let options = LinkOptions {
        connect_timeout: Duration::from_secs(1),
        ..LinkOptions::default()
    };
    // Nobody listening, and a socket that accepts but never speaks OPC UA.
    let silent = TcpListener::bind("127.0.0.1:0").unwrap();
    let silent_port = silent.local_addr().unwrap().port();
    for port in [free_port(), silent_port] {
        let url = format!("opc.tcp://127.0.0.1:{port}");
        let start = Instant::now();
        let message = MachineLink::connect(&url, &crank_nodes(), options.clone())
            .err()
            .expect("refused")
            .to_string();
        assert_eq!(
            message,
            format!("{url}: no answer within 1 s; is the machine's server running and reachable?")
        );
        assert!(
            start.elapsed() < Duration::from_secs(5),
            "{:?}",
            start.elapsed()
        );
    }
    drop(silent);
}

#[test]
fn an_asyncua_client_reads_what_the_shadow_publishes() {
    let variable = |folder: &str, name: &str, unit: &str, kind| PublishedVariable {
        folder: folder.into(),
        name: name.into(),
        unit: unit.into(),
        description: format!("the {name}"),
        kind,
    };
    let variables = [
        variable("Estimates", "crank.position", "rad", VariableKind::Double),
        variable("Estimates", "friction", "N·m", VariableKind::Double),
        variable("Residuals", "crank.position", "deg", VariableKind::Double),
        variable("Alarms", "state", "", VariableKind::Text),
        variable("Alarms", "active", "", VariableKind::Boolean),
    ];
    let port = free_port();
    let url = format!("opc.tcp://127.0.0.1:{port}");
    let server = ShadowServer::start(&url, "urn:twin:shadow:press", "press", &variables).unwrap();
    let source_time = 1_700_000_000.25;
    server
        .set(
            &[
                (0, PublishedValue::Double(1.5)),
                (1, PublishedValue::Double(-0.25)),
                (2, PublishedValue::Double(0.01)),
                (3, PublishedValue::Text("drifting".into())),
                (4, PublishedValue::Boolean(true)),
            ],
            source_time,
        )
        .unwrap();
    let wrong = server.set(&[(3, PublishedValue::Double(1.0))], source_time);
    assert!(wrong.is_err());
    assert!(server
        .set(&[(9, PublishedValue::Double(1.0))], source_time)
        .is_err());
    let output = Command::new(tools_python())
        .arg(script("reader.py"))
        .args([&url, "urn:twin:shadow:press", "press"])
        .output()
        .unwrap();
    server.stop(Duration::ZERO);
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let seen: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
    let values = &seen["values"];
    assert_eq!(values["Estimates/crank.position"]["value"], 1.5, "{seen}");
    assert_eq!(values["Estimates/friction"]["value"], -0.25);
    assert_eq!(values["Residuals/crank.position"]["value"], 0.01);
    assert_eq!(values["Alarms/state"]["value"], "drifting");
    assert_eq!(values["Alarms/active"]["value"], true);
    let source = values["Estimates/friction"]["source"].as_f64().unwrap();
    assert!((source - source_time).abs() < 1e-6, "{source}");
    assert!(values["Estimates/friction"]["node"]
        .as_str()
        .unwrap()
        .ends_with(";s=Estimates/friction"));
    let unit = &values["Estimates/crank.position"]["unit"];
    assert_eq!(unit["id"], 4_405_297, "C81, {seen}");
    assert_eq!(unit["name"], "rad");
    assert_eq!(
        unit["namespace"],
        "http://www.opcfoundation.org/UA/units/un/cefact"
    );
    assert_eq!(values["Estimates/friction"]["unit"]["name"], "N·m");
    assert!(values["Residuals/crank.position"]["unit"].is_null());
    let write = seen["write"].as_str().unwrap();
    assert!(write == "BadUserAccessDenied", "{seen}");
}
