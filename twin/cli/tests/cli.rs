//! The `twin` binary: each bad input is a one-line error naming what is wrong, a non-zero exit,
//! and nothing half-written that looks valid.

mod common;

use common::twin;
use std::path::Path;

fn scratch(test: &str) -> common::Scratch {
    common::scratch("cli", test)
}

/// Runs a failing command and checks its one-line error mentions every `part`.
fn fails_naming(args: &[&str], parts: &[&str], test: &str) -> common::Scratch {
    let dir = scratch(test);
    let output = twin(args, &dir);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!output.status.success(), "{args:?} should fail");
    assert_eq!(
        common::error_lines(stderr.trim()),
        1,
        "one line expected: {stderr}"
    );
    assert!(stderr.starts_with("error: "), "{stderr}");
    for part in parts {
        assert!(stderr.contains(part), "`{part}` missing from: {stderr}");
    }
    let written: Vec<_> = std::fs::read_dir(&dir).unwrap().collect();
    assert!(written.is_empty(), "nothing may be written: {written:?}");
    dir
}

#[test]
fn list_shows_scenarios_and_controllers() {
    let output = twin(&["list"], &scratch("list"));
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(output.status.success());
    assert!(
        stdout.contains("whitworth-crank-pi")
            && stdout.contains("crank-pi")
            && stdout.contains("passive"),
        "{stdout}"
    );
}

#[test]
fn run_writes_the_recording_and_the_summary() {
    let dir = scratch("run");
    let output = twin(
        &[
            "run",
            "whitworth-crank-pi",
            "--duration",
            "0.2",
            "--summary",
            "s.json",
        ],
        &dir,
    );
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    assert!(
        std::fs::metadata(dir.join("whitworth-crank-pi.rrd"))
            .unwrap()
            .len()
            > 0
    );
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("s.json")).unwrap()).unwrap();
    for key in [
        "scenario",
        "controller",
        "dt",
        "steps",
        "wall_s",
        "steps_per_s",
        "metrics",
    ] {
        assert!(summary.get(key).is_some(), "summary lacks {key}: {summary}");
    }
    assert_eq!(summary["steps"], 200);
    assert_eq!(summary["controller"], "crank-pi");
    assert!(summary["metrics"]["ram_stroke"].as_f64().unwrap() > 0.0);
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(stdout.contains("steps/s"), "{stdout}");
}

#[test]
fn unknown_scenario() {
    fails_naming(
        &["run", "lathe-of-theseus"],
        &["lathe-of-theseus"],
        "scenario",
    );
}

#[test]
fn unknown_controller() {
    fails_naming(
        &["run", "whitworth-crank-pi", "--controller", "magic"],
        &["magic", "crank-pi"],
        "controller",
    );
}

#[test]
fn bad_set_key_and_value() {
    fails_naming(
        &[
            "run",
            "whitworth-crank-pi",
            "--set",
            "controller.params.gian=3",
        ],
        &["gian"],
        "set-key",
    );
    fails_naming(
        &[
            "run",
            "whitworth-crank-pi",
            "--set",
            "controller.params.inertia=\"heavy\"",
        ],
        &["inertia"],
        "set-value",
    );
    fails_naming(
        &[
            "run",
            "whitworth-crank-pi",
            "--set",
            "controller.params.inertia=-1",
        ],
        &["controller.params.inertia = -1: must be > 0"],
        "set-negative",
    );
    fails_naming(
        &["run", "whitworth-crank-pi", "--set", "dt"],
        &["key=value"],
        "set-form",
    );
}

#[test]
fn non_positive_dt_or_duration() {
    fails_naming(
        &["run", "whitworth-crank-pi", "--set", "dt=0"],
        &["dt must be > 0"],
        "dt",
    );
    fails_naming(
        &["run", "whitworth-crank-pi", "--duration", "-2"],
        &["duration must be > 0"],
        "duration",
    );
}

