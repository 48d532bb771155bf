//! `twin serve --with-controller`: the scenario's controller inside the served twin, its setpoint
//! written by a Python asyncua client in lockstep, checked bit for bit against the same closed
//! loop stepped in-process (`Simulator::with_controller` and `step_closed_loop`); and the refusal
//! of a scenario without a reference.

mod common;

use common::{finished, free_port, scratch, tools_python};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};
use twin::{Scenario, Simulator};

const SCENARIO: &str = "feed-axis-micromilling";
/// 500 control periods at the feed axis's 10 kHz.
const DURATION: f64 = 0.05;
/// Control periods between the client's writes.
const BLOCK: usize = 100;
/// The offsets the client writes (reference m, rate m/s, acceleration m/s²), one per block.
const OFFSETS: [[f64; 3]; 4] = [
    [0.5e-6, 0.0, 0.0],
    [-0.25e-6, 1.0e-5, 0.0],
    [1.0e-6, 0.0, 2.0e-4],
    [0.0, 0.0, 0.0],
];

/// The server's output once it has ended; killed (and the test failed by its output) if it
/// outlives the client by more than a few seconds.
fn ended(mut server: Child) -> std::process::Output {
    let start = Instant::now();
    while server.try_wait().unwrap().is_none() && start.elapsed() < Duration::from_secs(10) {
        std::thread::sleep(Duration::from_millis(10));
    }
    server.kill().ok();
    server.wait_with_output().unwrap()
}

/// Per control update k of the in-process closed loop: the measured signals at k and the
/// efforts the controller commands at k. A write made while the served run waits at update p
/// takes effect at update p + 1: the step from update k carries the offset written at the
/// latest block start p with p + 1 ≤ k.
fn in_process() -> (Vec<String>, Vec<Vec<f64>>, Vec<f64>) {
    let loaded = Scenario::builtin(SCENARIO)
        .unwrap()
        .duration(DURATION)
        .build(&controllers::builtin())
        .unwrap();
    let mut simulator = Simulator::with_controller(loaded, &controllers::builtin()).unwrap();
    let names = simulator
        .signal_specs()
        .iter()
        .map(|s| s.name.clone())
        .collect();
    let zeros = vec![0.0; simulator.joints().len()];
    let mut measured = vec![simulator.measured().to_vec()];
    let mut efforts = Vec::new();
    for k in 0..OFFSETS.len() * BLOCK + 1 {
        let offset = (0..OFFSETS.len())
            .rev()
            .find(|&j| j * BLOCK < k)
            .map_or([0.0; 3], |j| OFFSETS[j]);
        measured.push(simulator.step_closed_loop(&zeros, offset).unwrap().to_vec());
        // The efforts of the update the step started from.
        efforts.push(simulator.commanded()[0]);
    }
    (names, measured, efforts)
}

