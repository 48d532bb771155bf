//! Every URDF the twin ships is a URDF other tools read: ROS's parser (`check_urdf`, urdfdom)
//! and MuJoCo's loader, which also rejects physically impossible inertia tensors. The twin's
//! extensions (`<loop_joint>`, `<wheel>`, `<spring>`) are elements both ignore.
//!
//! The tools come from `scripts/test-tools` (`scripts/test`, the README's test command, runs it);
//! a missing tool fails the test, it is not skipped.

use std::path::{Path, PathBuf};
use std::process::Command;

fn shipped_urdfs() -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir("../urdf")
        .expect("the urdf folder")
        .map(|entry| entry.expect("entry").path().canonicalize().expect("a path"))
        .filter(|path| path.extension().is_some_and(|e| e == "urdf"))
        .collect();
    files.sort();
    assert!(files.len() >= 5, "{files:?}");
    files
}

fn tool(command: &mut Command, what: &str) -> std::process::Output {
    command.output().unwrap_or_else(|e| {
        panic!("{what} is not installed ({e}): run `eval \"$(scripts/test-tools)\"` first")
    })
}

#[test]
fn every_shipped_urdf_passes_check_urdf() {
    for file in shipped_urdfs() {
        let out = tool(Command::new("check_urdf").arg(&file), "check_urdf");
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(
            out.status.success() && text.contains("Successfully Parsed"),
            "check_urdf {}:\n{text}\n{}",
            file.display(),
            String::from_utf8_lossy(&out.stderr)
        );
    }
}

/// Loads each file in MuJoCo and prints its body and joint counts.
const MUJOCO_LOAD: &str = r#"
import sys, mujoco
for path in sys.argv[1:]:
    model = mujoco.MjModel.from_xml_path(path)
    print(path, model.nbody, model.njnt)
"#;

#[test]
fn every_shipped_urdf_loads_in_mujoco_with_the_same_tree() {
    let python = std::env::var_os("TWIN_TOOLS_PYTHON").unwrap_or_else(|| "python3".into());
    let files = shipped_urdfs();
    // MuJoCo writes its warnings to MUJOCO_LOG.TXT in the working folder: keep it out of the tree.
    let scratch = twin_tests::scratch("mujoco");
    let out = tool(
        Command::new(&python)
            .current_dir(&scratch)
            .arg("-c")
            .arg(MUJOCO_LOAD)
            .args(&files),
        "MuJoCo (PyPI mujoco)",
    );
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "MuJoCo rejected a URDF:\n{text}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for (file, line) in files.iter().zip(text.lines()) {
        let mechanism =
            twin::engine::load_urdf_file(Path::new(file)).unwrap_or_else(|e| panic!("{e}"));
        // MuJoCo counts its world body; fixed joints merge bodies there, so compare movable ones.
        let counts: Vec<usize> = line
            .split_whitespace()
            .skip(1)
            .map(|n| n.parse().expect("a count"))
            .collect();
        let movable = mechanism
            .joints
            .iter()
            .filter(|j| j.motion.is_movable())
            .count();
        println!(
            "{}: MuJoCo {} bodies, {} joints; twin {} links, {movable} movable joints",
            file.display(),
            counts[0],
            counts[1],
            mechanism.links.len()
        );
        assert_eq!(counts[1], movable, "{}: joints", file.display());
    }
}
