//! Output-feedback power control of the parallel lathe (Sudhakara & Landers, ACC 2003): the
//! three-step design of Sudhakara eqs (12)–(15), Theorem 1's consistency check, and the
//! global-stability condition of Sudhakara eq (23).
//!
//! The design works on the linearisation Sudhakara eq (7) about the reference forces:
//! ΔḞ = A ΔF + B Δf_c, ΔP = C ΔF with A = diag(−1/τ_i), B = diag(K̄_iα/τ_i), C = [V_1 V_2].
//! The 1/τ_i in B is what Sudhakara eqs (8), (11) and (12) imply; Sudhakara eq (7a) prints B
//! without it.
//!
//! Two printing errors in the paper matter here, both checked by the tests below:
//! - Sudhakara eq (15), the closed form of H = K C⁺, has the wrong sign on h_1 and lacks the 1/(m_1
//!   m_2) of Sudhakara eq (12) in h_2. The gains here are computed as Sudhakara eq (14) says, with
//!   nalgebra's
//!   pseudo-inverse; they reproduce the behaviour of the paper's Figs 4–9, the printed
//!   Sudhakara eq (15)
//!   does not (for m = 1.5 / 1.49 s it makes the reference forces a saddle).
//! - Sudhakara eq (23) is printed as h_i ≥ f_ni/P_max, but its own derivation (the zero-feed line
//!   of Sudhakara eq (21) at P = P_max + f_ni/h_i must not enter the positive quadrant) and the
//!   Lyapunov
//!   gains of Sudhakara eq (26) (h_i = −f_ni/P_max) give h_i ≥ −f_ni/P_max, the form checked here.
//!
//! Theorem 1 does not hold for Sudhakara eq (12)'s K in general: K C⁺ C = K needs every row of K
//! parallel to C, i.e. τ_1 = V_2/V_1 and τ_2(m_1 + m_2) − m_1 m_2 = τ_1 τ_2. For Table 1 it fails,
//! so the output feedback does not place the poles at −1/m_i; [`Consistency::Report`] keeps the
//! design (as the paper did) and reports the poles it does place.

use models::lathe::{eigenvalues, Eigenvalue, Lathe, TOOLS};
use nalgebra::{Matrix1x2, Matrix2};
use serde::Deserialize;
use thiserror::Error;

/// Relative residual of K C⁺ C − K below which Theorem 1's consistency counts as met.
const CONSISTENCY_TOLERANCE: f64 = 1e-9;

/// What to do when Theorem 1's consistency condition fails.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Consistency {
    /// Refuse the design: H = K C⁺ would not place the poles that were asked for.
    #[default]
    Require,
    /// Keep H = K C⁺ and report the poles it actually places (needed to reproduce the paper,
    /// whose Table 1 design fails the condition).
    Report,
}

/// Design specification, Step 1 of the paper.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DesignSpec {
    /// m_1, m_2: desired closed-loop time constants, s (poles at −1/m_i).
    pub time_constants: [f64; 2],
    /// What to do when Theorem 1's consistency condition fails.
    pub consistency: Consistency,
}

impl Default for DesignSpec {
    /// The paper's globally stable design (Figs 4 and 6).
    fn default() -> Self {
        Self {
            time_constants: [0.5, 0.49],
            consistency: Consistency::Require,
        }
    }
}

/// Sudhakara eq (23) evaluated for a gain set: are the zero-feed lines of Sudhakara eq (21) kept
/// out of the positive force quadrant, which makes the reference forces the only rest point there?
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GlobalStabilityCheck {
    /// H, m/(rev·W).
    pub power_gains: [f64; TOOLS],
    /// −f_ni/P_max, the least gain Sudhakara eq (23) allows, m/(rev·W).
    pub lower_bounds: [f64; TOOLS],
    /// Sudhakara eq (21): spindle power at which tool i's commanded feed reaches zero (None for h_i
    /// = 0, whose feed never changes), W.
    pub zero_feed_powers: [Option<f64>; TOOLS],
    /// Both gains meet Sudhakara eq (23): a sufficient, not necessary, condition.
    pub satisfied: bool,
}

