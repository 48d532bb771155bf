//! The generic machine on the shipped examples (`examples/double-pendulum`, `examples/cart-pole`),
//! mechanisms none of the six: their free motion against MuJoCo 4.0 loading the same URDF, their
//! points' signals against their own kinematics, `joint-pid` holding them, one mass calibrated
//! from a run MuJoCo made under its own controller (logging torques and noisy encoders), a
//! shadow finding a mass fault, and what the generic machine refuses. Needs
//! `eval "$(scripts/test-tools)"` (`TWIN_TOOLS_PYTHON`, with MuJoCo); scripts/test provides it.

mod common;

use common::{columns, scratch, twin};
use serde_json::Value;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::Command;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// A shipped example's scenario, `examples/<name>/<name>.toml`.
fn scenario_of(name: &str) -> String {
    let path = repo().join(format!("examples/{name}/{name}.toml"));
    path.to_string_lossy().into_owned()
}

/// The double pendulum's scenario.
fn example() -> String {
    scenario_of("double-pendulum")
}

/// A shipped example's URDF, `examples/<name>/<file>`.
fn urdf_of(name: &str, file: &str) -> String {
    let path = repo().join(format!("examples/{name}/{file}"));
    path.to_string_lossy().into_owned()
}

fn ok(output: &std::process::Output) -> String {
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stderr}");
    String::from_utf8_lossy(&output.stdout).into_owned()
}

/// scripts/mujoco_machine.py on the double pendulum with `args`, in `dir`.
fn mujoco(dir: &Path, args: &[&str]) {
    mujoco_on(
        dir,
        &urdf_of("double-pendulum", "double_pendulum.urdf"),
        args,
    );
}

/// scripts/mujoco_machine.py on `urdf` with `args`, in `dir`.
fn mujoco_on(dir: &Path, urdf: &str, args: &[&str]) {
    let python = std::env::var("TWIN_TOOLS_PYTHON").unwrap_or_else(|_| {
        panic!("TWIN_TOOLS_PYTHON is not set: run `eval \"$(scripts/test-tools)\"` first")
    });
    let output = Command::new(python)
        .arg(repo().join("scripts/mujoco_machine.py"))
        .args(["--urdf", urdf])
        .args(args)
        .current_dir(dir)
        .output()
        .expect("python runs");
    ok(&output);
}

/// A shipped example moving free for 2 s from `initial` (joint, position, velocity), MuJoCo
/// loading its URDF (its `driven` joints given no torque) against the twin (`passive`), each
/// joint's true state compared: their largest difference, and the twin's run as columns.
fn free_swing(
    name: &str,
    urdf: &str,
    driven: &[&str],
    initial: &[(&str, f64, f64)],
) -> (f64, HashMap<String, Vec<f64>>) {
    let dir = scratch("generic-machine", &format!("free-{name}"));
    let mut args: Vec<String> = Vec::new();
    let mut sets: Vec<String> = Vec::new();
    for &(joint, position, velocity) in initial {
        args.extend([
            "--initial".into(),
            format!("{joint}={position:?},{velocity:?}"),
        ]);
        sets.extend([
            "--set".into(),
            format!("initial.{joint}.position={position:?}"),
        ]);
        sets.extend([
            "--set".into(),
            format!("initial.{joint}.velocity={velocity:?}"),
        ]);
    }
    for joint in driven {
        args.extend(["--torque".into(), format!("{joint}=0")]);
    }
    args.extend(["--duration", "2", "--dt", "0.001", "--out", "mujoco.csv"].map(String::from));
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    mujoco_on(&dir, &urdf_of(name, urdf), &args);
    let scenario = scenario_of(name);
    let mut run = vec![
        "run",
        &scenario,
        "--controller",
        "passive",
        "--duration",
        "2",
    ];
    run.extend(sets.iter().map(String::as_str));
    run.extend(["--csv", "twin.csv", "--out", "twin.rrd"]);
    ok(&twin(&run, &dir));
    let (theirs, ours) = (
        columns(&dir.join("mujoco.csv")),
        columns(&dir.join("twin.csv")),
    );
    let mut worst: f64 = 0.0;
    for &(joint, _, _) in initial {
        for state in ["position", "velocity"] {
            let column = format!("{joint}.{state}");
            let (a, b) = (&theirs[&column], &ours[&format!("true.{column}")]);
            assert_eq!(a.len(), b.len(), "{column}");
            let differences = a.iter().zip(b).map(|(x, y)| (x - y).abs());
            worst = worst.max(differences.fold(0.0, f64::max));
        }
    }
    (worst, ours)
}

