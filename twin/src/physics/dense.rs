//! Small dense linear algebra for the twin's integrator: symmetric positive (semi)definite
//! systems of a few unknowns, row-major in caller-owned buffers, so a step allocates nothing.

/// Calls `$call` with its const parameter set to the mechanism's size `$n` for the sizes the
/// machines have (1 to 8: the loops over coordinates then unroll), else with 0 (any size, read
/// at run time). A function so called takes its size as `if N == 0 { n } else { N }`.
macro_rules! sized {
    ($n:expr, $($call:ident)::+ ($($arg:expr),*)) => {
        match $n {
            1 => $($call)::+::<1>($($arg),*),
            2 => $($call)::+::<2>($($arg),*),
            3 => $($call)::+::<3>($($arg),*),
            4 => $($call)::+::<4>($($arg),*),
            5 => $($call)::+::<5>($($arg),*),
            6 => $($call)::+::<6>($($arg),*),
            7 => $($call)::+::<7>($($arg),*),
            8 => $($call)::+::<8>($($arg),*),
            _ => $($call)::+::<0>($($arg),*),
        }
    };
}
pub(super) use sized;

/// The size `n`, or `N` where the caller fixed it (see [`sized!`]).
#[inline(always)]
pub(super) const fn size<const N: usize>(n: usize) -> usize {
    if N == 0 {
        n
    } else {
        N
    }
}

/// Factorises the symmetric matrix `a` (n × n, row-major) in place as L·D·Lᵀ (unit lower L below
/// the diagonal, D on it). A pivot at or below `floor` × the largest diagonal marks a dependent
/// row (a redundant loop constraint): its D is set to 0 and [`ldl_solve`] gives it no share.
#[inline]
pub(super) fn ldl_factor(a: &mut [f64], n: usize, floor: f64) {
    sized!(n, ldl_factor_of(a, n, floor))
}

/// Solves L·D·Lᵀ·x = b in place (`b` becomes x) with the factors of [`ldl_factor`].
#[inline]
pub(super) fn ldl_solve(f: &[f64], n: usize, b: &mut [f64]) {
    ldl_forward(f, n, b);
    ldl_backward(f, n, b);
}

/// L·z = b in place (`b` becomes z).
#[inline]
pub(super) fn ldl_forward(f: &[f64], n: usize, b: &mut [f64]) {
    sized!(n, ldl_forward_of(f, n, b))
}

/// D·Lᵀ·x = z in place (`z` becomes x): the second half of [`ldl_solve`].
#[inline]
pub(super) fn ldl_backward(f: &[f64], n: usize, z: &mut [f64]) {
    sized!(n, ldl_backward_of(f, n, z))
}

#[inline(always)]
fn ldl_factor_of<const N: usize>(a: &mut [f64], n: usize, floor: f64) {
    let n = size::<N>(n);
    let a = &mut a[..n * n];
    let scale = (0..n).map(|i| a[i * n + i].abs()).fold(0.0, f64::max);
    let tiny = floor * scale;
    // Row j of L times D, kept while column j is made (the pivots so far on the diagonal).
    let mut scaled = [0.0; 16];
    let mut spill = Vec::new();
    let row_times_d: &mut [f64] = if n <= scaled.len() {
        &mut scaled[..n]
    } else {
        spill.resize(n, 0.0);
        &mut spill
    };
    for j in 0..n {
        let (above, rest) = a.split_at_mut(j * n);
        let (row_j, below) = rest.split_at_mut(n);
        for (k, slot) in row_times_d[..j].iter_mut().enumerate() {
            *slot = row_j[k] * above[k * n + k];
        }
        let d = row_j[j] - dot(&row_j[..j], &row_times_d[..j]);
        let dependent = d <= tiny;
        row_j[j] = if dependent { 0.0 } else { d };
        for row_i in below.chunks_exact_mut(n) {
            let s = row_i[j] - dot(&row_i[..j], &row_times_d[..j]);
            row_i[j] = if dependent { 0.0 } else { s / d };
        }
    }
}

/// a·b.
pub(super) fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

#[inline(always)]
fn ldl_forward_of<const N: usize>(f: &[f64], n: usize, b: &mut [f64]) {
    let n = size::<N>(n);
    let (f, b) = (&f[..n * n], &mut b[..n]);
    for i in 1..n {
        let row = &f[i * n..i * n + i];
        let sum: f64 = row.iter().zip(&b[..i]).map(|(l, z)| l * z).sum();
        b[i] -= sum;
    }
}

#[inline(always)]
fn ldl_backward_of<const N: usize>(f: &[f64], n: usize, z: &mut [f64]) {
    let n = size::<N>(n);
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
