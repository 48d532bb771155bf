//! The exact engine's equations of motion against Rapier's own mass matrix; the rapier engine
//! against closed forms: efforts, damping, springs, limits and dry friction on one slider, and a
//! slider striking a free box (momentum exchanged, energy not gained).

use super::exact::{ExactEngine, ExactSettings};
use super::*;
use crate::mechanism::Mechanism;
use crate::urdf;

fn whitworth() -> Mechanism {
    let text = include_str!("../../../urdf/whitworth.urdf");
    urdf::load_str(text, "whitworth.urdf").expect("loads")
}

#[test]
fn mass_matrix_matches_rapiers_own() {
    let mechanism = whitworth();
    let mut physics = ExactEngine::new(
        &mechanism,
        ExactSettings {
            dt: 1e-3,
            gravity: [0.0, -9.81],
            substeps: 1,
            integrator: Integrator::Rk4,
        },
    );
    let n = physics.q.len();
    for configuration in 0..5 {
        let q: Vec<f64> = (0..n)
            .map(|g| 0.7 * ((configuration * n + g) as f64).sin())
            .collect();
        physics.rapier.pose(&mechanism, &q, &mut physics.kin);
        let ours: Vec<f64> = (0..n)
            .map(|g| {
                let mut column = vec![0.0; n];
                physics
                    .dynamics
                    .inverse_mass_column(&physics.model, &physics.kin, g, &mut column);
                column[g]
            })
            .collect();
        let rapiers = physics.rapier.rapier_inverse_mass_diagonal(n);
        for g in 0..n {
            assert!(
                (ours[g] - rapiers[g]).abs() <= 1e-12 * rapiers[g].abs(),
                "coordinate {g}: twin {} vs Rapier {}",
                ours[g],
                rapiers[g]
            );
        }
    }
}

/// A slider of `mass` kg along x on the ground, with a 0.1 m square collision box, its joint's
/// `<dynamics>` and optional `<spring>` and `<limit>` as given (XML fragments).
fn slider(mass: f64, dynamics: &str, extra: &str) -> Mechanism {
    let text = format!(
        r#"<robot name="slider"><link name="ground"/>
        <link name="block"><inertial><origin xyz="0 0 0"/><mass value="{mass}"/>
          <inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="0.01"/></inertial>
          <collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision></link>
        <joint name="slide" type="prismatic"><parent link="ground"/><child link="block"/>
          <axis xyz="1 0 0"/>{dynamics}{extra}</joint></robot>"#
    );
    urdf::load_str(&text, "slider.urdf").expect("loads")
}

fn rapier(dt: f64, bodies: Vec<BodySpec>, restitution: f64) -> SolverSettings {
    let mut settings = SolverSettings::exact(dt, [0.0; 2], 1);
    settings.solver.engine = Engine::Rapier;
    settings.contact.restitution = restitution;
    settings.bodies = bodies;
    settings
}

/// Steps `steps` times under one constant effort and returns the last state.
fn advance(physics: &mut Physics, effort: f64, steps: usize) -> MechanismState {
    let mut state = MechanismState::default();
    for _ in 0..steps {
        physics.step(&[effort], &[]);
    }
    physics.read_state(&mut state);
    state
}

