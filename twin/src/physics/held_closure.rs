//! Closing the loops of a starting state with the coordinates the scenario gave held: only the
//! others move. A five-bar started at both crank angles starts there, its elbows placed to
//! close the loop; the mass-weighted correction of a step would move the cranks too.

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
    let free = |row: &[f64]| -> Vec<f64> {
        (row.iter().zip(held))
            .map(|(&x, &h)| if h { 0.0 } else { x })
            .collect()
    };
    let g_free: Vec<Vec<f64>> = (0..rows).map(|r| free(&g[r * n..(r + 1) * n])).collect();
    let mut a: Vec<Vec<f64>> = (0..rows)
        .map(|i| {
            (0..rows)
                .map(|j| g_free[i].iter().zip(&g_free[j]).map(|(x, y)| x * y).sum())
                .collect()
        })
        .collect();
    let Some(y) = solve(&mut a, phi.to_vec()) else {
        return false;
    };
    dq[..n].fill(0.0);
    for (row, &yr) in g_free.iter().zip(&y) {
        for (d, &gr) in dq.iter_mut().zip(row) {
            *d -= gr * yr;
        }
    }
    true
}

/// Solves a·x = b by Gaussian elimination with partial pivoting; `None` when a pivot is below
/// 1e-12 of the largest entry (singular).
fn solve(a: &mut [Vec<f64>], mut b: Vec<f64>) -> Option<Vec<f64>> {
    let m = b.len();
    let scale = (a.iter().flatten()).fold(0.0_f64, |s, x| s.max(x.abs()));
    if scale == 0.0 || !scale.is_finite() {
        return None;
    }
    for k in 0..m {
        let pivot = (k..m).max_by(|&i, &j| a[i][k].abs().total_cmp(&a[j][k].abs()))?;
        if a[pivot][k].abs() < 1e-12 * scale {
            return None;
        }
        a.swap(k, pivot);
        b.swap(k, pivot);
        let (top, bottom) = a.split_at_mut(k + 1);
        let (pivot_row, bk) = (&top[k], b[k]);
        for (row, bi) in bottom.iter_mut().zip(&mut b[k + 1..]) {
            let f = row[k] / pivot_row[k];
            for (x, p) in row[k..].iter_mut().zip(&pivot_row[k..]) {
                *x -= f * p;
            }
            *bi -= f * bk;
        }
    }
    let mut x = vec![0.0; m];
    for k in (0..m).rev() {
        let sum: f64 = (k + 1..m).map(|j| a[k][j] * x[j]).sum();
        x[k] = (b[k] - sum) / a[k][k];
    }
    Some(x)
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