// Measured (release): the largest difference over 2 s is about 1e-14 rad/s, on the velocities
// (both are RK4 at 1 ms on the same equations); the cart-pole's 8e-15 rad/s.

#[test]
fn the_double_pendulum_swings_free_as_mujoco_swings_it() {
    const DRIVEN: [&str; 2] = ["shoulder", "elbow"];
    let initial = [("shoulder", 1.0, 0.0), ("elbow", -0.5, 0.3)];
    let (worst, ours) = free_swing("double-pendulum", "double_pendulum.urdf", &DRIVEN, &initial);
    assert!(worst <= 1e-6, "{worst}");
    // The point at the lower bar's end, from the joints' angles (both bars hang along −y).
    let (q1, q2) = (
        &ours["true.shoulder.position"],
        &ours["true.elbow.position"],
    );
    for (k, (&a, &b)) in q1.iter().zip(q2).enumerate() {
        let x = 0.3 * a.sin() + 0.25 * (a + b).sin();
        let y = -0.3 * a.cos() - 0.25 * (a + b).cos();
        assert!((ours["true.tip.x"][k] - x).abs() < 1e-12, "row {k}");
        assert!((ours["true.tip.y"][k] - y).abs() < 1e-12, "row {k}");
    }
}

#[test]
fn the_cart_pole_moves_free_as_mujoco_moves_it() {
    let initial = [("cart", 0.1, 0.2), ("pole", 0.5, 0.0)];
    let (worst, ours) = free_swing("cart-pole", "cart_pole.urdf", &["cart"], &initial);
    assert!(worst <= 1e-6, "{worst}");
    // The pole's end: the cart's travel plus the pole's swing.
    let (x, q) = (&ours["true.cart.position"], &ours["true.pole.position"]);
    for (k, (&x, &q)) in x.iter().zip(q).enumerate() {
        assert!(
            (ours["true.bob.x"][k] - (x + 0.5 * q.sin())).abs() < 1e-12,
            "row {k}"
        );
        assert!(
            (ours["true.bob.y"][k] + 0.5 * q.cos()).abs() < 1e-12,
            "row {k}"
        );
    }
}

#[test]
fn joint_pid_moves_the_cart_and_holds_it_while_the_pole_swings() {
    let dir = scratch("generic-machine", "cart-pid");
    let scenario = scenario_of("cart-pole");
    let run = ["run", &scenario, "--csv", "run.csv", "--out", "run.rrd"];
    ok(&twin(&run, &dir));
    let table = columns(&dir.join("run.csv"));
    let cart = &table["true.cart.position"];
    // Within 5 mm of 0.3 m over the last second (the swinging pole pulls it to and fro); the
    // pole is not driven: it has no effort column.
    for &x in &cart[cart.len() - 1000..] {
        assert!((x - 0.3).abs() < 5e-3, "cart at {x}");
    }
    assert!(!table.contains_key("effort.pole"));
}

#[test]
fn joint_pid_holds_the_double_pendulum_where_its_targets_are() {
    let dir = scratch("generic-machine", "pid");
    let run = ["run", &example(), "--csv", "run.csv", "--out", "run.rrd"];
    ok(&twin(&run, &dir));
    let table = columns(&dir.join("run.csv"));
    // The last second, within four encoder counts of the targets: integral action on a
    // quantised encoder hunts over a few counts (measured: the elbow −0.4055 to −0.4027 rad,
    // its encoder reading three counts).
    let count = std::f64::consts::TAU / 4096.0;
    for (joint, target) in [("shoulder", 0.6), ("elbow", -0.4)] {
        let positions = &table[&format!("true.{joint}.position")];
        for &q in &positions[positions.len() - 1000..] {
            assert!((q - target).abs() <= 4.0 * count, "{joint} at {q}");
        }
    }
}

// Measured (release): MuJoCo's double pendulum, its lower bar 1.0 kg (0.8 in the URDF), under
// its own joint PID (multisine references), logging both torques and both encoders with 1e-4
// rad of noise: `twin calibrate` finds 1.00000011 kg [0.999993, 1.000007], "fits".

