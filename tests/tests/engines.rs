//! The exact and the rapier engine side by side (the guide, *The engines*): every built-in Whitworth,
//! arm and platform scenario runs on both and their headline figures agree within the bounds
//! measured there; the rapier engine's loop gaps and passive energy; the platform striking a
//! free box keeps momentum and gains no energy; an unknown engine is a one-line error.

use twin::engine::{load_urdf, mechanical_energy, Mechanism};
use twin::{Observer, ObserverError, RunSummary, StepView};
use twin_tests::{builtin, refusal, run, Configure};

/// Per scenario: its headline figures and how far the rapier engine's may lie from the exact
/// engine's (relative), about twice the difference measured (the guide, *The engines*).
const AGREEMENT: &[(&str, &[(&str, f64)])] = &[
    (
        "whitworth-crank-pi",
        &[("crank_turns", 1e-4), ("ram_stroke", 1e-5)],
    ),
    (
        "whitworth-tracking",
        &[("tracking_mse", 0.12), ("crank_reversals", 0.0)],
    ),
    (
        "whitworth-cutting",
        &[
            ("velocity_error_rms_percent/after_first_cut", 0.12),
            ("velocity_error_max_percent/after_first_cut", 0.01),
            ("cuts", 0.0),
        ],
    ),
    (
        "arm-milling",
        &[
            ("peak_current/shoulder", 5e-4),
            ("path_deviation_max", 5e-3),
            ("contour_time", 5e-4),
        ],
    ),
    (
        "platform-path",
        &[("path_error_rms", 1e-2), ("heading_error_rms", 5e-3)],
    ),
    (
        "platform-path-s",
        &[("path_error_rms", 1e-2), ("heading_error_rms", 1e-2)],
    ),
];

/// Largest loop gap the rapier engine may leave per Whitworth scenario at the default settings
/// (4 substeps, 2 PGS iterations), m: about twice the measured.
const RAPIER_GAPS: &[(&str, f64)] = &[
    ("whitworth-crank-pi", 1.2e-6),
    ("whitworth-tracking", 8e-6),
    ("whitworth-cutting", 2.5e-6),
];

fn metric(summary: &RunSummary, name: &str) -> f64 {
    summary
        .metric(name)
        .unwrap_or_else(|| panic!("{}: metric {name} missing", summary.scenario))
}

/// The scenario on both engines at once (two threads): (exact, rapier).
fn both(name: &str) -> (RunSummary, RunSummary) {
    std::thread::scope(|scope| {
        let on = |engine: &'static str| {
            scope.spawn(move || run(builtin(name).with("solver.engine", engine).loaded(), None))
        };
        let (exact, rapier) = (on("exact"), on("rapier"));
        let join = |h: std::thread::ScopedJoinHandle<'_, RunSummary>| {
            h.join()
                .unwrap_or_else(|_| panic!("{name}: a run panicked"))
        };
        (join(exact), join(rapier))
    })
}

#[test]
fn every_whitworth_arm_and_platform_scenario_agrees_on_both_engines() {
    for &(name, headlines) in AGREEMENT {
        let (exact, rapier) = both(name);
        for summary in [&exact, &rapier] {
            assert!(summary.failure.is_none(), "{name}: {:?}", summary.failure);
        }
        for &(figure, tolerance) in headlines {
            let (a, b) = (metric(&exact, figure), metric(&rapier, figure));
            let difference = (b - a).abs() / a.abs().max(f64::MIN_POSITIVE);
            println!("{name:<20} {figure:<44} exact {a:.6e} rapier {b:.6e} ({difference:.2e})");
            assert!(
                difference <= tolerance,
                "{name}: {figure} exact {a} vs rapier {b}: {difference:.3e} > {tolerance}"
            );
        }
        if let Some(&(_, bound)) = RAPIER_GAPS.iter().find(|(n, _)| *n == name) {
            let gap = metric(&rapier, "loop_closure_error_max");
            println!("{name:<20} rapier loop gap {gap:.3e} m (exact {:.1e} m)", {
                metric(&exact, "loop_closure_error_max")
            });
            assert!(gap <= bound, "{name}: rapier loop gap {gap} m > {bound} m");
        }
    }
}

