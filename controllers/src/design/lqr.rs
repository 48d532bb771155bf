//! Infinite-horizon linear-quadratic regulator: the state feedback `u = −Kx` minimising
//! `∫ xᵀQx + uᵀRu dt` for `ẋ = Ax + Bu`. The Whitworth paper's LQT baseline (Perrusquía eq (39))
//! and the reduced problem behind the optimal sliding hyperplane (Perrusquía eqs (24)–(25)) are
//! both of this form.

use super::care::{solve_care, CareError};
use nalgebra::DMatrix;

/// Optimal regulator for `(A, B, Q, R)`.
#[derive(Debug, Clone, PartialEq)]
pub struct Lqr {
    /// `K = R⁻¹BᵀX` (m×n); `A − BK` is Hurwitz.
    pub gain: DMatrix<f64>,
    /// Stabilising CARE solution `X`; the optimal cost from `x₀` is `x₀ᵀXx₀`.
    pub riccati: DMatrix<f64>,
}

/// Solves the regulator through the CARE; every [`CareError`] (bad weights, unstabilisable pair,
/// …) is passed through unchanged.
pub fn lqr(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    q: &DMatrix<f64>,
    r: &DMatrix<f64>,
) -> Result<Lqr, CareError> {
    let solution = solve_care(a, b, q, r)?;
    Ok(Lqr {
        gain: solution.gain,
        riccati: solution.x,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn double_integrator_gain() {
        let a = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, 0.0, 0.0]);
        let b = DMatrix::from_row_slice(2, 1, &[0.0, 1.0]);
        let design = lqr(&a, &b, &DMatrix::identity(2, 2), &DMatrix::identity(1, 1)).unwrap();
        let expected = DMatrix::from_row_slice(1, 2, &[1.0, 3f64.sqrt()]);
        assert!(
            (&design.gain - expected).norm() < 1e-12,
            "K = {}",
            design.gain
        );
        // Closed loop s² + √3 s + 1: both poles at Re = −√3/2.
        for lambda in (&a - &b * &design.gain).complex_eigenvalues().iter() {
            assert!(
                (lambda.re + 3f64.sqrt() / 2.0).abs() < 1e-12,
                "λ = {lambda}"
            );
        }
    }

    #[test]
    fn closed_loop_is_in_the_open_left_half_plane() {
        // An unstable, lightly coupled 3-state plant with two inputs.
        let a = DMatrix::from_row_slice(3, 3, &[0.5, 1.0, 0.0, 0.0, 0.2, 1.0, -1.0, 0.0, 0.1]);
        let b = DMatrix::from_row_slice(3, 2, &[0.0, 0.0, 1.0, 0.0, 0.0, 2.0]);
        let q = DMatrix::from_diagonal(&nalgebra::DVector::from_row_slice(&[10.0, 1.0, 0.1]));
        let r = DMatrix::from_row_slice(2, 2, &[1.0, 0.2, 0.2, 0.5]);
        let design = lqr(&a, &b, &q, &r).unwrap();
        assert_eq!(design.gain.shape(), (2, 3));
        for lambda in (&a - &b * &design.gain).complex_eigenvalues().iter() {
            assert!(lambda.re < -1e-3, "λ = {lambda}");
        }
        let x = &design.riccati;
        let expected_gain = r.clone().try_inverse().unwrap() * b.transpose() * x;
        assert!((&design.gain - expected_gain).norm() < 1e-10);
    }

    #[test]
    fn unstabilisable_pair_is_an_error() {
        let a = DMatrix::from_row_slice(2, 2, &[2.0, 0.0, 0.0, 0.0]);
        let b = DMatrix::from_row_slice(2, 1, &[0.0, 1.0]);
        let err = lqr(&a, &b, &DMatrix::identity(2, 2), &DMatrix::identity(1, 1));
        assert!(
            matches!(err, Err(CareError::Unstabilisable { .. })),
            "{err:?}"
        );
    }
}
