//! Continuous algebraic Riccati equation (CARE)
//! `AᵀX + XA − XBR⁻¹BᵀX + Q = 0`, solved for its stabilising solution.
//!
//! Method: the matrix sign function of the Hamiltonian
//! `H = [[A, −BR⁻¹Bᵀ], [−Q, −Aᵀ]]`, computed by the Newton iteration
//! `Z ← (Z/c + c·Z⁻¹)/2` with determinant scaling `c = |det Z|^{1/2n}`
//! (Roberts 1971/1980; Gardiner & Laub 1986; scaling from Byers 1987, "Solving the algebraic
//! Riccati equation with the matrix sign function", Linear Algebra Appl. 85:267–279). This is the
//! scheme Drake's `ContinuousAlgebraicRiccatiEquation` uses. With `W = sign(H)`, the stable
//! invariant subspace of `H` is the null space of `W + I`; writing it as the graph `[I; X]` gives
//! the overdetermined system `[W₁₂; W₂₂ + I]·X = −[W₁₁ + I; W₂₁]`, solved in the least-squares
//! sense (SVD) and symmetrised.
//!
//! The sign function exists only if `H` has no eigenvalue on the imaginary axis, which is exactly
//! what fails when `(A, B)` is not stabilisable or `(A, Q)` has an unobservable mode on the axis;
//! the iterate then turns singular or stops converging. Every result is verified before it is
//! returned (`X` symmetric positive semidefinite, `A − BK` Hurwitz, small residual), so a solution
//! of the wrong branch never leaves this module.

use nalgebra::{Cholesky, DMatrix, Schur, SymmetricEigen, SVD};
use serde::Deserialize;
use thiserror::Error;

/// Why a CARE could not be solved.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum CareError {
    /// The matrices do not fit together (A n×n, B n×m, Q n×n, R m×m, n, m ≥ 1).
    #[error("CARE dimension mismatch: {0}")]
    DimensionMismatch(String),
    /// A NaN or infinite entry.
    #[error("CARE input {matrix} has a non-finite entry")]
    NonFinite {
        /// Which input: `A`, `B`, `Q` or `R`.
        matrix: &'static str,
    },
    /// Q must be symmetric positive semidefinite (a state cost).
    #[error("CARE weight Q must be symmetric positive semidefinite ({reason})")]
    QNotPositiveSemidefinite {
        /// What is wrong with Q (asymmetry, a negative eigenvalue).
        reason: String,
    },
    /// R must be symmetric positive definite (every input costs something).
    #[error("CARE weight R must be symmetric positive definite ({reason})")]
    RNotPositiveDefinite {
        /// What is wrong with R (asymmetry, no Cholesky factor).
        reason: String,
    },
    /// An iterative stage ran out of iterations.
    #[error("CARE {stage} did not converge within {iterations} iterations")]
    NoConvergence {
        /// The stage that gave up, e.g. `matrix sign iteration`.
        stage: &'static str,
        /// The iteration cap it reached.
        iterations: usize,
    },
    /// No stabilising solution exists: `(A, B)` is not stabilisable or `(A, Q)` has an
    /// unobservable mode on the imaginary axis.
    #[error(
        "no stabilising CARE solution: (A, B) not stabilisable or (A, Q) not detectable ({reason})"
    )]
    Unstabilisable {
        /// The symptom: a singular iterate, a rank-deficient basis, a non-Hurwitz `A − BK`, …
        reason: String,
    },
    /// A solution was found but does not satisfy the equation to the required accuracy.
    #[error("CARE solution inaccurate: backward residual {backward_residual:e} exceeds {limit:e}")]
    Inaccurate {
        /// The backward residual reached (see [`CareSolution::backward_residual`]).
        backward_residual: f64,
        /// The accepted limit, [`CareOptions::max_backward_residual`].
        limit: f64,
    },
}

