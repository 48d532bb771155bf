//! `twin serve` against an OPC UA stack the twin did not write (Python asyncua, from
//! `scripts/test-tools`): lockstep commands and reads checked against the twin's own open-loop
//! response (built-in machines and the five shipped examples), read-only signals, the recording
//! after the server ends; a subscriber that gets every control update with its source
//! timestamp; and wall-clock pacing.

mod common;

use common::{finished, free_port, scratch, tools_python};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};
use twin::{Scenario, Simulator};

const TORQUE: f64 = 20.0;
const PERIODS: usize = 100;
const DURATION: f64 = 0.3;

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

/// The Python client (tests/serve/client.py) writing `command` to `joint`'s actuator of
/// `machine` for PERIODS periods, run to its end.
fn drive(url: &str, machine: &str, joint: &str, command: &str) -> std::process::Output {
    finished(
        Command::new(tools_python())
            .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/serve/client.py"))
            .args([url, machine, joint, command, &PERIODS.to_string()]),
    )
}

fn serve(args: &[&str], dir: &Path) -> Child {
    Command::new(env!("CARGO_BIN_EXE_twin"))
        .arg("serve")
        .args(args)
        .current_dir(dir)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("twin serve starts")
}

/// The crank angle after one period at zero (the command written while the run waits at a
/// control update takes effect at the next) and PERIODS − 1 at TORQUE, by the twin's step API.
fn open_loop_position() -> f64 {
    open_loop("whitworth-crank-pi", "crank", TORQUE)
}

/// `joint`'s position after one period at zero command and PERIODS − 1 at `command` on its
/// actuator (the others at zero), by the twin's step API.
fn open_loop(scenario: &str, joint: &str, command: f64) -> f64 {
    let loaded = Scenario::open(scenario)
        .unwrap()
        .duration(DURATION)
        .build(&controllers::builtin())
        .unwrap();
    let mut simulator = Simulator::new(loaded).unwrap();
    let position = format!("{joint}.position");
    let index = (simulator.signal_specs().iter())
        .position(|s| s.name == position)
        .unwrap();
    let actuator = (simulator.actuators().iter())
        .position(|a| a.joint == joint)
        .unwrap();
    let mut commands = vec![0.0; simulator.actuators().len()];
    let mut measured = simulator.step(&commands).unwrap().to_vec();
    commands[actuator] = command;
    for _ in 1..PERIODS {
        measured = simulator.step(&commands).unwrap().to_vec();
    }
    measured[index]
}

/// The arm (three current-driven joints) and the feed axis (a linear motor) served in lockstep:
/// a Python client's command on one actuator moves it as the twin's own step API does.
#[test]
fn a_python_client_drives_the_arm_and_the_feed_axis_in_lockstep() {
    let cases = [
        ("arm-milling", "arm", "shoulder", 5.0),
        ("feed-axis-micromilling", "feed_axis", "table", 2.0),
    ];
    for (scenario, machine, joint, command) in cases {
        let dir = scratch("serve", scenario);
        let url = format!("opc.tcp://127.0.0.1:{}", free_port());
        let duration = DURATION.to_string();
        let args = [
            scenario,
            "--lockstep",
            "--opcua",
            &url,
            "--duration",
            &duration,
        ];
        let server = serve(&args, &dir);
        let client = drive(&url, machine, joint, &command.to_string());
        let served = ended(server);
        let stderr = String::from_utf8_lossy(&served.stderr);
        assert!(
            client.status.success() && served.status.success(),
            "{scenario}: client: {}\nserver: {stderr}",
            String::from_utf8_lossy(&client.stderr)
        );
        let seen: serde_json::Value = serde_json::from_slice(&client.stdout).unwrap();
        let after = seen["position_after"].as_f64().unwrap();
        let expected = open_loop(scenario, joint, command);
        assert!(
            (after - expected).abs() <= 1e-9 * expected.abs().max(1e-3),
            "{scenario}: served {after}, open loop {expected}"
        );
        assert!(after != seen["position_before"].as_f64().unwrap(), "{seen}");
        assert_eq!(seen["state"], "finished", "{seen}");
    }
}

