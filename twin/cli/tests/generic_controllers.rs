//! The controllers for any mechanism beyond `joint-pid`, on the shipped examples through the
//! `twin` binary: `replay` reproducing a run from its own efforts, `computed-torque` tracking a
//! quintic waypoint move on the double pendulum and quintic moves through the five-bar's loop,
//! `lqr` balancing the cart-pole's pole upright and moving the five-bar through its loop.

mod common;

use common::{cells, columns, scratch, twin};
use std::path::{Path, PathBuf};

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// A shipped example's scenario file, `examples/<example>/<file>.toml`.
fn scenario(example: &str, file: &str) -> String {
    let path = repo().join(format!("examples/{example}/{file}.toml"));
    path.to_string_lossy().into_owned()
}

fn ok(output: &std::process::Output) -> String {
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stderr}");
    String::from_utf8_lossy(&output.stdout).into_owned()
}

fn refused(output: &std::process::Output) -> String {
    assert!(!output.status.success(), "ran, and should not have");
    String::from_utf8_lossy(&output.stderr).into_owned()
}

#[test]
fn replaying_a_runs_own_efforts_reproduces_it_bit_for_bit() {
    let dir = scratch("generic-controllers", "replay");
    let logged = dir.join("logged.csv").to_string_lossy().into_owned();
    let pid = scenario("double-pendulum", "double-pendulum");
    ok(&twin(
        &["run", &pid, "--csv", &logged, "--out", "pid.rrd"],
        &dir,
    ));
    let file = format!("controller.params.file=\"{logged}\"");
    let replay = scenario("double-pendulum", "replay");
    let run = [
        "run",
        &replay,
        "--set",
        &file,
        "--csv",
        "replayed.csv",
        "--out",
        "replay.rrd",
    ];
    ok(&twin(&run, &dir));
    let (a, b) = (
        cells(&dir.join("logged.csv")),
        cells(&dir.join("replayed.csv")),
    );
    assert_eq!(a["time"], b["time"]);
    let mut compared = 0;
    for (name, column) in &a {
        if name.starts_with("true.") || name.starts_with("effort.") {
            assert_eq!(column, &b[name], "{name}");
            compared += 1;
        }
    }
    // Two efforts and every true signal (the joints' and the tip's), 4001 rows each (0 to 4 s).
    assert!(compared >= 2 + 8 && a["time"].len() == 4001, "{compared}");
}

#[test]
fn a_replay_names_the_file_row_and_column_it_cannot_take() {
    let dir = scratch("generic-controllers", "replay-refusals");
    let replay = scenario("double-pendulum", "replay");
    let write = |name: &str, text: &str| {
        std::fs::write(dir.join(name), text).unwrap();
        format!("controller.params.file=\"{}\"", dir.join(name).display())
    };
    let header = "time [s],effort.shoulder [N·m],effort.elbow [N·m]\n";
    let cases = [
        (
            write("cell.csv", &format!("{header}0,1,2\n0.001,1,x\n")),
            "row 3, column \"effort.elbow [N·m]\"",
        ),
        (
            write(
                "unit.csv",
                "time [s],effort.shoulder [N],effort.elbow [N·m]\n0,1,2\n0.001,1,2\n",
            ),
            "column \"effort.shoulder [N]\"",
        ),
        (
            write(
                "missing.csv",
                "time [s],effort.shoulder [N·m]\n0,1\n0.001,1\n",
            ),
            "no column \"effort.elbow [N·m]\"",
        ),
    ];
    for (set, expected) in cases {
        let stderr = refused(&twin(
            &["run", &replay, "--set", &set, "--out", "x.rrd"],
            &dir,
        ));
        assert!(stderr.contains(expected), "{stderr}");
        assert!(
            stderr.contains("controller.params.file") || stderr.contains("params.file"),
            "{stderr}"
        );
        assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    }
}