/// Iteration controls of the sign-function solver.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CareOptions {
    /// Cap on sign-function iterations; with determinant scaling 10–20 is typical.
    pub max_iterations: usize,
    /// Stop when `‖Z_{k+1} − Z_k‖_F ≤ tolerance·‖Z_{k+1}‖_F`.
    pub tolerance: f64,
    /// Largest accepted backward residual (see [`CareSolution::backward_residual`]).
    pub max_backward_residual: f64,
}

impl Default for CareOptions {
    fn default() -> Self {
        Self {
            max_iterations: 100,
            tolerance: 1e-13,
            max_backward_residual: 1e-10,
        }
    }
}

/// Stabilising CARE solution with the matching optimal gain.
#[derive(Debug, Clone, PartialEq)]
pub struct CareSolution {
    /// `X = Xᵀ ⪰ 0`.
    pub x: DMatrix<f64>,
    /// `K = R⁻¹BᵀX`; `A − BK` is Hurwitz.
    pub gain: DMatrix<f64>,
    /// Sign-function iterations used.
    pub iterations: usize,
    /// `‖AᵀX + XA − XBR⁻¹BᵀX + Q‖_F / ‖X‖_F` of the returned `X`.
    pub relative_residual: f64,
    /// The same residual scaled by the size of the terms it is made of,
    /// `‖Q‖_F + 2‖A‖_F‖X‖_F + ‖G‖_F‖X‖_F²` with `G = BR⁻¹Bᵀ`: rounding alone leaves it near
    /// machine precision, whereas `relative_residual` has a floor near `ε‖G‖‖X‖`, which is large
    /// for nearly uncontrollable plants.
    pub backward_residual: f64,
}

/// Relative asymmetry accepted in Q and R (they are symmetrised afterwards).
const SYMMETRY_TOL: f64 = 1e-10;
/// Relative size of a negative eigenvalue still counted as zero in the PSD tests.
const PSD_TOL: f64 = 1e-10;
/// Relative singular value below which the graph basis `[W₁₂; W₂₂ + I]` counts as rank deficient.
const RANK_TOL: f64 = 1e-11;
/// Relative distance to the imaginary axis that marks a Hamiltonian eigenvalue as lying on it.
const IMAGINARY_AXIS_TOL: f64 = 1e-8;
/// Once the relative change is below this and stops shrinking, rounding has taken over.
const STAGNATION_LEVEL: f64 = 1e-8;
/// Iteration cap for the eigenvalue and SVD helpers (they converge in a few dozen sweeps).
const DECOMPOSITION_MAX_ITER: usize = 10_000;

/// Solves the CARE with [`CareOptions::default`].
pub fn solve_care(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    q: &DMatrix<f64>,
    r: &DMatrix<f64>,
) -> Result<CareSolution, CareError> {
    solve_care_with(a, b, q, r, &CareOptions::default())
}

