//! Small dense linear algebra for the twin's integrator: symmetric positive (semi)definite
//! systems of a few unknowns, row-major in caller-owned buffers, so a step allocates nothing.

/// Factorises the symmetric matrix `a` (n × n, row-major) in place as L·D·Lᵀ (unit lower L below
/// the diagonal, D on it). A pivot at or below `floor` × the largest diagonal marks a dependent
/// row (a redundant loop constraint): its D is set to 0 and [`ldl_solve`] gives it no share.
pub(super) fn ldl_factor(a: &mut [f64], n: usize, floor: f64) {
    let scale = (0..n).map(|i| a[i * n + i].abs()).fold(0.0, f64::max);
    let tiny = floor * scale;
    for j in 0..n {
        let mut d = a[j * n + j];
        for k in 0..j {
            d -= a[j * n + k] * a[j * n + k] * a[k * n + k];
        }
        let dependent = d <= tiny;
        a[j * n + j] = if dependent { 0.0 } else { d };
        for i in j + 1..n {
            let mut s = a[i * n + j];
            for k in 0..j {
                s -= a[i * n + k] * a[j * n + k] * a[k * n + k];
            }
            a[i * n + j] = if dependent { 0.0 } else { s / d };
        }
    }
}

/// Solves L·D·Lᵀ·x = b in place (`b` becomes x) with the factors of [`ldl_factor`].
pub(super) fn ldl_solve(f: &[f64], n: usize, b: &mut [f64]) {
    ldl_forward(f, n, b);
    ldl_backward(f, n, b);
}

/// L·z = b in place (`b` becomes z).
pub(super) fn ldl_forward(f: &[f64], n: usize, b: &mut [f64]) {
    let (f, b) = (&f[..n * n], &mut b[..n]);
    for i in 1..n {
        let row = &f[i * n..i * n + i];
        let sum: f64 = row.iter().zip(&b[..i]).map(|(l, z)| l * z).sum();
        b[i] -= sum;
    }
}

/// D·Lᵀ·x = z in place (`z` becomes x): the second half of [`ldl_solve`].
pub(super) fn ldl_backward(f: &[f64], n: usize, z: &mut [f64]) {
    let (f, z) = (&f[..n * n], &mut z[..n]);
    for i in 0..n {
        let d = f[i * n + i];
        z[i] = if d == 0.0 { 0.0 } else { z[i] / d };
    }
    for i in (0..n).rev() {
        let mut x = z[i];
        for k in i + 1..n {
            x -= f[k * n + i] * z[k];
        }
        z[i] = x;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solves_a_positive_definite_system() {
        let a = [4.0, 1.0, 0.5, 1.0, 3.0, -0.2, 0.5, -0.2, 2.0];
        let x = [0.3, -1.2, 2.5];
        let mut b: Vec<f64> = (0..3)
            .map(|i| (0..3).map(|k| a[i * 3 + k] * x[k]).sum())
            .collect();
        let mut f = a;
        ldl_factor(&mut f, 3, 1e-12);
        ldl_solve(&f, 3, &mut b);
        for i in 0..3 {
            assert!((b[i] - x[i]).abs() < 1e-14, "{b:?}");
        }
    }

    #[test]
    fn a_dependent_row_gets_no_share() {
        // Rows 0 and 1 are the same constraint twice: the solution puts it all on the first.
        let mut f = [2.0, 2.0, 2.0, 2.0];
        ldl_factor(&mut f, 2, 1e-12);
        let mut b = [4.0, 4.0];
        ldl_solve(&f, 2, &mut b);
        assert_eq!(b, [2.0, 0.0]);
    }
}