/// The rest-to-rest quintic through `points` ([time, position]) at `t`, written out here apart
/// from the twin's.
fn quintic(points: &[[f64; 2]], t: f64) -> f64 {
    let (first, last) = (points[0], points[points.len() - 1]);
    if t <= first[0] {
        return first[1];
    }
    if t >= last[0] {
        return last[1];
    }
    let k = points
        .windows(2)
        .position(|w| w[0][0] <= t && t < w[1][0])
        .unwrap();
    let ([t0, p0], [t1, p1]) = (points[k], points[k + 1]);
    let u = (t - t0) / (t1 - t0);
    p0 + (p1 - p0) * u.powi(3) * (10.0 - 15.0 * u + 6.0 * u * u)
}

// Measured (debug build): the largest true error over the 4 s, shoulder 2.8e-4 rad, elbow
// 3.2e-4 rad (a fifth of an encoder count), peak torques 2.9 and 0.6 N·m.

#[test]
fn computed_torque_tracks_a_quintic_waypoint_move_on_the_double_pendulum() {
    let dir = scratch("generic-controllers", "computed-torque");
    let ct = scenario("double-pendulum", "computed-torque");
    ok(&twin(
        &["run", &ct, "--csv", "run.csv", "--out", "run.rrd"],
        &dir,
    ));
    let table = columns(&dir.join("run.csv"));
    let moves: [(&str, &[[f64; 2]]); 2] = [
        (
            "shoulder",
            &[[0.0, 0.0], [1.0, 0.8], [2.5, -0.4], [3.5, 0.0]],
        ),
        ("elbow", &[[0.0, 0.0], [1.5, -0.9], [3.0, 0.5]]),
    ];
    // Within 1 mrad (two thirds of an encoder count) all along the move.
    for (joint, points) in moves {
        let positions = &table[&format!("true.{joint}.position")];
        let worst = (table["time"].iter().zip(positions))
            .map(|(&t, &q)| (q - quintic(points, t)).abs())
            .fold(0.0, f64::max);
        assert!(worst < 1e-3, "{joint}: {worst} rad");
    }
    // An underactuated mechanism is refused by name.
    let cart = scenario("cart-pole", "cart-pole");
    let set = [
        "--controller",
        "computed-torque",
        "--set",
        "controller.params.joints.cart.kp=1.0",
        "--set",
        "controller.params.joints.pole.kp=1.0",
    ];
    let args: Vec<&str> = ["run", &cart]
        .into_iter()
        .chain(set)
        .chain(["--out", "x.rrd"])
        .collect();
    let stderr = refused(&twin(&args, &dir));
    assert!(stderr.contains("actuator on joint `pole`"), "{stderr}");
}

// Measured (debug build): from 0.15 rad off upright, the pole within 1.2e-4 rad of upright and
// the cart within 1.7 mm of 0 over the last second; the cart travels 0.115 m, its force peaks
// at 28 N (40 N allowed).

#[test]
fn lqr_balances_the_cart_poles_pole_upright() {
    let dir = scratch("generic-controllers", "lqr");
    let balance = scenario("cart-pole", "balance");
    let stdout = ok(&twin(
        &["run", &balance, "--csv", "run.csv", "--out", "run.rrd"],
        &dir,
    ));
    assert!(
        stdout.contains("status                       ok"),
        "{stdout}"
    );
    let table = columns(&dir.join("run.csv"));
    let (pole, cart) = (&table["true.pole.position"], &table["true.cart.position"]);
    let upright = std::f64::consts::PI;
    for &q in &pole[pole.len() - 1000..] {
        assert!((q - upright).abs() < 1e-3, "pole at {q}");
    }
    for &x in &cart[cart.len() - 1000..] {
        assert!(x.abs() < 5e-3, "cart at {x}");
    }
    assert!(pole.iter().all(|q| (q - upright).abs() <= 0.15 + 1e-12));
    // The same start, no control: the pole falls.
    let passive = [
        "run",
        &balance,
        "--controller",
        "passive",
        "--csv",
        "free.csv",
        "--out",
        "free.rrd",
    ];
    ok(&twin(&passive, &dir));
    let free = columns(&dir.join("free.csv"));
    let fallen = free["true.pole.position"]
        .iter()
        .map(|q| (q - upright).abs())
        .fold(0.0, f64::max);
    assert!(fallen > 1.0, "{fallen}");
    // A point no effort can hold (the pole leaning) is refused by name.
    let leaning = [
        "run",
        &balance,
        "--set",
        "controller.params.joints.pole.target=2.0",
        "--out",
        "x.rrd",
    ];
    let stderr = refused(&twin(&leaning, &dir));
    assert!(
        stderr.contains("no equilibrium the actuators can hold"),
        "{stderr}"
    );
}