#[test]
fn a_mass_is_calibrated_from_a_run_mujoco_made() {
    let dir = scratch("generic-machine", "calibrate");
    let args = [
        "--set",
        "link.lower.mass=1.0",
        "--controller",
        "pid",
        "--gain",
        "bandwidth=20",
        "--reference",
        "shoulder=multisine:amp=0.5,fmin=0.2,fmax=2,tones=6,seed=1,offset=0.3",
        "--reference",
        "elbow=multisine:amp=0.5,fmin=0.2,fmax=2,tones=6,seed=2",
        "--duration",
        "5",
        "--dt",
        "0.0001",
        "--control-period",
        "0.001",
        "--log",
        "effort.shoulder,effort.elbow,shoulder.position,elbow.position",
        "--noise",
        "shoulder.position=1e-4",
        "--noise",
        "elbow.position=1e-4",
        "--seed",
        "0",
        "--out",
        "run.csv",
    ];
    mujoco(&dir, &args);
    let calibrate = [
        "calibrate",
        &example(),
        "--data",
        "run.csv",
        "--fit",
        "urdf.link.lower.mass",
        "--noise",
        "shoulder.position=1e-4",
        "--noise",
        "elbow.position=1e-4",
        "--out-dir",
        "calibration",
    ];
    let report = ok(&twin(&calibrate, &dir));
    assert!(report.starts_with("verdict: fits"), "{report}");
    let json: Value =
        serde_json::from_slice(&std::fs::read(dir.join("calibration/calibration.json")).unwrap())
            .unwrap();
    let text = json.to_string();
    let mass = &json["parameters"][0];
    let interval = &mass["interval"];
    let (low, high) = (interval[0].as_f64(), interval[1].as_f64());
    assert!(
        low.zip(high).is_some_and(|(l, h)| l <= 1.0 && 1.0 <= h),
        "{text}"
    );
}

// Measured (release): the lower bar 0.8 → 1.0 kg at 8 s of a 12-s hold: detected at 8.81 s,
// put on urdf.link.lower.mass, 0.98 [0.94, 1.02]. Before the batch-means NIS spread, the first
// NIS window after learning (6.5 s) alarmed on this held, quantised pendulum.

#[test]
fn a_shadow_finds_the_lower_bar_grown_heavier() {
    let dir = scratch("generic-machine", "shadow");
    let run = [
        "run",
        &example(),
        "--duration",
        "12",
        "--set",
        "faults.0.kind=link_mass",
        "--set",
        "faults.0.link=lower",
        "--set",
        "faults.0.value=1.0",
        "--set",
        "faults.0.start=8",
        "--csv",
        "run.csv",
        "--out",
        "run.rrd",
    ];
    ok(&twin(&run, &dir));
    let shadow = [
        "shadow",
        &example(),
        "--data",
        "run.csv",
        "--signals",
        "shoulder.position,elbow.position",
        "--track",
        "urdf.link.lower.mass",
        "--summary",
        "shadow.json",
        "--out",
        "shadow.rrd",
    ];
    ok(&twin(&shadow, &dir));
    let summary: Value =
        serde_json::from_slice(&std::fs::read(dir.join("shadow.json")).unwrap()).unwrap();
    let anomalies = summary["anomalies"].as_array().unwrap();
    assert_eq!(anomalies.len(), 1, "{summary:#}");
    let anomaly = &anomalies[0];
    let detected = anomaly["detected"].as_f64().unwrap();
    assert!((8.0..=10.0).contains(&detected), "{anomaly:#}");
    assert_eq!(anomaly["attribution"]["parameter"], "urdf.link.lower.mass");
    let interval = &anomaly["attribution"]["interval"];
    let (low, high) = (interval[0].as_f64().unwrap(), interval[1].as_f64().unwrap());
    assert!(low <= 1.0 && 1.0 <= high, "{anomaly:#}");
}

#[test]
fn what_the_generic_machine_cannot_take_is_refused_by_name() {
    let dir = scratch("generic-machine", "refused");
    let cases = [
        ("points.tip.link=nosuch", "the URDF has no link `nosuch`"),
        ("process.cutting=true", "it has no process"),
        ("points.tip.spring.stiffness=-1", "points.tip"),
    ];
    for (set, expected) in cases {
        let args = [
            "run",
            &example(),
            "--duration",
            "0.1",
            "--set",
            set,
            "--out",
            "x.rrd",
        ];
        let output = twin(&args, &dir);
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(1), "{set}: {stderr}");
        assert_eq!(stderr.lines().count(), 1, "{set}: {stderr}");
        assert!(stderr.contains(expected), "{set}: {stderr}");
        assert!(!dir.join("x.rrd").exists(), "{set}");
    }
}

// Measured (release): from the cranks at 0.3 rad (0.5 rad/s) and −0.2 rad, falling 2 s under
// gravity (the left crank turns through 4.1 rad), the four joints agree to 3.2e-7 rad with
// MuJoCo at 10 µs (3.2e-5 at 0.1 ms: MuJoCo's soft loop closure, its error falling with the
// step squared; the twin closes the loop to 1e-12 m at 0.1 ms).