#[test]
fn the_arm_crash_runs_on_both_engines_and_only_rapier_stops_the_hand() {
    // The exact engine has no contacts: the hand passes through the clamp (the detector reports
    // it) and the contour is finished; on the rapier engine the clamp holds the hand.
    let (exact, rapier) = both("arm-crash");
    for summary in [&exact, &rapier] {
        assert!(summary.failure.is_none(), "{:?}", summary.failure);
        assert!(metric(summary, "collisions") >= 1.0);
    }
    let (through, held) = (
        metric(&exact, "deepest_penetration"),
        metric(&rapier, "deepest_penetration"),
    );
    println!("arm-crash: deepest penetration exact {through:.3e} m, rapier {held:.3e} m");
    assert_eq!(metric(&exact, "contour_finished"), 1.0);
    assert!(
        held < 0.1 * through,
        "Rapier let the hand {held} m into the clamp"
    );
}

/// The platform's and the box's momentum and kinetic energy, step by step.
struct Momentum {
    mechanism: Mechanism,
    box_mass: f64,
    dt: f64,
    /// (time, momentum [x, y], kinetic energy, box x) per step.
    samples: Vec<(f64, [f64; 2], f64, f64)>,
    last_box: Option<[f64; 2]>,
}

impl Observer for Momentum {
    fn observe(&mut self, view: &StepView) -> Result<(), ObserverError> {
        let state = view.state;
        let mut momentum = [0.0; 2];
        for (l, link) in self.mechanism.links.iter().enumerate() {
            let Some(inertial) = link.inertial else {
                continue;
            };
            let pose = state.link_poses[l];
            let [cx, cy] = pose.rotate(inertial.centre_of_mass[0], inertial.centre_of_mass[1]);
            let omega = state.link_angular_velocities[l];
            let [vx, vy] = state.link_velocities[l];
            momentum[0] += inertial.mass * (vx - omega * cy);
            momentum[1] += inertial.mass * (vy + omega * cx);
        }
        let at = [state.body_poses[0].x, state.body_poses[0].y];
        // Outside a contact the box moves at constant velocity: the difference is exact there.
        let velocity = self.last_box.map_or([0.0; 2], |p| {
            [(at[0] - p[0]) / self.dt, (at[1] - p[1]) / self.dt]
        });
        self.last_box = Some(at);
        momentum[0] += self.box_mass * velocity[0];
        momentum[1] += self.box_mass * velocity[1];
        let energy = mechanical_energy(&self.mechanism, state, [0.0; 2])
            + 0.5 * self.box_mass * (velocity[0].powi(2) + velocity[1].powi(2));
        self.samples.push((view.time, momentum, energy, at[0]));
        Ok(())
    }
}

#[test]
fn the_platform_striking_a_free_box_keeps_momentum_and_gains_no_energy() {
    // Coasting at 0.1 m/s with the drives off on an ice floor (μ = 1e-9: the tyres pass a
    // negligible 1e-8 N), nothing outside acts in the plane: the momentum the box takes is the
    // platform's loss, and the contact (restitution 0) can only take energy.
    let loaded = builtin("platform-obstacle")
        .controller("passive")
        .duration(6.0)
        .with("process.friction", 1e-9)
        .with("initial.floor_x.velocity", 0.1)
        .loaded();
    let urdf = std::fs::read_to_string("../urdf/platform.urdf").expect("URDF");
    let mut observer = Momentum {
        mechanism: load_urdf(&urdf, "platform.urdf").unwrap_or_else(|e| panic!("{e}")),
        box_mass: 0.5,
        dt: loaded.scenario.dt,
        samples: Vec::new(),
        last_box: None,
    };
    let summary = twin::Twin::new(loaded)
        .and_then(|t| t.run_with(None, &mut [&mut observer]))
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(summary.failure.is_none(), "{:?}", summary.failure);
    let samples = &observer.samples;
    let (_, before, energy_before, box_start) = samples[1];
    let &(_, after, energy_after, box_end) = samples.last().expect("steps");
    let energy_max = samples[1..].iter().map(|s| s.2).fold(f64::MIN, f64::max);
    println!(
        "momentum {before:?} → {after:?} kg·m/s, energy {energy_before:.6e} → {energy_after:.6e} J \
         (max {energy_max:.6e}), box {box_start:.4} → {box_end:.4} m"
    );
    assert!(
        box_end > box_start + 0.05,
        "the box was not pushed: {box_end} m"
    );
    // The tyres' 1e-8 N over 6 s at most: 2e-7 kg·m/s.
    let lost = (after[0] - before[0]).hypot(after[1] - before[1]);
    assert!(lost <= 3e-7, "momentum changed by {lost} kg·m/s");
    assert!(
        energy_max <= energy_before * (1.0 + 1e-6),
        "energy grew to {energy_max} J"
    );
    // Restitution 0: the pair ends at one speed, keeping m₁/(m₁ + m₂) of the energy.
    let platform = 2.92 + 2e-6;
    let kept = platform / (platform + observer.box_mass);
    let ratio = energy_after / energy_before;
    assert!(
        (ratio - kept).abs() <= 1e-3 * kept,
        "kept {ratio} of the energy, not {kept}"
    );
}

