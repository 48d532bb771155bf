//! The binary's outputs under trouble: two runs to one file, a live viewer that is not there, a
//! write that fails, and a run killed outright (then salvaged).

mod common;

use common::{finished, parts, scratch, verify};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

fn twin(args: &[&str], dir: &std::path::Path) -> Command {
    let mut command = Command::new(env!("CARGO_BIN_EXE_twin"));
    command.args(args).current_dir(dir);
    command
}

#[test]
fn two_runs_to_one_file_leave_one_complete_recording() {
    let dir = scratch("outputs", "concurrent");
    let args = [
        "run",
        "whitworth-crank-pi",
        "--duration",
        "3",
        "--out",
        "same.rrd",
    ];
    let children: Vec<_> = (0..2)
        .map(|_| {
            twin(&args, &dir)
                .stdout(Stdio::null())
                .stderr(Stdio::piped())
                .spawn()
                .unwrap()
        })
        .collect();
    for child in children {
        let output = child.wait_with_output().unwrap();
        assert!(
            output.status.success(),
            "{}",
            String::from_utf8_lossy(&output.stderr)
        );
    }
    verify(&dir.join("same.rrd"));
    assert!(parts(&dir).is_empty(), "{:?}", parts(&dir));
}

#[test]
fn a_missing_live_viewer_costs_neither_the_file_nor_the_run() {
    let dir = scratch("outputs", "connect");
    // A port nobody listens on: bound, then released.
    let port = std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    let url = format!("rerun+http://127.0.0.1:{port}/proxy");
    let start = Instant::now();
    let output = finished(&mut twin(
        &[
            "run",
            "whitworth-crank-pi",
            "--duration",
            "1",
            "--connect",
            &url,
        ],
        &dir,
    ));
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stderr}");
    assert!(stderr.starts_with("warning: live viewer"), "{stderr}");
    assert!(
        stderr.contains("the recording file is complete"),
        "{stderr}"
    );
    assert!(start.elapsed() < Duration::from_secs(30));
    verify(&dir.join("whitworth-crank-pi.rrd"));
    assert!(parts(&dir).is_empty());
}

#[test]
fn a_failing_write_stops_the_run_at_once_with_the_os_reason() {
    let dir = scratch("outputs", "full");
    // A 1 MiB file-size limit stands in for a full disk: writes fail with EFBIG.
    let binary = env!("CARGO_BIN_EXE_twin");
    let script = format!(
        "ulimit -f 2048; exec {binary} run whitworth-crank-pi --duration 600 --summary s.json"
    );
    let start = Instant::now();
    let output = finished(Command::new("sh").args(["-c", &script]).current_dir(&dir));
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("File too large"), "{stderr}");
    assert_eq!(common::error_lines(stderr.trim()), 1, "{stderr}");
    // 600 s of simulation would take minutes: the run stopped at the failure.
    assert!(start.elapsed() < Duration::from_secs(60));
    let left: Vec<_> = std::fs::read_dir(&dir).unwrap().collect();
    assert!(left.is_empty(), "nothing may be left: {left:?}");
}

#[test]
fn a_killed_runs_part_file_is_salvaged_into_a_verified_recording() {
    let dir = scratch("outputs", "kill9");
    let mut child = twin(
        &[
            "run",
            "whitworth-crank-pi",
            "--duration",
            "5000",
            "--out",
            "run.rrd",
        ],
        &dir,
    )
    .stdout(Stdio::null())
    .stderr(Stdio::null())
    .spawn()
    .unwrap();
    std::thread::sleep(Duration::from_millis(2500));
    child.kill().unwrap();
    child.wait().unwrap();
    let left = parts(&dir);
    assert_eq!(left.len(), 1, "{left:?}");
    assert!(left[0].starts_with("run.rrd.") && left[0].ends_with(".part"));
    let output = finished(&mut twin(&["salvage", &left[0]], &dir));
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    assert!(stdout.contains("s of simulated time"), "{stdout}");
    assert!(stdout.contains("into run.rrd"), "{stdout}");
    verify(&dir.join("run.rrd"));
    // A second salvage does not overwrite the first.
    let again = finished(&mut twin(&["salvage", &left[0]], &dir));
    assert_eq!(again.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&again.stderr).contains("exists"));
}