#[test]
fn the_five_bar_falls_free_as_mujoco_lets_it_fall() {
    let joints = ["left", "left_elbow", "right", "right_elbow"];
    let args = [
        "--initial",
        "left=0.3,0.5",
        "--initial",
        "right=-0.2",
        "--torque",
        "left=0",
        "--torque",
        "right=0",
        "--duration",
        "2",
    ];
    let (theirs, ours) = loop_runs("five-bar", "five_bar.urdf", &joints, &args, &[]);
    for joint in joints {
        let column = format!("{joint}.position");
        let (a, b) = (&theirs[&column], &ours[&format!("true.{column}")]);
        let worst = a
            .iter()
            .zip(b)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max);
        assert!(worst <= 1e-6, "{column}: {worst}");
    }
    // The end point, from the left chain's angles: the crank from (−0.1, 0) pointing up at
    // zero, its distal link turned −0.3398… rad from it at zero.
    let (q1, q2) = (
        &ours["true.left.position"],
        &ours["true.left_elbow.position"],
    );
    for (k, (&a, &b)) in q1.iter().zip(q2).enumerate() {
        let crank = std::f64::consts::FRAC_PI_2 + a;
        let distal = crank - 0.3398369094541218 + b;
        let x = -0.1 + 0.2 * crank.cos() + 0.3 * distal.cos();
        let y = 0.2 * crank.sin() + 0.3 * distal.sin();
        assert!((ours["true.end.x"][k] - x).abs() < 1e-12, "row {k}");
        assert!((ours["true.end.y"][k] - y).abs() < 1e-12, "row {k}");
    }
}

#[test]
fn joint_pid_moves_the_five_bar_and_holds_its_loop_closed() {
    let dir = scratch("generic-machine", "five-bar-pid");
    let scenario = scenario_of("five-bar");
    let run = [
        "run",
        &scenario,
        "--summary",
        "run.json",
        "--out",
        "run.rrd",
    ];
    ok(&twin(&run, &dir));
    let summary: Value =
        serde_json::from_slice(&std::fs::read(dir.join("run.json")).unwrap()).unwrap();
    let metric = |name: &str| summary["metrics"][name].as_f64().unwrap();
    for joint in ["left", "right"] {
        let error = metric(&format!("controller_final/{joint}.error"));
        assert!(error.abs() < 5e-3, "{joint}: {error}");
    }
    assert!(metric("loop_closure_error_max") < 1e-9, "{summary:#}");
}

#[test]
fn the_gantry_moves_free_as_mujoco_moves_it() {
    // Its spring-damper is the scenario's, not the URDF's: off here, as MuJoCo has none. The
    // slide is thrown up and falls back within its travel (the twin's limits are hard stops,
    // MuJoCo's are off).
    let dir = scratch("generic-machine", "gantry-free");
    let urdf = urdf_of("gantry", "gantry.urdf");
    let args = [
        "--initial",
        "x=0.05,0.3",
        "--initial",
        "y=0.1,0.9",
        "--torque",
        "x=0",
        "--torque",
        "y=0",
        "--duration",
        "0.35",
        "--dt",
        "0.001",
        "--out",
        "mujoco.csv",
    ];
    mujoco_on(&dir, &urdf, &args);
    let scenario = scenario_of("gantry");
    let run = [
        "run",
        &scenario,
        "--controller",
        "passive",
        "--duration",
        "0.35",
        "--set",
        "points.tool.spring.stiffness=0",
        "--set",
        "points.tool.spring.damping=0",
        "--set",
        "initial.x.position=0.05",
        "--set",
        "initial.x.velocity=0.3",
        "--set",
        "initial.y.position=0.1",
        "--set",
        "initial.y.velocity=0.9",
        "--csv",
        "twin.csv",
        "--out",
        "twin.rrd",
    ];
    ok(&twin(&run, &dir));
    let (theirs, ours) = (
        columns(&dir.join("mujoco.csv")),
        columns(&dir.join("twin.csv")),
    );
    for column in ["x.position", "x.velocity", "y.position", "y.velocity"] {
        let (a, b) = (&theirs[column], &ours[&format!("true.{column}")]);
        let worst = a
            .iter()
            .zip(b)
            .map(|(p, q)| (p - q).abs())
            .fold(0.0, f64::max);
        assert!(worst <= 1e-6, "{column}: {worst}");
    }
}

#[test]
fn joint_pid_holds_the_gantry_against_its_spring_contact() {
    let dir = scratch("generic-machine", "gantry-pid");
    let scenario = scenario_of("gantry");
    let run = ["run", &scenario, "--csv", "run.csv", "--out", "run.rrd"];
    ok(&twin(&run, &dir));
    let table = columns(&dir.join("run.csv"));
    let last = |name: &str| *table[name].last().unwrap();
    assert!((last("true.x.position") - 0.1).abs() < 1e-5);
    assert!((last("true.y.position") + 0.06).abs() < 1e-5);
    // The tool 10 mm into the spring's rest point (20 kN/m: 200 N up) and the slide's weight
    // (3 kg): the y motor holds −200 + 29.43 N.
    let tool_y = last("true.tool.y");
    let held = -2.0e4 * (-0.35 - tool_y) + 3.0 * 9.81;
    assert!(
        (last("effort.y") - held).abs() < 2.0,
        "{} for {held}",
        last("effort.y")
    );
}

