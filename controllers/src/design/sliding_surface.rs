//! Optimal sliding hyperplane `s = C·e` (Whitworth paper §5.2, Perrusquía eqs (13)–(26)).
//!
//! Construction, for `ė = Ae − B(u + …)` with B (n×m) of full column rank:
//! 1. Regular form (Perrusquía eqs (14)–(16)): `Ψ = T·e` with `T = [N; B†]`, where the rows of `N`
//!    are an orthonormal basis of the left null space of B (`N·B = 0`) and `B† = (BᵀB)⁻¹Bᵀ`; then
//!    `T·B = [0; I]`, `T⁻¹ = [Nᵀ, B]`, and `Ā = T·A·T⁻¹` splits into `A₁₁ … A₂₂` (Perrusquía eq
//!    (17)).
//! 2. The cost `∫ eᵀQe` (Perrusquía eq (20)) in the new coordinates (Perrusquía eq (21)) has weight
//!    `T⁻ᵀ·Q·T⁻¹`, split into `Q₁₁, Q₁₂, Q₂₂`.
//! 3. With `Ψ₂` as the input of the `Ψ₁` subsystem, the change `v = Ψ₂ + Q₂₂⁻¹Q₁₂ᵀΨ₁`
//!    (Perrusquía eq (22)) removes the cross term: `Ψ̇₁ = (A₁₁ − A₁₂Q₂₂⁻¹Q₁₂ᵀ)Ψ₁ + A₁₂v`
//!    (Perrusquía eq (23)) with cost `∫ Ψ₁ᵀQ̄Ψ₁ + vᵀQ₂₂v`,
//!    `Q̄ = Q₁₁ − Q₁₂Q₂₂⁻¹Q₁₂ᵀ` (Perrusquía eq (24)).
//! 4. That LQR problem (Perrusquía eq (25), Riccati solution `P`) gives `Ψ₂ = −C₁Ψ₁`,
//!    `C₁ = Q₂₂⁻¹(A₁₂ᵀP + Q₁₂ᵀ)` (Perrusquía eq (26)); with `C₂ = I` (Perrusquía eq (19)) the
//!    hyperplane in the original
//!    error coordinates is `C = [C₁, I]·T = C₁·N + B†`, so `C·B = I` (used in Appendix A).
//!
//! Two misprints in the paper are corrected here. Perrusquía eq (21) writes the transformed weight
//! as `T·Q·T⁻¹` (a similarity); the cost `eᵀQe = Ψᵀ(T⁻ᵀQT⁻¹)Ψ` needs the congruence. With the
//! similarity, the slider's sliding pole would come out as `−b·√(q₁/q₂)` — depending on the mass —
//! instead of the optimum `−√(q₁/q₂)` of `∫ q₁e² + q₂ė²`. Perrusquía eq (23) prints `A₂₂` where
//! substituting Perrusquía eq (22) into Perrusquía eq (17) gives `A₁₂`.

use super::care::{solve_care, CareError};
use nalgebra::{Cholesky, DMatrix, SymmetricEigen, SVD};
use serde::Deserialize;
use thiserror::Error;

/// Why the hyperplane design failed.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SlidingSurfaceError {
    /// A must be n×n, B n×m with 1 ≤ m < n, Q n×n.
    #[error("sliding-surface dimension mismatch: {0}")]
    DimensionMismatch(String),
    /// A NaN or infinite entry.
    #[error("sliding-surface input {matrix} has a non-finite entry")]
    NonFinite {
        /// Which input: `A`, `B` or `Q`.
        matrix: &'static str,
    },
    /// B must have full column rank for T (Perrusquía eq (15)) to be invertible.
    #[error("B must have full column rank (σ_min/σ_max = {ratio:e})")]
    InputRankDeficient {
        /// σ_min/σ_max of B.
        ratio: f64,
    },
    /// Q must be symmetric positive semidefinite.
    #[error("Q must be symmetric positive semidefinite ({reason})")]
    BadStateWeight {
        /// What is wrong with Q (asymmetry, a negative eigenvalue).
        reason: String,
    },
    /// `Q₂₂ = BᵀQB` must be positive definite: it is the input weight of the reduced problem.
    #[error("Q₂₂ = BᵀQB must be positive definite: Q has to weight the input directions")]
    InputDirectionsUnweighted,
    /// Slider model or weights out of range.
    #[error("slider design needs {what} > 0 and finite (got {value})")]
    BadSliderParameter {
        /// Which one: `mass`, `position weight` or `velocity weight`.
        what: &'static str,
        /// The value given (kg for the mass).
        value: f64,
    },
    /// The reduced LQR problem (Perrusquía eq (25)) failed.
    #[error("reduced LQR problem of the sliding surface: {0}")]
    Reduced(#[from] CareError),
}

