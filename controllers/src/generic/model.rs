//! The mechanism's equations of motion as the model-based generic controllers use them, from the
//! engine's own ([`framework::Dynamics`]): the efforts that give an acceleration (computed
//! torque) and the linearisation at a point (LQR).
//!
//! The engine gives q̈(q, q̇, u) on the independent coordinates. It is affine in the efforts u:
//! q̈ = M⁻¹·(S·u − h), with S the map from the actuators to the coordinates. So at a state the
//! free acceleration a₀ = q̈(q, q̇, 0) = −M⁻¹·h and one evaluation per actuator j with a unit
//! effort give the columns of M⁻¹·S exactly (to round-off), with no derivative taken. A and B of
//! the linearisation are central differences, as `twin linearize` takes them: a step per
//! coordinate hⱼ = ∛ε·max(|xⱼ|, 1).

use framework::{Dynamics, PlantInterface};
use nalgebra::{DMatrix, DVector};

/// The equations at one state, in the coordinates' and actuators' orders.
pub(crate) struct Response {
    /// a₀ = q̈ with no effort.
    pub free: DVector<f64>,
    /// M⁻¹·S: column j is q̈'s answer to a unit effort of actuator j.
    pub per_effort: DMatrix<f64>,
}

/// The coordinates' accelerations at (q, q̇) with no effort and per unit effort of each of the
/// `actuators` actuators.
pub(crate) fn response(
    dynamics: &dyn Dynamics,
    actuators: usize,
    position: &[f64],
    velocity: &[f64],
) -> Result<Response, String> {
    let k = position.len();
    let mut efforts = vec![0.0; actuators];
    let mut free = DVector::zeros(k);
    dynamics.acceleration(position, velocity, &efforts, free.as_mut_slice())?;
    let mut per_effort = DMatrix::zeros(k, actuators);
    let mut answer = vec![0.0; k];
    for j in 0..actuators {
        efforts[j] = 1.0;
        dynamics.acceleration(position, velocity, &efforts, &mut answer)?;
        efforts[j] = 0.0;
        for i in 0..k {
            per_effort[(i, j)] = answer[i] - free[i];
        }
    }
    Ok(Response { free, per_effort })
}

/// x = (q, q̇) and ẋ = f(x, u) linearised at (x₀, u₀): A = ∂f/∂x, B = ∂f/∂u.
pub(crate) struct Linearisation {
    /// A, 2k × 2k.
    pub a: DMatrix<f64>,
    /// B, 2k × m.
    pub b: DMatrix<f64>,
}

/// The central-difference step for a value: ∛ε·max(|v|, 1), as represented at v.
fn step_at(value: f64) -> f64 {
    let h = f64::EPSILON.cbrt() * value.abs().max(1.0);
    (value + h) - value
}

/// A and B at the state `x0` (positions, then velocities) under the efforts `u0`.
pub(crate) fn linearise(
    dynamics: &dyn Dynamics,
    x0: &[f64],
    u0: &[f64],
) -> Result<Linearisation, String> {
    let n = x0.len();
    let k = n / 2;
    let mut a = DMatrix::zeros(n, n);
    for i in 0..k {
        a[(i, k + i)] = 1.0;
    }
    let (mut plus, mut minus) = (vec![0.0; k], vec![0.0; k]);
    for j in 0..n {
        let h = step_at(x0[j]);
        for (sign, answer) in [(1.0, &mut plus), (-1.0, &mut minus)] {
            let mut x = x0.to_vec();
            x[j] += sign * h;
            dynamics.acceleration(&x[..k], &x[k..], u0, answer)?;
        }
        for i in 0..k {
            a[(k + i, j)] = (plus[i] - minus[i]) / (2.0 * h);
        }
    }
    let response = response(dynamics, u0.len(), &x0[..k], &x0[k..])?;
    let mut b = DMatrix::zeros(n, u0.len());
    b.rows_mut(k, k).copy_from(&response.per_effort);
    Ok(Linearisation { a, b })
}

/// Where a coordinate's signals are in the measurement and which actuator drives it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct CoordinateSignals {
    /// `<joint>.position`.
    pub position: usize,
    /// `<joint>.velocity`.
    pub velocity: usize,
    /// Whether it turns (its position error is taken the short way round).
    pub turns: bool,
}

