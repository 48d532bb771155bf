//! Helpers shared by the binary's tests.

use std::path::{Path, PathBuf};
use std::process::Command;

/// A fresh folder for one test.
pub fn scratch(group: &str, test: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("twin-{group}-{}-{test}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
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