/// MuJoCo's run (`args`, at 10 µs, rows every 1 ms) of example `name`'s URDF, and the twin's
/// `passive` run from every joint of `joints` where MuJoCo's first row has it (the driven ones
/// alone would let the twin assemble a loop on another branch), at 0.1 ms, with `sets`: both
/// runs' columns.
fn loop_runs(
    name: &str,
    urdf: &str,
    joints: &[&str],
    args: &[&str],
    sets: &[&str],
) -> (HashMap<String, Vec<f64>>, HashMap<String, Vec<f64>>) {
    let dir = scratch("generic-machine", &format!("loop-{name}"));
    let mut mujoco_args = args.to_vec();
    mujoco_args.extend([
        "--dt",
        "1e-5",
        "--control-period",
        "1e-3",
        "--out",
        "mujoco.csv",
    ]);
    mujoco_on(&dir, &urdf_of(name, urdf), &mujoco_args);
    let theirs = columns(&dir.join("mujoco.csv"));
    let mut all: Vec<String> = ["dt=1e-4", "control_period=1e-3"].map(String::from).into();
    all.extend(sets.iter().map(|s| s.to_string()));
    for joint in joints {
        for state in ["position", "velocity"] {
            let start = theirs[&format!("{joint}.{state}")][0];
            all.push(format!("initial.{joint}.{state}={start:?}"));
        }
    }
    let scenario = scenario_of(name);
    let mut run = vec![
        "run",
        &scenario,
        "--controller",
        "passive",
        "--duration",
        "2",
    ];
    for set in &all {
        run.extend(["--set", set]);
    }
    run.extend(["--csv", "twin.csv", "--out", "twin.rrd"]);
    ok(&twin(&run, &dir));
    (theirs, columns(&dir.join("twin.csv")))
}

// Measured (release): the crank thrown from 0.5 rad at 3 rad/s, through bottom dead centre, 2 s:
// the crank 3.1e-9 rad, the rod's pin 2.2e-9 rad and the ram 7.9e-11 m from MuJoCo at 10 µs.

#[test]
fn the_slider_crank_runs_free_as_mujoco_runs_it() {
    let joints = ["crank", "crank_pin", "ram"];
    let args = [
        "--initial",
        "crank=0.5,3.0",
        "--torque",
        "crank=0",
        "--duration",
        "2",
    ];
    // The pressing force is the scenario's, not the URDF's: off, as MuJoCo has none.
    let sets = ["points.ram_face.force=[0.0, 0.0]"];
    let (theirs, ours) = loop_runs("slider-crank", "slider_crank.urdf", &joints, &args, &sets);
    for joint in joints {
        let column = format!("{joint}.position");
        let (a, b) = (&theirs[&column], &ours[&format!("true.{column}")]);
        let worst = a
            .iter()
            .zip(b)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max);
        assert!(worst <= 1e-6, "{column}: {worst}");
    }
}

#[test]
fn joint_pid_turns_the_press_against_its_pressing_force() {
    let dir = scratch("generic-machine", "press-pid");
    let scenario = scenario_of("slider-crank");
    let run = [
        "run",
        &scenario,
        "--summary",
        "run.json",
        "--out",
        "run.rrd",
    ];
    ok(&twin(&run, &dir));
    let summary: Value =
        serde_json::from_slice(&std::fs::read(dir.join("run.json")).unwrap()).unwrap();
    let metric = |name: &str| summary["metrics"][name].as_f64().unwrap();
    assert!(
        metric("controller_final/crank.error").abs() < 5e-3,
        "{summary:#}"
    );
    assert!(metric("loop_closure_error_max") < 1e-9, "{summary:#}");
}

