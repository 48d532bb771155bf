//! Single-input pole placement by Ackermann's formula
//! `K = [0 … 0 1]·𝒞⁻¹·φ(A)`, `𝒞 = [b, Ab, …, Aⁿ⁻¹b]`, which makes the characteristic polynomial
//! of `A − bK` equal to the desired monic `φ`. This is how the paper's feedforward-feedback
//! baseline is tuned: Perrusquía eq (38) asks for `det(λI − A + BK) = λ² + 2ξω_nλ + ω_n²`.
//!
//! Sign convention: the closed loop is `A − bK`, i.e. `u = −Kx` on the state, or `u = +Ke` on the
//! paper's error `e = z_d − z` (Perrusquía eq (12) has `ė = Ae − B(u + …)`). The paper writes its
//! feedback as `u_f = −Ke` next to Perrusquía eq (38), which with its own error definition would
//! give `A + BK`; the gains here are the ones that realise Perrusquía eq (38) itself.
//!
//! Ackermann's formula inverts the controllability matrix, so it is meant for the small models
//! used here (a few states), not as a general-purpose placement routine.

use nalgebra::{DMatrix, RowDVector, SVD};
use serde::Deserialize;
use thiserror::Error;

/// Why a pole-placement design failed.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum PolePlacementError {
    /// A must be n×n (n ≥ 1) and b n×1.
    #[error("pole placement dimension mismatch: {0}")]
    DimensionMismatch(String),
    /// The number of poles (a complex pair counts twice) or coefficients differs from n.
    #[error("pole placement needs {expected} poles/coefficients, got {got}")]
    WrongOrder {
        /// The state dimension n.
        expected: usize,
        /// The order the poles or coefficients give.
        got: usize,
    },
    /// A NaN or infinite value in the model or the specification.
    #[error("pole placement input {what} has a non-finite entry")]
    NonFinite {
        /// Which input: `A`, `b`, `coefficients` or `poles`.
        what: &'static str,
    },
    /// A second-order specification with ω_n ≤ 0 or ξ < 0.
    #[error("second-order specification needs ω_n > 0 and ξ ≥ 0 (got ω_n = {natural_frequency}, ξ = {damping_ratio})")]
    BadSecondOrder {
        /// The natural frequency ω_n given, rad/s.
        natural_frequency: f64,
        /// The damping ratio ξ given.
        damping_ratio: f64,
    },
    /// `(A, b)` is not controllable, so some poles cannot be moved.
    #[error("(A, b) is not controllable: controllability matrix σ_min/σ_max = {ratio:e}")]
    Uncontrollable {
        /// σ_min/σ_max of the controllability matrix `[b, Ab, …, Aⁿ⁻¹b]`.
        ratio: f64,
    },
}

/// A desired closed-loop pole; complex poles are given once and stand for the conjugate pair,
/// so the characteristic polynomial is always real.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Pole {
    /// A real pole at `s = value`, rad/s.
    Real(f64),
    /// The pair `s = re ± i·im`, rad/s.
    Complex {
        /// Real part, rad/s; negative for a stable pair.
        re: f64,
        /// Imaginary part (damped frequency), rad/s.
        im: f64,
    },
}

/// Relative singular value below which the controllability matrix counts as singular.
const CONTROLLABILITY_TOL: f64 = 1e-12;

/// Coefficients `[c₁, …, c_n]` of the monic polynomial `λⁿ + c₁λⁿ⁻¹ + … + c_n` whose roots are
/// `poles` (each complex entry contributing `λ² − 2·re·λ + re² + im²`).
pub fn characteristic_polynomial(poles: &[Pole]) -> Result<Vec<f64>, PolePlacementError> {
    let mut coefficients = vec![1.0];
    for pole in poles {
        let factor = match *pole {
            Pole::Real(p) => vec![1.0, -p],
            Pole::Complex { re, im } => vec![1.0, -2.0 * re, re * re + im * im],
        };
        if factor.iter().any(|c| !c.is_finite()) {
            return Err(PolePlacementError::NonFinite { what: "poles" });
        }
        let mut product = vec![0.0; coefficients.len() + factor.len() - 1];
        for (i, a) in coefficients.iter().enumerate() {
            for (j, f) in factor.iter().enumerate() {
                product[i + j] += a * f;
            }
        }
        coefficients = product;
    }
    Ok(coefficients.split_off(1))
}