#[test]
fn malformed_toml_names_the_file() {
    let dir = scratch("toml");
    let file = dir.join("broken.toml");
    std::fs::write(&file, "name = \"x\"\nmachine = [unclosed\n").unwrap();
    let output = twin(
        &[
            "run",
            file.to_str().unwrap(),
            "--out",
            "/dev/null/never.rrd",
        ],
        &dir,
    );
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!output.status.success());
    assert!(stderr.contains("broken.toml"), "{stderr}");
    assert_eq!(common::error_lines(stderr.trim()), 1, "{stderr}");
}

#[test]
fn malformed_urdf_names_the_urdf() {
    let dir = scratch("urdf");
    std::fs::write(dir.join("bad.urdf"), "<robot name='w'><link name='ground'/><joint name='j' type='revolute'><parent link='ground'/><child link='nowhere'/></joint></robot>").unwrap();
    let builtin = include_str!("../../scenarios/whitworth-crank-pi.toml")
        .replace("urdf = \"urdf/whitworth.urdf\"", "urdf = \"bad.urdf\"");
    std::fs::write(dir.join("mine.toml"), builtin).unwrap();
    let output = twin(&["run", "mine.toml", "--out", "out/never.rrd"], &dir);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!output.status.success());
    assert!(
        stderr.contains("bad.urdf") && stderr.contains("nowhere"),
        "{stderr}"
    );
    assert!(!dir.join("out").exists());
}

#[test]
fn unwritable_out_path() {
    fails_naming(
        &[
            "run",
            "whitworth-crank-pi",
            "--duration",
            "0.1",
            "--out",
            "missing-folder/run.rrd",
        ],
        &["missing-folder/run.rrd"],
        "out",
    );
}

#[test]
fn a_users_own_scenario_file_runs() {
    let dir = scratch("own");
    let text = include_str!("../../scenarios/whitworth-crank-pi.toml")
        .replace("name = \"whitworth-crank-pi\"", "name = \"my-shaper\"");
    std::fs::write(dir.join("my-shaper.toml"), text).unwrap();
    let output = twin(&["run", "my-shaper.toml", "--duration", "0.1"], &dir);
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    assert!(dir.join("my-shaper.rrd").exists());
}

#[test]
fn bad_viewer_url() {
    fails_naming(
        &[
            "run",
            "whitworth-crank-pi",
            "--duration",
            "0.1",
            "--connect",
            "notaurl",
        ],
        &["bad viewer URL `notaurl`"],
        "connect",
    );
}

