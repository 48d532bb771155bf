//! `twin linearize`: linear.json and the table on success; every bad input a one-line error
//! naming the argument or key, exit 1 (usage errors 2), nothing left on disk.

mod common;

use common::twin;

fn scratch(test: &str) -> common::Scratch {
    common::scratch("linearize", test)
}

/// A failing command: its exit code, one line naming every `part`, nothing written.
fn fails(args: &[&str], code: i32, parts: &[&str], test: &str) {
    let dir = scratch(test);
    let output = twin(args, &dir);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(code), "{args:?}: {stderr}");
    let lines = if code == 2 { 2 } else { 1 };
    assert_eq!(stderr.trim().lines().count(), lines, "{stderr}");
    assert!(stderr.starts_with("error: "), "{stderr}");
    for part in parts {
        assert!(stderr.contains(part), "`{part}` missing from: {stderr}");
    }
    let written: Vec<_> = std::fs::read_dir(&dir).unwrap().collect();
    assert!(written.is_empty(), "nothing may be written: {written:?}");
}

#[test]
fn writes_linear_json_and_prints_the_poles() {
    let dir = scratch("ok");
    let output = twin(
        &["linearize", "feed-axis-micromilling", "--out-dir", "lin"],
        &dir,
    );
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    assert!(
        stdout.contains("poles") && stdout.contains("-2.500000e1"),
        "{stdout}"
    );
    let text = std::fs::read_to_string(dir.join("lin/linear.json")).unwrap();
    let json: serde_json::Value = serde_json::from_str(&text).unwrap();
    for key in [
        "states",
        "inputs",
        "outputs",
        "A",
        "B",
        "C",
        "D",
        "Ad",
        "Bd",
        "poles",
        "operating_point",
    ] {
        assert!(json.get(key).is_some(), "{key} missing");
    }
    assert_eq!(json["states"][0]["name"], "table.position");
    assert_eq!(json["states"][0]["unit"], "m");
    assert_eq!(json["inputs"][0]["unit"], "N");
    assert_eq!(json["control_period"], 1e-4);
}

#[test]
fn unknown_scenario_and_key() {
    fails(
        &["linearize", "lathe-of-theseus", "--out-dir", "d"],
        1,
        &["lathe-of-theseus"],
        "scenario",
    );
    fails(
        &[
            "linearize",
            "feed-axis-micromilling",
            "--set",
            "process.no_such=1",
            "--out-dir",
            "d",
        ],
        1,
        &["no_such"],
        "key",
    );
}

#[test]
fn operating_times_outside_the_run() {
    let base = ["linearize", "whitworth-crank-pi", "--out-dir", "d", "--at"];
    for (at, says, test) in [
        ("-1", "--at -1 s: must be ≥ 0", "negative"),
        ("nan", "--at NaN s: must be a finite time", "nan"),
        ("inf", "--at inf s: must be a finite time", "inf"),
        (
            "1e9",
            "--at 1000000000 s: is beyond the scenario's duration",
            "beyond",
        ),
    ] {
        let args: Vec<&str> = base.iter().copied().chain([at]).collect();
        fails(&args, 1, &[says], test);
    }
    fails(
        &[&base[..], &["ten"]].concat(),
        2,
        &["--at"],
        "not-a-number",
    );
}

#[test]
fn a_run_that_diverges_first() {
    fails(
        &[
            "linearize",
            "whitworth-crank-pi",
            "--set",
            "health.max_joint_speed=1",
            "--at",
            "1",
            "--out-dir",
            "d",
        ],
        1,
        &["diverged before the operating time 1 s"],
        "diverges",
    );
}

#[test]
fn an_output_folder_that_cannot_be_written() {
    let dir = scratch("unwritable");
    std::fs::write(dir.join("file"), "not a folder").unwrap();
    let output = twin(
        &[
            "linearize",
            "feed-axis-micromilling",
            "--out-dir",
            "file/sub",
        ],
        &dir,
    );
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.starts_with("error: --out-dir file/sub") && common::error_lines(stderr.trim()) == 1,
        "{stderr}"
    );
    fails(
        &["linearize", "feed-axis-micromilling"],
        2,
        &["--out-dir"],
        "missing",
    );
}