/// Perrusquía eq (38): `[2ξω_n, ω_n²]` for `λ² + 2ξω_nλ + ω_n²`.
pub fn second_order_polynomial(
    natural_frequency: f64,
    damping_ratio: f64,
) -> Result<[f64; 2], PolePlacementError> {
    let valid = natural_frequency.is_finite()
        && natural_frequency > 0.0
        && damping_ratio.is_finite()
        && damping_ratio >= 0.0;
    if !valid {
        return Err(PolePlacementError::BadSecondOrder {
            natural_frequency,
            damping_ratio,
        });
    }
    Ok([
        2.0 * damping_ratio * natural_frequency,
        natural_frequency * natural_frequency,
    ])
}

/// Ackermann's formula: the gain row `K` with `det(λI − A + bK) = λⁿ + c₁λⁿ⁻¹ + … + c_n`.
pub fn ackermann(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    coefficients: &[f64],
) -> Result<RowDVector<f64>, PolePlacementError> {
    let n = a.nrows();
    if n == 0 || !a.is_square() {
        return Err(PolePlacementError::DimensionMismatch(format!(
            "A is {}×{}, must be square and non-empty",
            a.nrows(),
            a.ncols()
        )));
    }
    if b.shape() != (n, 1) {
        return Err(PolePlacementError::DimensionMismatch(format!(
            "b is {}×{}, must be {n}×1 (single input)",
            b.nrows(),
            b.ncols()
        )));
    }
    if coefficients.len() != n {
        return Err(PolePlacementError::WrongOrder {
            expected: n,
            got: coefficients.len(),
        });
    }
    for (values, what) in [
        (a.as_slice(), "A"),
        (b.as_slice(), "b"),
        (coefficients, "coefficients"),
    ] {
        if values.iter().any(|v| !v.is_finite()) {
            return Err(PolePlacementError::NonFinite { what });
        }
    }

    let mut controllability = DMatrix::<f64>::zeros(n, n);
    let mut column = b.clone();
    for k in 0..n {
        controllability.set_column(k, &column.column(0));
        column = a * column;
    }
    let singular_values = SVD::new(controllability.clone(), false, false).singular_values;
    let ratio = singular_values.min() / singular_values.max();
    if ratio.is_nan() || ratio <= CONTROLLABILITY_TOL {
        return Err(PolePlacementError::Uncontrollable { ratio });
    }
    // wᵀ = e_nᵀ 𝒞⁻¹, i.e. 𝒞ᵀw = e_n.
    let mut e_n = DMatrix::<f64>::zeros(n, 1);
    e_n[(n - 1, 0)] = 1.0;
    let w = controllability
        .transpose()
        .lu()
        .solve(&e_n)
        .ok_or(PolePlacementError::Uncontrollable { ratio })?;

    // φ(A) by Horner's rule.
    let identity = DMatrix::<f64>::identity(n, n);
    let mut phi = identity.clone();
    for &c in coefficients {
        phi = phi * a + &identity * c;
    }
    Ok(RowDVector::from_iterator(
        n,
        (w.transpose() * phi).iter().copied(),
    ))
}