#[test]
fn a_python_client_moves_the_feed_axis_setpoint_in_lockstep() {
    let dir = scratch("serve_setpoint", "lockstep");
    let url = format!("opc.tcp://127.0.0.1:{}", free_port());
    let duration = DURATION.to_string();
    let server = Command::new(env!("CARGO_BIN_EXE_twin"))
        .args(["serve", SCENARIO, "--with-controller", "--lockstep"])
        .args(["--opcua", &url, "--duration", &duration])
        .args(["--out", "run.rrd", "--summary", "summary.json"])
        .current_dir(&dir)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("twin serve starts");
    let offsets = serde_json::to_string(&OFFSETS).unwrap();
    let client = finished(
        Command::new(tools_python())
            .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/serve/setpoint.py"))
            .args([&url, "feed_axis", "table", &BLOCK.to_string(), &offsets]),
    );
    let served = ended(server);
    let stderr = String::from_utf8_lossy(&served.stderr);
    assert!(
        client.status.success(),
        "client: {}\nserver: {stderr}",
        String::from_utf8_lossy(&client.stderr)
    );
    assert!(served.status.success(), "server: {stderr}");
    let seen: serde_json::Value = serde_json::from_slice(&client.stdout).unwrap();
    check_address_space(&seen);

    let (names, measured, efforts) = in_process();
    let blocks = seen["blocks"].as_array().unwrap();
    assert_eq!(blocks.len(), OFFSETS.len());
    for (j, block) in blocks.iter().enumerate() {
        let period = (j + 1) * BLOCK;
        assert_eq!(block["period"], period as u64, "{block}");
        let read_back: Vec<f64> = serde_json::from_value(block["read_back"].clone()).unwrap();
        assert_eq!(read_back, OFFSETS[j]);
        for (i, name) in names.iter().enumerate() {
            let served = f64::from_bits(block["measured"][name].as_u64().unwrap());
            let expected = measured[period][i];
            assert_eq!(
                served.to_bits(),
                expected.to_bits(),
                "{name} at update {period}: served {served}, in process {expected}"
            );
        }
        let effort = f64::from_bits(block["effort"].as_u64().unwrap());
        assert_eq!(
            effort.to_bits(),
            efforts[period].to_bits(),
            "effort at {period}"
        );
    }
    // The setpoint moved the axis: the in-process loop without offsets ends elsewhere.
    let position = names.iter().position(|n| n == "table.position").unwrap();
    let unmoved = unmoved_position(position);
    assert!(
        (measured[3 * BLOCK][position] - unmoved).abs() > 1e-8,
        "offset run {} vs plain {unmoved}",
        measured[3 * BLOCK][position]
    );

    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["controller"], "p-pi", "{summary}");
    assert_eq!(summary["steps"], 500, "{summary}");
    common::verify(&dir.join("run.rrd"));
    assert!(common::parts(&dir).is_empty());
}

#[test]
fn a_scenario_without_a_reference_is_refused_with_the_controller_inside() {
    let dir = scratch("serve_setpoint", "no_reference");
    let url = format!("opc.tcp://127.0.0.1:{}", free_port());
    let output = finished(
        Command::new(env!("CARGO_BIN_EXE_twin"))
            .args([
                "serve",
                "whitworth-crank-pi",
                "--with-controller",
                "--lockstep",
            ])
            .args(["--opcua", &url])
            .current_dir(&dir),
    );
    assert_eq!(output.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(common::error_lines(&stderr), 1, "{stderr}");
    assert!(stderr.contains("whitworth-crank-pi"), "{stderr}");
    assert!(stderr.contains("no [reference]"), "{stderr}");
    assert!(!dir.join("whitworth-crank-pi.rrd").exists());
}

/// What the client saw of the address space: the setpoints writable, the effort not, with their
/// units, a NaN refused, the run finished.
fn check_address_space(seen: &serde_json::Value) {
    let commands: Vec<&str> = (seen["commands"].as_array().unwrap().iter())
        .map(|v| v.as_str().unwrap())
        .collect();
    assert_eq!(
        commands,
        [
            "effort.table",
            "setpoint.reference",
            "setpoint.reference_acceleration",
            "setpoint.reference_rate"
        ]
    );
    let described = |name: &str| seen["descriptions"][name].as_str().unwrap().to_string();
    assert!(described("setpoint.reference").contains(", m ("), "{seen}");
    assert!(
        described("setpoint.reference_rate").contains("m/s"),
        "{seen}"
    );
    let refused = seen["effort_write"].as_str().unwrap();
    assert!(refused == "BadUserAccessDenied", "{seen}");
    assert_eq!(seen["nan_write"], "BadOutOfRange");
    assert_eq!(seen["state"], "finished");
}

/// The table's position after three blocks of the in-process loop without offsets.
fn unmoved_position(position: usize) -> f64 {
    let loaded = Scenario::builtin(SCENARIO)
        .unwrap()
        .duration(DURATION)
        .build(&controllers::builtin())
        .unwrap();
    let mut simulator = Simulator::with_controller(loaded, &controllers::builtin()).unwrap();
    let zeros = vec![0.0; simulator.joints().len()];
    for _ in 0..3 * BLOCK {
        simulator.step_closed_loop(&zeros, [0.0; 3]).unwrap();
    }
    simulator.measured()[position]
}
