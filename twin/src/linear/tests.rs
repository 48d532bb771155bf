//! The linearisation of a pendulum written here against its closed form: the central
//! differences' error, the poles ±j·√(m·g·l/I), the zero-order hold.

use super::model::{differentiate, Jacobians, Plant};
use crate::physics::{MechanismState, ReducedDynamics};
use crate::urdf;

const GRAVITY: f64 = 9.81;
const MASS: f64 = 2.0;
const LENGTH: f64 = 0.4;
const IZZ: f64 = 0.01;

/// A bob on a pivot (its centre of mass LENGTH along the link's x), damped by `damping`.
fn pendulum(damping: f64) -> crate::mechanism::Mechanism {
    let text = format!(
        r#"<robot name="pendulum">
  <link name="ground"/>
  <link name="bob"><inertial><origin xyz="{LENGTH} 0 0"/><mass value="{MASS}"/>
    <inertia ixx="{IZZ}" ixy="0" ixz="0" iyy="{IZZ}" iyz="0" izz="{IZZ}"/></inertial></link>
  <joint name="pivot" type="continuous"><parent link="ground"/><child link="bob"/>
    <origin xyz="0 0 0" rpy="0 0 0"/><axis xyz="0 0 1"/><limit effort="10" velocity="100"/>
    <dynamics damping="{damping}" friction="0"/></joint>
</robot>"#
    );
    urdf::load_str(&text, "pendulum").unwrap_or_else(|e| panic!("{e}"))
}

/// A, B, C at angle θ (from +x, gravity along −y) and rate θ̇, the pivot torque held at 0.
fn linearise(damping: f64, angle: f64, rate: f64) -> Jacobians {
    let mechanism = pendulum(damping);
    let state = MechanismState {
        joint_positions: vec![angle],
        joint_velocities: vec![rate],
        ..MechanismState::default()
    };
    let mut dynamics = ReducedDynamics::new(&mechanism, [0.0, -GRAVITY], &state, &[], &[0]);
    let x0 = dynamics.operating_state();
    let mut outputs = |state: &MechanismState, values: &mut Vec<f64>| {
        values.clear();
        values.push(state.link_poses[1].y);
    };
    let mut plant = Plant {
        dynamics: &mut dynamics,
        input_joints: &[0],
        joints: 1,
        outputs: &mut outputs,
    };
    differentiate(&mut plant, &x0, &[0.0]).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn the_hanging_pendulum_has_the_closed_form_frequency() {
    let inertia = IZZ + MASS * LENGTH * LENGTH;
    let damping = 0.05;
    let j = linearise(damping, -std::f64::consts::FRAC_PI_2, 0.0);
    // θ̈ = (−m·g·l·cos θ + τ − c·θ̇)/I: at θ = −π/2, ∂θ̈/∂θ = −m·g·l/I = −ω².
    let omega_squared = MASS * GRAVITY * LENGTH / inertia;
    let expected = [[0.0, 1.0], [-omega_squared, -damping / inertia]];
    for (r, row) in expected.iter().enumerate() {
        for (c, want) in row.iter().enumerate() {
            let got = j.a[(r, c)];
            assert!(
                (got - want).abs() <= 1e-9 * want.abs().max(1.0),
                "A[{r}][{c}] {got} vs {want}"
            );
        }
    }
    assert!(
        (j.b[(1, 0)] - 1.0 / inertia).abs() <= 1e-12 / inertia,
        "B {}",
        j.b[(1, 0)]
    );
    // y = the link frame's height, l·sin θ for the frame at the pivot: 0 here, ∂y/∂θ = cos θ = 0.
    assert!(j.c[(0, 0)].abs() < 1e-12 && j.c[(0, 1)] == 0.0, "C {}", j.c);
    let poles = j.a.clone().complex_eigenvalues();
    let (re, im) = (
        -damping / (2.0 * inertia),
        (omega_squared - (damping / (2.0 * inertia)).powi(2)).sqrt(),
    );
    for pole in poles.iter() {
        assert!(
            (pole.re - re).abs() < 1e-9 && (pole.im.abs() - im).abs() < 1e-9,
            "{pole}"
        );
    }
}

#[test]
fn the_central_difference_error_is_far_below_the_model_at_every_angle() {
    // ∂θ̈/∂θ = m·g·l·sin θ / I at any θ, ∂θ̈/∂θ̇ = 0 without damping: the error of
    // h = ∛ε·max(|θ|, 1) is O(h²) truncation plus O(ε·|θ|/h) round-off: ~1e-11 of m·g·l/I
    // within a turn, ~1e-8 at 40 rad, where the step has grown with |θ|.
    let inertia = IZZ + MASS * LENGTH * LENGTH;
    let mut worst: f64 = 0.0;
    for angle in [
        -3.0,
        -std::f64::consts::FRAC_PI_2,
        -0.7,
        0.3,
        1.2,
        2.5,
        6.0,
        40.0,
    ] {
        let j = linearise(0.0, angle, 2.0);
        let want = MASS * GRAVITY * LENGTH * f64::sin(angle) / inertia;
        let error = (j.a[(1, 0)] - want).abs() / (MASS * GRAVITY * LENGTH / inertia);
        println!("pendulum at θ = {angle} rad: central-difference error {error:.2e} of m·g·l/I");
        let bound = if angle.abs() < std::f64::consts::TAU {
            1e-9
        } else {
            2e-8
        };
        assert!(error < bound, "at {angle}: {error:e}");
        worst = worst.max(error);
        assert!(
            j.a[(1, 1)].abs() < 1e-9,
            "∂θ̈/∂θ̇ at {angle}: {}",
            j.a[(1, 1)]
        );
    }
    println!("pendulum: largest central-difference error {worst:.2e} of m·g·l/I");
}