/// Optimal hyperplane and the intermediate quantities of Perrusquía eqs (14)–(26).
#[derive(Debug, Clone, PartialEq)]
pub struct SlidingHyperplane {
    /// `C` (m×n) with `s = C·e` (Perrusquía eq (13)); `C·B = I`.
    pub c: DMatrix<f64>,
    /// `T = [N; B†]` (Perrusquía eq (15)).
    pub transform: DMatrix<f64>,
    /// `C₁` (m×(n−m)) of Perrusquía eq (26).
    pub c1: DMatrix<f64>,
    /// Riccati solution `P` of the reduced problem (Perrusquía eq (25)); the sliding-motion cost
    /// from `Ψ₁(0)` is `Ψ₁(0)ᵀPΨ₁(0)`.
    pub riccati: DMatrix<f64>,
    /// `A₁₁ − A₁₂C₁`: the reduced-order dynamics `Ψ̇₁ = (A₁₁ − A₁₂C₁)Ψ₁` while `s = 0`.
    pub sliding_matrix: DMatrix<f64>,
}

/// Weights of `∫ q_pos·e² + q_vel·ė² dt` (Perrusquía eq (20) with `Q = diag(q_pos, q_vel)`) for the
/// slider.
///
/// The optimum sliding motion is `ė = −√(q_pos/q_vel)·e`. The default ratio 1000 puts that pole at
/// `−√1000 ≈ −31.6 rad/s`, the natural frequency of the baseline of Perrusquía eq (38), so the two
/// designs have the same bandwidth. The paper gives no numeric Q for the OSMC.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SliderWeights {
    /// Weight on the position error, 1/m² (relative).
    pub position: f64,
    /// Weight on the velocity error, s²/m² (relative).
    pub velocity: f64,
}

impl Default for SliderWeights {
    fn default() -> Self {
        Self {
            position: 1000.0,
            velocity: 1.0,
        }
    }
}

/// Relative tolerances for the symmetry / semidefiniteness / rank tests.
const SYMMETRY_TOL: f64 = 1e-10;
const PSD_TOL: f64 = 1e-10;
const RANK_TOL: f64 = 1e-12;
const DECOMPOSITION_MAX_ITER: usize = 10_000;

/// The slider model of Perrusquía eq (10), `ż = [[0, 1], [0, 0]]·z + [0, 1/m]ᵀ·(u + d)`.
pub fn slider_state_space(mass: f64) -> Result<(DMatrix<f64>, DMatrix<f64>), SlidingSurfaceError> {
    positive("mass", mass)?;
    Ok((
        DMatrix::from_row_slice(2, 2, &[0.0, 1.0, 0.0, 0.0]),
        DMatrix::from_row_slice(2, 1, &[0.0, 1.0 / mass]),
    ))
}

/// The optimal hyperplane for the slider (Perrusquía eq (10)) of mass `mass` kg. In closed form,
/// `C = m·[√(q_pos/q_vel), 1]` and the sliding pole is `−√(q_pos/q_vel)`.
pub fn slider_hyperplane(
    mass: f64,
    weights: &SliderWeights,
) -> Result<SlidingHyperplane, SlidingSurfaceError> {
    positive("position weight", weights.position)?;
    positive("velocity weight", weights.velocity)?;
    let (a, b) = slider_state_space(mass)?;
    let q = DMatrix::from_row_slice(2, 2, &[weights.position, 0.0, 0.0, weights.velocity]);
    optimal_hyperplane(&a, &b, &q)
}

