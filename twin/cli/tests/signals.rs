//! SIGINT and SIGTERM stop a run cleanly: the recording is finished (it verifies), the summary
//! says `interrupted` and where, and the exit code is 128 + the signal.

mod common;

use common::{parts, scratch, verify};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

fn interrupt_with(signal: &str, code: i32) {
    let dir = scratch("signals", signal);
    let mut child = Command::new(env!("CARGO_BIN_EXE_twin"))
        .args(["run", "whitworth-crank-pi", "--duration", "5000"])
        .args(["--summary", "s.json", "--out", "run.rrd"])
        .current_dir(&dir)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Let it get well into stepping (its temporary recording exists from the start).
    std::thread::sleep(Duration::from_millis(1500));
    assert!(child.try_wait().unwrap().is_none(), "the run ended early");
    let sent = Command::new("kill")
        .args([&format!("-{signal}"), &child.id().to_string()])
        .status()
        .unwrap();
    assert!(sent.success());
    let start = Instant::now();
    while child.try_wait().unwrap().is_none() {
        assert!(
            start.elapsed() < Duration::from_secs(30),
            "no stop after {signal}"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    let output = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(code), "{stderr}");
    assert!(
        stderr.contains(&format!("interrupted by {signal}")),
        "{stderr}"
    );
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("s.json")).unwrap()).unwrap();
    assert_eq!(summary["status"], "interrupted");
    let reached = summary["time_reached"].as_f64().unwrap();
    assert!(reached > 0.0 && reached < 5000.0, "{reached}");
    verify(&dir.join("run.rrd"));
    assert!(parts(&dir).is_empty(), "{:?}", parts(&dir));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn sigint_finishes_the_recording_and_exits_130() {
    interrupt_with("SIGINT", 130);
}

#[test]
fn sigterm_finishes_the_recording_and_exits_143() {
    interrupt_with("SIGTERM", 143);
}
