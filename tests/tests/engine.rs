//! The engine against references computed without it: an RK4 Newton–Euler model of the arm
//! (`models::serial_chain`), closed-form pendulum periods and spring–damper decay, energy of
//! passive linkages, and the Whitworth ram against its closed-form Jacobian.

use models::serial_chain::{ChainLink, SerialChain};
use std::f64::consts::{FRAC_PI_2, TAU};
use twin::engine::mechanical_energy;
use twin::engine::{JointMotion, Mechanism};
use twin::engine::{MechanismState, Physics, SolverSettings};
use twin_tests::{builtin, run, Configure};

const GRAVITY: [f64; 2] = [0.0, -9.81];

fn load(path: &str) -> Mechanism {
    let text = std::fs::read_to_string(path).expect("URDF file");
    twin::engine::load_urdf(&text, path).unwrap_or_else(|e| panic!("{e}"))
}

fn arm(damped: bool) -> Mechanism {
    let mut mechanism = load("../urdf/arm.urdf");
    if !damped {
        // Undamped, the arm swings into its ±3 rad stops, which (inelastic) take energy: free
        // them too, so the energy measures the integrator alone.
        for joint in &mut mechanism.joints {
            joint.damping = 0.0;
            joint.limits = None;
        }
    }
    mechanism
}

fn physics(mechanism: &Mechanism, dt: f64) -> Physics {
    Physics::new(mechanism, SolverSettings::exact(dt, GRAVITY, 1))
}

/// The arm as a serial chain, read from the same URDF values (frames, masses, inertias, damping).
fn chain_of(mechanism: &Mechanism) -> SerialChain {
    let links = mechanism
        .joints
        .iter()
        .map(|joint| {
            assert_eq!(joint.motion, JointMotion::Revolute { sign: 1.0 });
            let inertial = mechanism.links[joint.child].inertial.expect("mass");
            ChainLink {
                origin: [joint.origin.x, joint.origin.y, joint.origin.angle],
                mass: inertial.mass,
                centre_of_mass: inertial.centre_of_mass,
                izz: inertial.izz,
                damping: joint.damping,
            }
        })
        .collect();
    SerialChain {
        links,
        gravity: GRAVITY,
    }
}

/// Largest joint difference (rad) between the twin and the reference over `duration`, and
/// the twin's largest energy drift (J).
fn passive_arm_against_reference(damped: bool, duration: f64) -> (f64, f64, f64) {
    let mechanism = arm(damped);
    let chain = chain_of(&mechanism);
    let dt = 1e-3;
    let sub = 10;
    let mut twin = physics(&mechanism, dt);
    let n = mechanism.joints.len();
    let (mut q, mut qd) = (vec![0.0; n], vec![0.0; n]);
    let mut state = MechanismState::default();
    twin.read_state(&mut state);
    let start = mechanical_energy(&mechanism, &state, GRAVITY);
    let (mut worst, mut drift) = (0.0f64, 0.0f64);
    for _ in 0..(duration / dt).round() as usize {
        twin.step(&vec![0.0; n], &[]);
        for _ in 0..sub {
            chain.rk4_step(&mut q, &mut qd, &vec![0.0; n], dt / sub as f64);
        }
        twin.read_state(&mut state);
        for (twin_q, reference_q) in state.joint_positions.iter().zip(&q) {
            worst = worst.max((twin_q - reference_q).abs());
        }
        drift = drift.max((mechanical_energy(&mechanism, &state, GRAVITY) - start).abs());
    }
    // Energy above the lowest configuration (hanging straight down, at rest).
    let mut hanging = vec![0.0; n];
    hanging[0] = -FRAC_PI_2;
    let height = chain.energy(&vec![0.0; n], &vec![0.0; n]) - chain.energy(&hanging, &vec![0.0; n]);
    (worst, drift, height)
}

#[test]
fn passive_arm_falls_as_an_independent_newton_euler_reference() {
    let (worst, _, _) = passive_arm_against_reference(true, 2.0);
    println!("arm passive fall, 2 s at dt = 1 ms: largest joint difference {worst:.3e} rad");
    assert!(worst < 1e-3, "joint difference {worst} rad");
}

#[test]
fn undamped_passive_arm_keeps_its_energy() {
    let (worst, drift, energy) = passive_arm_against_reference(false, 10.0);
    println!(
        "undamped arm, 10 s: energy drift {drift:.3e} J of {energy:.3} J ({:.2e}), joints within {worst:.2e} rad of the reference",
        drift / energy
    );
    assert!(drift <= 1e-3 * energy, "drift {drift} J of {energy} J");
}

