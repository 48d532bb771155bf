//! The two-wheeled mobile platform end to end: both controllers on both paths, slip and odometry
//! drift on a slippery floor, bad input caught before the run, and the PID grid search.

use controllers::Registry;
use twin::{Overrides, RunSummary, Twin};
use twin_tests::{run, scenario, scratch};

fn metric(summary: &RunSummary, name: &str) -> f64 {
    summary
        .metric(name)
        .unwrap_or_else(|| panic!("metric {name} missing"))
}

/// |odometry − true pose| of H at the end of the run, m.
fn odometry_drift(summary: &RunSummary) -> f64 {
    (metric(summary, "controller_final/odometry.x_h") - metric(summary, "final_x_h"))
        .hypot(metric(summary, "controller_final/odometry.y_h") - metric(summary, "final_y_h"))
}

fn run_with(name: &str, controller: Option<&str>, set: &[&str]) -> RunSummary {
    let loaded = twin::load_scenario(
        name,
        &Overrides {
            controller: controller.map(String::from),
            set: set.iter().map(|s| s.to_string()).collect(),
            ..Default::default()
        },
    )
    .unwrap_or_else(|e| panic!("{e}"));
    run(loaded, None)
}

#[test]
fn both_controllers_follow_both_paths() {
    for path in ["platform-path", "platform-path-s"] {
        let optimal = run(scenario(path, &[]), None);
        let pid = run_with(path, Some("pid"), &[]);
        for summary in [&optimal, &pid] {
            assert!(summary.failure.is_none(), "{:?}", summary.failure);
            assert!(metric(summary, "path_error_rms") < 2e-3);
            assert!(metric(summary, "final_position_error") < 5e-3);
        }
        let final_heading = metric(&optimal, "heading_error_final").abs().to_degrees();
        assert!(final_heading < 0.5, "{path}: final Δβ = {final_heading}°");
        println!(
            "{path}: RMS path error energy-optimal {:.3e} m, pid {:.3e} m, ratio {:.3}",
            metric(&optimal, "path_error_rms"),
            metric(&pid, "path_error_rms"),
            metric(&optimal, "path_error_rms") / metric(&pid, "path_error_rms")
        );
    }
}

#[test]
fn a_slippery_floor_makes_the_wheels_slip_and_the_odometry_drift() {
    let grip = run_with("platform-path", None, &["duration=14"]);
    let slippery = run_with(
        "platform-path",
        None,
        &["duration=14", "process.friction=0.05"],
    );
    let (slip_grip, slip_low) = (
        metric(&grip, "wheel_slip_max"),
        metric(&slippery, "wheel_slip_max"),
    );
    let (drift_grip, drift_low) = (odometry_drift(&grip), odometry_drift(&slippery));
    assert!(slip_low > 5.0 * slip_grip, "slip {slip_grip} → {slip_low}");
    assert!(
        drift_low > 2.0 * drift_grip,
        "drift {drift_grip} → {drift_low}"
    );
}

#[test]
fn bad_paths_are_errors_before_the_run() {
    for (set, expected) in [
        (
            r#"process.path.segments=[{kind="straight", length=-0.5}]"#,
            "length must be",
        ),
        (
            r#"process.path.segments=[{kind="curve", radius=0.0, clothoid_length=0.3, arc_length=0.5}]"#,
            "radius must be",
        ),
        ("process.friction=0", "friction must be > 0"),
    ] {
        let loaded = scenario("platform-path", &[set]);
        let err = Twin::new(loaded, &Registry::builtin())
            .err()
            .unwrap_or_else(|| panic!("{set} must be rejected"));
        assert!(err.to_string().contains(expected), "{err}");
    }
}

#[test]
fn a_user_urdf_with_a_bad_wheel_is_an_error_before_the_run() {
    let dir = scratch("platform-bad-wheel");
    let urdf = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../urdf/platform.urdf"
    ))
    .unwrap();
    let scenario_text = twin::scenario::BUILTIN
        .iter()
        .find(|(name, _)| *name == "platform-path")
        .unwrap()
        .1;
    std::fs::write(dir.join("scenario.toml"), scenario_text).unwrap();
    std::fs::create_dir_all(dir.join("urdf")).unwrap();
    for (from, to, expected) in [
        (
            r#"radius="0.04""#,
            r#"radius="-0.04""#,
            "radius must be > 0",
        ),
        (r#"axis="0 1 0""#, r#"axis="0 0.6 0.8""#, "not planar"),
    ] {
        std::fs::write(dir.join("urdf/platform.urdf"), urdf.replacen(from, to, 1)).unwrap();
        let loaded = twin::load_scenario(
            dir.join("scenario.toml").to_str().unwrap(),
            &Overrides::default(),
        )
        .unwrap();
        let err = Twin::new(loaded, &Registry::builtin()).err().unwrap();
        assert!(err.to_string().contains(expected), "{err}");
        assert!(err.to_string().contains("left_wheel"), "{err}");
    }
}

/// The PID's tuning: every combination of the grid on the Fig. 7 path, ranked by RMS path error
/// of H. Run with
/// `cargo test --release -p twin-tests --test platform -- --ignored --nocapture pid_grid_search`.
#[test]
#[ignore]
fn pid_grid_search() {
    let mut rows = Vec::new();
    for kp_v in [60.0, 120.0, 240.0] {
        for kp_w in [1.0, 2.0, 4.0] {
            for integral_time in [f64::INFINITY, 0.5, 0.1] {
                let (ki_v, ki_w) = (kp_v / integral_time, kp_w / integral_time);
                let set = [
                    format!("controller.params.kp_v={kp_v}"),
                    format!("controller.params.kp_w={kp_w}"),
                    format!("controller.params.ki_v={ki_v}"),
                    format!("controller.params.ki_w={ki_w}"),
                ];
                let set: Vec<&str> = set.iter().map(String::as_str).collect();
                let summary = run_with("platform-path", Some("pid"), &set);
                let score = if summary.failure.is_some() {
                    f64::INFINITY
                } else {
                    metric(&summary, "path_error_rms")
                };
                rows.push((
                    score,
                    kp_v,
                    kp_w,
                    integral_time,
                    metric(&summary, "heading_error_final"),
                    metric(&summary, "wheel_slip_max"),
                ));
            }
        }
    }
    rows.sort_by(|a, b| a.0.total_cmp(&b.0));
    println!("kp_v N·s/m  kp_w N·m·s  T_i s  RMS path error m  final Δβ rad  peak slip");
    for (score, kp_v, kp_w, ti, heading, slip) in &rows {
        println!("{kp_v:>10} {kp_w:>10} {ti:>6} {score:>17.4e} {heading:>13.3e} {slip:>10.3e}");
    }
}