/// The five shipped examples of the generic machine (no `machine`: their URDFs and scenarios
/// from examples/), served in lockstep: the client finds them under `generic` and a command on
/// one actuator moves its joint as the twin's own step API does, loops and springs included.
#[test]
fn a_python_client_drives_each_shipped_example_in_lockstep() {
    let examples = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples");
    let cases = [
        ("double-pendulum", "shoulder", 1.0),
        ("cart-pole", "cart", 2.0),
        ("slider-crank", "crank", 5.0),
        ("five-bar", "left", 1.0),
        ("gantry", "x", 5.0),
    ];
    for (example, joint, command) in cases {
        let path = examples.join(format!("{example}/{example}.toml"));
        let scenario = path.to_string_lossy().into_owned();
        let dir = scratch("serve", &format!("example-{example}"));
        let url = format!("opc.tcp://127.0.0.1:{}", free_port());
        let duration = DURATION.to_string();
        let args = [&scenario, "--lockstep", "--opcua", &url];
        let server = serve(&[&args[..], &["--duration", &duration]].concat(), &dir);
        let client = drive(&url, "generic", joint, &command.to_string());
        let served = ended(server);
        assert!(
            client.status.success() && served.status.success(),
            "{example}: client: {}\nserver: {}",
            String::from_utf8_lossy(&client.stderr),
            String::from_utf8_lossy(&served.stderr)
        );
        let seen: serde_json::Value = serde_json::from_slice(&client.stdout).unwrap();
        let after = seen["position_after"].as_f64().unwrap();
        let expected = open_loop(&scenario, joint, command);
        assert_eq!(
            after.to_bits(),
            expected.to_bits(),
            "{example}: {after} for {expected}"
        );
        assert!(after != seen["position_before"].as_f64().unwrap(), "{seen}");
        assert_eq!(seen["position_write"], "BadUserAccessDenied", "{seen}");
        assert_eq!(seen["state"], "finished", "{seen}");
    }
}

#[test]
fn a_python_client_drives_the_crank_in_lockstep() {
    let dir = scratch("serve", "lockstep");
    let url = format!("opc.tcp://127.0.0.1:{}", free_port());
    let duration = DURATION.to_string();
    let args = [
        "whitworth-crank-pi",
        "--lockstep",
        "--opcua",
        &url,
        "--duration",
        &duration,
        "--out",
        "run.rrd",
        "--summary",
        "summary.json",
    ];
    let server = serve(&args, &dir);
    let client = drive(&url, "whitworth", "crank", &TORQUE.to_string());
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
    assert_eq!(seen["period_before"], 0);
    assert_eq!(seen["effort_read_back"], TORQUE);
    assert_eq!(seen["advanced_to"], PERIODS as u64);
    assert_eq!(seen["period_after"], PERIODS as u64);
    let (before, after) = (
        seen["position_before"].as_f64().unwrap(),
        seen["position_after"].as_f64().unwrap(),
    );
    // A positive torque turns the crank counter-clockwise: about ½·τ/J·t² with J ≈ 1.5 kg·m².
    assert!(after - before > 0.02 && after - before < 0.5, "{seen}");
    let expected = open_loop_position();
    assert!(
        (after - expected).abs() < 1e-9,
        "served {after}, open loop {expected}"
    );
    let refused = seen["position_write"].as_str().unwrap();
    assert!(refused == "BadUserAccessDenied", "{seen}");
    assert_eq!(seen["nan_write"], "BadOutOfRange");
    assert_eq!(seen["state"], "finished");
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["steps"], 300, "{summary}");
    assert_eq!(summary["controller"], "opcua-client");
    let contents = twin::recordings::inspect(&dir.join("run.rrd")).unwrap();
    assert!(
        contents.events.iter().any(|e| e.contains("run ended: ok")),
        "{:?}",
        contents.events
    );
    common::verify(&dir.join("run.rrd"));
    assert!(common::parts(&dir).is_empty());
}

/// Control updates in the subscribed run: 2 s at the crank's 1 ms control period, both ends.
const SUBSCRIBED_UPDATES: u64 = 2001;

/// A subscriber asking sampling 0 and a queue gets every control update of a lockstep run, in
/// order, each with its own source timestamp: the run's simulated time mapped to the wall
/// clock, one control period apart. The client advances 250 periods at a time and waits for
/// them to arrive, so a loaded machine only makes the test slower.
#[test]
fn a_subscriber_gets_every_control_update_with_its_source_timestamp() {
    let dir = scratch("serve", "every-update");
    let port = free_port();
    let url = format!("opc.tcp://127.0.0.1:{port}");
    let args = ["whitworth-crank-pi", "--lockstep", "--opcua", &url];
    let server = serve(&[&args[..], &["--duration", "2"]].concat(), &dir);
    let client = finished(
        Command::new(tools_python())
            .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/serve/subscriber.py"))
            .args([&url, "whitworth", "crank.position", "1000", "seen.json"])
            .args(["lockstep", "250"])
            .current_dir(&dir),
    );
    let served = ended(server);
    let stderr = String::from_utf8_lossy(&served.stderr);
    assert!(
        client.status.success() && served.status.success(),
        "client ({}): {}\nserver ({}): {stderr}",
        client.status,
        String::from_utf8_lossy(&client.stderr),
        served.status
    );
    let listening: Vec<&str> = stderr.lines().filter(|l| l.contains("listening")).collect();
    let line = format!(
        "listening on opc.tcp://127.0.0.1:{port}/ (machine nsu=urn:twin:whitworth;s=whitworth)"
    );
    assert_eq!(listening, [line.as_str()], "{stderr}");
    let seen: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("seen.json")).unwrap()).unwrap();
    for (item, revised) in seen["revised"].as_object().unwrap() {
        assert_eq!(revised["sampling_ms"], 1.0, "{item}: {revised}");
        assert_eq!(revised["queue"], 1000, "{item}: {revised}");
    }
    assert_eq!(seen["state"], "finished");
    assert_eq!(seen["updates"], SUBSCRIBED_UPDATES);
    assert_eq!(seen["received"], SUBSCRIBED_UPDATES);
    let periods = notifications(&seen, "status.period");
    let expected: Vec<f64> = (0..SUBSCRIBED_UPDATES).map(|p| p as f64).collect();
    assert_eq!(periods.iter().map(|n| n.1).collect::<Vec<_>>(), expected);
    let stamps: Vec<i64> = periods.iter().map(|n| n.0).collect();
    let start = stamps[0];
    for (period, stamp) in stamps.iter().enumerate() {
        assert_eq!(stamp - start, period as i64 * 1000, "period {period}: µs");
    }
    // status.time is the simulated time the stamps map; the signal comes with every update.
    for (stamp, time) in notifications(&seen, "status.time") {
        assert!(
            (time - (stamp - start) as f64 * 1e-6).abs() < 1e-9,
            "{time} at {stamp}"
        );
    }
    let positions = notifications(&seen, "crank.position");
    assert_eq!(positions.iter().map(|n| n.0).collect::<Vec<_>>(), stamps);
    assert!(positions.iter().any(|n| n.1 != positions[0].1));
}