/// Solves the CARE `AᵀX + XA − XBR⁻¹BᵀX + Q = 0` for its stabilising solution.
pub fn solve_care_with(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    q: &DMatrix<f64>,
    r: &DMatrix<f64>,
    options: &CareOptions,
) -> Result<CareSolution, CareError> {
    check_dimensions(a, b, q, r)?;
    for (matrix, name) in [(a, "A"), (b, "B"), (q, "Q"), (r, "R")] {
        if matrix.iter().any(|v| !v.is_finite()) {
            return Err(CareError::NonFinite { matrix: name });
        }
    }
    let n = a.nrows();
    let q = symmetrised(q).map_err(|reason| CareError::QNotPositiveSemidefinite { reason })?;
    let r = symmetrised(r).map_err(|reason| CareError::RNotPositiveDefinite { reason })?;
    let q_min = min_symmetric_eigenvalue(&q)?;
    if q_min < -PSD_TOL * q.norm() {
        return Err(CareError::QNotPositiveSemidefinite {
            reason: format!("smallest eigenvalue {q_min:e}"),
        });
    }
    let r_chol = Cholesky::new(r.clone()).ok_or_else(|| CareError::RNotPositiveDefinite {
        reason: "Cholesky factorisation failed".into(),
    })?;
    let r_inv_bt = r_chol.solve(&b.transpose());
    let g = symmetric_part(&(b * &r_inv_bt));

    let mut h = DMatrix::<f64>::zeros(2 * n, 2 * n);
    h.view_mut((0, 0), (n, n)).copy_from(a);
    h.view_mut((0, n), (n, n)).copy_from(&(-&g));
    h.view_mut((n, 0), (n, n)).copy_from(&(-&q));
    h.view_mut((n, n), (n, n)).copy_from(&(-a.transpose()));

    let (w, iterations) = matrix_sign(&h, options)?;

    // Stable subspace of H = null space of (W + I) = span [I; X].
    let mut lhs = DMatrix::<f64>::zeros(2 * n, n);
    lhs.view_mut((0, 0), (n, n))
        .copy_from(&w.view((0, n), (n, n)));
    lhs.view_mut((n, 0), (n, n))
        .copy_from(&(w.view((n, n), (n, n)) + DMatrix::<f64>::identity(n, n)));
    let mut rhs = DMatrix::<f64>::zeros(2 * n, n);
    rhs.view_mut((0, 0), (n, n))
        .copy_from(&(-(w.view((0, 0), (n, n)) + DMatrix::<f64>::identity(n, n))));
    rhs.view_mut((n, 0), (n, n))
        .copy_from(&(-w.view((n, 0), (n, n))));
    let svd = SVD::try_new(lhs, true, true, f64::EPSILON, DECOMPOSITION_MAX_ITER).ok_or(
        CareError::NoConvergence {
            stage: "SVD of the invariant-subspace basis",
            iterations: DECOMPOSITION_MAX_ITER,
        },
    )?;
    let sigma_max = svd.singular_values.max();
    let sigma_min = svd.singular_values.min();
    if sigma_min.is_nan() || sigma_min <= RANK_TOL * sigma_max {
        return Err(CareError::Unstabilisable {
            reason: format!(
                "the stable invariant subspace of the Hamiltonian is not a graph over the state \
                 (σ_min/σ_max = {:e})",
                sigma_min / sigma_max
            ),
        });
    }
    let x = svd
        .solve(&rhs, RANK_TOL * sigma_max)
        .map_err(|_| CareError::NoConvergence {
            stage: "SVD of the invariant-subspace basis",
            iterations: DECOMPOSITION_MAX_ITER,
        })?;
    let x = symmetric_part(&x);
    let gain = &r_inv_bt * &x;

    verify(a, b, &q, &g, x, gain, iterations, options)
}

fn check_dimensions(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    q: &DMatrix<f64>,
    r: &DMatrix<f64>,
) -> Result<(), CareError> {
    let (n, m) = (a.nrows(), b.ncols());
    let bad = |s: String| Err(CareError::DimensionMismatch(s));
    if n == 0 || !a.is_square() {
        return bad(format!(
            "A is {}×{}, must be square and non-empty",
            a.nrows(),
            a.ncols()
        ));
    }
    if m == 0 || b.nrows() != n {
        return bad(format!(
            "B is {}×{}, must be {n}×m with m ≥ 1",
            b.nrows(),
            b.ncols()
        ));
    }
    if q.shape() != (n, n) {
        return bad(format!("Q is {}×{}, must be {n}×{n}", q.nrows(), q.ncols()));
    }
    if r.shape() != (m, m) {
        return bad(format!("R is {}×{}, must be {m}×{m}", r.nrows(), r.ncols()));
    }
    Ok(())
}

/// `(M + Mᵀ)/2`.
fn symmetric_part(m: &DMatrix<f64>) -> DMatrix<f64> {
    (m + m.transpose()) * 0.5
}

/// The symmetric part of `m` if `m` is symmetric up to rounding, else the reason it is not.
fn symmetrised(m: &DMatrix<f64>) -> Result<DMatrix<f64>, String> {
    let asym = (m - m.transpose()).norm();
    if asym > SYMMETRY_TOL * m.norm() {
        return Err(format!("not symmetric: ‖M − Mᵀ‖_F = {asym:e}"));
    }
    Ok(symmetric_part(m))
}