#[test]
fn a_free_body_needs_the_rapier_engine_and_unknown_engines_are_one_line_errors() {
    let exact = refusal(builtin("platform-obstacle").with("solver.engine", "exact"));
    let message = exact.expect("the exact engine cannot move a free body");
    assert!(
        message.contains("rapier") && !message.contains('\n'),
        "{message}"
    );
    for engine in ["warp", "", "Rapier"] {
        let message = refusal(builtin("whitworth-crank-pi").with("solver.engine", engine))
            .unwrap_or_else(|| panic!("engine `{engine}` accepted"));
        assert!(
            message.contains("solver.engine")
                && message.contains("exact")
                && message.contains("rapier")
                && !message.contains('\n'),
            "{message}"
        );
    }
}

/// The passive Whitworth released from rest for 10 s: (largest energy gain, largest loss, loop
/// gap), J, J, m.
fn passive_whitworth(engine: &str, substeps: usize) -> (f64, f64, f64) {
    struct Energy(Mechanism, Vec<f64>);
    impl Observer for Energy {
        fn observe(&mut self, view: &StepView) -> Result<(), ObserverError> {
            self.1
                .push(mechanical_energy(&self.0, view.state, [0.0, -9.81]));
            Ok(())
        }
    }
    let urdf = std::fs::read_to_string("../urdf/whitworth.urdf").expect("URDF");
    let mechanism = load_urdf(&urdf, "whitworth.urdf").unwrap_or_else(|e| panic!("{e}"));
    let loaded = builtin("whitworth-crank-pi")
        .controller("passive")
        .duration(10.0)
        .with("solver.engine", engine)
        .with("solver.rapier_substeps", substeps)
        .loaded();
    let mut energy = Energy(mechanism, Vec::new());
    let summary = twin::Twin::new(loaded)
        .and_then(|t| t.run_with(None, &mut [&mut energy]))
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(summary.failure.is_none(), "{:?}", summary.failure);
    let start = energy.1[0];
    let gain = energy.1.iter().map(|e| e - start).fold(0.0, f64::max);
    let loss = energy.1.iter().map(|e| start - e).fold(0.0, f64::max);
    let gap = metric(&summary, "loop_closure_error_max");
    println!(
        "passive Whitworth, 10 s, {engine} ({substeps} substeps): {start:.4} J, largest gain \
         {gain:.3e} J, largest loss {loss:.3e} J, loop gap {gap:.2e} m"
    );
    (gain, loss, gap)
}

#[test]
fn the_passive_whitworth_drifts_in_energy_on_rapier_as_a_first_order_integrator_does() {
    // The exact engine keeps the 33.6 J to 1e-8 J (tests/tests/engine.rs). Rapier's
    // semi-implicit Euler gains about 0.015 J/s here (0.15 J in 10 s, 0.45 %), and the drift
    // halves with the substep: the integrator's, not the closures' (whose gap falls 4×).
    let (gain, loss, gap) = passive_whitworth("rapier", 4);
    assert!(
        gain <= 0.3 && loss <= 0.08,
        "gain {gain} J, loss {loss} J of 33.6 J"
    );
    assert!(gap <= 3e-6, "loop gap {gap} m");
    let (finer, _, finer_gap) = passive_whitworth("rapier", 8);
    let (order, closure) = (finer / gain, finer_gap / gap);
    assert!(
        (0.4..=0.6).contains(&order),
        "drift ratio {order} at half the substep"
    );
    assert!(
        (0.2..=0.3).contains(&closure),
        "gap ratio {closure} at half the substep"
    );
}