fn positive(what: &'static str, value: f64) -> Result<(), SlidingSurfaceError> {
    if value > 0.0 && value.is_finite() {
        Ok(())
    } else {
        Err(SlidingSurfaceError::BadSliderParameter { what, value })
    }
}

/// The hyperplane `C` minimising `∫ eᵀQe` over the sliding motion of `ė = Ae − B(…)`
/// (Perrusquía eqs (14)–(26), with the corrections listed in the module docs).
pub fn optimal_hyperplane(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    q: &DMatrix<f64>,
) -> Result<SlidingHyperplane, SlidingSurfaceError> {
    check_system(a, b, q)?;
    let q = checked_weight(q)?;

    let sv = SVD::new(b.clone(), false, false).singular_values;
    let ratio = sv.min() / sv.max();
    if ratio.is_nan() || ratio <= RANK_TOL {
        return Err(SlidingSurfaceError::InputRankDeficient { ratio });
    }

    let RegularForm {
        null_rows,
        b_pinv,
        transform,
        transform_inv,
    } = regular_form(b, ratio)?;
    let (n, m) = (a.nrows(), b.ncols());
    let p = n - m;

    // Perrusquía eqs (16)–(17) and (21) (congruence for the weight).
    let a_bar = &transform * a * &transform_inv;
    let q_bar_full = symmetric_part(&(transform_inv.transpose() * &q * &transform_inv));
    let a11 = a_bar.view((0, 0), (p, p)).into_owned();
    let a12 = a_bar.view((0, p), (p, m)).into_owned();
    let q11 = q_bar_full.view((0, 0), (p, p)).into_owned();
    let q12 = q_bar_full.view((0, p), (p, m)).into_owned();
    let q22 = q_bar_full.view((p, p), (m, m)).into_owned();
    let q22_chol =
        Cholesky::new(q22.clone()).ok_or(SlidingSurfaceError::InputDirectionsUnweighted)?;
    let q22_inv_q12t = q22_chol.solve(&q12.transpose());

    // Perrusquía eqs (22)–(25).
    let a_reduced = &a11 - &a12 * &q22_inv_q12t;
    let q_reduced = symmetric_part(&(&q11 - &q12 * &q22_inv_q12t));
    let reduced = solve_care(&a_reduced, &a12, &q_reduced, &q22)?;
    let riccati = reduced.x;

    // Perrusquía eq (26) and C = [C₁, I]·T.
    let c1 = q22_chol.solve(&(a12.transpose() * &riccati + q12.transpose()));
    let c = &c1 * &null_rows + &b_pinv;
    let sliding_matrix = &a11 - &a12 * &c1;
    Ok(SlidingHyperplane {
        c,
        transform,
        c1,
        riccati,
        sliding_matrix,
    })
}

/// Checks that A is square, B is n×m with 1 ≤ m < n, Q is n×n, and all three are finite.
fn check_system(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    q: &DMatrix<f64>,
) -> Result<(), SlidingSurfaceError> {
    let (n, m) = (a.nrows(), b.ncols());
    if n == 0 || !a.is_square() {
        return Err(SlidingSurfaceError::DimensionMismatch(format!(
            "A is {}×{}, must be square and non-empty",
            a.nrows(),
            a.ncols()
        )));
    }
    if b.nrows() != n || m == 0 || m >= n {
        return Err(SlidingSurfaceError::DimensionMismatch(format!(
            "B is {}×{}, must be {n}×m with 1 ≤ m < {n}",
            b.nrows(),
            b.ncols()
        )));
    }
    if q.shape() != (n, n) {
        return Err(SlidingSurfaceError::DimensionMismatch(format!(
            "Q is {}×{}, must be {n}×{n}",
            q.nrows(),
            q.ncols()
        )));
    }
    for (matrix, name) in [(a, "A"), (b, "B"), (q, "Q")] {
        if matrix.iter().any(|v| !v.is_finite()) {
            return Err(SlidingSurfaceError::NonFinite { matrix: name });
        }
    }
    Ok(())
}