fn min_symmetric_eigenvalue(m: &DMatrix<f64>) -> Result<f64, CareError> {
    let eig = SymmetricEigen::try_new(m.clone(), f64::EPSILON, DECOMPOSITION_MAX_ITER).ok_or(
        CareError::NoConvergence {
            stage: "symmetric eigenvalue decomposition",
            iterations: DECOMPOSITION_MAX_ITER,
        },
    )?;
    Ok(eig.eigenvalues.min())
}

/// Largest real part of the eigenvalues of `m` and smallest |real part|.
fn real_part_extremes(m: &DMatrix<f64>) -> Result<(f64, f64), CareError> {
    let schur = Schur::try_new(m.clone(), f64::EPSILON, DECOMPOSITION_MAX_ITER).ok_or(
        CareError::NoConvergence {
            stage: "Schur eigenvalue decomposition",
            iterations: DECOMPOSITION_MAX_ITER,
        },
    )?;
    let eigenvalues = schur.complex_eigenvalues();
    let max_re = eigenvalues
        .iter()
        .map(|l| l.re)
        .fold(f64::NEG_INFINITY, f64::max);
    let min_abs_re = eigenvalues
        .iter()
        .map(|l| l.re.abs())
        .fold(f64::INFINITY, f64::min);
    Ok((max_re, min_abs_re))
}

/// The Hamiltonian's eigenvalue closest to the imaginary axis, relative to ‖H‖, if it lies on
/// the axis; used to explain a failed sign iteration.
fn imaginary_axis_eigenvalue(h: &DMatrix<f64>) -> Result<Option<f64>, CareError> {
    let (_, min_abs_re) = real_part_extremes(h)?;
    let relative = min_abs_re / h.norm();
    // 0/0 (an all-zero H) counts as on the axis.
    Ok((relative.is_nan() || relative <= IMAGINARY_AXIS_TOL).then_some(relative))
}

/// Newton iteration for `sign(H)` with determinant scaling (Byers 1987).
fn matrix_sign(
    h: &DMatrix<f64>,
    options: &CareOptions,
) -> Result<(DMatrix<f64>, usize), CareError> {
    let dim = h.nrows() as f64;
    let singular = |reason: &str| CareError::Unstabilisable {
        reason: format!("{reason}: the Hamiltonian has an eigenvalue on the imaginary axis"),
    };
    let mut z = h.clone();
    let mut previous_change = f64::INFINITY;
    for iteration in 1..=options.max_iterations {
        let lu = z.clone().lu();
        let log_abs_det: f64 = lu.u().diagonal().iter().map(|d| d.abs().ln()).sum();
        if !log_abs_det.is_finite() {
            return Err(singular("sign iteration met a singular iterate"));
        }
        let z_inv = match lu.try_inverse() {
            Some(inv) if inv.iter().all(|v| v.is_finite()) => inv,
            _ => return Err(singular("sign iteration met a singular iterate")),
        };
        let c = (log_abs_det / dim).exp();
        let next = (&z / c + z_inv * c) * 0.5;
        let change = (&next - &z).norm() / next.norm();
        z = next;
        if !change.is_finite() {
            return Err(singular("sign iteration diverged"));
        }
        // Quadratic convergence: either the change meets the tolerance, or it has reached the
        // rounding floor and stopped decreasing.
        if change <= options.tolerance
            || (change <= STAGNATION_LEVEL && change >= 0.5 * previous_change)
        {
            return Ok((z, iteration));
        }
        previous_change = change;
    }
    match imaginary_axis_eigenvalue(h)? {
        Some(relative) => Err(CareError::Unstabilisable {
            reason: format!(
                "sign iteration did not converge; a Hamiltonian eigenvalue has |Re λ|/‖H‖ = \
                 {relative:e}"
            ),
        }),
        None => Err(CareError::NoConvergence {
            stage: "matrix sign iteration",
            iterations: options.max_iterations,
        }),
    }
}

