//! `twin compare` and `twin calibrate` as a user runs them: a run logged with `--csv`, a scenario
//! file whose `[calibration]` table names it, the three output files, the calibrated scenario
//! taken by the other commands, and the usage errors of the options.

mod common;

use common::{scratch, twin};
use std::path::Path;
use std::process::Command;

fn ok(output: &std::process::Output) -> String {
    let text = String::from_utf8_lossy(&output.stdout).to_string();
    assert!(
        output.status.success(),
        "{text}\n{}",
        String::from_utf8_lossy(&output.stderr)
    );
    text
}

fn logged_run(dir: &Path) {
    ok(&twin(
        &[
            "run",
            "whitworth-crank-pi",
            "--duration",
            "2",
            "--set",
            "urdf.link.ram.mass=5.8",
            "--csv",
            "run.csv",
            "--out",
            "run.rrd",
        ],
        dir,
    ));
}

#[test]
fn a_scenario_file_calibrates_from_its_table_and_the_other_commands_take_the_result() {
    let dir = scratch("calibrate", "table");
    logged_run(&dir);
    let builtin = "urdf = \"urdf/whitworth.urdf\"";
    let text = twin::BUILTIN_SCENARIOS
        .iter()
        .find(|(name, _)| *name == "whitworth-crank-pi")
        .map(|(_, text)| text.to_string())
        .unwrap();
    assert!(text.contains(builtin));
    let table = "\n[calibration]\ndata = [\"run.csv\"]\n\n[calibration.fit]\n\"urdf.link.ram.mass\" = { bounds = [1.0, 20.0] }\n";
    std::fs::write(dir.join("shaper.toml"), format!("{text}{table}")).unwrap();
    let report = ok(&twin(
        &["calibrate", "shaper.toml", "--out-dir", "cal"],
        &dir,
    ));
    assert!(report.contains("urdf.link.ram.mass"), "{report}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("cal/calibration.json")).unwrap())
            .unwrap();
    let estimate = json["parameters"][0]["estimate"].as_f64().unwrap();
    assert!((estimate / 5.8 - 1.0).abs() < 1e-6, "{estimate}");
    assert!(dir.join("cal/calibration.rrd").is_file());
    // The calibrated scenario, as every command takes a scenario file.
    let calibrated = "cal/calibrated.toml";
    ok(&twin(
        &["run", calibrated, "--duration", "0.2", "--out", "again.rrd"],
        &dir,
    ));
    ok(&twin(
        &["linearize", calibrated, "--out-dir", "linear"],
        &dir,
    ));
    let compared = ok(&twin(
        &[
            "compare",
            calibrated,
            "--data",
            "run.csv",
            "--out-dir",
            "cmp",
        ],
        &dir,
    ));
    assert!(compared.contains("crank.position"), "{compared}");
    assert!(dir.join("cmp/comparison.json").is_file() && dir.join("cmp/comparison.rrd").is_file());
}

#[test]
fn a_recording_is_data_too() {
    let dir = scratch("calibrate", "recording");
    logged_run(&dir);
    let report = ok(&twin(
        &[
            "calibrate",
            "whitworth-crank-pi",
            "--data",
            "run.rrd",
            "--fit",
            "urdf.link.ram.mass",
        ],
        &dir,
    ));
    let line = report
        .lines()
        .find(|l| l.starts_with("urdf.link.ram.mass"))
        .unwrap();
    let estimate: f64 = line.split_whitespace().nth(2).unwrap().parse().unwrap();
    // The recording holds the signals in f64 at their display units, so a unit conversion
    // rounds them: 1e-6 is still well within.
    assert!((estimate / 5.8 - 1.0).abs() < 1e-6, "{report}");
}

#[test]
fn malformed_options_are_usage_errors_naming_the_option() {
    let dir = scratch("calibrate", "usage");
    logged_run(&dir);
    for (args, expected) in [
        (
            vec!["--fit", "urdf.link.ram.mass=abc"],
            "--fit urdf.link.ram.mass=abc: `abc` is not a finite number",
        ),
        (
            vec![
                "--fit",
                "urdf.link.ram.mass",
                "--bounds",
                "urdf.joint.crank.damping=0,1",
            ],
            "is not fitted; add --fit urdf.joint.crank.damping",
        ),
        (
            vec![
                "--fit",
                "urdf.link.ram.mass",
                "--bounds",
                "urdf.link.ram.mass=1",
            ],
            "expected KEY=LO,HI",
        ),
        (
            vec![
                "--fit",
                "urdf.link.ram.mass",
                "--noise",
                "crank.position=-1",
            ],
            "σ must be a finite number > 0",
        ),
        (
            vec!["--fit", "urdf.link.ram.mass", "--starts", "0"],
            "give at least 1 start",
        ),
        (vec![], "give a parameter to fit"),
    ] {
        let mut all = vec!["calibrate", "whitworth-crank-pi", "--data", "run.csv"];
        all.extend(args);
        let output = twin(&all, &dir);
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{all:?}: {stderr}");
        assert!(
            stderr.contains(expected) && common::error_lines(&stderr) == 1,
            "{all:?}: {stderr}"
        );
    }
    let output = twin(
        &[
            "calibrate",
            "whitworth-crank-pi",
            "--data",
            "nowhere.csv",
            "--fit",
            "urdf.link.ram.mass",
        ],
        &dir,
    );
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("nowhere.csv"), "{stderr}");
}

