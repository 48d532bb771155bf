//! A URDF published for another tool, run unmodified on the generic machine: Drake's own
//! `Acrobot.urdf`, from the `drake` wheel on PyPI. It turns about y in a z-up world, welds its
//! base to an undeclared `world`, offsets its joints along their axis, marks a hand with a
//! `<frame>` and drives its elbow through a `<transmission>` with no `hardwareInterface`. The
//! twin lays it onto its plane and is held to Drake's own simulation of it (pydrake
//! `MultibodyPlant`, scripts/drake_acrobot.py): swinging free, and with its elbow driven.
//! Needs `eval "$(scripts/test-tools)"` (`TWIN_TOOLS_PYTHON`, with Drake); scripts/test provides
//! it.

mod common;

use common::{columns, scratch, tools_python, twin};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn ok(output: &Output) -> String {
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stderr}");
    String::from_utf8_lossy(&output.stdout).into_owned()
}

/// scripts/drake_acrobot.py with `args`, in `dir`.
fn drake(dir: &Path, args: &[&str]) -> String {
    let output = Command::new(tools_python())
        .arg(repo().join("scripts/drake_acrobot.py"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("python runs");
    ok(&output)
}

/// A scenario in `dir` on the wheel's Acrobot.urdf, as it is installed, from shoulder 0.8 rad
/// and elbow −0.5 rad at rest, under `controller` (a TOML table's body).
fn scenario(dir: &Path, controller: &str) -> PathBuf {
    let urdf = drake(dir, &["--where"]);
    let text = format!(
        r#"name = "acrobot"
description = "Drake's Acrobot.urdf, unmodified"
urdf = "{}"
duration = 2.0
dt = 1.0e-3

[controller]
{controller}

[initial.shoulder]
position = 0.8

[initial.elbow]
position = -0.5
"#,
        urdf.trim()
    );
    let path = dir.join("acrobot.toml");
    std::fs::write(&path, text).unwrap();
    path
}

/// The largest difference of the joints' true states between the twin's run and Drake's,
/// and of the elbow's effort.
fn worst(dir: &Path) -> (f64, f64) {
    let (theirs, ours) = (
        columns(&dir.join("drake.csv")),
        columns(&dir.join("twin.csv")),
    );
    let largest = |a: &[f64], b: &[f64]| {
        assert_eq!(a.len(), b.len());
        (a.iter().zip(b)).fold(0.0_f64, |m, (x, y)| m.max((x - y).abs()))
    };
    let mut states: f64 = 0.0;
    for joint in ["shoulder", "elbow"] {
        for state in ["position", "velocity"] {
            let column = format!("{joint}.{state}");
            states = states.max(largest(&theirs[&column], &ours[&format!("true.{column}")]));
        }
    }
    (
        states,
        largest(&theirs["effort.elbow"], &ours["effort.elbow"]),
    )
}

// Measured: 2.3e-10 (free) and 3.1e-10 (elbow driven) on the velocities over 2 s, with Drake's
// error-controlled RK5 at 1e-12 against the twin's RK4 at 1 ms; the elbow's effort to 7.5e-10.

#[test]
fn the_acrobot_swings_free_as_drake_swings_it() {
    let dir = scratch("published-urdf", "free");
    let path = scenario(&dir, r#"name = "passive""#);
    drake(
        &dir,
        &[
            "--initial",
            "shoulder=0.8,0",
            "--initial",
            "elbow=-0.5,0",
            "--duration",
            "2",
            "--out",
            "drake.csv",
        ],
    );
    let output = twin(
        &[
            "run",
            path.to_str().unwrap(),
            "--csv",
            "twin.csv",
            "--out",
            "twin.rrd",
        ],
        &dir,
    );
    ok(&output);
    let (states, _) = worst(&dir);
    assert!(states < 1e-9, "the twin and Drake differ by {states:e}");
    // What the twin read in its own way is said, naming the element.
    let stderr = String::from_utf8_lossy(&output.stderr);
    for note in [
        "joint \"base_weld\" welds link \"base_link\" to `world`",
        "joint \"shoulder\": its offset of 0.15 m along the joints' axis is left out",
        "<frame> \"hand\" left out",
        "transmission \"elbow_trans\" drives joint \"elbow\" with no effort limit",
    ] {
        assert!(stderr.contains(note), "`{note}` missing from: {stderr}");
    }
}

#[test]
fn the_acrobot_with_its_elbow_driven_moves_as_drake_moves_it() {
    let dir = scratch("published-urdf", "driven");
    let path = scenario(
        &dir,
        "name = \"joint-pid\"\n\n[controller.params.joints.elbow]\nkp = 20.0\nki = 0.0\nkd = 2.0\ntarget = 0.4",
    );
    drake(
        &dir,
        &[
            "--initial",
            "shoulder=0.8,0",
            "--initial",
            "elbow=-0.5,0",
            "--pd",
            "elbow=20,2,0.4",
            "--duration",
            "2",
            "--out",
            "drake.csv",
        ],
    );
    ok(&twin(
        &[
            "run",
            path.to_str().unwrap(),
            "--csv",
            "twin.csv",
            "--out",
            "twin.rrd",
        ],
        &dir,
    ));
    let (states, effort) = worst(&dir);
    assert!(states < 1e-9, "the twin and Drake differ by {states:e}");
    assert!(
        effort < 1e-8,
        "the elbow's efforts differ by {effort:e} N·m"
    );
}