/// The signals of every coordinate of `dynamics` in `plant`'s measurement.
pub(crate) fn coordinate_signals(
    plant: &PlantInterface,
    dynamics: &dyn Dynamics,
) -> Result<Vec<CoordinateSignals>, framework::ControllerError> {
    dynamics
        .coordinates()
        .iter()
        .map(|c| {
            Ok(CoordinateSignals {
                position: plant.signal(&format!("{}.position", c.joint))?,
                velocity: plant.signal(&format!("{}.velocity", c.joint))?,
                turns: c.kind == framework::EffortKind::Torque,
            })
        })
        .collect()
}

/// `reference − measured` for a coordinate: the short way round for one that turns, so a
/// reference at π and a reading of −π + δ are δ apart, not 2π.
pub(crate) fn position_error(reference: f64, measured: f64, turns: bool) -> f64 {
    let error = reference - measured;
    if turns {
        let tau = std::f64::consts::TAU;
        error - tau * (error / tau).round()
    } else {
        error
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use framework::{Coordinate, EffortKind};

    /// Two coordinates with M = [[2, 0.5], [0.5, 1]] and h = (3·q₀ + q̇₁, −1), both driven, the
    /// second actuator on the first coordinate (S swaps them).
    pub(crate) struct TwoJoints {
        pub coordinates: Vec<Coordinate>,
    }

    impl TwoJoints {
        pub(crate) fn new() -> Self {
            let coordinate = |joint: &str| Coordinate {
                joint: joint.into(),
                kind: EffortKind::Torque,
            };
            Self {
                coordinates: vec![coordinate("a"), coordinate("b")],
            }
        }

        pub(crate) fn mass() -> DMatrix<f64> {
            DMatrix::from_row_slice(2, 2, &[2.0, 0.5, 0.5, 1.0])
        }

        pub(crate) fn bias(q: &[f64], v: &[f64]) -> DVector<f64> {
            DVector::from_row_slice(&[3.0 * q[0] + v[1], -1.0])
        }
    }

    impl Dynamics for TwoJoints {
        fn coordinates(&self) -> &[Coordinate] {
            &self.coordinates
        }

        fn acceleration(
            &self,
            position: &[f64],
            velocity: &[f64],
            efforts: &[f64],
            acceleration: &mut [f64],
        ) -> Result<(), String> {
            let tau = DVector::from_row_slice(&[efforts[1], efforts[0]]);
            let rhs = tau - Self::bias(position, velocity);
            let qdd = Self::mass().lu().solve(&rhs).ok_or("singular")?;
            acceleration.copy_from_slice(qdd.as_slice());
            Ok(())
        }
    }

    #[test]
    fn the_response_and_linearisation_are_the_equations_own() {
        let model = TwoJoints::new();
        let (q, v) = ([0.3, -0.2], [0.1, 0.4]);
        let r = response(&model, 2, &q, &v).unwrap();
        let inverse = TwoJoints::mass().try_inverse().unwrap();
        let swapped = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, 1.0, 0.0]);
        assert!((&r.per_effort - &inverse * swapped).amax() < 1e-12);
        assert!((&r.free + &inverse * TwoJoints::bias(&q, &v)).amax() < 1e-12);
        let x0 = [q[0], q[1], v[0], v[1]];
        let l = linearise(&model, &x0, &[0.0, 0.0]).unwrap();
        // ∂q̈/∂q₀ = −M⁻¹·(3, 0), ∂q̈/∂q̇₁ = −M⁻¹·(1, 0).
        for (column, slope) in [(0, 3.0), (3, 1.0)] {
            for i in 0..2 {
                let expected = -inverse[(i, 0)] * slope;
                assert!((l.a[(2 + i, column)] - expected).abs() < 1e-8, "{}", l.a);
            }
        }
        assert_eq!((l.a[(0, 2)], l.a[(1, 3)], l.a[(0, 0)]), (1.0, 1.0, 0.0));
        assert!((l.b.rows(2, 2) - &r.per_effort).amax() < 1e-12);
        assert!((position_error(3.1, -3.1, true) - (6.2 - std::f64::consts::TAU)).abs() < 1e-12);
        assert_eq!(position_error(3.1, -3.1, false), 6.2);
    }
}