/// What the bad-input corpus found, each ended with its reason and before any work: a noise σ
/// whose residuals overflow, a noise for a signal the scenario lacks, a table's σ that is not a
/// positive number, a FIFO as the data, an output folder that is a file; and a reader that stops
/// early ends `twin compare` quietly.
#[test]
fn bad_inputs_end_with_their_reason_before_any_work() {
    let dir = scratch("calibrate", "bad-inputs");
    logged_run(&dir);
    let fit = [
        "calibrate",
        "whitworth-crank-pi",
        "--data",
        "run.csv",
        "--fit",
        "urdf.link.ram.mass",
    ];
    let refused = |extra: &[&str], code: i32, expected: &str| {
        let mut all = fit.to_vec();
        all.extend(extra);
        let output = twin(&all, &dir);
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(code), "{extra:?}: {stderr}");
        assert!(stderr.contains(expected), "{extra:?}: {stderr}");
        assert!(
            !stderr.contains("iteration"),
            "{extra:?}: refused after work: {stderr}"
        );
    };
    refused(
        &["--noise", "crank.position=1e-300"],
        1,
        "not finite at the start",
    );
    refused(
        &["--noise", "nosuch=1e-3"],
        1,
        "--noise nosuch: no such signal",
    );
    std::fs::write(dir.join("afile"), "x").unwrap();
    refused(&["--out-dir", "afile"], 1, "--out-dir afile");
    let text = twin::BUILTIN_SCENARIOS
        .iter()
        .find(|(name, _)| *name == "whitworth-crank-pi")
        .map(|(_, text)| text.to_string())
        .unwrap();
    let table = "\n[calibration.noise]\n\"crank.position\" = -1.0\n";
    std::fs::write(dir.join("negative.toml"), format!("{text}{table}")).unwrap();
    let negative = [
        "calibrate",
        "negative.toml",
        "--data",
        "run.csv",
        "--fit",
        "urdf.link.ram.mass",
    ];
    let output = twin(&negative, &dir);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("[calibration.noise]"), "{stderr}");
    compare_refuses_a_fifo_and_ends_quietly_in_a_pipe(&dir);
}

/// `twin compare` refuses a FIFO as its data (not a regular file), and ends quietly when the
/// reader of its output (`head -1`) stops early.
fn compare_refuses_a_fifo_and_ends_quietly_in_a_pipe(dir: &Path) {
    #[cfg(unix)]
    {
        let fifo = dir.join("fifo.csv");
        let made = Command::new("mkfifo").arg(&fifo).status();
        if made.is_ok_and(|s| s.success()) {
            let output = twin(
                &["compare", "whitworth-crank-pi", "--data", "fifo.csv"],
                dir,
            );
            let stderr = String::from_utf8_lossy(&output.stderr);
            assert_eq!(output.status.code(), Some(1), "{stderr}");
            assert!(stderr.contains("not a regular file"), "{stderr}");
        }
    }
    let piped = Command::new("sh")
        .arg("-c")
        .arg(format!(
            "{} compare whitworth-crank-pi --data run.csv | head -1",
            env!("CARGO_BIN_EXE_twin")
        ))
        .current_dir(dir)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&piped.stderr);
    assert!(
        !stderr.contains("panicked") && !stderr.contains("Broken pipe"),
        "{stderr}"
    );
}
