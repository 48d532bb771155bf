//! Helpers shared by the binary's tests (each test file uses some of them).
#![allow(dead_code)]

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// Longest any command of these tests may take (a debug build on a loaded 2-core machine).
pub const BOUND: Duration = Duration::from_secs(60);

/// Runs `command` to its end with stdout and stderr captured, killing it and failing the test
/// if it outlives [`BOUND`] (a hang is a failure, not a stuck CI).
pub fn finished(command: &mut Command) -> Output {
    finished_within(command, BOUND)
}

/// [`finished`] with its own bound, for commands that run long by design.
pub fn finished_within(command: &mut Command, bound: Duration) -> Output {
    let mut child = command
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the command starts");
    let start = Instant::now();
    while child.try_wait().expect("wait").is_none() {
        if start.elapsed() > bound {
            child.kill().ok();
            let output = child.wait_with_output().expect("output");
            panic!(
                "{command:?} still running after {bound:?}: {}",
                String::from_utf8_lossy(&output.stderr)
            );
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    child.wait_with_output().expect("output")
}

/// `twin ARGS` in `cwd`, run to its end within [`BOUND`].
pub fn twin<S: AsRef<std::ffi::OsStr>>(args: &[S], cwd: &Path) -> Output {
    finished(
        Command::new(env!("CARGO_BIN_EXE_twin"))
            .args(args)
            .current_dir(cwd),
    )
}

/// A fresh folder for one test.
pub fn scratch(group: &str, test: &str) -> Scratch {
    let dir = std::env::temp_dir().join(format!("twin-{group}-{}-{test}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    Scratch(dir)
}

/// A test's folder: removed when it goes out of scope on a passing test, kept when the test
/// fails (it is panicking then) so that what the command wrote can be read.
pub struct Scratch(PathBuf);

impl Drop for Scratch {
    fn drop(&mut self) {
        if !std::thread::panicking() {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}

impl std::ops::Deref for Scratch {
    type Target = Path;
    fn deref(&self) -> &Path {
        &self.0
    }
}

impl AsRef<Path> for Scratch {
    fn as_ref(&self) -> &Path {
        &self.0
    }
}

impl AsRef<std::ffi::OsStr> for Scratch {
    fn as_ref(&self) -> &std::ffi::OsStr {
        self.0.as_os_str()
    }
}

/// `rerun rrd verify` with the CLI `scripts/test-tools` provides; a missing CLI fails the test.
pub fn verify(path: &Path) {
    let cli = std::env::var_os("TWIN_RERUN_CLI").unwrap_or_else(|| "rerun".into());
    let output = Command::new(&cli)
        .args(["rrd", "verify"])
        .arg(path)
        .output()
        .unwrap_or_else(|e| {
            panic!("the Rerun CLI {cli:?} is needed (eval \"$(scripts/test-tools)\"): {e}")
        });
    assert!(
        output.status.success(),
        "rrd verify {}: {}",
        path.display(),
        String::from_utf8_lossy(&output.stderr)
    );
}

/// Temporary files (`*.part`) in `dir`.
pub fn parts(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|f| f.ends_with(".part"))
        .collect()
}

/// The tools' Python (`scripts/test-tools`: asyncua, MuJoCo, …), or a failure saying how to get
/// it.
pub fn tools_python() -> PathBuf {
    match std::env::var_os("TWIN_TOOLS_PYTHON") {
        Some(path) if !path.is_empty() => PathBuf::from(path),
        _ => panic!("TWIN_TOOLS_PYTHON is unset: run eval \"$(scripts/test-tools)\" first"),
    }
}

/// A loopback port nobody listens on now.
pub fn free_port() -> u16 {
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    listener.local_addr().unwrap().port()
}

/// The lines of an error's stderr without its `hint:` line (a usage error's last).
pub fn error_lines(stderr: &str) -> usize {
    stderr.lines().filter(|l| !l.starts_with("hint: ")).count()
}

/// A run CSV's columns by name (without the unit), each a column of numbers.
pub fn columns(path: &Path) -> HashMap<String, Vec<f64>> {
    (cells(path).into_iter())
        .map(|(name, column)| (name, column.iter().map(|c| c.parse().unwrap()).collect()))
        .collect()
}

/// A run CSV's cells by column name (units left off), as written: for comparing bit for bit.
pub fn cells(path: &Path) -> HashMap<String, Vec<String>> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let names: Vec<String> = (lines.next().unwrap().split(','))
        .map(|h| h.split(" [").next().unwrap().to_string())
        .collect();
    let mut table: HashMap<String, Vec<String>> = HashMap::new();
    for line in lines {
        for (name, cell) in names.iter().zip(line.split(',')) {
            table.entry(name.clone()).or_default().push(cell.into());
        }
    }
    table
}