/// Places the closed-loop poles of `A − bK` at `poles`.
pub fn place_poles(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    poles: &[Pole],
) -> Result<RowDVector<f64>, PolePlacementError> {
    let order: usize = poles
        .iter()
        .map(|p| match p {
            Pole::Real(_) => 1,
            Pole::Complex { .. } => 2,
        })
        .sum();
    if order != a.nrows() {
        return Err(PolePlacementError::WrongOrder {
            expected: a.nrows(),
            got: order,
        });
    }
    ackermann(a, b, &characteristic_polynomial(poles)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn slider(b: f64) -> (DMatrix<f64>, DMatrix<f64>) {
        (
            DMatrix::from_row_slice(2, 2, &[0.0, 1.0, 0.0, 0.0]),
            DMatrix::from_row_slice(2, 1, &[0.0, b]),
        )
    }

    /// For `ẍ = b·u`, `A − bK = [[0, 1], [−b·k₁, −b·k₂]]` has `λ² + b·k₂λ + b·k₁`, so matching
    /// Perrusquía eq (38) gives `k₁ = ω_n²/b`, `k₂ = 2ξω_n/b`.
    #[test]
    fn eq_38_baseline_on_the_slider() {
        let coefficients = second_order_polynomial(1000f64.sqrt(), 1.0).unwrap();
        // b = 1/m for the twin's 5 kg ram and the value of Perrusquía eq (36).
        for b in [1.0 / 5.0, 2222.22] {
            let (a, bm) = slider(b);
            let k = ackermann(&a, &bm, &coefficients).unwrap();
            let expected = [1000.0 / b, 2.0 * 1000f64.sqrt() / b];
            for (got, want) in k.iter().zip(expected) {
                assert!((got - want).abs() <= 1e-9 * want, "b={b}: K = {k}");
            }
        }
        // Same result from the pole list: a double pole at −√1000 (ξ = 1).
        let (a, bm) = slider(0.2);
        let p = -(1000f64.sqrt());
        let k = place_poles(&a, &bm, &[Pole::Real(p), Pole::Real(p)]).unwrap();
        assert!((k[0] - 5000.0).abs() < 1e-8 && (k[1] - 10.0 * 1000f64.sqrt()).abs() < 1e-9);
    }

    #[test]
    fn complex_and_real_poles_on_a_third_order_plant() {
        let a = DMatrix::from_row_slice(3, 3, &[0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 2.0, -1.0, 0.5]);
        let b = DMatrix::from_row_slice(3, 1, &[0.0, 0.0, 1.0]);
        let poles = [Pole::Complex { re: -2.0, im: 3.0 }, Pole::Real(-1.0)];
        let k = place_poles(&a, &b, &poles).unwrap();
        let closed = &a - &b * DMatrix::from_row_slice(1, 3, k.as_slice());
        let mut eig: Vec<_> = closed.complex_eigenvalues().iter().copied().collect();
        eig.sort_by(|x, y| x.im.total_cmp(&y.im));
        let expected = [(-2.0, -3.0), (-1.0, 0.0), (-2.0, 3.0)];
        for (l, (re, im)) in eig.iter().zip(expected) {
            assert!(
                (l.re - re).abs() < 1e-9 && (l.im - im).abs() < 1e-9,
                "{eig:?}"
            );
        }
    }

    #[test]
    fn cayley_hamilton_on_a_non_companion_plant() {
        // φ(A − bK) = 0 certifies the characteristic polynomial (A − bK is cyclic).
        let a = DMatrix::from_row_slice(3, 3, &[1.0, 2.0, 0.0, -1.0, 0.5, 1.0, 0.3, 0.0, -2.0]);
        let b = DMatrix::from_row_slice(3, 1, &[1.0, 0.0, 1.0]);
        let c = [6.0, 11.0, 6.0];
        let k = ackermann(&a, &b, &c).unwrap();
        let closed = &a - &b * DMatrix::from_row_slice(1, 3, k.as_slice());
        let id = DMatrix::<f64>::identity(3, 3);
        let phi =
            &closed * &closed * &closed + &closed * &closed * c[0] + &closed * c[1] + id * c[2];
        assert!(phi.norm() < 1e-9, "φ(A − bK) = {phi}");
    }

    #[test]
    fn polynomial_from_poles() {
        let c = characteristic_polynomial(&[Pole::Real(-1.0), Pole::Complex { re: -1.0, im: 1.0 }])
            .unwrap();
        // (λ + 1)(λ² + 2λ + 2) = λ³ + 3λ² + 4λ + 2
        assert_eq!(c, vec![3.0, 4.0, 2.0]);
    }

    #[test]
    fn errors() {
        let a = DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 0.0, 2.0]);
        let b = DMatrix::from_row_slice(2, 1, &[1.0, 0.0]);
        let err = ackermann(&a, &b, &[3.0, 2.0]);
        assert!(
            matches!(err, Err(PolePlacementError::Uncontrollable { .. })),
            "{err:?}"
        );
        let (a, b) = slider(1.0);
        assert_eq!(
            place_poles(&a, &b, &[Pole::Real(-1.0)]),
            Err(PolePlacementError::WrongOrder {
                expected: 2,
                got: 1
            })
        );
        let err = ackermann(&a, &DMatrix::zeros(2, 2), &[1.0, 1.0]);
        assert!(
            matches!(err, Err(PolePlacementError::DimensionMismatch(_))),
            "{err:?}"
        );
        assert_eq!(
            ackermann(&a, &b, &[f64::NAN, 1.0]),
            Err(PolePlacementError::NonFinite {
                what: "coefficients"
            })
        );
        assert!(matches!(
            second_order_polynomial(0.0, 1.0),
            Err(PolePlacementError::BadSecondOrder { .. })
        ));
    }
}