/// The design of Steps 2–3 with the checks of Theorem 1 and Sudhakara eq (23).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OutputFeedbackDesign {
    /// The specification the design was made for.
    pub spec: DesignSpec,
    /// K of Sudhakara eq (12), Δf_c = −K ΔF, m/(rev·N).
    pub state_feedback: [[f64; 2]; 2],
    /// H = K C⁺ of Sudhakara eq (14), Δf_c = −H ΔP, m/(rev·W).
    pub power_gains: [f64; TOOLS],
    /// ‖K C⁺ C − K‖ / ‖K‖ (Frobenius): zero when Theorem 1's consistency holds.
    pub consistency_residual: f64,
    /// Eigenvalues of A − B K: −1/m_i by construction.
    pub state_feedback_poles: [Eigenvalue; 2],
    /// Eigenvalues of A − B H C, Sudhakara eq (10): the poles the output feedback really places.
    pub output_feedback_poles: [Eigenvalue; 2],
    /// Sudhakara eq (23) evaluated for H.
    pub global_stability: GlobalStabilityCheck,
}

/// Why the output-feedback design failed.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum DesignError {
    /// A desired closed-loop time constant m_i is zero, negative or not finite.
    #[error(
        "output-feedback design: time constant m_{index} must be finite and > 0 (got {value})"
    )]
    NonPositiveTimeConstant {
        /// Which one: i of m_i, from 1.
        index: usize,
        /// The value given, s.
        value: f64,
    },
    /// K fails Theorem 1's consistency `K C⁺ C = K` while [`Consistency::Require`] is set.
    #[error(
        "output-feedback design: K of eq (12) fails Theorem 1's consistency K C⁺ C = K (relative \
         residual {residual:.3e}), so H = K C⁺ places the poles at {achieved_poles:?} instead of \
         −1/m_i; set consistency = \"report\" to keep it anyway"
    )]
    Inconsistent {
        /// ‖K C⁺ C − K‖ / ‖K‖ (Frobenius).
        residual: f64,
        /// Eigenvalues of A − B H C: the poles H = K C⁺ places instead of −1/m_i, 1/s.
        achieved_poles: [Eigenvalue; 2],
    },
    /// nalgebra could not compute C⁺; holds its message.
    #[error("output-feedback design: pseudo-inverse of C failed: {0}")]
    PseudoInverse(&'static str),
}

/// Steps 1–3: K from Sudhakara eq (12), H = K C⁺ from Sudhakara eq (14), Theorem 1 checked,
/// Sudhakara eq (23) evaluated.
pub fn design(lathe: &Lathe, spec: &DesignSpec) -> Result<OutputFeedbackDesign, DesignError> {
    for (i, m) in spec.time_constants.iter().enumerate() {
        if !(m.is_finite() && *m > 0.0) {
            return Err(DesignError::NonPositiveTimeConstant {
                index: i + 1,
                value: *m,
            });
        }
    }
    let [m1, m2] = spec.time_constants;
    let [tau1, tau2] = lathe.feed_time_constants();
    let [slope1, slope2] = lathe.force_feed_slopes();
    let [v1, v2] = lathe.cutting_speeds();

    let a = Matrix2::new(-1.0 / tau1, 0.0, 0.0, -1.0 / tau2);
    let b = Matrix2::new(slope1 / tau1, 0.0, 0.0, slope2 / tau2);
    let c = Matrix1x2::new(v1, v2);
    // Sudhakara eq (12): puts A − B K in companion form with characteristic polynomial
    // (s + 1/m_1)(s + 1/m_2).
    let k = Matrix2::new(
        -1.0 / slope1,
        -tau1 / slope1,
        tau2 / (m1 * m2 * slope2),
        (tau2 * (m1 + m2) - m1 * m2) / (m1 * m2 * slope2),
    );
    let c_pseudo_inverse = c.pseudo_inverse(0.0).map_err(DesignError::PseudoInverse)?;
    let h = k * c_pseudo_inverse;
    let consistency_residual = (k * c_pseudo_inverse * c - k).norm() / k.norm();
    let output_feedback_poles = eigenvalues(rows(&(a - b * h * c)));
    if spec.consistency == Consistency::Require
        && (consistency_residual.is_nan() || consistency_residual > CONSISTENCY_TOLERANCE)
    {
        return Err(DesignError::Inconsistent {
            residual: consistency_residual,
            achieved_poles: output_feedback_poles,
        });
    }
    let power_gains = [h[0], h[1]];
    Ok(OutputFeedbackDesign {
        spec: *spec,
        state_feedback: rows(&k),
        power_gains,
        consistency_residual,
        state_feedback_poles: eigenvalues(rows(&(a - b * k))),
        output_feedback_poles,
        global_stability: global_stability(lathe, power_gains),
    })
}

