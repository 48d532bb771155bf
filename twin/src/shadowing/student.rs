//! Student's t quantile, for a threshold set from statistics learnt over a few batches: a new
//! value standardised by a mean and a spread estimated from n batches is a t variable with
//! n − 1 degrees of freedom (scaled by √(1 + 1/n)), and its false-alarm rate is the t's tail,
//! not the normal's.

/// The quantile of Student's t with `dof` degrees of freedom at upper-tail probability `tail`
/// (in (0, ½)): t with P(T > t) = `tail`. Solved by bisection on the regularised incomplete
/// beta function, P(T > t) = ½ I_x(ν/2, ½) with x = ν/(ν + t²); relative error below 1e-9.
pub(super) fn student_quantile(tail: f64, dof: f64) -> f64 {
    let (a, b) = (0.5 * dof, 0.5);
    let target = (2.0 * tail).clamp(1e-300, 1.0);
    let prefactor = ln_gamma(a + b) - ln_gamma(a) - ln_gamma(b);
    // I_x rises from 0 at x = 0 (t = ∞) to 1 at x = 1 (t = 0): bisect on log x, as the
    // x of a far tail is tiny.
    let (mut low, mut high) = (-700.0_f64, 0.0_f64);
    for _ in 0..200 {
        let mid = 0.5 * (low + high);
        if incomplete_beta(mid.exp(), a, b, prefactor) < target {
            low = mid;
        } else {
            high = mid;
        }
    }
    let x = (0.5 * (low + high)).exp();
    (dof * (1.0 - x) / x).sqrt()
}

/// I_x(a, b), the regularised incomplete beta function (the continued fraction of Numerical
/// Recipes' `betai`, evaluated by Lentz's method), `prefactor` = ln Γ(a+b) − ln Γ(a) − ln Γ(b).
fn incomplete_beta(x: f64, a: f64, b: f64, prefactor: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    if x >= 1.0 {
        return 1.0;
    }
    let front = (prefactor + a * x.ln() + b * (1.0 - x).ln()).exp();
    if x < (a + 1.0) / (a + b + 2.0) {
        front * continued_fraction(x, a, b) / a
    } else {
        1.0 - front * continued_fraction(1.0 - x, b, a) / b
    }
}

/// The continued fraction of the incomplete beta function.
fn continued_fraction(x: f64, a: f64, b: f64) -> f64 {
    const TINY: f64 = 1e-300;
    let (qab, qap, qam) = (a + b, a + 1.0, a - 1.0);
    let mut c = 1.0;
    let mut d = 1.0 - qab * x / qap;
    d = 1.0 / if d.abs() < TINY { TINY } else { d };
    let mut h = d;
    for m in 1..=300 {
        let m = f64::from(m);
        let m2 = 2.0 * m;
        for numerator in [
            m * (b - m) * x / ((qam + m2) * (a + m2)),
            -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2)),
        ] {
            d = 1.0 + numerator * d;
            d = 1.0 / if d.abs() < TINY { TINY } else { d };
            c = 1.0 + numerator / c;
            c = if c.abs() < TINY { TINY } else { c };
            h *= d * c;
        }
        if (d * c - 1.0).abs() < 1e-15 {
            break;
        }
    }
    h
}

/// ln Γ(x) for x > 0 (Lanczos, g = 7, nine terms; relative error below 1e-13).
fn ln_gamma(x: f64) -> f64 {
    const G: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        // Reflection: Γ(x) Γ(1 − x) = π / sin(πx).
        let pi = std::f64::consts::PI;
        return (pi / (pi * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let sum = (1..9).fold(G[0], |sum, k| sum + G[k] / (x + k as f64));
    let t = x + 7.5;
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + sum.ln()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn student_quantiles_match_scipy() {
        // scipy.stats.t.ppf(1 − tail, dof), scipy 1.17.1.
        for (tail, dof, table) in [
            (0.025, 1.0, 12.706_204_736_174_694),
            (0.025, 4.0, 2.776_445_105_197_793_4),
            (0.025, 1000.0, 1.962_339_080_826_408_3),
            (1e-6, 7.0, 14.241_469_651_921_154),
            (5.7e-6, 2.0, 296.171_906_582_147_8),
            (5.7e-6, 18.0, 5.994_399_711_354_642),
            (5.7e-6, 60.0, 4.788_359_584_697_644),
            (5.7e-6, 1000.0, 4.411_087_415_234_786),
        ] {
            let t = student_quantile(tail, dof);
            assert!(
                (t / table - 1.0).abs() < 1e-9,
                "{tail} {dof}: {t} for {table}"
            );
        }
    }
}