/// The double pendulum's scenario in `dir` with both joints driven by a DC servo (5 N·m/A at
/// the joint, 10 A) and joint-pid's gains turned from N·m into A.
fn servo_pendulum(dir: &Path) -> PathBuf {
    let mut text = pendulum_text();
    for (from, to) in [
        ("kp = 120.0", "kp = 24.0"),
        ("ki = 60.0 ", "ki = 12.0 "),
        ("kd = 12.0 ", "kd = 2.4  "),
        ("kp = 40.0", "kp = 8.0"),
        ("ki = 20.0", "ki = 4.0"),
        ("kd = 3.0", "kd = 0.6"),
    ] {
        assert!(text.contains(from), "{from}");
        text = text.replacen(from, to, 1);
    }
    text.push_str(
        r#"
[actuators."*"]
kind = "dc-servo"

[actuators."*".drive]
torque_constant = 0.1       # N·m/A
back_emf_constant = 0.1     # V·s/rad
resistance = 1.0            # Ω
inductance = 1.0e-3         # H
gear_ratio = 50.0
supply_voltage = 48.0       # V
current_limit = 10.0        # A
current_bandwidth = 2000.0  # rad/s
current_loop_period = 1.0e-4
"#,
    );
    let path = dir.join("servo.toml");
    std::fs::write(&path, text).unwrap();
    path
}

/// The double pendulum's scenario, its URDF named by absolute path.
fn pendulum_text() -> String {
    let text = std::fs::read_to_string(example()).unwrap();
    let urdf = urdf_of("double-pendulum", "double_pendulum.urdf");
    text.replace(
        "urdf = \"double_pendulum.urdf\"",
        &format!("urdf = {urdf:?}"),
    )
}

/// Every joint of the double pendulum driven through `kind` with the data sheet `sheet` (under
/// `[actuators."*".<key>]`), its gains unchanged (the command is a torque), written to `dir`.
fn motor_pendulum(dir: &Path, kind: &str, key: &str, sheet: &str) -> PathBuf {
    let mut text = pendulum_text();
    text.push_str(&format!(
        "\n[actuators.\"*\"]\nkind = \"{kind}\"\n\n[actuators.\"*\".{key}]\n{sheet}"
    ));
    let path = dir.join(format!("{kind}.toml"));
    std::fs::write(&path, text).unwrap();
    path
}

/// Runs the double pendulum `scenario` in `dir` driven through `kind`, checks it reaches its
/// targets within four encoder counts and its currents stay within 10 A; its run CSV's columns.
fn drives_to_targets(dir: &Path, scenario: &Path, kind: &str) -> HashMap<String, Vec<f64>> {
    let run = [
        "run",
        scenario.to_str().unwrap(),
        "--csv",
        "run.csv",
        "--out",
        "run.rrd",
    ];
    ok(&twin(&run, dir));
    let table = columns(&dir.join("run.csv"));
    let count = std::f64::consts::TAU / 4096.0;
    for (joint, target) in [("shoulder", 0.6), ("elbow", -0.4)] {
        let positions = &table[&format!("true.{joint}.position")];
        for &q in &positions[positions.len() - 1000..] {
            assert!((q - target).abs() <= 4.0 * count, "{kind}: {joint} at {q}");
        }
    }
    let current = &table["shoulder.current"];
    assert!(current.iter().all(|i| i.abs() <= 10.0 + 1e-9), "{kind}");
    table
}

/// The platform's gear motor and the feed axis's amplifier drive a generic machine's joints:
/// the command a torque, the current a signal, the targets reached, bad data refused by entry.
#[test]
fn gear_motors_and_current_amplifiers_drive_the_double_pendulum_to_its_targets() {
    let dir = scratch("generic-machine", "motors");
    let motors = [
        (
            "gear-motor",
            "motor",
            "gear_ratio = 50.0\ntorque_constant = 0.1\nresistance = 1.0\ninductance = 1.0e-3\n\
             supply_voltage = 48.0\ncurrent_limit = 10.0\n",
            "actuators.\"*\".motor.inductance=0",
        ),
        (
            "current-amplifier",
            "amplifier",
            "amplifier_gain = 2.0\nforce_constant = 5.0\ncurrent_limit = 10.0\n",
            "actuators.\"*\".amplifier.force_constant=-5",
        ),
    ];
    for (kind, key, sheet, bad) in motors {
        let scenario = motor_pendulum(&dir, kind, key, sheet);
        let table = drives_to_targets(&dir, &scenario, kind);
        let (current, command) = (&table["shoulder.current"], &table["effort.shoulder"]);
        let n = current.len();
        // Held, the current carries the bars' weight: the commanded torque at 5 N·m per ampere.
        let held = command[n - 1] / 5.0;
        assert!(
            (current[n - 1] - held).abs() < 0.01 * held.abs().max(0.1),
            "{kind}: {} A",
            current[n - 1]
        );
        let entry = "actuators.\"*\"";
        assert!(refused(&dir, &scenario, bad).contains(entry), "{bad}");
        let effort = refused(&dir, &scenario, "actuators.\"*\".kind=effort");
        assert!(
            effort.contains(&format!("is for kind = \"{kind}\"")),
            "{effort}"
        );
        let feed_axis = refused(
            &dir,
            Path::new("feed-axis-micromilling"),
            &format!("actuators.table.kind={kind}"),
        );
        assert!(
            feed_axis.contains("the generic machine's"),
            "{kind}: {feed_axis}"
        );
    }
    // A kind without its data sheet names the table it needs.
    let scenario = motor_pendulum(&dir, motors[0].0, motors[0].1, motors[0].2);
    let stderr = refused(&dir, &scenario, "actuators.\"*\".kind=current-amplifier");
    assert!(
        stderr.contains("needs its data sheet: [actuators.<joint>.amplifier]"),
        "{stderr}"
    );
}

