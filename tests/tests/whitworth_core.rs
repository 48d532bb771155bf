//! The twin core on its first machine: physics against the closed-form kinematics, determinism,
//! and a diverging run that stops cleanly (the passive linkage's energy: `engine.rs`).

use twin_tests::{builtin, run, scratch, Configure};

#[test]
fn simulated_ram_follows_the_analytic_kinematics_over_whole_turns() {
    let summary = run(builtin("whitworth-crank-pi").duration(3.0).loaded(), None);
    assert!(summary.failure.is_none(), "{:?}", summary.failure);
    let turns = summary.metric("crank_turns").unwrap();
    assert!(
        turns < -2.5,
        "the crank must make whole turns clockwise, made {turns}"
    );
    let ram_error = summary.metric("ram_model_error_max").unwrap();
    let loop_error = summary.metric("loop_closure_error_max").unwrap();
    println!("ram error vs y(q): {ram_error:.3e} m, loop closure: {loop_error:.3e} m");
    // The loop closures are projected exactly every step (the guide, *The engines*).
    assert!(
        ram_error <= 1e-9,
        "ram error {ram_error:e} m over {turns} turns"
    );
    assert!(loop_error <= 1e-9, "loop closure error {loop_error:e} m");
    let stroke = summary.metric("ram_stroke").unwrap();
    assert!((stroke - 0.4667).abs() < 1e-5, "stroke {stroke}");
}

#[test]
fn same_inputs_give_bit_identical_series_and_other_inputs_do_not() {
    let one_second = || builtin("whitworth-crank-pi").duration(1.0);
    let first = run(one_second().loaded(), None);
    let second = run(one_second().loaded(), None);
    assert_eq!(first.series_digest, second.series_digest);
    assert_eq!(first.metrics, second.metrics);
    let other = run(
        one_second()
            .with("controller.params.crank_speed", -6.0)
            .loaded(),
        None,
    );
    assert_ne!(first.series_digest, other.series_digest);
}

#[test]
fn a_diverging_run_stops_with_step_time_and_signal_and_keeps_its_recording() {
    let dir = scratch("diverge");
    let out = dir.join("diverge.rrd");
    // A gravity no linkage survives: the loop closures tear apart within a few steps.
    let summary = run(
        builtin("whitworth-crank-pi")
            .with("gravity", [0.0, -1.0e9])
            .duration(2.0)
            .loaded(),
        Some(&out),
    );
    let failure = summary.failure.expect("the run must diverge");
    println!("{failure}");
    assert!(failure.step > 0 && failure.step < 2000, "{failure}");
    assert!((failure.time - failure.step as f64 * 1e-3).abs() < 1e-12);
    assert!(
        failure.signal.contains("loop_gap") || failure.signal.ends_with("velocity"),
        "{failure}"
    );
    assert_eq!(summary.steps, failure.step);
    let bytes = std::fs::read(&out).expect("the recording is kept");
    assert!(
        bytes.len() > 1000,
        "recording too small: {} bytes",
        bytes.len()
    );
    let parts: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|name| name.ends_with(".part"))
        .collect();
    assert!(parts.is_empty(), "temporary files left: {parts:?}");
}

#[test]
fn control_period_holds_the_effort_between_updates() {
    let one_second = || builtin("whitworth-crank-pi").duration(1.0);
    let fast = run(one_second().loaded(), None);
    let held = run(one_second().with("control_period", 0.005).loaded(), None);
    assert!(held.failure.is_none());
    assert_ne!(fast.series_digest, held.series_digest);
    // Both still turn the crank at about one turn per second.
    for summary in [fast, held] {
        let turns = summary.metric("crank_turns").unwrap();
        assert!((turns + 0.9).abs() < 0.15, "turns {turns}");
    }
}