/// Sudhakara eq (23) with the sign its derivation implies: h_i ≥ −f_ni/P_max for both tools.
pub fn global_stability(lathe: &Lathe, power_gains: [f64; TOOLS]) -> GlobalStabilityCheck {
    let max_power = lathe.params().max_spindle_power;
    let nominal = lathe.nominal_feeds();
    let lower_bounds = nominal.map(|feed| -feed / max_power);
    let zero_feed_powers =
        [0, 1].map(|i| (power_gains[i] != 0.0).then(|| max_power + nominal[i] / power_gains[i]));
    GlobalStabilityCheck {
        power_gains,
        lower_bounds,
        zero_feed_powers,
        satisfied: (0..TOOLS).all(|i| power_gains[i] >= lower_bounds[i]),
    }
}

fn rows(matrix: &Matrix2<f64>) -> [[f64; 2]; 2] {
    [
        [matrix[(0, 0)], matrix[(0, 1)]],
        [matrix[(1, 0)], matrix[(1, 1)]],
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use models::lathe::{
        EquilibriumKind, FeedRegime, ForceBox, LatheParams, PhasePortrait, PortraitSpec, PowerLoop,
        ReverseTrajectorySpec, PAPER_STEP,
    };

    fn table1() -> Lathe {
        Lathe::new(LatheParams::default()).unwrap()
    }

    fn paper_design(m1: f64, m2: f64) -> OutputFeedbackDesign {
        design(
            &table1(),
            &DesignSpec {
                time_constants: [m1, m2],
                consistency: Consistency::Report,
            },
        )
        .unwrap()
    }

    /// Positive initial forces up to 5 kN on a 12 × 12 grid, 20 s each (the slowest closed-loop
    /// pole of either design is −0.84 1/s).
    fn portrait(power_loop: &PowerLoop) -> PhasePortrait {
        power_loop
            .phase_portrait(&PortraitSpec {
                max_forces: [5000.0, 5000.0],
                points_per_axis: 12,
                duration: 20.0,
                step: PAPER_STEP,
                record_every: 25,
                tolerance: 1.0,
            })
            .unwrap()
    }

    fn assert_close(actual: f64, expected: f64, tolerance: f64) {
        assert!(
            (actual - expected).abs() <= tolerance,
            "{actual} vs {expected} (± {tolerance})"
        );
    }

    #[test]
    fn state_feedback_of_eq12_places_the_requested_poles() {
        for (m1, m2) in [(0.5, 0.49), (1.5, 1.49)] {
            let design = paper_design(m1, m2);
            let [slow, fast] = design.state_feedback_poles;
            assert_close(slow.re, -1.0 / m2, 1e-9);
            assert_close(fast.re, -1.0 / m1, 1e-9);
            assert_eq!((slow.im, fast.im), (0.0, 0.0));
        }
    }

    #[test]
    fn power_gains_are_k_times_the_pseudo_inverse_not_the_printed_eq15() {
        let lathe = table1();
        let [tau1, tau2] = lathe.feed_time_constants();
        let [s1, s2] = lathe.force_feed_slopes();
        let [v1, v2] = lathe.cutting_speeds();
        let speeds_squared = v1 * v1 + v2 * v2;
        for (m1, m2, expected_mm_per_kw) in [
            (0.5, 0.49, [-0.013052, -0.055230]),
            (1.5, 1.49, [-0.013052, -0.072655]),
        ] {
            let design = paper_design(m1, m2);
            let [h1, h2] = design.power_gains;
            // K C⁺ worked by hand from Sudhakara eq (12).
            assert_close(h1, -(v1 + tau1 * v2) / (s1 * speeds_squared), 1e-20);
            let h2_by_hand =
                (tau2 * v1 + (tau2 * (m1 + m2) - m1 * m2) * v2) / (m1 * m2 * s2 * speeds_squared);
            assert_close(h2, h2_by_hand, 1e-20);
            // mm/kW = 1e-6 m/W.
            assert_close(h1 * 1e6, expected_mm_per_kw[0], 1e-6);
            assert_close(h2 * 1e6, expected_mm_per_kw[1], 1e-6);
            // The printed Sudhakara eq (15) flips h_1's sign.
            let printed_h1 = (v1 + tau1 * v2) / (s1 * speeds_squared);
            assert!(printed_h1 > 0.0 && h1 < 0.0);
        }
        // Taken literally, Sudhakara eq (15) for m = 1.5 / 1.49 s turns the reference forces into a
        // saddle, unlike the paper's own Figs 5 and 7, so it cannot be what the paper simulated.
        let (m1, m2) = (1.5, 1.49);
        let printed = [
            (v1 + tau1 * v2) / (s1 * speeds_squared),
            (tau2 * v1 + tau2 * v2 * (m1 + m2) - m1 * m2 * v2) / (s2 * speeds_squared),
        ];
        let literal = PowerLoop::new(lathe, printed).unwrap();
        assert_eq!(literal.desired_equilibrium().kind, EquilibriumKind::Saddle);
    }

    #[test]
    fn table1_design_fails_theorem1_consistency() {
        let achieved = match design(&table1(), &DesignSpec::default()) {
            Err(DesignError::Inconsistent {
                residual,
                achieved_poles,
            }) => {
                assert_close(residual, 0.680, 1e-3);
                achieved_poles
            }
            other => panic!("expected Inconsistent, got {other:?}"),
        };
        // Not −2.04 and −2.0 as asked for.
        assert_close(achieved[0].re, -20.115, 1e-3);
        assert_close(achieved[1].re, -4.432, 1e-3);
        assert_eq!(paper_design(0.5, 0.49).output_feedback_poles, achieved);
    }

    /// Theorem 1 holds for Sudhakara eq (12) when the rows of K are parallel to C = [V_1 V_2]:
    /// τ_1 = V_2/V_1 (= 2 for Table 1's diameters) and τ_2(m_1 + m_2) − m_1 m_2 = τ_1 τ_2,
    /// e.g. τ_2 = 1 s with m = 0.5 s, 3 s. Then H = K C⁺ places the poles exactly.
    #[test]
    fn a_plant_meeting_theorem1_gets_its_poles_from_output_feedback() {
        let mut params = LatheParams::default();
        params.tools[0].feed_time_constant = 2.0;
        params.tools[1].feed_time_constant = 1.0;
        let lathe = Lathe::new(params).unwrap();
        let design = design(
            &lathe,
            &DesignSpec {
                time_constants: [0.5, 3.0],
                consistency: Consistency::Require,
            },
        )
        .unwrap();
        assert!(design.consistency_residual < 1e-12);
        let [slow, fast] = design.output_feedback_poles;
        assert_close(slow.re, -1.0 / 0.5, 1e-9);
        assert_close(fast.re, -1.0 / 3.0, 1e-9);
    }

    /// Figs 4 and 6: with m = 0.5 / 0.49 s the only rest point is the reference forces, a stable
    /// node, and every positive initial force reaches it.
    #[test]
    fn fast_design_has_one_equilibrium_that_attracts_every_positive_force() {
        let lathe = table1();
        let design = paper_design(0.5, 0.49);
        let power_loop = PowerLoop::new(lathe.clone(), design.power_gains).unwrap();
        let equilibria = power_loop.equilibria();
        assert_eq!(equilibria.len(), 1, "{equilibria:?}");
        let only = equilibria[0];
        let reference = lathe.reference_forces();
        assert_close(only.forces[0], reference[0], 1e-6);
        assert_close(only.forces[1], reference[1], 1e-6);
        assert_eq!(only.kind, EquilibriumKind::StableNode);
        assert_close(only.eigenvalues[0].re, -20.115, 1e-3);
        assert_close(only.eigenvalues[1].re, -4.432, 1e-3);
        let portrait = portrait(&power_loop);
        assert!(portrait.non_converging_initial_forces().is_empty());
        // Sudhakara eq (23) is only sufficient: these gains miss it (tool 2's zero-feed line
        // crosses the quadrant at 4.15 kW) yet the loop still converges from everywhere.
        assert!(!design.global_stability.satisfied);
        assert_close(
            design.global_stability.zero_feed_powers[1].unwrap(),
            4152.4,
            0.1,
        );
    }

    /// Figs 5 and 7–9: with m = 1.5 / 1.49 s a saddle appears between tool 2's zero-feed line
    /// and the reference forces; initial forces below its stable manifold end with tool 2 at
    /// zero feed and zero force.
    #[test]
    fn slow_design_has_a_saddle_and_a_region_of_low_forces_that_fails() {
        let lathe = table1();
        let design = paper_design(1.5, 1.49);
        let power_loop = PowerLoop::new(lathe.clone(), design.power_gains).unwrap();
        let equilibria = power_loop.equilibria();
        assert_eq!(equilibria.len(), 3, "{equilibria:?}");
        let [idle, saddle, desired] = [equilibria[0], equilibria[1], equilibria[2]];

        assert!(desired.is_asymptotically_stable());
        assert_close(desired.forces[0], lathe.reference_forces()[0], 1e-6);
        assert_close(desired.eigenvalues[1].re, -0.837, 1e-3);

        assert_eq!(saddle.kind, EquilibriumKind::Saddle);
        assert_close(saddle.forces[0], 2086.5, 0.1);
        assert_close(saddle.forces[1], 470.2, 0.1);
        assert_close(saddle.eigenvalues[0].re, -20.087, 1e-3);
        assert_close(saddle.eigenvalues[1].re, 1.241, 1e-3);
        assert_eq!(
            saddle.feed_regimes,
            [FeedRegime::Regulating, FeedRegime::Regulating]
        );

        // Where the failing trajectories go: tool 2 withdrawn to zero feed, tool 1 alone.
        assert_eq!(idle.kind, EquilibriumKind::StableNode);
        assert_eq!(idle.feed_regimes[1], FeedRegime::ZeroFeed);
        assert_eq!(idle.forces[1], 0.0);
        assert_close(idle.forces[0], 1809.7, 0.1);

        // The saddle sits above tool 2's zero-feed line of Sudhakara eq (21) (7.95 kW), 11.89 kW.
        let zero_feed_power = design.global_stability.zero_feed_powers[1].unwrap();
        assert_close(zero_feed_power, 7953.2, 0.1);
        assert!(saddle.spindle_power > zero_feed_power);
        assert_close(saddle.spindle_power, 11886.6, 0.1);

        // R_a's boundary by the reverse-trajectory method: nearly the constant-power line through
        // the saddle, parallel to the saturation line (Sudhakara eq (22)).
        let window = ForceBox {
            min: [0.0, 0.0],
            max: [5000.0, 5000.0],
        };
        let [upper, lower] = power_loop
            .reverse_trajectories(
                &saddle,
                &ReverseTrajectorySpec {
                    offset: 1.0,
                    duration: 5.0,
                    step: PAPER_STEP,
                    window,
                },
            )
            .unwrap();
        let mut boundary: Vec<[f64; 2]> = upper.into_iter().chain(lower).collect();
        boundary.sort_by(|a, b| a[0].total_cmp(&b[0]));
        assert!(boundary[0][0] < 100.0 && boundary.last().unwrap()[1] < 20.0);
        for point in &boundary {
            assert_close(lathe.spindle_power(*point), 11930.0, 120.0);
        }

        // The simulated portrait agrees with that boundary point for point.
        let below_boundary = |forces: [f64; 2]| {
            boundary.windows(2).any(|pair| {
                let [a, b] = [pair[0], pair[1]];
                if !(a[0] <= forces[0] && forces[0] <= b[0]) || a[0] == b[0] {
                    return false;
                }
                let t = (forces[0] - a[0]) / (b[0] - a[0]);
                forces[1] < a[1] + t * (b[1] - a[1])
            })
        };
        let portrait = portrait(&power_loop);
        for trajectory in &portrait.trajectories {
            assert_eq!(
                !trajectory.converged,
                below_boundary(trajectory.initial_forces),
                "{:?}",
                trajectory.initial_forces
            );
            if !trajectory.converged {
                assert_close(trajectory.final_forces[0], idle.forces[0], 1.0);
                assert!(trajectory.final_forces[1] < 1.0);
            }
        }
        // Extent on this 417 N grid: 9 of 144 starts, all below 12 kW, reaching F_1 = 2.08 kN
        // (at F_2 = 0.42 kN) and F_2 = 1.25 kN (at F_1 = 0.42 kN). The boundary itself meets the
        // axes near F_1 = 3.0 kN and F_2 = 1.5 kN.
        let failing = portrait.non_converging_initial_forces();
        assert_eq!(failing.len(), 9, "{failing:?}");
        assert!(failing.iter().all(|f| lathe.spindle_power(*f) < 12e3));
        let widest = failing
            .iter()
            .fold([0.0_f64; 2], |m, f| [m[0].max(f[0]), m[1].max(f[1])]);
        assert_close(widest[0], 2083.3, 0.1);
        assert_close(widest[1], 1250.0, 0.1);
    }

    /// Sudhakara eq (23): with h_2 raised to −f_n2/P_max tool 2's zero-feed line passes through the
    /// origin, the saddle and the idle rest point vanish, and every positive start converges.
    #[test]
    fn gains_meeting_eq23_remove_the_failing_region() {
        let lathe = table1();
        let slow = paper_design(1.5, 1.49);
        assert!(!slow.global_stability.satisfied);
        let bound = slow.global_stability.lower_bounds[1];
        assert_close(bound * 1e6, -0.043763, 1e-6);
        let gains = [slow.power_gains[0], bound];
        let check = global_stability(&lathe, gains);
        assert!(check.satisfied);
        assert!(check.zero_feed_powers[1].unwrap().abs() < 1e-9);
        let power_loop = PowerLoop::new(lathe, gains).unwrap();
        let equilibria = power_loop.equilibria();
        assert_eq!(equilibria.len(), 1, "{equilibria:?}");
        assert!(equilibria[0].is_asymptotically_stable());
        assert!(portrait(&power_loop)
            .non_converging_initial_forces()
            .is_empty());
    }

    #[test]
    fn eq23_accepts_the_printed_positive_bound_and_the_lyapunov_gains() {
        let lathe = table1();
        let [fn1, fn2] = lathe.nominal_feeds();
        for gains in [[fn1 / 20e3, fn2 / 20e3], [-fn1 / 20e3, -fn2 / 20e3]] {
            assert!(global_stability(&lathe, gains).satisfied);
        }
        assert!(!global_stability(&lathe, [0.0, -1.01 * fn2 / 20e3]).satisfied);
        assert_eq!(
            global_stability(&lathe, [0.0, 1e-8]).zero_feed_powers[0],
            None
        );
    }

    #[test]
    fn non_positive_time_constants_are_rejected() {
        for (bad, index) in [([0.0, 0.49], 1), ([0.5, -1.0], 2), ([0.5, f64::NAN], 2)] {
            let result = design(
                &table1(),
                &DesignSpec {
                    time_constants: bad,
                    consistency: Consistency::Report,
                },
            );
            assert!(
                matches!(result, Err(DesignError::NonPositiveTimeConstant { index: i, .. }) if i == index),
                "{result:?}"
            );
        }
    }

    #[test]
    fn spec_reads_from_toml() {
        let spec: DesignSpec =
            toml::from_str("time_constants = [1.5, 1.49]\nconsistency = \"report\"").unwrap();
        assert_eq!(spec.time_constants, [1.5, 1.49]);
        assert_eq!(spec.consistency, Consistency::Report);
        let defaults: DesignSpec = toml::from_str("").unwrap();
        assert_eq!(defaults, DesignSpec::default());
        assert!(toml::from_str::<DesignSpec>("gain = 1.0").is_err());
    }
}