#[test]
fn passive_whitworth_keeps_its_energy_and_closes_its_loops_exactly() {
    let summary = run(
        builtin("whitworth-crank-pi")
            .controller("passive")
            .duration(10.0)
            .loaded(),
        None,
    );
    assert!(summary.failure.is_none(), "{:?}", summary.failure);
    let drift = summary.metric("mechanical_energy_drift_max").unwrap();
    let gap = summary.metric("loop_closure_error_max").unwrap();
    let ram = summary.metric("ram_model_error_max").unwrap();
    let turns = summary.metric("crank_turns").unwrap().abs();
    println!("passive Whitworth, 10 s: energy drift {drift:.3e} J, loop gap {gap:.2e} m, ram error {ram:.2e} m, {turns:.2} turns");
    assert!(turns > 0.2, "the linkage hardly moved: {turns} turns");
    // 0.1 % of the 33.6 J it starts with (energy measured from y = 0).
    assert!(drift <= 0.0336, "energy drift {drift} J");
    assert!(gap <= 1e-9 && ram <= 1e-9, "gap {gap} m, ram error {ram} m");
}

#[test]
fn whitworth_closes_its_loops_exactly_at_any_speed_and_substep_count() {
    for (name, builder) in [
        ("crank-pi, 3 s", builtin("whitworth-crank-pi").duration(3.0)),
        (
            "crank-pi, 3 s at 2 turns/s",
            builtin("whitworth-crank-pi")
                .duration(3.0)
                .with("controller.params.crank_speed", -2.0 * TAU),
        ),
        (
            "crank-pi, 2 s, 3 substeps",
            builtin("whitworth-crank-pi")
                .duration(2.0)
                .with("substeps", 3),
        ),
        ("whitworth-tracking", builtin("whitworth-tracking")),
        ("whitworth-cutting", builtin("whitworth-cutting")),
    ] {
        let summary = run(builder.loaded(), None);
        assert!(summary.failure.is_none(), "{name}: {:?}", summary.failure);
        let gap = summary.metric("loop_closure_error_max").unwrap();
        let ram = summary.metric("ram_model_error_max").unwrap();
        let velocity = summary.metric("ram_velocity_error_relative_max").unwrap();
        println!("{name}: loop gap {gap:.2e} m, ram error {ram:.2e} m, ram velocity vs J·q̇ {velocity:.2e}");
        assert!(gap <= 1e-9, "{name}: loop gap {gap} m");
        assert!(ram <= 1e-9, "{name}: ram error {ram} m");
        assert!(
            velocity <= 1e-9,
            "{name}: ram velocity off J·q̇ by {velocity} (relative)"
        );
    }
}

/// A bar of `mass` on a revolute joint about +z, centre of mass `length` out, released
/// `amplitude` rad from hanging down.
fn pendulum_urdf(mass: f64, length: f64, izz: f64, amplitude: f64) -> String {
    format!(
        r#"<robot name="pendulum">
  <link name="ground"/>
  <link name="bob"><inertial><origin xyz="{length} 0 0"/><mass value="{mass}"/>
    <inertia ixx="{izz}" ixy="0" ixz="0" iyy="{izz}" iyz="0" izz="{izz}"/></inertial></link>
  <joint name="pivot" type="continuous"><parent link="ground"/><child link="bob"/>
    <origin xyz="0 0 0" rpy="0 0 {angle}"/><axis xyz="0 0 1"/></joint>
</robot>"#,
        angle = -FRAC_PI_2 + amplitude
    )
}

/// Times at which a sampled velocity crosses zero from above (linear interpolation in a step).
fn zero_crossings(samples: &[(f64, f64)]) -> Vec<f64> {
    samples
        .windows(2)
        .filter(|w| w[0].1 > 0.0 && w[1].1 <= 0.0)
        .map(|w| w[0].0 + (w[1].0 - w[0].0) * w[0].1 / (w[0].1 - w[1].1))
        .collect()
}

#[test]
fn pendulum_swings_with_its_closed_form_period() {
    let (mass, length, izz, amplitude) = (2.0, 0.4, 0.01, 1.0);
    let mechanism =
        twin::engine::load_urdf(&pendulum_urdf(mass, length, izz, amplitude), "pendulum")
            .unwrap_or_else(|e| panic!("{e}"));
    let dt = 1e-3;
    let mut twin = physics(&mechanism, dt);
    let mut state = MechanismState::default();
    let mut samples = Vec::new();
    for step in 1..=10_000 {
        twin.step(&[0.0], &[]);
        twin.read_state(&mut state);
        samples.push((step as f64 * dt, state.joint_velocities[0]));
    }
    // Large swings: T = T₀ / AGM(1, cos(θ₀/2)), T₀ = 2π·√(I_pivot / (m·g·l)).
    let small = TAU * ((izz + mass * length * length) / (mass * 9.81 * length)).sqrt();
    let (mut a, mut b) = (1.0f64, (amplitude / 2.0).cos());
    for _ in 0..30 {
        (a, b) = ((a + b) / 2.0, (a * b).sqrt());
    }
    let exact = small / a;
    let crossings = zero_crossings(&samples);
    let periods = crossings.len() - 1;
    let measured = (crossings[periods] - crossings[0]) / periods as f64;
    println!("pendulum, 1 rad swing at dt = 1 ms: period {measured:.9} s vs {exact:.9} s over {periods} periods");
    assert!(periods >= 5);
    assert!(
        (measured - exact).abs() <= 1e-3 * exact,
        "period {measured} vs {exact}"
    );
}