/// The regular form's change of coordinates `Ψ = T·e` (Perrusquía eqs (14)–(16)).
struct RegularForm {
    /// N: orthonormal rows spanning the left null space of B (`N·B = 0`), p×n.
    null_rows: DMatrix<f64>,
    /// B† = (BᵀB)⁻¹Bᵀ, m×n.
    b_pinv: DMatrix<f64>,
    /// T = [N; B†].
    transform: DMatrix<f64>,
    /// T⁻¹ = [Nᵀ, B].
    transform_inv: DMatrix<f64>,
}

/// The regular form of B (full column rank; `ratio` is its singular-value ratio, for the error).
fn regular_form(b: &DMatrix<f64>, ratio: f64) -> Result<RegularForm, SlidingSurfaceError> {
    let (n, m) = (b.nrows(), b.ncols());
    // Perrusquía eq (15). Householder QR of [B, I] yields a full orthogonal factor whose first m
    // columns span range(B) (B has full rank), so the remaining columns span its orthogonal
    // complement.
    let p = n - m;
    let mut augmented = DMatrix::<f64>::zeros(n, m + n);
    augmented.view_mut((0, 0), (n, m)).copy_from(b);
    augmented
        .view_mut((0, m), (n, n))
        .copy_from(&DMatrix::<f64>::identity(n, n));
    let orthogonal = augmented.qr().q();
    let mut null_rows = orthogonal.columns(m, p).transpose();
    for mut row in null_rows.row_iter_mut() {
        // Fix each row's sign (largest entry positive) so T is reproducible.
        let pivot = row.iter().fold(
            0.0,
            |best: f64, v| if v.abs() > best.abs() { *v } else { best },
        );
        if pivot < 0.0 {
            row.neg_mut();
        }
    }
    let btb = Cholesky::new(b.transpose() * b)
        .ok_or(SlidingSurfaceError::InputRankDeficient { ratio })?;
    let b_pinv = btb.solve(&b.transpose());
    let mut transform = DMatrix::<f64>::zeros(n, n);
    transform.view_mut((0, 0), (p, n)).copy_from(&null_rows);
    transform.view_mut((p, 0), (m, n)).copy_from(&b_pinv);
    let mut transform_inv = DMatrix::<f64>::zeros(n, n);
    transform_inv
        .view_mut((0, 0), (n, p))
        .copy_from(&null_rows.transpose());
    transform_inv.view_mut((0, p), (n, m)).copy_from(b);
    Ok(RegularForm {
        null_rows,
        b_pinv,
        transform,
        transform_inv,
    })
}

fn symmetric_part(m: &DMatrix<f64>) -> DMatrix<f64> {
    (m + m.transpose()) * 0.5
}

