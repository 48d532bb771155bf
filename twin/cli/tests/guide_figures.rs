//! The calibration chapter's figures are its commands' own outputs: `scripts/doc-figures` runs
//! the chapter's shell blocks in order with this build's `twin`, and every output block and every
//! figure its prose quotes must be what they print. Needs the tools of `scripts/test-tools`
//! (MuJoCo plays the chapter's machines); scripts/test provides them.

use std::path::Path;
use std::process::Command;

#[test]
fn the_calibration_chapter_shows_what_its_commands_print() {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let python = std::env::var("TWIN_TOOLS_PYTHON").unwrap_or_else(|_| {
        panic!("TWIN_TOOLS_PYTHON is not set: run `eval \"$(scripts/test-tools)\"` first (scripts/test does)")
    });
    let output = Command::new(&python)
        .arg(repo.join("scripts/doc-figures"))
        .arg("docs/src/calibration.md")
        .env("TWIN", env!("CARGO_BIN_EXE_twin"))
        .current_dir(&repo)
        .output()
        .unwrap_or_else(|e| panic!("{python}: {e}"));
    assert!(
        output.status.success(),
        "{}\n{}",
        String::from_utf8_lossy(&output.stdout),
        String::from_utf8_lossy(&output.stderr)
    );
}