/// A run summary's metric `key`.
fn metric(dir: &Path, summary: &str, key: &str) -> f64 {
    let text = std::fs::read_to_string(dir.join(summary)).unwrap();
    let json: serde_json::Value = serde_json::from_str(&text).unwrap();
    json["metrics"][key]
        .as_f64()
        .unwrap_or_else(|| panic!("{summary}: no metric {key}"))
}

// Measured (release): each crank within 0.10 mrad of its quintic all along the move (the
// double pendulum's tree, with no encoders: 0.09 / 0.31 mrad), the loop closed to 1e-12 m.

#[test]
fn computed_torque_tracks_quintic_moves_through_the_five_bars_loop() {
    let dir = scratch("generic-controllers", "computed-torque-loop");
    let ct = scenario("five-bar", "computed-torque");
    let args = ["run", &ct, "--csv", "run.csv", "--summary", "run.json"];
    ok(&twin(&[&args[..], &["--out", "run.rrd"]].concat(), &dir));
    let table = columns(&dir.join("run.csv"));
    let moves: [(&str, &[[f64; 2]]); 2] = [
        ("left", &[[0.0, 0.0], [1.0, 0.4], [2.0, 0.2]]),
        ("right", &[[0.0, 0.0], [1.2, -0.4], [2.2, -0.1]]),
    ];
    for (joint, points) in moves {
        let positions = &table[&format!("true.{joint}.position")];
        let worst = (table["time"].iter().zip(positions))
            .map(|(&t, &q)| (q - quintic(points, t)).abs())
            .fold(0.0, f64::max);
        assert!(worst < 3e-4, "{joint}: {worst} rad");
    }
    let closure = metric(&dir, "run.json", "loop_closure_error_max");
    assert!(closure <= 1e-12, "loop closed to {closure} m");
}

// Measured (release): the cranks start at ±0.2 rad exactly (the elbows placed to close the loop
// there) and end within 2e-14 rad of ±0.4, holding 0.800964 N·m; joint-pid's integrator finds
// 0.800990 N·m after 10 s, still 1.6e-5 rad off its target.

#[test]
fn lqr_moves_the_five_bar_through_its_loop_and_holds_it_with_the_static_torques() {
    let dir = scratch("generic-controllers", "lqr-loop");
    let lqr = scenario("five-bar", "lqr");
    let args = ["run", &lqr, "--csv", "run.csv", "--summary", "run.json"];
    ok(&twin(&[&args[..], &["--out", "run.rrd"]].concat(), &dir));
    let table = columns(&dir.join("run.csv"));
    // The scenario's starting crank angles are where it starts: only the elbows moved to
    // close the loop.
    assert_eq!(table["true.left.position"][0], 0.2);
    assert_eq!(table["true.right.position"][0], -0.2);
    let last = table["time"].len() - 1;
    for (joint, target) in [("left", 0.4), ("right", -0.4)] {
        let q = table[&format!("true.{joint}.position")][last];
        assert!((q - target).abs() < 1e-9, "{joint} at {q}");
    }
    let closure = metric(&dir, "run.json", "loop_closure_error_max");
    assert!(closure <= 1e-12, "loop closed to {closure} m");
    // joint-pid's integrator, given time, finds the same holding torques.
    let pid = scenario("five-bar", "five-bar");
    let args = ["run", &pid, "--duration", "10", "--csv", "pid.csv"];
    ok(&twin(&[&args[..], &["--out", "pid.rrd"]].concat(), &dir));
    let held = columns(&dir.join("pid.csv"));
    for joint in ["left", "right"] {
        let column = format!("effort.{joint}");
        let (lqr, pid) = (table[&column][last], *held[&column].last().unwrap());
        assert!(
            (lqr - pid).abs() < 1e-4,
            "{joint}: lqr {lqr}, joint-pid {pid} N·m"
        );
    }
}