/// What `twin run <scenario> --set <set>` says, refused in `dir` with exit code 1.
fn refused(dir: &Path, scenario: &Path, set: &str) -> String {
    let args = [
        "run",
        scenario.to_str().unwrap(),
        "--duration",
        "0.01",
        "--set",
        set,
        "--out",
        "x.rrd",
    ];
    let output = twin(&args, dir);
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    assert_eq!(output.status.code(), Some(1), "{set}: {stderr}");
    stderr
}

#[test]
fn dc_servos_drive_the_double_pendulum_to_its_targets() {
    let dir = scratch("generic-machine", "dc-servo");
    let scenario = servo_pendulum(&dir);
    let table = drives_to_targets(&dir, &scenario, "dc-servo");
    // Commands are currents, and each servo's current is a signal of its own.
    let current = &table["shoulder.current"];
    let command = &table["effort.shoulder"];
    let n = current.len();
    // Held, the shoulder's current carries the bars' weight: the same torque as the ideal
    // drive's, 5 N·m per ampere.
    assert!((current[n - 1] - command[n - 1]).abs() < 0.05 * command[n - 1].abs().max(0.1));
    // What the servo cannot take is refused by its entry.
    for (set, expected) in [
        ("actuators.\"*\".drive.resistance=0", "actuators.\"*\""),
        ("actuators.\"*\".kind=effort", "is for kind = \"dc-servo\""),
    ] {
        let args = [
            "run",
            scenario.to_str().unwrap(),
            "--set",
            set,
            "--out",
            "x.rrd",
        ];
        let output = twin(&args, &dir);
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(1), "{set}: {stderr}");
        assert!(stderr.contains(expected), "{set}: {stderr}");
    }
    let args = [
        "run",
        "arm-milling",
        "--duration",
        "0.01",
        "--set",
        "actuators.elbow.kind=dc-servo",
        "--out",
        "x.rrd",
    ];
    let stderr = String::from_utf8_lossy(&twin(&args, &dir).stderr).into_owned();
    assert!(stderr.contains("the generic machine's"), "{stderr}");
}

#[test]
fn a_force_table_in_time_presses_as_the_constant_force_it_holds() {
    let dir = scratch("generic-machine", "force-table");
    std::fs::write(
        dir.join("press.csv"),
        "time [s],fx [N],fy [kN]\n0,0,0.3\n10,0,0.3\n",
    )
    .unwrap();
    let scenario = dir.join("press.toml");
    let text = std::fs::read_to_string(scenario_of("slider-crank")).unwrap();
    let urdf = urdf_of("slider-crank", "slider_crank.urdf");
    let text = text
        .replace("urdf = \"slider_crank.urdf\"", &format!("urdf = {urdf:?}"))
        .replace("force = [0.0, 300.0]", "force_table = \"press.csv\"");
    assert!(text.contains("force_table"));
    std::fs::write(&scenario, text).unwrap();
    let constant = scenario_of("slider-crank");
    for (name, path) in [
        ("constant", constant.as_str()),
        ("table", scenario.to_str().unwrap()),
    ] {
        let csv = format!("{name}.csv");
        let run = [
            "run",
            path,
            "--duration",
            "1",
            "--csv",
            &csv,
            "--out",
            "x.rrd",
        ];
        ok(&twin(&run, &dir));
    }
    // 0.3 kN, converted to 300 N once, gives the same run to the last bit.
    let (a, b) = (
        std::fs::read(dir.join("constant.csv")).unwrap(),
        std::fs::read(dir.join("table.csv")).unwrap(),
    );
    assert!(a == b, "the runs differ");
    // A table without its unit is refused, naming the entry, the file and the column.
    std::fs::write(dir.join("press.csv"), "time [s],fx [N],fy\n0,0,300\n").unwrap();
    let args = ["run", scenario.to_str().unwrap(), "--out", "y.rrd"];
    let output = twin(&args, &dir);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("points.ram_face.force_table"), "{stderr}");
    assert!(
        stderr.contains("press.csv") && stderr.contains("\"fy [N]\""),
        "{stderr}"
    );
    assert!(!dir.join("y.rrd").exists());
}

