//! Hostile inputs, outputs and signals, one test per reproducer of the hardening issue: each ends
//! in bounded time with a one-line error naming what to change (exit 1, or 2 for usage), leaves
//! nothing half-written, and a stopped run keeps a complete recording.

mod common;

use common::twin;
use std::path::Path;
use std::process::Output;
use std::time::{Duration, Instant};

fn scratch(test: &str) -> common::Scratch {
    common::scratch("hostile", test)
}

fn stderr(output: &Output) -> String {
    String::from_utf8_lossy(&output.stderr).into_owned()
}

/// Files left in `dir` (none may be after a failed command).
fn files(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// Exit 1, one line `error: …` naming every part, nothing written in `dir` besides `keep`.
fn fails(output: &Output, parts: &[&str], dir: &Path, keep: &[&str]) {
    let text = stderr(output);
    assert_eq!(output.status.code(), Some(1), "exit code; stderr: {text}");
    assert_eq!(
        common::error_lines(text.trim()),
        1,
        "one line expected: {text}"
    );
    assert!(text.starts_with("error: "), "{text}");
    for part in parts {
        assert!(text.contains(part), "`{part}` missing from: {text}");
    }
    let left: Vec<String> = files(dir)
        .into_iter()
        .filter(|f| !keep.contains(&f.as_str()))
        .collect();
    assert!(left.is_empty(), "nothing may be left behind: {left:?}");
}

fn run_fails(test: &str, args: &[&str], parts: &[&str]) {
    let dir = scratch(test);
    let output = twin(args, &dir);
    fails(&output, parts, &dir, &[]);
}

/// A scenario file in `dir` from a built-in one, its URDF replaced by `urdf` (written beside).
fn scenario_with_urdf(dir: &Path, urdf: &str) -> String {
    std::fs::write(dir.join("m.urdf"), urdf).unwrap();
    let toml = include_str!("../../scenarios/whitworth-crank-pi.toml")
        .replace("urdf = \"urdf/whitworth.urdf\"", "urdf = \"m.urdf\"");
    assert!(toml.contains("m.urdf"));
    std::fs::write(dir.join("m.toml"), toml).unwrap();
    "m.toml".into()
}

fn urdf_fails(test: &str, urdf: &str, parts: &[&str]) {
    let dir = scratch(test);
    let scenario = scenario_with_urdf(&dir, urdf);
    let output = twin(&["run", &scenario, "--duration", "0.01"], &dir);
    fails(&output, parts, &dir, &["m.toml", "m.urdf"]);
}

const WHITWORTH: &str = include_str!("../../../urdf/whitworth.urdf");

#[test]
fn huge_sensor_delay_is_refused() {
    for delay in ["1e16", "1e15", "11"] {
        run_fails(
            &format!("delay{delay}"),
            &[
                "run",
                "whitworth-crank-pi",
                "--set",
                &format!("sensors.\"crank.position\".delay={delay}"),
            ],
            &["sensors.\"crank.position\"", "delay", "duration"],
        );
    }
}

#[test]
fn huge_analysis_grids_are_refused() {
    for grid in ["1000000000", "100000", "4294967296", "101"] {
        run_fails(
            &format!("grid{grid}"),
            &["analyze", "lathe", "--grid", grid],
            &["--grid", "1 to 100"],
        );
    }
    // Within the grid cap but beyond the work cap: the integration-step bound names the way out.
    run_fails(
        "gridwork",
        &["analyze", "lathe", "--grid", "100", "--duration", "200"],
        &["integration steps", "fewer grid points"],
    );
}

#[test]
fn deeply_nested_urdf_is_refused_before_parsing() {
    for depth in [20_000, 1_000_000] {
        let urdf = format!(
            "<robot name=\"r\">{}{}</robot>",
            "<a>".repeat(depth),
            "</a>".repeat(depth)
        );
        let start = Instant::now();
        urdf_fails(
            &format!("deep{depth}"),
            &urdf,
            &["m.urdf", "nested more than"],
        );
        assert!(start.elapsed() < Duration::from_secs(20), "{depth} levels");
    }
}

#[test]
fn very_deep_set_keys_are_refused() {
    let segments = vec!["a"; 12_000].join(".");
    run_fails(
        "setdeep",
        &[
            "run",
            "whitworth-crank-pi",
            "--set",
            &format!("{segments}=1"),
        ],
        &["--set a.a.a", "longer than 256"],
    );
    run_fails(
        "setlevels",
        &["run", "whitworth-crank-pi", "--set", "a.b.c.d.e.f.g.h.i=1"],
        &["deeper than 8"],
    );
}

#[test]
fn non_finite_urdf_origins_are_refused() {
    let visual = "<origin xyz=\"-0.125 0.12093 0\"/>";
    assert!(WHITWORTH.contains(visual));
    for bad in [
        "<origin xyz=\"-0.125 0.12093 nan\"/>",
        "<origin xyz=\"NaN 0.12093 0\"/>",
        "<origin xyz=\"-0.125 0.12093 0\" rpy=\"nan 0 0\"/>",
        "<origin xyz=\"-0.125 0.12093 0\" rpy=\"0 0 inf\"/>",
    ] {
        urdf_fails(
            "nanorigin",
            &WHITWORTH.replacen(visual, bad, 1),
            &["link \"ground\" <visual>", "must be finite"],
        );
    }
}

#[test]
fn a_root_other_than_robot_is_refused() {
    let urdf = WHITWORTH
        .replace("<robot ", "<model ")
        .replace("</robot>", "</model>");
    urdf_fails("root", &urdf, &["m.urdf", "<model>", "<robot>"]);
}

#[test]
fn bad_effort_limits_are_refused() {
    for effort in ["nan", "-5", "inf"] {
        let urdf = WHITWORTH.replace("effort=\"300\"", &format!("effort=\"{effort}\""));
        urdf_fails(
            &format!("effort{effort}"),
            &urdf,
            &["joint \"crank\" <limit>", "effort"],
        );
    }
}

#[test]
fn unbounded_or_non_finite_timing_is_refused() {
    let cases: [(&[&str], &[&str]); 7] = [
        (
            &["--set", "control_period=inf"],
            &["control_period", "finite"],
        ),
        (&["--duration", "1e308"], &["max_steps", "--set max_steps"]),
        (&["--duration", "-inf"], &["duration", "finite"]),
        (&["--set", "dt=1e-12"], &["max_steps"]),
        (&["--set", "substeps=1000000000"], &["substeps", "1 and 64"]),
        (
            &["--set", "urdf=\"/dev/zero\""],
            &["/dev/zero", "larger than 8 MiB"],
        ),
        (
            &["--set", "controller.params.natural_frequency=inf"],
            &["controller.params.natural_frequency", "finite"],
        ),
    ];
    for (k, (extra, parts)) in cases.iter().enumerate() {
        let mut args = vec!["run", "whitworth-crank-pi"];
        args.extend_from_slice(extra);
        run_fails(&format!("timing{k}"), &args, parts);
    }
}

#[test]
fn arrays_of_the_wrong_length_are_refused() {
    run_fails(
        "gravity",
        &[
            "run",
            "whitworth-crank-pi",
            "--set",
            "gravity=[0, -9.81, 5, 1]",
        ],
        &["`gravity`", "4 elements"],
    );
    run_fails(
        "gaps",
        &[
            "run",
            "lathe-turning",
            "--set",
            "process.approach_gaps=[1e-3, 1e-3, 1e-3]",
        ],
        &["approach_gaps", "3 elements"],
    );
    run_fails(
        "short",
        &["run", "whitworth-crank-pi", "--set", "gravity=[0]"],
        &["gravity"],
    );
}

#[test]
fn scenario_names_cannot_leave_the_folder() {
    for name in ["../x", "/tmp/x", ".hidden", "a/b"] {
        run_fails(
            "name",
            &[
                "run",
                "whitworth-crank-pi",
                "--set",
                &format!("name=\"{name}\""),
            ],
            &["name", "names the recording file"],
        );
    }
}

#[test]
fn bad_output_paths_fail_before_the_run() {
    let dir = scratch("outdir");
    std::fs::create_dir(dir.join("folder")).unwrap();
    for (args, parts) in [
        (&["--out", "folder"][..], &["folder", "directory"][..]),
        (&["--summary", "folder"], &["folder", "directory"]),
        (&["--summary", "/proc/x.json"], &["/proc/x.json"]),
        (&["--out", "/proc/x.rrd"], &["/proc/x.rrd"]),
    ] {
        let mut all = vec!["run", "whitworth-crank-pi", "--duration", "5"];
        all.extend_from_slice(args);
        let start = Instant::now();
        let output = twin(&all, &dir);
        fails(&output, parts, &dir, &["folder"]);
        assert!(output.stdout.is_empty(), "no run may happen: {args:?}");
        assert!(start.elapsed() < Duration::from_secs(10), "{args:?}");
        assert!(files(&dir.join("folder")).is_empty());
    }
}

#[test]
fn recording_and_summary_must_differ() {
    let dir = scratch("same");
    let output = twin(
        &[
            "run",
            "whitworth-crank-pi",
            "--duration",
            "0.1",
            "--out",
            "x.json",
            "--summary",
            "./x.json",
        ],
        &dir,
    );
    let text = stderr(&output);
    assert_eq!(output.status.code(), Some(2), "{text}");
    assert!(text.contains("different files"), "{text}");
    assert!(files(&dir).is_empty());
}

#[test]
fn usage_errors_exit_2_in_one_line_and_a_hint() {
    let dir = scratch("usage");
    for args in [
        &["run", "whitworth-crank-pi", "--bogus"][..],
        &["run"],
        &["analyze", "lathe", "--grid", "-1"],
        &["run", "whitworth-crank-pi", "--duration", "soon"],
        &["frobnicate"],
    ] {
        let output = twin(args, &dir);
        let text = stderr(&output);
        assert_eq!(output.status.code(), Some(2), "{args:?}: {text}");
        let lines: Vec<&str> = text.trim().lines().collect();
        assert_eq!(lines.len(), 2, "{args:?}: {text}");
        assert!(lines[0].starts_with("error: "), "{text}");
        assert!(lines[1].starts_with("hint: "), "{text}");
    }
    for (args, named) in [
        (&["run"][..], "<SCENARIO>"),
        (&["reproduce"], "<PAPER>"),
        (&["analyze", "lathe", "--h1=1e-8"], "--h2"),
        (&["analyze"], "<MACHINE>"),
        (&["sweep", "whitworth-crank-pi", "--grid"], "--grid"),
    ] {
        let text = stderr(&twin(args, &dir));
        let first = text.lines().next().unwrap_or_default();
        assert!(first.contains(named), "{args:?}: {text}");
    }
    let alone = twin::<&str>(&[], &dir);
    assert_eq!(alone.status.code(), Some(2));
    let text = stderr(&alone);
    for command in ["run", "sweep", "reproduce", "analyze", "bench", "list"] {
        assert!(text.contains(&format!("  {command}")), "{text}");
    }
    let help = twin(&["--help"], &dir);
    assert_eq!(help.status.code(), Some(0));
    let text = String::from_utf8_lossy(&help.stdout);
    assert!(
        text.contains("Exit codes: 0 ok, 1 error, 2 usage error, 3"),
        "{text}"
    );
    assert!(files(&dir).is_empty());
}

#[test]
fn a_non_utf8_argument_is_named() {
    use std::os::unix::ffi::OsStrExt;
    let dir = scratch("non-utf8");
    let bad = std::ffi::OsStr::from_bytes(b"whit\xffworth");
    let output = twin(&[std::ffi::OsStr::new("run"), bad], &dir);
    let text = stderr(&output);
    assert_eq!(output.status.code(), Some(2), "{text}");
    assert!(
        text.starts_with("error: argument 2 `whit\u{fffd}worth` is not UTF-8"),
        "{text}"
    );
    let output = twin(
        &[
            std::ffi::OsStr::new("run"),
            std::ffi::OsStr::new("whitworth-crank-pi"),
            std::ffi::OsStr::new("--controller"),
            bad,
        ],
        &dir,
    );
    let text = stderr(&output);
    assert!(text.contains("(the value of --controller)"), "{text}");
    assert!(files(&dir).is_empty());
}

#[test]
fn a_diverging_run_exits_3_and_keeps_its_recording() {
    let dir = scratch("diverge");
    let output = twin(
        &[
            "run",
            "whitworth-crank-pi",
            "--duration",
            "2",
            "--set",
            "health.max_joint_speed=1e-3",
            "--summary",
            "s.json",
        ],
        &dir,
    );
    let text = stderr(&output);
    assert_eq!(output.status.code(), Some(3), "{text}");
    assert!(text.contains("diverged at step"), "{text}");
    assert_eq!(files(&dir), ["s.json", "whitworth-crank-pi.rrd"]);
}

#[test]
fn overflowing_controller_designs_are_refused_when_built() {
    for (scenario, key, parts) in [
        (
            "whitworth-crank-pi",
            "controller.params.natural_frequency",
            &["crank-pi", "overflow"],
        ),
        (
            "arm-milling",
            "controller.params.servo.bandwidth",
            &["servo.bandwidth", "overflow"],
        ),
        (
            "platform-path",
            "controller.params.sampling_interval",
            &["sampling_interval", "overflow"],
        ),
    ] {
        run_fails(
            "design",
            &["run", scenario, "--set", &format!("{key}=1e300")],
            parts,
        );
    }
    run_fails(
        "gravity",
        &[
            "run",
            "platform-path",
            "--set",
            "process.floor_gravity=1e300",
        ],
        &["floor_gravity", "(0, 100]"],
    );
}

/// A URDF that renames what a scenario's sensor names: the error names both files
/// (found by the property tests: a platform wheel renamed `nan`).
#[test]
fn a_renamed_urdf_part_named_by_the_scenario_names_the_urdf() {
    let dir = scratch("renamed");
    let urdf = include_str!("../../../urdf/platform.urdf")
        .replace("<wheel name=\"right_wheel\"", "<wheel name=\"nan\"");
    std::fs::write(dir.join("m.urdf"), urdf).unwrap();
    let toml = include_str!("../../scenarios/platform-path.toml")
        .replace("urdf = \"urdf/platform.urdf\"", "urdf = \"m.urdf\"");
    std::fs::write(dir.join("m.toml"), toml).unwrap();
    let output = twin(&["run", "m.toml", "--duration", "0.01"], &dir);
    fails(
        &output,
        &["m.toml", "URDF m.urdf", "sensors.\"right_wheel.position\""],
        &dir,
        &["m.toml", "m.urdf"],
    );
}