#[test]
fn spring_damper_decays_at_its_physical_rate_not_a_numerical_one() {
    // A lightly damped mode like a milling tool's: 800 Hz, ζ = 0.02, 0.5 kg.
    let (mass, frequency, zeta) = (0.5, 800.0, 0.02);
    let omega = TAU * frequency;
    let (stiffness, damping) = (mass * omega * omega, 2.0 * zeta * mass * omega);
    let urdf = format!(
        r#"<robot name="mass_spring">
  <link name="ground"/>
  <link name="mass"><inertial><mass value="{mass}"/>
    <inertia ixx="1e-4" ixy="0" ixz="0" iyy="1e-4" iyz="0" izz="1e-4"/></inertial></link>
  <joint name="slide" type="prismatic"><parent link="ground"/><child link="mass"/>
    <axis xyz="1 0 0"/><limit effort="0" velocity="1"/><dynamics damping="{damping}"/>
    <spring stiffness="{stiffness}" reference="-0.001"/></joint>
</robot>"#
    );
    let mechanism = twin::engine::load_urdf(&urdf, "mass_spring").unwrap_or_else(|e| panic!("{e}"));
    let dt = 1e-5;
    let mut twin = physics(&mechanism, dt);
    let mut state = MechanismState::default();
    let (mut samples, mut positions) = (Vec::new(), Vec::new());
    for step in 1..=(0.05 / dt) as usize {
        twin.step(&[0.0], &[]);
        twin.read_state(&mut state);
        samples.push((step as f64 * dt, state.joint_velocities[0]));
        positions.push(state.joint_positions[0] + 0.001);
    }
    // Peaks (velocity through zero downwards): amplitude ratio e^(−σ·t), σ = ζ·ω₀.
    let peak_value = |t: f64| {
        let i = ((t / dt).floor() as usize)
            .saturating_sub(1)
            .min(positions.len() - 2);
        let frac = (t - (i + 1) as f64 * dt) / dt;
        positions[i] + frac * (positions[i + 1] - positions[i])
    };
    let peaks = zero_crossings(&samples);
    let (first, last) = (peaks[0], peaks[peaks.len() - 1]);
    let decay = (peak_value(first) / peak_value(last)).ln() / (last - first);
    let damped = TAU * (peaks.len() - 1) as f64 / (last - first);
    let (exact_decay, exact_damped) = (zeta * omega, omega * (1.0 - zeta * zeta).sqrt());
    println!(
        "spring–damper 800 Hz, ζ 0.02 at dt = 10 µs: decay {decay:.4} vs {exact_decay:.4} 1/s, ω_d {damped:.3} vs {exact_damped:.3} rad/s"
    );
    assert!(
        (decay - exact_decay).abs() <= 1e-3 * exact_decay,
        "decay {decay} vs {exact_decay}"
    );
    assert!(
        (damped - exact_damped).abs() <= 1e-3 * exact_damped,
        "ω_d {damped} vs {exact_damped}"
    );
}

#[test]
fn dry_friction_holds_below_breakaway_and_slides_above_it() {
    let urdf = |friction: f64| {
        format!(
            r#"<robot name="block">
  <link name="ground"/>
  <link name="block"><inertial><mass value="2.0"/>
    <inertia ixx="1e-3" ixy="0" ixz="0" iyy="1e-3" iyz="0" izz="1e-3"/></inertial></link>
  <joint name="slide" type="prismatic"><parent link="ground"/><child link="block"/>
    <axis xyz="1 0 0"/><limit effort="100" velocity="1"/><dynamics friction="{friction}"/></joint>
</robot>"#
        )
    };
    let mechanism = twin::engine::load_urdf(&urdf(5.0), "block").unwrap_or_else(|e| panic!("{e}"));
    let mut state = MechanismState::default();
    for (push, expected) in [(4.0, 0.0), (9.0, (9.0 - 5.0) / 2.0)] {
        let mut twin = physics(&mechanism, 1e-3);
        for _ in 0..1000 {
            twin.step(&[push], &[]);
        }
        twin.read_state(&mut state);
        let speed = state.joint_velocities[0];
        println!("push {push} N against 5 N of friction: {speed:.6} m/s after 1 s");
        assert!(
            (speed - expected).abs() < 1e-9,
            "push {push}: {speed} m/s, expected {expected}"
        );
    }
}

#[test]
fn a_joint_stops_at_its_limit() {
    // Released 1 rad from hanging down towards a stop 0.3 rad on, where gravity holds it.
    let mut mechanism = twin::engine::load_urdf(&pendulum_urdf(2.0, 0.4, 0.01, 1.0), "pendulum")
        .unwrap_or_else(|e| panic!("{e}"));
    mechanism.joints[0].limits = Some([-0.3, 0.3]);
    let mut twin = physics(&mechanism, 1e-3);
    let mut state = MechanismState::default();
    for _ in 0..2000 {
        twin.step(&[0.0], &[]);
        twin.read_state(&mut state);
        assert!(
            state.joint_positions[0] >= -0.3,
            "{}",
            state.joint_positions[0]
        );
    }
    assert_eq!(state.joint_positions[0], -0.3);
    assert_eq!(state.joint_velocities[0], 0.0);
}