/// An item's notifications: (source timestamp in µs since the UNIX epoch, value), none with
/// the overflow bit.
fn notifications(seen: &serde_json::Value, item: &str) -> Vec<(i64, f64)> {
    (seen["items"][item].as_array().unwrap().iter())
        .map(|n| {
            assert_eq!(n[2], false, "{item}: overflow at {n}");
            (n[0].as_i64().unwrap(), n[1].as_f64().unwrap())
        })
        .collect()
}

#[test]
fn wall_clock_pacing_runs_at_the_rate_and_counts_misses() {
    let dir = scratch("serve", "rate");
    let url = format!("opc.tcp://127.0.0.1:{}", free_port());
    let started = Instant::now();
    let output = finished(
        Command::new(env!("CARGO_BIN_EXE_twin"))
            .args([
                "serve",
                "whitworth-crank-pi",
                "--rate",
                "10",
                "--duration",
                "10",
            ])
            .args([
                "--opcua",
                &url,
                "--out",
                "run.rrd",
                "--summary",
                "summary.json",
            ])
            .current_dir(&dir),
    );
    let wall = started.elapsed();
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    // 10 s at 10 × real time is 1 s of wall clock, plus starting and the server's linger.
    assert!(
        wall >= Duration::from_millis(1000) && wall < Duration::from_secs(8),
        "{wall:?}"
    );
    assert!(stdout.contains("deadline misses: "), "{stdout}");
    let summary = std::fs::read_to_string(dir.join("summary.json")).unwrap();
    let summary: serde_json::Value = serde_json::from_str(&summary).unwrap();
    let misses = summary["metrics"]["serve.deadline_misses"].as_f64();
    assert!(misses.is_some(), "{summary}");
    assert!(
        stdout.contains(&format!("deadline misses: {}", misses.unwrap())),
        "{stdout}"
    );
    // Misses depend on the machine's load; each one logged is a warning in the recording.
    let events = twin::recordings::inspect(&dir.join("run.rrd"))
        .unwrap()
        .events;
    let logged = events
        .iter()
        .filter(|e| e.contains("deadline miss"))
        .count() as f64;
    let misses = misses.unwrap();
    // The last update's miss, if any, has no later update to be logged at.
    assert!(
        logged <= misses && (misses <= 1.0 || logged > 0.0),
        "{misses}: {events:?}"
    );
}

#[test]
fn a_host_beyond_loopback_is_refused() {
    let dir = scratch("serve", "loopback");
    let output = finished(
        Command::new(env!("CARGO_BIN_EXE_twin"))
            .args([
                "serve",
                "whitworth-crank-pi",
                "--opcua",
                "opc.tcp://0.0.0.0:4840",
            ])
            .current_dir(&dir),
    );
    assert_eq!(output.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(common::error_lines(&stderr), 1, "{stderr}");
    assert!(stderr.contains("not a loopback address"), "{stderr}");
}

/// The machine object's parts, the crank's axis folder and a task-space signal, as the client
/// browsed them.
fn check_address_space(seen: &serde_json::Value) {
    let names = |key: &str| {
        seen[key]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_str().unwrap().to_string())
            .collect::<Vec<_>>()
    };
    for part in ["Advance", "Axes", "Commands", "Signals", "Status"] {
        assert!(names("machine").contains(&part.to_string()), "{seen}");
    }
    assert_eq!(
        names("axis"),
        ["crank.position", "crank.velocity", "effort.crank"]
    );
    assert!(
        names("signals").contains(&"ram_position".to_string()),
        "{seen}"
    );
}
