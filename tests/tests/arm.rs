//! The machining arm end to end (Ilyukhin et al. 2014): the adaptive path-speed correction keeps
//! every motor current near its tolerance and the tool on the path, and finishes before the safe
//! constant speed; the blind constant V0 saturates the shoulder and distorts the path; bad
//! programs and parameters are refused before the run.

use twin::{RunSummary, ScenarioValue};
use twin_tests::{builtin, refusal, run, Configure};

const TOLERANCE: f64 = 18.0;
const MOTORS: [&str; 4] = ["shoulder", "elbow", "wrist", "spindle"];

fn peak_ratio(summary: &RunSummary) -> f64 {
    MOTORS
        .iter()
        .map(|m| summary.metric(&format!("peak_current/{m}")).unwrap() / TOLERANCE)
        .fold(0.0, f64::max)
}

fn constant(speed: f64) -> RunSummary {
    run(
        builtin("arm-milling")
            .controller("path-speed-constant")
            .with("controller.params.path_speed", speed)
            .duration(20.0)
            .loaded(),
        None,
    )
}

#[test]
fn adaptive_correction_against_constant_speeds() {
    let adaptive = run(builtin("arm-milling").loaded(), None);
    assert!(adaptive.failure.is_none(), "{:?}", adaptive.failure);
    let blind = constant(0.020);
    let safe = constant(0.014);
    let m = |s: &RunSummary, name: &str| s.metric(name).unwrap();
    println!(
        "adaptive: {:.2} s, peak/tol {:.3}, deviation {:.4} mm, V deep {:.2} / out {:.2} mm/s",
        m(&adaptive, "contour_time"),
        peak_ratio(&adaptive),
        1e3 * m(&adaptive, "path_deviation_max"),
        1e3 * m(&adaptive, "path_speed_mean_deep_zone"),
        1e3 * m(&adaptive, "path_speed_mean_outside"),
    );
    println!(
        "constant V0: deviation {:.2} mm, shoulder at limit {:.3}; safe: {:.2} s, peak/tol {:.3}",
        1e3 * m(&blind, "path_deviation_max"),
        m(&blind, "at_limit_fraction/shoulder"),
        m(&safe, "contour_time"),
        peak_ratio(&safe),
    );
    // Adaptive: within 5 % of the tolerance, on the path to 0.1 mm, V0 where nothing overloads.
    assert_eq!(m(&adaptive, "contour_finished"), 1.0);
    assert!(peak_ratio(&adaptive) <= 1.05, "{}", peak_ratio(&adaptive));
    assert!(m(&adaptive, "path_deviation_max") <= 1e-4);
    assert!(m(&adaptive, "path_speed_mean_outside") > 0.0195);
    assert!(m(&adaptive, "path_speed_mean_deep_zone") < 0.018);
    // The safe constant speed never overloads but is slower.
    assert_eq!(m(&safe, "contour_finished"), 1.0);
    assert!(peak_ratio(&safe) <= 1.0, "{}", peak_ratio(&safe));
    assert!(m(&adaptive, "contour_time") < m(&safe, "contour_time"));
    // Constant V0: the shoulder is clipped at its limit and the path is distorted.
    assert!(m(&blind, "at_limit_fraction/shoulder") > 0.05);
    assert!(m(&blind, "path_deviation_max") >= 5.0 * m(&adaptive, "path_deviation_max"));
}

fn refused(key: &str, value: impl Into<ScenarioValue>) -> String {
    refusal(builtin("arm-milling").with(key, value))
        .unwrap_or_else(|| panic!("{key} must be refused before the run"))
}

#[test]
fn bad_programs_and_parameters_are_refused_before_the_run() {
    let err = refused("controller.params.servo.contour.start", [0.95, -0.25]);
    assert!(err.contains("out of the arm's reach"), "{err}");
    let err = refused("controller.params.current_tolerance", 0.0);
    assert!(err.contains("current_tolerance"), "{err}");
    let err = refused("controller.params.current_tolerance", -18.0);
    assert!(err.contains("current_tolerance"), "{err}");
    for key in [
        "speed_filter_lead",
        "speed_filter_lag",
        "current_filter_lead",
        "current_filter_lag",
    ] {
        for value in [0.0, -0.01] {
            let err = refused(&format!("controller.params.{key}"), value);
            assert!(err.contains(key), "{err}");
        }
    }
    // A shoulder drive of another gear ratio than the URDF's 84 N·m limit was drawn for.
    let drive: toml::Table = [
        ("torque_constant", 0.035),
        ("back_emf_constant", 0.035),
        ("resistance", 0.3),
        ("inductance", 0.0005),
        ("gear_ratio", 100.0),
        ("supply_voltage", 48.0),
        ("current_limit", 20.0),
        ("current_bandwidth", 2000.0),
        ("current_loop_period", 0.0001),
    ]
    .into_iter()
    .map(|(name, value)| (name.to_string(), toml::Value::Float(value)))
    .collect();
    let err = refused("process.drives.shoulder", drive);
    assert!(err.contains("peak joint torque"), "{err}");
}
