//! The two-wheeled mobile platform end to end: both controllers on both paths, slip and odometry
//! drift on a slippery floor, bad input caught before the run, and the PID grid search.

use twin::{RunSummary, Scenario, ScenarioBuilder, ScenarioValue, Twin};
use twin_tests::{builtin, run, scratch, Configure};

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

fn run_built(builder: ScenarioBuilder) -> RunSummary {
    run(builder.loaded(), None)
}

#[test]
fn both_controllers_follow_both_paths() {
    for path in ["platform-path", "platform-path-s"] {
        let optimal = run_built(builtin(path));
        let pid = run_built(builtin(path).controller("pid"));
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
    let grip = run_built(builtin("platform-path").duration(14.0));
    let slippery = run_built(
        builtin("platform-path")
            .duration(14.0)
            .with("process.friction", 0.05),
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

/// A path given as one segment of `kind` with these lengths, m.
fn one_segment(kind: &str, lengths: &[(&str, f64)]) -> ScenarioValue {
    let mut segment = toml::Table::new();
    segment.insert("kind".into(), kind.into());
    for &(name, value) in lengths {
        segment.insert(name.into(), value.into());
    }
    vec![segment].into()
}

#[test]
fn bad_paths_are_errors_before_the_run() {
    let curve = [
        ("radius", 0.0),
        ("clothoid_length", 0.3),
        ("arc_length", 0.5),
    ];
    for (key, value, expected) in [
        (
            "process.path.segments",
            one_segment("straight", &[("length", -0.5)]),
            "length must be",
        ),
        (
            "process.path.segments",
            one_segment("curve", &curve),
            "radius must be",
        ),
        ("process.friction", 0.0.into(), "friction must be > 0"),
    ] {
        let loaded = builtin("platform-path").with(key, value).loaded();
        let err = Twin::new(loaded)
            .err()
            .unwrap_or_else(|| panic!("{key} ({expected}) must be rejected"));
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
    let scenario_text = twin::BUILTIN_SCENARIOS
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
        let loaded = Scenario::from_file(dir.join("scenario.toml"))
            .and_then(|b| b.build(&controllers::builtin()))
            .unwrap();
        let err = Twin::new(loaded).err().unwrap();
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
                let summary = run_built(
                    builtin("platform-path")
                        .controller("pid")
                        .with("controller.params.kp_v", kp_v)
                        .with("controller.params.kp_w", kp_w)
                        .with("controller.params.ki_v", ki_v)
                        .with("controller.params.ki_w", ki_w),
                );
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
