//! Closing the loops of a starting state with the coordinates the scenario gave held: only the
//! others move. A five-bar started at both crank angles starts there, its elbows placed to
//! close the loop; the mass-weighted correction of a step would move the cranks too.

use nalgebra::{DMatrix, DVector};

/// The least correction of the free coordinates (`held[i]` false) that brings the constraints
/// `phi` to zero to first order, given their Jacobian `g` (rows of `n`, row-major): dq_F =
/// −G_Fᵀ (G_F G_Fᵀ)⁻¹ φ, into `dq` (held entries 0). False when the free coordinates cannot
/// close the loops (G_F G_Fᵀ singular: the held ones already fix the loop, or too many were
/// given).
pub(super) fn held_correction(
    phi: &[f64],
    g: &[f64],
    n: usize,
    held: &[bool],
    dq: &mut [f64],
) -> bool {
    let rows = phi.len();
    let g_free = DMatrix::from_fn(rows, n, |r, c| if held[c] { 0.0 } else { g[r * n + c] });
    let normal = &g_free * g_free.transpose();
    let scale = normal.amax();
    if scale == 0.0 || !scale.is_finite() {
        return false;
    }
    let lu = normal.lu();
    // Singular to working precision: a pivot below 1e-12 of the largest entry.
    if lu.u().diagonal().iter().any(|p| p.abs() < 1e-12 * scale) {
        return false;
    }
    let Some(y) = lu.solve(&DVector::from_column_slice(phi)) else {
        return false;
    };
    let correction = -(g_free.transpose() * y);
    dq[..n].copy_from_slice(correction.as_slice());
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_held_coordinate_does_not_move_and_the_constraint_closes() {
        // One constraint q0 + 2 q1 + q2 = 1 from 0, q0 held: the least (q1, q2) is (0.4, 0.2).
        let (phi, g) = ([-1.0], [1.0, 2.0, 1.0]);
        let mut dq = [0.0; 3];
        assert!(held_correction(&phi, &g, 3, &[true, false, false], &mut dq));
        assert_eq!(dq[0], 0.0);
        assert!(
            (dq[1] - 0.4).abs() < 1e-15 && (dq[2] - 0.2).abs() < 1e-15,
            "{dq:?}"
        );
        // Every coordinate held: nothing can close it.
        assert!(!held_correction(&phi, &g, 3, &[true; 3], &mut dq));
    }
}