/// Accepts `X` only if it is the stabilising, PSD solution and satisfies the equation.
#[allow(clippy::too_many_arguments)]
fn verify(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    q: &DMatrix<f64>,
    g: &DMatrix<f64>,
    x: DMatrix<f64>,
    gain: DMatrix<f64>,
    iterations: usize,
    options: &CareOptions,
) -> Result<CareSolution, CareError> {
    if x.iter().any(|v| !v.is_finite()) {
        return Err(CareError::Unstabilisable {
            reason: "the extracted X is not finite".into(),
        });
    }
    let x_norm = x.norm();
    let x_min = min_symmetric_eigenvalue(&x)?;
    if x_min < -PSD_TOL * x_norm {
        return Err(CareError::Unstabilisable {
            reason: format!("X is not positive semidefinite (smallest eigenvalue {x_min:e})"),
        });
    }
    let closed_loop = a - b * &gain;
    let (max_re, _) = real_part_extremes(&closed_loop)?;
    if max_re.is_nan() || max_re >= -100.0 * f64::EPSILON * closed_loop.norm() {
        return Err(CareError::Unstabilisable {
            reason: format!("A − BK is not Hurwitz (largest real part {max_re:e})"),
        });
    }
    let residual = (a.transpose() * &x + &x * a - &x * g * &x + q).norm();
    let scale = q.norm() + 2.0 * a.norm() * x_norm + g.norm() * x_norm * x_norm;
    let (relative_residual, backward_residual) = if residual == 0.0 {
        (0.0, 0.0)
    } else {
        (residual / x_norm, residual / scale)
    };
    if backward_residual.is_nan() || backward_residual > options.max_backward_residual {
        return Err(CareError::Inaccurate {
            backward_residual,
            limit: options.max_backward_residual,
        });
    }
    Ok(CareSolution {
        x,
        gain,
        iterations,
        relative_residual,
        backward_residual,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// SplitMix64: a small deterministic generator so the random cases are reproducible.
    struct SplitMix64(u64);

    impl SplitMix64 {
        fn next_u64(&mut self) -> u64 {
            self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^ (z >> 31)
        }

        /// Uniform in [-1, 1).
        fn uniform(&mut self) -> f64 {
            (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        }

        fn matrix(&mut self, rows: usize, cols: usize, scale: f64) -> DMatrix<f64> {
            DMatrix::from_fn(rows, cols, |_, _| scale * self.uniform())
        }
    }

    /// `(‖Res‖/‖X‖, ‖Res‖/(‖Q‖ + 2‖A‖‖X‖ + ‖G‖‖X‖²), ε‖G‖‖X‖)`, computed independently of the
    /// solver; the last is the rounding floor of the first.
    fn residuals(
        a: &DMatrix<f64>,
        b: &DMatrix<f64>,
        q: &DMatrix<f64>,
        r: &DMatrix<f64>,
        x: &DMatrix<f64>,
    ) -> (f64, f64, f64) {
        let g = b * r.clone().try_inverse().unwrap() * b.transpose();
        let res = (a.transpose() * x + x * a - x * &g * x + q).norm();
        let xn = x.norm();
        let scale = q.norm() + 2.0 * a.norm() * xn + g.norm() * xn * xn;
        (res / xn, res / scale, f64::EPSILON * g.norm() * xn)
    }

    #[test]
    fn double_integrator_closed_form() {
        let a = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, 0.0, 0.0]);
        let b = DMatrix::from_row_slice(2, 1, &[0.0, 1.0]);
        let q = DMatrix::identity(2, 2);
        let r = DMatrix::from_element(1, 1, 1.0);
        let sol = solve_care(&a, &b, &q, &r).unwrap();
        let s3 = 3f64.sqrt();
        let expected = DMatrix::from_row_slice(2, 2, &[s3, 1.0, 1.0, s3]);
        assert!((&sol.x - expected).norm() < 1e-12, "X = {}", sol.x);
        assert!(sol.relative_residual < 1e-13, "{}", sol.relative_residual);
    }

    #[test]
    fn scalar_closed_form() {
        // 2aX − X²b²/r + q = 0  ⇒  X = r(a + √(a² + b²q/r))/b².
        for &(a, b, q, r) in &[
            (1.0f64, 1.0f64, 1.0f64, 1.0f64),
            (-2.0, 0.5, 3.0, 0.1),
            (5.0, 2.0, 0.0, 4.0),
        ] {
            let expected = r * (a + (a * a + b * b * q / r).sqrt()) / (b * b);
            let sol = solve_care(
                &DMatrix::from_element(1, 1, a),
                &DMatrix::from_element(1, 1, b),
                &DMatrix::from_element(1, 1, q),
                &DMatrix::from_element(1, 1, r),
            )
            .unwrap();
            assert!(
                (sol.x[(0, 0)] - expected).abs() <= 1e-12 * expected.abs().max(1.0),
                "a={a}: X = {} expected {expected}",
                sol.x[(0, 0)]
            );
        }
    }

    #[test]
    fn stable_plant_without_state_cost_gives_zero() {
        let a = DMatrix::from_row_slice(2, 2, &[-1.0, 2.0, 0.0, -3.0]);
        let b = DMatrix::from_row_slice(2, 1, &[0.0, 1.0]);
        let sol = solve_care(&a, &b, &DMatrix::zeros(2, 2), &DMatrix::identity(1, 1)).unwrap();
        assert!(sol.x.norm() < 1e-12, "X = {}", sol.x);
    }

    #[test]
    fn random_stabilisable_systems() {
        let mut rng = SplitMix64(0x5EED_CA7E);
        let (mut worst, mut worst_backward, mut well_scaled) = (0.0f64, 0.0f64, 0);
        for case in 0..300 {
            let n = 1 + case % 6;
            let m = 1 + (case / 6) % n.min(3);
            let scale = [0.5, 1.0, 3.0][case % 3];
            let a = rng.matrix(n, n, scale);
            let b = rng.matrix(n, m, 1.0);
            let cq = rng.matrix(1 + case % n, n, 1.0);
            let q = cq.transpose() * cq;
            let dr = rng.matrix(m, m, 1.0);
            let r = dr.transpose() * dr + DMatrix::identity(m, m) * 0.1;
            let sol = solve_care(&a, &b, &q, &r)
                .unwrap_or_else(|e| panic!("case {case} (n={n}, m={m}): {e}"));
            assert_eq!(sol.x, sol.x.transpose());
            let closed = &a - &b * &sol.gain;
            assert!(closed.complex_eigenvalues().iter().all(|l| l.re < 0.0));
            let (relative, backward, floor) = residuals(&a, &b, &q, &r, &sol.x);
            assert!(
                backward <= 1e-12,
                "case {case}: backward residual {backward:e}"
            );
            worst_backward = worst_backward.max(backward);
            // ‖Res‖/‖X‖ cannot beat ε‖G‖‖X‖ (evaluating XGX rounds at that level); hold it to
            // 1e-9 wherever that floor is well below the target.
            if floor <= 1e-10 {
                assert!(
                    relative <= 1e-9,
                    "case {case}: relative residual {relative:e}"
                );
                worst = worst.max(relative);
                well_scaled += 1;
            }
        }
        assert!(well_scaled >= 290, "only {well_scaled} well-scaled cases");
        println!(
            "{well_scaled}/300 well-scaled: worst ‖Res‖/‖X‖ = {worst:e}; \
             all 300: worst backward residual = {worst_backward:e}"
        );
    }

    #[test]
    fn unstable_uncontrollable_mode_is_rejected() {
        let a = DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 0.0, -1.0]);
        let b = DMatrix::from_row_slice(2, 1, &[0.0, 1.0]);
        let err = solve_care(&a, &b, &DMatrix::identity(2, 2), &DMatrix::identity(1, 1));
        assert!(
            matches!(err, Err(CareError::Unstabilisable { .. })),
            "{err:?}"
        );
    }

    #[test]
    fn imaginary_axis_hamiltonian_is_rejected() {
        // Uncontrollable, unweighted oscillator: Hamiltonian eigenvalues ±i.
        let a = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, -1.0, 0.0]);
        let b = DMatrix::zeros(2, 1);
        let err = solve_care(&a, &b, &DMatrix::zeros(2, 2), &DMatrix::identity(1, 1));
        assert!(
            matches!(err, Err(CareError::Unstabilisable { .. })),
            "{err:?}"
        );
        // Undetectable integrator: nilpotent Hamiltonian.
        let one = DMatrix::from_element(1, 1, 1.0);
        let err = solve_care(&DMatrix::zeros(1, 1), &one, &DMatrix::zeros(1, 1), &one);
        assert!(
            matches!(err, Err(CareError::Unstabilisable { .. })),
            "{err:?}"
        );
    }

    #[test]
    fn input_errors() {
        let a = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, 0.0, 0.0]);
        let b = DMatrix::from_row_slice(2, 1, &[0.0, 1.0]);
        let q = DMatrix::identity(2, 2);
        let r = DMatrix::identity(1, 1);
        let err = solve_care(&a, &DMatrix::zeros(3, 1), &q, &r);
        assert!(
            matches!(err, Err(CareError::DimensionMismatch(_))),
            "{err:?}"
        );
        let err = solve_care(&a, &b, &q, &DMatrix::identity(2, 2));
        assert!(
            matches!(err, Err(CareError::DimensionMismatch(_))),
            "{err:?}"
        );
        let err = solve_care(&a, &b, &q, &DMatrix::from_element(1, 1, 0.0));
        assert!(
            matches!(err, Err(CareError::RNotPositiveDefinite { .. })),
            "{err:?}"
        );
        let err = solve_care(&a, &b, &q, &DMatrix::from_element(1, 1, -1.0));
        assert!(
            matches!(err, Err(CareError::RNotPositiveDefinite { .. })),
            "{err:?}"
        );
        let r2 = DMatrix::from_row_slice(2, 2, &[1.0, 0.5, 0.0, 1.0]);
        let err = solve_care(&a, &DMatrix::identity(2, 2), &q, &r2);
        assert!(
            matches!(err, Err(CareError::RNotPositiveDefinite { .. })),
            "{err:?}"
        );
        let err = solve_care(&a, &b, &(-&q), &r);
        assert!(
            matches!(err, Err(CareError::QNotPositiveSemidefinite { .. })),
            "{err:?}"
        );
        let mut a_nan = a.clone();
        a_nan[(0, 0)] = f64::NAN;
        let err = solve_care(&a_nan, &b, &q, &r);
        assert_eq!(err, Err(CareError::NonFinite { matrix: "A" }));
    }

    #[test]
    fn iteration_cap_reports_non_convergence() {
        let a = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, 0.0, 0.0]);
        let b = DMatrix::from_row_slice(2, 1, &[0.0, 1.0]);
        let options = CareOptions {
            max_iterations: 1,
            ..Default::default()
        };
        let err = solve_care_with(
            &a,
            &b,
            &DMatrix::identity(2, 2),
            &DMatrix::identity(1, 1),
            &options,
        );
        assert!(
            matches!(err, Err(CareError::NoConvergence { iterations: 1, .. })),
            "{err:?}"
        );
        let strict = CareOptions {
            max_backward_residual: 0.0,
            ..Default::default()
        };
        let q = DMatrix::from_row_slice(2, 2, &[2.0, 0.3, 0.3, 0.7]);
        let err = solve_care_with(&a, &b, &q, &DMatrix::from_element(1, 1, 0.3), &strict);
        assert!(matches!(err, Err(CareError::Inaccurate { .. })), "{err:?}");
    }
}