#[test]
fn sweep_records_failed_runs_reports_plainly_and_refuses_bad_studies_before_writing() {
    let dir = scratch("sweep");
    let args = [
        "sweep",
        "whitworth-crank-pi",
        "--set",
        "duration=0.2",
        "--grid",
        "health.max_joint_speed=[1e-6, 1e3]",
        "--samples",
        "2",
        "--record",
        "failed",
        "--out",
        "s",
    ];
    let output = twin(&args, &dir);
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    // Not a terminal: plain progress lines, one per failure and the last count.
    assert!(
        stdout.contains("run 0 failed: run diverged at step"),
        "{stdout}"
    );
    assert!(stdout.contains("4/4 runs done, 2 failed"), "{stdout}");
    assert!(stdout.contains("failure rate 50.0 %"), "{stdout}");
    let mut kept: Vec<String> = std::fs::read_dir(dir.join("s/recordings"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    kept.sort();
    assert_eq!(kept, ["0.rrd", "1.rrd"], "only the failed runs' recordings");
    for file in ["study.json", "results.csv", "report.json", "study.rrd"] {
        assert!(dir.join("s").join(file).is_file(), "{file}");
    }
    let merged = twin(&["sweep", "merge", "s", "--out", "m"], &dir);
    assert!(merged.status.success());
    assert_eq!(
        std::fs::read(dir.join("s/results.csv")).unwrap(),
        std::fs::read(dir.join("m/results.csv")).unwrap()
    );
    let _ = std::fs::remove_dir_all(&dir);
    let base = ["sweep", "whitworth-crank-pi", "--out", "s"];
    let with = |extra: &[&'static str]| [&base[..], extra].concat();
    fails_naming(
        &with(&["--shard", "3/2"]),
        &["--shard 3/2", "out of range"],
        "sweep-shard",
    );
    fails_naming(
        &with(&["--grid", "k=log(0,1,3)"]),
        &["--grid k=log(0,1,3)", "a > 0"],
        "sweep-grid",
    );
    fails_naming(
        &with(&["--spec", "mse=1"]),
        &["--spec mse=1", "metric<value"],
        "sweep-spec",
    );
    fails_naming(
        &with(&["--samples", "0"]),
        &["--samples must be ≥ 1"],
        "sweep-samples",
    );
    fails_naming(
        &with(&["--set", "controller.params.bogus=1"]),
        &["controller.params", "bogus"],
        "sweep-key",
    );
    fails_naming(
        &["sweep", "merge", "nowhere", "--out", "m"],
        &["nowhere"],
        "sweep-merge",
    );
}

#[test]
fn two_runs_of_the_same_scenario_write_the_same_bytes() {
    let dir = scratch("identical");
    for out in ["a.rrd", "b.rrd"] {
        let output = twin(
            &["run", "whitworth-crank-pi", "--duration", "2", "--out", out],
            &dir,
        );
        assert!(
            output.status.success(),
            "{}",
            String::from_utf8_lossy(&output.stderr)
        );
    }
    let a = std::fs::read(dir.join("a.rrd")).unwrap();
    let b = std::fs::read(dir.join("b.rrd")).unwrap();
    assert!(a.len() > 10_000, "{} bytes", a.len());
    let first_difference = a.iter().zip(&b).position(|(x, y)| x != y);
    assert_eq!(
        (a.len(), first_difference),
        (b.len(), None),
        "the recordings differ"
    );
}

#[test]
fn a_bad_controller_parameter_is_refused_before_the_run_with_its_key_path() {
    fails_naming(
        &[
            "run",
            "whitworth-crank-pi",
            "--set",
            "controller.params.natural_frequency=-1",
        ],
        &["controller.params.natural_frequency = -1: must be > 0"],
        "bad-gain",
    );
}

#[test]
fn arm_crash_reports_the_pair_and_stops_with_exit_3_under_the_flag() {
    let dir = scratch("crash");
    let output = twin(
        &["run", "arm-crash", "--duration", "3", "--summary", "s.json"],
        &dir,
    );
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stderr}");
    assert!(
        stderr.contains("warning: collision: `hand` and `clamp` touched first, at t = 1.467 s"),
        "{stderr}"
    );
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("s.json")).unwrap()).unwrap();
    assert_eq!(summary["status"], "ok");
    assert_eq!(summary["metrics"]["first_collision_time"], 1.467);
    assert!(summary["metrics"]["collisions"].as_f64().unwrap() >= 1.0);

    let output = twin(
        &[
            "run",
            "arm-crash",
            "--set",
            "health.stop_on_collision=true",
            "--summary",
            "stop.json",
            "--out",
            "stop.rrd",
        ],
        &dir,
    );
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(3), "{stderr}");
    let error = stderr.lines().find(|l| l.starts_with("error: ")).unwrap();
    assert!(
        error.starts_with(
            "error: run stopped at step 1467 (t = 1.467000 s): collision hand/clamp, "
        ) && error.ends_with("µm deep"),
        "{error}"
    );
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("stop.json")).unwrap()).unwrap();
    assert_eq!(summary["status"], "failed");
    assert_eq!(summary["time_reached"], 1.467);
    assert!(summary["failure"]
        .as_str()
        .unwrap()
        .contains("collision hand/clamp"));
    // The recording is complete up to the crash.
    assert!(std::fs::metadata(dir.join("stop.rrd")).unwrap().len() > 0);
}

