//! The matrix exponential and the zero-order-hold discretisation built on it.

use nalgebra::DMatrix;

/// Padé degree: with ‖A/2ˢ‖∞ ≤ ½ the (6, 6) approximant's relative error bound
/// 2³⁻²ᵠ·(q!)²/((2q)!·(2q+1)!) is 3.4·10⁻¹⁶ (Golub & Van Loan, *Matrix Computations*, §11.3).
const PADE_DEGREE: usize = 6;

/// e^A by scaling and squaring with the diagonal Padé approximant (Golub & Van Loan, Algorithm
/// 11.3.1): A is scaled by 2⁻ˢ until ‖A‖∞ ≤ ½, e^(A/2ˢ) ≈ D⁻¹·N with N = Σ cₖ·Aᵏ,
/// D = Σ cₖ·(−A)ᵏ, cₖ = (2q−k)!·q! / ((2q)!·k!·(q−k)!), then squared s times. `None` when A is
/// not finite.
pub fn exp(a: &DMatrix<f64>) -> Option<DMatrix<f64>> {
    let n = a.nrows();
    let norm = (0..n)
        .map(|r| a.row(r).iter().map(|v| v.abs()).sum::<f64>())
        .fold(0.0, f64::max);
    if !norm.is_finite() {
        return None;
    }
    let squarings = if norm > 0.5 {
        (norm.log2().ceil() as i32 + 1).max(0)
    } else {
        0
    };
    let scaled = a * 0.5f64.powi(squarings);
    let identity = DMatrix::<f64>::identity(n, n);
    let (mut numerator, mut denominator) = (identity.clone(), identity.clone());
    let mut power = identity;
    let mut coefficient = 1.0;
    let q = PADE_DEGREE as f64;
    for k in 1..=PADE_DEGREE {
        let k_f = k as f64;
        coefficient *= (q - k_f + 1.0) / (k_f * (2.0 * q - k_f + 1.0));
        power = &power * &scaled;
        let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
        numerator += &power * coefficient;
        denominator += &power * (sign * coefficient);
    }
    let mut result = denominator.lu().solve(&numerator)?;
    for _ in 0..squarings {
        result = &result * &result;
    }
    result.iter().all(|v| v.is_finite()).then_some(result)
}

/// Zero-order hold over `period` (s): the input held over each period,
/// `x[k+1] = Ad·x[k] + Bd·u[k]` with [[Ad, Bd], [0, I]] = exp([[A, B], [0, 0]]·T) (Van Loan's
/// augmented matrix).
pub fn zero_order_hold(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    period: f64,
) -> Option<(DMatrix<f64>, DMatrix<f64>)> {
    let (n, m) = (a.nrows(), b.ncols());
    let mut augmented = DMatrix::<f64>::zeros(n + m, n + m);
    augmented.view_mut((0, 0), (n, n)).copy_from(&(a * period));
    augmented.view_mut((0, n), (n, m)).copy_from(&(b * period));
    let e = exp(&augmented)?;
    Some((
        e.view((0, 0), (n, n)).into_owned(),
        e.view((0, n), (n, m)).into_owned(),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_rotation_generator_gives_the_rotation() {
        // exp([[0, −ω], [ω, 0]]·t) is the rotation by ωt; ωt = 7 needs four squarings.
        let angle = 7.0;
        let a = DMatrix::from_row_slice(2, 2, &[0.0, -angle, angle, 0.0]);
        let e = exp(&a).unwrap();
        let expected = [angle.cos(), -angle.sin(), angle.sin(), angle.cos()];
        for (value, want) in e.transpose().iter().zip(expected) {
            assert!((value - want).abs() < 1e-14, "{value} vs {want}");
        }
    }

    #[test]
    fn a_jordan_block_gives_its_closed_form_and_diagonals_their_exponentials() {
        // exp([[λ, 1], [0, λ]]) = e^λ·[[1, 1], [0, 1]]; diag(−30, 0.1) → diag(e^−30, e^0.1).
        let lambda = -2.5;
        let e = exp(&DMatrix::from_row_slice(2, 2, &[lambda, 1.0, 0.0, lambda])).unwrap();
        let want = lambda.exp();
        assert!((e[(0, 0)] - want).abs() < 1e-15 && (e[(0, 1)] - want).abs() < 1e-15);
        assert!(e[(1, 0)] == 0.0 && (e[(1, 1)] - want).abs() < 1e-15);
        let d = exp(&DMatrix::from_row_slice(2, 2, &[-30.0, 0.0, 0.0, 0.1])).unwrap();
        assert!(((d[(0, 0)] - (-30.0f64).exp()) / (-30.0f64).exp()).abs() < 1e-13);
        assert!(((d[(1, 1)] - 0.1f64.exp()) / 0.1f64.exp()).abs() < 1e-14);
        assert!(exp(&DMatrix::from_row_slice(1, 1, &[f64::NAN])).is_none());
    }

    #[test]
    fn zero_order_hold_of_a_mass_with_damping_is_the_closed_form() {
        // m ẍ + b ẋ = F, x = (position, velocity), a = b/m, over T: Ad = [[1, (1 − e^−aT)/a],
        // [0, e^−aT]], Bd = [(T − (1 − e^−aT)/a)/(a·m), (1 − e^−aT)/(a·m)].
        let (m, b, period) = (10.0, 250.0, 1e-4);
        let a = b / m;
        let (ad, bd) = zero_order_hold(
            &DMatrix::from_row_slice(2, 2, &[0.0, 1.0, 0.0, -a]),
            &DMatrix::from_row_slice(2, 1, &[0.0, 1.0 / m]),
            period,
        )
        .unwrap();
        // 1 − e^−aT by exp_m1: the closed form keeps its digits at aT = 2.5e-3.
        let (decay, lost) = ((-a * period).exp(), -(-a * period).exp_m1());
        let want_ad = [1.0, lost / a, 0.0, decay];
        // (T − (1 − e^−aT)/a)/(a·m) = Σₖ₌₂ (−a)ᵏ⁻²·Tᵏ/k! / m, summed: the difference cancels.
        let mut term = period * period / 2.0;
        let mut series = 0.0;
        for k in 3..30 {
            series += term;
            term *= -a * period / k as f64;
        }
        let want_bd = [series / m, lost / (a * m)];
        let values = ad
            .transpose()
            .iter()
            .chain(bd.iter())
            .copied()
            .collect::<Vec<_>>();
        for (value, want) in values.into_iter().zip(want_ad.into_iter().chain(want_bd)) {
            assert!(
                (value - want).abs() <= 1e-14 * want.abs() + 1e-300,
                "{value} vs {want}"
            );
        }
    }
}