#[test]
fn rapier_engine_slider_takes_efforts_damping_springs_and_friction() {
    // 2 kg pushed by 4 N for 1 s from rest: v = 2 m/s, x = 1 m (semi-implicit Euler, four
    // substeps of dt/4: x leads by a·t·dt/8 = 0.25 mm).
    let mut physics = Physics::new(&slider(2.0, "", ""), rapier(1e-3, Vec::new(), 0.0));
    let state = advance(&mut physics, 4.0, 1000);
    println!(
        "pushed: {:?} m, {:?} m/s",
        state.joint_positions, state.joint_velocities
    );
    assert!((state.joint_velocities[0] - 2.0).abs() < 1e-9, "{state:?}");
    assert!((state.joint_positions[0] - 1.0).abs() < 3e-4, "{state:?}");
    // Damping 4 N·s/m on 2 kg: v(1 s) = v₀·e⁻² from 1 m/s (implicit, so within a step's error).
    let damped = slider(2.0, r#"<dynamics damping="4" friction="0"/>"#, "");
    let mut physics = Physics::new(&damped, rapier(1e-3, Vec::new(), 0.0));
    physics.set_joint_states(&[(0, 0.0, 1.0)]);
    let v = advance(&mut physics, 0.0, 1000).joint_velocities[0];
    println!("damped: {v} m/s against {}", (-2.0f64).exp());
    assert!((v - (-2.0f64).exp()).abs() < 3e-3 * v, "damped to {v}");
    // Dry friction 5 N: 4 N cannot move it; 9 N accelerates it at (9 − 5)/2 m/s².
    let dry = slider(2.0, r#"<dynamics damping="0" friction="5"/>"#, "");
    for (effort, expected) in [(4.0, 0.0), (9.0, 2.0)] {
        let mut physics = Physics::new(&dry, rapier(1e-3, Vec::new(), 0.0));
        let v = advance(&mut physics, effort, 1000).joint_velocities[0];
        println!("dry friction, {effort} N: {v} m/s");
        assert!((v - expected).abs() < 1e-6, "{effort} N: {v} m/s");
    }
    // A spring of 800 N/m on 2 kg released 0.01 m out: period 2π·√(m/k) = 0.3142 s.
    let spring = slider(2.0, "", r#"<spring stiffness="800" reference="0"/>"#);
    let mut physics = Physics::new(&spring, rapier(1e-4, Vec::new(), 0.0));
    physics.set_joint_states(&[(0, 0.01, 0.0)]);
    let half_period = (std::f64::consts::PI * (2.0f64 / 800.0).sqrt() / 1e-4).round() as usize;
    let x = advance(&mut physics, 0.0, half_period).joint_positions[0];
    println!("spring: {x} m after half a period");
    assert!((x + 0.01).abs() < 2e-4, "after half a period {x} m");
    // A limit at 0.1 m holds a slider pushed into it.
    let limited = slider(
        2.0,
        "",
        r#"<limit lower="-0.1" upper="0.1" effort="10" velocity="1"/>"#,
    );
    let mut physics = Physics::new(&limited, rapier(1e-3, Vec::new(), 0.0));
    let x = advance(&mut physics, 10.0, 2000).joint_positions[0];
    println!("limit: {x} m");
    assert!((x - 0.1).abs() < 1e-3, "pushed into its stop at {x} m");
}

/// A free 0.1 m box of `mass` kg at x = 0.3 m.
fn free_box(mass: f64) -> BodySpec {
    BodySpec {
        name: "box".into(),
        kind: BodyKind::Free,
        pose: [0.3, 0.0, 0.0],
        shapes: vec![BodyShape {
            size: Some([0.1, 0.1]),
            radius: None,
            points: None,
            origin: [0.0; 3],
        }],
        mass: Some(mass),
    }
}

/// The slider (2 kg at 1 m/s) strikes the box (1 kg) head on, and both move on free: nothing
/// but the contact acts along x, so the box's momentum is the slider's loss (the contact's
/// impulse) and the kinetic energy cannot grow. Returns both velocities and energies.
fn strike(restitution: f64) -> ([f64; 2], [f64; 2]) {
    let (m1, m2, dt) = (2.0, 1.0, 1e-3);
    let mut physics = Physics::new(
        &slider(m1, "", ""),
        rapier(dt, vec![free_box(m2)], restitution),
    );
    physics.set_joint_states(&[(0, 0.0, 1.0)]);
    let mut state = MechanismState::default();
    let mut previous = 0.3;
    let mut box_velocity = 0.0;
    for _ in 0..500 {
        physics.step(&[0.0], &[]);
        physics.read_state(&mut state);
        box_velocity = (state.body_poses[0].x - previous) / dt;
        previous = state.body_poses[0].x;
    }
    let v1 = state.joint_velocities[0];
    let energy = |v1: f64, v2: f64| 0.5 * m1 * v1 * v1 + 0.5 * m2 * v2 * v2;
    let momentum = m1 * v1 + m2 * box_velocity;
    assert!(
        (momentum - m1).abs() < 1e-9 * m1,
        "momentum {momentum} of {m1} kg·m/s"
    );
    assert!(
        box_velocity > v1 - 1e-9,
        "the box stays behind: {box_velocity} < {v1}"
    );
    (
        [v1, box_velocity],
        [energy(1.0, 0.0), energy(v1, box_velocity)],
    )
}

#[test]
fn rapier_engine_contacts_keep_momentum_and_gain_no_energy() {
    // Inelastic: both at m₁v₀/(m₁ + m₂) = 2/3 m/s, a third of the energy lost.
    let ([v1, v2], [before, after]) = strike(0.0);
    println!("inelastic strike: {v1:.6} {v2:.6} m/s, energy {before:.6} → {after:.6} J");
    assert!(
        (v1 - 2.0 / 3.0).abs() < 5e-3 && (v2 - 2.0 / 3.0).abs() < 5e-3,
        "{v1} {v2}"
    );
    assert!(after <= before && (after - before * 2.0 / 3.0).abs() < 1e-4 * before);
    // Elastic: 1/3 and 4/3 m/s, the energy kept.
    let ([v1, v2], [before, after]) = strike(1.0);
    println!("elastic strike: {v1:.6} {v2:.6} m/s, energy {before:.6} → {after:.6} J");
    assert!(
        (v1 - 1.0 / 3.0).abs() < 1e-3 && (v2 - 4.0 / 3.0).abs() < 1e-3,
        "{v1} {v2}"
    );
    assert!(
        after <= before * (1.0 + 1e-9),
        "energy grew: {before} → {after} J"
    );
}

#[test]
fn rapier_engine_hands_out_non_finite_state_as_nan() {
    // Rapier disables a body whose state turns non-finite instead of handing NaN on; the engine
    // reports it, so the run's health check stops there as with the exact engine.
    let mechanism = slider(2.0, "", "");
    let mut physics = Physics::new(&mechanism, rapier(1e-3, vec![free_box(1.0)], 0.0));
    let load = Load {
        link: 1,
        force: [f64::NAN, 0.0],
        point: [0.0, 0.0],
        damping: NO_DAMPING,
        stiffness: NO_STIFFNESS,
    };
    let mut state = MechanismState::default();
    physics.step(&[0.0], &[load]);
    physics.read_state(&mut state);
    println!("after a NaN load: {state:?}");
    assert!(state.joint_positions[0].is_nan() || state.joint_velocities[0].is_nan());
    physics.step(&[0.0], &[]);
    physics.read_state(&mut state);
    assert!(state.joint_positions[0].is_nan() || state.joint_velocities[0].is_nan());
}

/// The Whitworth coasting from one turn a second (gravity on, no effort) for 0.25 s at `dt`
/// with `integrator`: the ram's position at the end, and the largest loop gap on the way.
fn coast(integrator: Integrator, dt: f64) -> (f64, f64) {
    let mechanism = whitworth();
    let mut settings = SolverSettings::exact(dt, [0.0, -9.81], 1);
    settings.solver.integrator = integrator;
    let mut physics = Physics::new(&mechanism, settings);
    let joint = |name: &str| {
        (mechanism.joints.iter())
            .position(|j| j.name == name)
            .unwrap()
    };
    physics.set_joint_states(&[(joint("crank"), 0.0, -std::f64::consts::TAU)]);
    let efforts = vec![0.0; mechanism.joints.len()];
    let mut state = MechanismState::default();
    let mut gap = 0.0_f64;
    for _ in 0..(0.25 / dt).round() as usize {
        physics.step(&efforts, &[]);
        physics.read_state(&mut state);
        gap = (state.loop_gaps.iter()).fold(gap, |m, g| m.max(g.abs()));
    }
    (state.joint_positions[joint("ram")], gap)
}

#[test]
fn each_integrator_closes_the_loops_and_converges_at_its_order() {
    let reference = coast(Integrator::Rk4, 1.0 / 16_000.0).0;
    for (integrator, order) in [
        (Integrator::Rk4, 4.0),
        (Integrator::Midpoint, 2.0),
        (Integrator::SemiImplicitEuler, 1.0),
    ] {
        let (coarse, coarse_gap) = coast(integrator, 2e-3);
        let (fine, fine_gap) = coast(integrator, 1e-3);
        let observed = ((coarse - reference).abs() / (fine - reference).abs()).log2();
        assert!(
            (observed - order).abs() < 0.5,
            "{integrator:?}: order {observed:.2}, not {order} ({coarse:e}, {fine:e} m against \
             {reference:e} m)"
        );
        // The closure holds φ to 1e-12; the gap between the loop frames of the links' poses
        // rounds a little above it.
        let gap = coarse_gap.max(fine_gap);
        assert!(gap <= 2e-12, "{integrator:?}: a loop gap of {gap:e} m");
        println!("{integrator:?}: order {observed:.2}, loop gap {gap:.1e} m");
    }
}

#[test]
fn an_integrator_other_than_rk4_is_the_exact_engines_only() {
    let mut options = SolverOptions {
        integrator: Integrator::Midpoint,
        ..SolverOptions::default()
    };
    assert_eq!(options.validate(), Ok(()));
    options.engine = Engine::Rapier;
    let error = options.validate().unwrap_err();
    assert!(
        error.contains("solver.integrator = \"midpoint\" is the exact engine's"),
        "{error}"
    );
}