/// A tap test on a machine that starts with a move and is held away from zero: the gantry's x
/// axis under joint-pid (its integrator off) taken to 0.1 m against the workpiece's spring. The
/// response is measured where the axis comes to rest, about that operating point: its static
/// compliance is 1/(kp + k_spring) = 1/60 000 m/N, its mode the 11 kg carriage and slide on
/// that stiffness. (Taken about zero, the 0.1 m offset read as 5 m/N at 0 Hz and a 0.03 kg mode.)
#[test]
fn a_tap_test_on_the_gantry_held_off_zero_measures_its_closed_loop_stiffness() {
    let dir = scratch("generic-machine", "gantry-tap");
    let gantry = scenario_of("gantry");
    let args = [
        "frf",
        &gantry,
        "--input",
        "x",
        "--output",
        "x.position",
        "--averages",
        "4",
        "--segment",
        "2048",
        "--rate",
        "1000",
        "--set",
        "sensors.\"x.position\".resolution=0",
        "--set",
        "controller.params.joints.x.ki=0",
        "--out-dir",
        "tap",
    ];
    let stdout = ok(&twin(&args, &dir));
    let table = columns(&dir.join("tap/frf.csv"));
    let (dc, coherence) = (table["magnitude"][0], table["coherence"][0]);
    assert_eq!(table["frequency_hz"][0], 0.0);
    assert!((dc * 60_000.0 - 1.0).abs() < 1e-6, "{dc} m/N at 0 Hz");
    assert!(coherence > 0.999, "γ² {coherence} at 0 Hz");
    let figure = |label: &str| -> f64 {
        let after = stdout
            .split(label)
            .nth(1)
            .unwrap_or_else(|| panic!("{stdout}"));
        after
            .split_whitespace()
            .next()
            .unwrap()
            .trim_end_matches(',')
            .parse()
            .unwrap()
    };
    let (stiffness, mass) = (figure("stiffness "), figure("mass "));
    assert!(
        (stiffness / 60_000.0 - 1.0).abs() < 0.02,
        "{stiffness} N/m: {stdout}"
    );
    assert!((mass / 11.0 - 1.0).abs() < 0.1, "{mass} kg: {stdout}");
}

/// A built-in machine takes `[points]` beside its own signals: a point that carries nothing
/// changes nothing of the run (every other column bit for bit), and it moves with its link; a
/// force on it is a load the machine's controller meets (the feed axis's integrator takes a
/// 50 N push on its table).
#[test]
fn a_built_in_machine_takes_points_beside_its_own_signals() {
    let dir = scratch("generic-machine", "built-in-points");
    let run = |name: &str, sets: &[&str]| {
        let mut args = vec!["run", name, "--csv", "run.csv", "--out", "run.rrd"];
        for set in sets {
            args.extend(["--set", set]);
        }
        ok(&twin(&args, &dir));
        common::cells(&dir.join("run.csv"))
    };
    let bare = run("whitworth-crank-pi", &["duration=2.0"]);
    let pin = [
        "duration=2.0",
        "points.pin.link=crank",
        "points.pin.at=[0.1, 0.0]",
    ];
    let with_pin = run("whitworth-crank-pi", &pin);
    for (name, column) in &bare {
        assert_eq!(&with_pin[name], column, "{name}");
    }
    let number = |column: &str| -> Vec<f64> {
        with_pin[column]
            .iter()
            .map(|c| c.parse().unwrap())
            .collect()
    };
    let (x, y) = (number("true.pin.x"), number("true.pin.y"));
    let radius: Vec<f64> = x.iter().zip(&y).map(|(x, y)| x.hypot(*y)).collect();
    let spread = radius
        .iter()
        .fold(0.0_f64, |m, r| m.max((r - radius[0]).abs()));
    assert!(
        spread < 1e-9,
        "the crank's point wanders {spread} m off its circle"
    );
    assert!(
        with_pin.contains_key("ram_position"),
        "the machine's own signals stay"
    );
    let effort = |cells: &HashMap<String, Vec<String>>| -> f64 {
        let column = &cells["effort.table"];
        let tail = &column[column.len() / 2..];
        tail.iter().map(|c| c.parse::<f64>().unwrap()).sum::<f64>() / tail.len() as f64
    };
    let free = effort(&run("feed-axis-micromilling", &[]));
    let push = ["points.probe.link=table", "points.probe.force=[50.0, 0.0]"];
    let pushed = effort(&run("feed-axis-micromilling", &push));
    assert!(
        (pushed - free + 50.0).abs() < 0.5,
        "{free} N, then {pushed} N"
    );
}