#[test]
fn frf_writes_the_tap_test_and_refuses_bad_input() {
    let dir = scratch("frf");
    let tap = [
        "frf",
        "milling-constant-15000",
        "--input",
        "tool_x",
        "--output",
        "tool_x.position",
        "--set",
        "process.cutting=false",
        "--averages",
        "2",
        "--out-dir",
        "tap",
    ];
    let output = twin(&tap, &dir);
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    assert!(stdout.contains("f_n 786.4"), "{stdout}");
    let csv = std::fs::read_to_string(dir.join("tap/frf.csv")).unwrap();
    assert!(csv.starts_with("frequency_hz,magnitude,phase_deg,coherence,real,imag\n"));
    assert_eq!(csv.lines().count(), 1 + 2049);
    assert!(std::fs::metadata(dir.join("tap/frf.rrd")).unwrap().len() > 0);
    frf_refuses_bad_input(&dir);
}

/// `twin frf` refusing an unknown excitation, an amplitude over the actuator's limit and a band
/// beyond Nyquist, and a tap test that diverges leaving no output folder.
fn frf_refuses_bad_input(dir: &Path) {
    let unknown = twin(
        &[
            "frf",
            "milling-z04",
            "--input",
            "tool_x",
            "--output",
            "tool_x.position",
            "--excitation",
            "hammer",
        ],
        dir,
    );
    assert_eq!(unknown.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&unknown.stderr).contains("hammer"));
    fails_naming(
        &[
            "frf",
            "milling-z04",
            "--input",
            "spindle",
            "--output",
            "spindle.velocity",
            "--amplitude",
            "13",
        ],
        &["--amplitude", "limit 12", "spindle"],
        "frf-limit",
    );
    fails_naming(
        &[
            "frf",
            "milling-z04",
            "--input",
            "tool_x",
            "--output",
            "tool_x.position",
            "--band",
            "0",
            "6000",
        ],
        &["--band", "Nyquist"],
        "frf-band",
    );
    let diverged = twin(
        &[
            "frf",
            "milling-constant-15000",
            "--input",
            "tool_x",
            "--output",
            "tool_x.position",
            "--set",
            "health.max_joint_speed=0.05",
            "--set",
            "initial.spindle.velocity=0",
            "--set",
            "controller.params.speed=1e-3",
            "--out-dir",
            "diverged",
        ],
        dir,
    );
    assert_eq!(diverged.status.code(), Some(3));
    assert!(String::from_utf8_lossy(&diverged.stderr).contains("tool_x.velocity"));
    assert!(!dir.join("diverged").exists());
}

#[test]
fn an_integrator_is_the_exact_engines_and_bench_names_it() {
    fails_naming(
        &[
            "run",
            "whitworth-crank-pi",
            "--engine",
            "rapier",
            "--set",
            "solver.integrator=midpoint",
            "--duration",
            "0.01",
        ],
        &["solver.integrator = \"midpoint\" is the exact engine's"],
        "integrator-rapier",
    );
    fails_naming(
        &[
            "run",
            "whitworth-crank-pi",
            "--set",
            "solver.integrator=euler",
        ],
        &["solver.integrator", "euler"],
        "integrator-unknown",
    );
    let dir = scratch("integrator-bench");
    let args = [
        "bench",
        "whitworth-crank-pi",
        "--duration",
        "0.05",
        "--set",
        "solver.integrator=semi_implicit_euler",
    ];
    let output = twin(&args, &dir);
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(output.status.success(), "{stdout}");
    let row = (stdout.lines())
        .find(|l| l.starts_with("whitworth-crank-pi"))
        .unwrap_or_default();
    assert!(row.contains("exact semi_implicit_euler"), "{stdout}");
}