/// How far the double pendulum's tip is from the path of point.toml and
/// point-computed-torque.toml (x a quintic sweep through waypoints, y held at −0.45 m) in the
/// run CSV at `path`, from 1 s on: (time, along x, along y), s and m.
fn tip_offsets(path: &Path) -> Vec<(f64, f64, f64)> {
    let table = columns(path);
    let sweep = [
        [0.0, 0.0],
        [1.0, 0.0],
        [2.0, 0.15],
        [3.0, -0.15],
        [4.0, 0.0],
    ];
    (table["time"].iter().enumerate())
        .filter(|(_, &t)| t >= 1.0)
        .map(|(k, &t)| {
            let (x, y) = (table["true.tip.x"][k], table["true.tip.y"][k]);
            (t, x - quintic(&sweep, t), y + 0.45)
        })
        .collect()
}

// Measured (release): the inverse kinematics reaches the path at every update (1e-16 m left);
// from 1 s, with joint-pid's gains and no feed-forward, the tip within 5.5 mm of the path along
// x and 2.8 mm along y.

#[test]
fn joint_pid_moves_the_double_pendulums_tip_along_a_path_in_the_plane() {
    let dir = scratch("generic-controllers", "point");
    let point = scenario("double-pendulum", "point");
    let args = ["run", &point, "--csv", "run.csv", "--summary", "run.json"];
    ok(&twin(&[&args[..], &["--out", "run.rrd"]].concat(), &dir));
    let reach = metric(&dir, "run.json", "controller_final/tip.reach");
    assert!(reach < 1e-9, "the tip's path left {reach} m out of reach");
    for (t, x, y) in tip_offsets(&dir.join("run.csv")) {
        let off = x.hypot(y);
        assert!(off < 0.01, "at {t} s the tip is {off} m off its path");
    }
    // A joint the point moves takes no target; a point the scenario lacks is named.
    let set = ["--set", "controller.params.joints.elbow.target=0.2"];
    let stderr = refused(&twin(
        &[&["run", &point][..], &set, &["--out", "x.rrd"]].concat(),
        &dir,
    ));
    assert!(stderr.contains("joints.elbow.target"), "{stderr}");
    let text = std::fs::read_to_string(&point).unwrap();
    let folder = Path::new(&point).parent().unwrap();
    std::fs::copy(
        folder.join("double_pendulum.urdf"),
        dir.join("double_pendulum.urdf"),
    )
    .unwrap();
    let renamed = text.replace(
        "[controller.params.points.tip]",
        "[controller.params.points.nib]",
    );
    std::fs::write(dir.join("nib.toml"), renamed).unwrap();
    let stderr = refused(&twin(&["run", "nib.toml", "--out", "x.rrd"], &dir));
    assert!(
        stderr.contains("points.nib") && stderr.contains("no point `nib`"),
        "{stderr}"
    );
}

// Measured (release): the tip within 0.095 mm of the path along x and 0.057 mm along y from 1 s
// (joint-pid on the same path: 5.5 and 2.8 mm); without the encoders, 14 and 5 µm.

#[test]
fn computed_torque_moves_the_double_pendulums_tip_along_a_path_through_its_inverse_dynamics() {
    let dir = scratch("generic-controllers", "point-computed-torque");
    let point = scenario("double-pendulum", "point-computed-torque");
    let args = ["run", &point, "--csv", "run.csv", "--summary", "run.json"];
    ok(&twin(&[&args[..], &["--out", "run.rrd"]].concat(), &dir));
    let reach = metric(&dir, "run.json", "controller_final/tip.reach");
    assert!(reach < 1e-9, "the tip's path left {reach} m out of reach");
    for (t, x, y) in tip_offsets(&dir.join("run.csv")) {
        let off = x.abs().max(y.abs());
        assert!(off < 2e-4, "at {t} s the tip is {off} m off its path");
    }
    // A joint the point moves takes no target, as with joint-pid.
    let set = ["--set", "controller.params.joints.elbow.target=0.2"];
    let stderr = refused(&twin(
        &[&["run", &point][..], &set, &["--out", "x.rrd"]].concat(),
        &dir,
    ));
    assert!(stderr.contains("joints.elbow.target"), "{stderr}");
}