/// Q symmetrised after checking it is symmetric PSD up to rounding.
fn checked_weight(q: &DMatrix<f64>) -> Result<DMatrix<f64>, SlidingSurfaceError> {
    let asym = (q - q.transpose()).norm();
    if asym > SYMMETRY_TOL * q.norm() {
        return Err(SlidingSurfaceError::BadStateWeight {
            reason: format!("not symmetric: ‖Q − Qᵀ‖_F = {asym:e}"),
        });
    }
    let q = symmetric_part(q);
    let eig = SymmetricEigen::try_new(q.clone(), f64::EPSILON, DECOMPOSITION_MAX_ITER).ok_or(
        SlidingSurfaceError::BadStateWeight {
            reason: "eigenvalue iteration did not converge".into(),
        },
    )?;
    let min = eig.eigenvalues.min();
    if min < -PSD_TOL * q.norm() {
        return Err(SlidingSurfaceError::BadStateWeight {
            reason: format!("smallest eigenvalue {min:e}"),
        });
    }
    Ok(q)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `L` with `SᵀL + LS + W = 0` (Kronecker form; small sizes only).
    fn lyapunov(s: &DMatrix<f64>, w: &DMatrix<f64>) -> DMatrix<f64> {
        let p = s.nrows();
        let id = DMatrix::<f64>::identity(p, p);
        let st = s.transpose();
        let op = id.kronecker(&st) + st.kronecker(&id);
        let rhs = DMatrix::from_column_slice(p * p, 1, (-w).as_slice());
        let vec = op.lu().solve(&rhs).unwrap();
        DMatrix::from_column_slice(p, p, vec.as_slice())
    }

    /// Cost matrix of the sliding motion for an arbitrary `C₁`: on `s = 0`, `e = (Nᵀ − B·C₁)Ψ₁`,
    /// `Ψ̇₁ = (A₁₁ − A₁₂C₁)Ψ₁`, so `∫ eᵀQe = Ψ₁(0)ᵀLΨ₁(0)`.
    fn sliding_cost(
        a: &DMatrix<f64>,
        b: &DMatrix<f64>,
        q: &DMatrix<f64>,
        t: &DMatrix<f64>,
        c1: &DMatrix<f64>,
    ) -> DMatrix<f64> {
        let (n, m) = (a.nrows(), b.ncols());
        let p = n - m;
        let t_inv = t.clone().try_inverse().unwrap();
        let a_bar = t * a * &t_inv;
        let s = a_bar.view((0, 0), (p, p)) - a_bar.view((0, p), (p, m)) * c1;
        let e_of_psi1 = t_inv.columns(0, p) - t_inv.columns(p, m) * c1;
        lyapunov(&s, &(e_of_psi1.transpose() * q * e_of_psi1))
    }

    #[test]
    fn slider_closed_form() {
        let mass = 5.0;
        for weights in [
            SliderWeights::default(),
            SliderWeights {
                position: 4.0,
                velocity: 0.25,
            },
        ] {
            let h = slider_hyperplane(mass, &weights).unwrap();
            let lambda = (weights.position / weights.velocity).sqrt();
            let expected = [mass * lambda, mass];
            for (got, want) in h.c.iter().zip(expected) {
                assert!((got - want).abs() <= 1e-10 * want, "C = {}", h.c);
            }
            assert!((h.sliding_matrix[(0, 0)] + lambda).abs() <= 1e-10 * lambda);
            // P = √(q_pos·q_vel): the optimal cost of the first-order motion.
            let p = (weights.position * weights.velocity).sqrt();
            assert!((h.riccati[(0, 0)] - p).abs() <= 1e-10 * p);
            let (_, b) = slider_state_space(mass).unwrap();
            let cb = (&h.c * &b)[(0, 0)];
            assert!((cb - 1.0).abs() < 1e-12, "CB = {cb}");
        }
    }

    #[test]
    fn slider_pole_does_not_depend_on_mass() {
        // The slider of Perrusquía eq (36) (m₅ = 4.5e-4 kg) and a heavy ram give the same motion.
        for mass in [4.5e-4, 5.0, 300.0] {
            let h = slider_hyperplane(mass, &SliderWeights::default()).unwrap();
            assert!((h.sliding_matrix[(0, 0)] + 1000f64.sqrt()).abs() < 1e-9);
            assert!((h.c[(0, 1)] - mass).abs() <= 1e-12 * mass);
        }
    }

    #[test]
    fn cross_weight_leaves_the_slider_surface_unchanged() {
        // ∫ 2q₁₂·e·ė dt = q₁₂·[e²] depends only on the end points, so C must not move. A
        // similarity-transformed weight (Perrusquía eq (21) as printed) would break this
        // invariance.
        let (a, b) = slider_state_space(2.0).unwrap();
        let plain = optimal_hyperplane(
            &a,
            &b,
            &DMatrix::from_row_slice(2, 2, &[9.0, 0.0, 0.0, 1.0]),
        )
        .unwrap();
        let crossed = optimal_hyperplane(
            &a,
            &b,
            &DMatrix::from_row_slice(2, 2, &[9.0, 2.0, 2.0, 1.0]),
        )
        .unwrap();
        assert!(
            (&plain.c - &crossed.c).norm() < 1e-10,
            "{} vs {}",
            plain.c,
            crossed.c
        );
    }

    #[test]
    fn general_systems_are_optimal_over_nearby_surfaces() {
        let cases = [
            (
                DMatrix::from_row_slice(3, 3, &[0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 1.0, -2.0, 0.3]),
                DMatrix::from_row_slice(3, 1, &[0.2, 0.0, 1.5]),
                DMatrix::from_row_slice(3, 3, &[4.0, 1.0, 0.0, 1.0, 2.0, 0.5, 0.0, 0.5, 1.0]),
            ),
            (
                DMatrix::from_row_slice(
                    4,
                    4,
                    &[
                        0.5, 1.0, 0.0, 0.0, 0.0, -0.2, 1.0, 0.3, 0.0, 0.0, 0.1, 1.0, 1.0, 0.0, 0.0,
                        0.0,
                    ],
                ),
                DMatrix::from_row_slice(4, 2, &[0.0, 0.0, 1.0, 0.0, 0.3, 0.0, 0.0, 2.0]),
                DMatrix::from_diagonal(&nalgebra::DVector::from_row_slice(&[3.0, 1.0, 0.5, 2.0])),
            ),
        ];
        for (a, b, q) in cases {
            let h = optimal_hyperplane(&a, &b, &q).unwrap();
            let m = b.ncols();
            assert!((&h.c * &b - DMatrix::<f64>::identity(m, m)).norm() < 1e-10);
            for l in h.sliding_matrix.complex_eigenvalues().iter() {
                assert!(l.re < 0.0, "sliding motion not stable: {l}");
            }
            // The cost of the optimal motion equals P, and any perturbed C₁ costs more.
            let best = sliding_cost(&a, &b, &q, &h.transform, &h.c1);
            assert!(
                (&best - &h.riccati).norm() < 1e-8 * h.riccati.norm(),
                "{best} vs {}",
                h.riccati
            );
            for k in 0..h.c1.len() {
                for delta in [-1e-2, 1e-2] {
                    let mut c1 = h.c1.clone();
                    c1[k] += delta;
                    let cost = sliding_cost(&a, &b, &q, &h.transform, &c1);
                    assert!(
                        cost.trace() > best.trace(),
                        "perturbation {k}/{delta} lowered the cost"
                    );
                }
            }
        }
    }

    #[test]
    fn errors() {
        let (a, b) = slider_state_space(1.0).unwrap();
        assert!(matches!(
            slider_hyperplane(0.0, &SliderWeights::default()),
            Err(SlidingSurfaceError::BadSliderParameter { what: "mass", .. })
        ));
        assert!(matches!(
            slider_hyperplane(
                1.0,
                &SliderWeights {
                    position: 1.0,
                    velocity: -1.0
                }
            ),
            Err(SlidingSurfaceError::BadSliderParameter { .. })
        ));
        let q_pos_only = DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 0.0, 0.0]);
        assert_eq!(
            optimal_hyperplane(&a, &b, &q_pos_only),
            Err(SlidingSurfaceError::InputDirectionsUnweighted)
        );
        // No position weight: the reduced pair (0, b) with Q̄ = 0 has no stabilising solution.
        let q_vel_only = DMatrix::from_row_slice(2, 2, &[0.0, 0.0, 0.0, 1.0]);
        assert!(matches!(
            optimal_hyperplane(&a, &b, &q_vel_only),
            Err(SlidingSurfaceError::Reduced(
                CareError::Unstabilisable { .. }
            ))
        ));
        assert!(matches!(
            optimal_hyperplane(&a, &DMatrix::zeros(2, 1), &DMatrix::identity(2, 2)),
            Err(SlidingSurfaceError::InputRankDeficient { .. })
        ));
        assert!(matches!(
            optimal_hyperplane(&a, &DMatrix::identity(2, 2), &DMatrix::identity(2, 2)),
            Err(SlidingSurfaceError::DimensionMismatch(_))
        ));
        assert!(matches!(
            optimal_hyperplane(
                &a,
                &b,
                &DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 0.0, -1.0])
            ),
            Err(SlidingSurfaceError::BadStateWeight { .. })
        ));
    }
}
