//! The guide's commands run as written and its figures are their own outputs: `scripts/doc-figures`
//! runs a chapter's shell blocks in order with this build's `twin`, and every output block and
//! every figure its prose quotes must be what they print. Needs the tools of `scripts/test-tools`
//! (MuJoCo plays the calibration chapter's machines, asyncua the live-twin chapter's client);
//! scripts/test provides them.

use std::path::Path;
use std::process::Command;

#[test]
fn the_calibration_and_own_machine_chapters_show_what_their_commands_print() {
    doc_figures(&["docs/src/calibration.md", "docs/src/own-machine.md"]);
}

/// One run, in this order: the README's and the live-twin chapter's servers listen on one port.
#[test]
fn the_readme_the_live_twin_and_the_shadow_chapters_show_what_their_commands_print() {
    doc_figures(&["README.md", "docs/src/live-twin.md", "docs/src/shadow.md"]);
}

/// `scripts/doc-figures` on `chapters` (paths from the checkout), which must pass.
fn doc_figures(chapters: &[&str]) {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let python = std::env::var("TWIN_TOOLS_PYTHON").unwrap_or_else(|_| {
        panic!("TWIN_TOOLS_PYTHON is not set: run `eval \"$(scripts/test-tools)\"` first (scripts/test does)")
    });
    let output = Command::new(&python)
        .arg(repo.join("scripts/doc-figures"))
        .args(chapters)
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