// Measured (release): from 1 s, the five-bar's end point within 0.26 mm of its path along x
// and 0.13 mm along y (lqr has no feed-forward and keeps the gains of the path's first point),
// its efforts at most 2.8 N·m; the path's first point solved from [initial] to 1e-16 m.

#[test]
fn lqr_moves_the_five_bars_end_point_along_a_path_through_the_closed_loop() {
    let dir = scratch("generic-controllers", "point-lqr");
    let point = scenario("five-bar", "point-lqr");
    let args = ["run", &point, "--csv", "run.csv", "--summary", "run.json"];
    ok(&twin(&[&args[..], &["--out", "run.rrd"]].concat(), &dir));
    let reach = metric(&dir, "run.json", "controller_final/end.reach");
    assert!(
        reach < 1e-9,
        "the end point's path left {reach} m out of reach"
    );
    let table = columns(&dir.join("run.csv"));
    let sweep = [
        [0.0, 0.0],
        [1.0, 0.0],
        [2.0, 0.05],
        [3.0, -0.05],
        [4.0, 0.0],
    ];
    for (k, &t) in table["time"].iter().enumerate().filter(|(_, &t)| t >= 1.0) {
        let x = table["true.end.x"][k] - quintic(&sweep, t);
        let y = table["true.end.y"][k] - 0.44;
        assert!(
            x.abs() < 5e-4 && y.abs() < 3e-4,
            "at {t} s the end point is ({x}, {y}) m off its path"
        );
    }
    // A path that starts out of the mechanism's reach is refused before the run, by its table.
    let set = [
        "--set",
        "controller.params.points.end.y.points=[[0.0, 2.0], [1.0, 0.44]]",
    ];
    let stderr = refused(&twin(
        &[&["run", &point][..], &set, &["--out", "x.rrd"]].concat(),
        &dir,
    ));
    assert!(
        stderr.contains("points") && stderr.contains("out of reach"),
        "{stderr}"
    );
}

/// An `[initial]` state the loop cannot close as given (every joint of the five-bar named, the
/// elbows where the cranks cannot meet) is not silently moved: the run starts from the nearest
/// closed configuration and says so in a note naming the joints.
#[test]
fn an_initial_state_the_loop_cannot_hold_is_said_in_a_note() {
    let dir = scratch("generic-controllers", "initial-unheld");
    let lqr = scenario("five-bar", "lqr");
    let folder = Path::new(&lqr).parent().unwrap();
    std::fs::copy(folder.join("five_bar.urdf"), dir.join("five_bar.urdf")).unwrap();
    let elbows = "[initial.left_elbow]\nposition = 2.5\nvelocity = 0.0\n\n\
                  [initial.right_elbow]\nposition = -2.5\nvelocity = 0.0\n\n[initial.right]";
    let text = std::fs::read_to_string(&lqr).unwrap();
    std::fs::write(
        dir.join("all.toml"),
        text.replacen("[initial.right]", elbows, 1),
    )
    .unwrap();
    let output = twin(
        &["run", "all.toml", "--duration", "0.1", "--out", "x.rrd"],
        &dir,
    );
    ok(&output);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        stderr.contains(
            "[initial]: the loops cannot close with left, left_elbow, right, right_elbow"
        ),
        "{stderr}"
    );
    // Given as the example gives it (the cranks only), no note.
    let output = twin(&["run", &lqr, "--duration", "0.1", "--out", "y.rrd"], &dir);
    ok(&output);
    assert!(!String::from_utf8_lossy(&output.stderr).contains("[initial]"));
}
