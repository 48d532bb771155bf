//! Parallel turning: two single-point tools cutting a stepped part on one spindle, after
//! Sudhakara & Landers, "Output Feedback Force Control for a Parallel Turning Operation"
//! (ACC 2003). This module holds the open-loop process: the static force law Sudhakara eq (1), the
//! feed servos Sudhakara eqs (2)–(3) and the operating point of Sudhakara eqs (4)–(6).
//! [`closed_loop`](super::closed_loop) closes the power-feedback loop of Sudhakara eqs
//! (16)–(23) and analyses it.
//!
//! # Units
//!
//! Everything here is SI: forces in N, cutting speeds in m/s, feeds in m per spindle revolution,
//! depths and diameters in m, power in W, spindle speed in rad/s.
//!
//! The paper mixes units. Its Sudhakara eq (1) only reproduces its own nominal feeds (Table 1:
//! 0.528 and 0.875 mm) when evaluated with F in kN, d and f in mm and V in km/min (its
//! nomenclature), while Sudhakara eqs (4), (5), (7b) and (19)–(23) need V in m/s so that kN·m/s =
//! kW. So K = 1.17 "kN/mm²" is really kN · mm^−(α+β) · (km/min)^−γ.
//! [`cutting_coefficient_from_paper_units`] converts it once:
//!
//! K_SI = K_paper · 10³ (N/kN) · (10³ mm/m)^(α+β) · (0.06 (km/min)/(m/s))^γ,
//!
//! after which Sudhakara eq (1) reads F\[N] = K_SI · d\[m]^β · V\[m/s]^γ · f\[m]^α. For Table 1
//! this is K_SI ≈ 4.765·10⁸ N·m^−1.76·(m/s)^0.27.

use serde::Deserialize;
use thiserror::Error;

/// The paper's machine has two tools; arrays indexed by tool hold tool 1 first.
pub const TOOLS: usize = 2;

/// Converts the paper's cutting coefficient (Sudhakara eq (1) in kN, mm and km/min) into the SI
/// form used here (N, m, m/s); see the module docs for the derivation.
pub fn cutting_coefficient_from_paper_units(
    coefficient_kn_mm_km_per_min: f64,
    feed_exponent: f64,
    depth_exponent: f64,
    speed_exponent: f64,
) -> f64 {
    const NEWTONS_PER_KN: f64 = 1e3;
    const MM_PER_M: f64 = 1e3;
    const KM_PER_MIN_PER_M_PER_S: f64 = 60.0 / 1e3;
    coefficient_kn_mm_km_per_min
        * NEWTONS_PER_KN
        * MM_PER_M.powf(feed_exponent + depth_exponent)
        * KM_PER_MIN_PER_M_PER_S.powf(speed_exponent)
}

/// One tool's cutting process and feed servo (Table 1, SI).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ToolParams {
    /// Work diameter D_i the tool cuts at, m.
    pub diameter: f64,
    /// Depth of cut d_i, m.
    pub depth_of_cut: f64,
    /// K_i of Sudhakara eq (1) in SI: N · m^−(α+β) · (m/s)^−γ.
    pub cutting_coefficient: f64,
    /// α_i, feed exponent of Sudhakara eq (1); in (0, 1].
    pub feed_exponent: f64,
    /// β_i, depth-of-cut exponent of Sudhakara eq (1).
    pub depth_exponent: f64,
    /// γ_i, cutting-speed exponent of Sudhakara eq (1).
    pub speed_exponent: f64,
    /// τ_i of the feed servo, Sudhakara eq (2), s.
    pub feed_time_constant: f64,
}

impl ToolParams {
    /// A Table 1 tool (steel part, coated carbide insert) at the given geometry and servo.
    fn table1(diameter: f64, depth_of_cut: f64, feed_time_constant: f64) -> Self {
        let (feed_exponent, depth_exponent, speed_exponent) = (0.89, 0.87, -0.27);
        Self {
            diameter,
            depth_of_cut,
            cutting_coefficient: cutting_coefficient_from_paper_units(
                1.17,
                feed_exponent,
                depth_exponent,
                speed_exponent,
            ),
            feed_exponent,
            depth_exponent,
            speed_exponent,
            feed_time_constant,
        }
    }

    /// V_i = π D_i N_s (N_s in rev/s), written with the spindle speed in rad/s, m/s.
    pub fn cutting_speed(&self, spindle_speed: f64) -> f64 {
        0.5 * spindle_speed * self.diameter
    }

    /// K̄_i = K_i d_i^β V_i^γ: the feed-independent part of Sudhakara eq (1), N · m^−α.
    pub fn static_gain(&self, cutting_speed: f64) -> f64 {
        self.cutting_coefficient
            * self.depth_of_cut.powf(self.depth_exponent)
            * cutting_speed.powf(self.speed_exponent)
    }

    /// Sudhakara eq (1): F_i = K̄_i f_i^α, N. A tool with no feed (or a negative one) cuts nothing.
    pub fn cutting_force(&self, cutting_speed: f64, feed_per_rev: f64) -> f64 {
        self.static_gain(cutting_speed) * feed_per_rev.max(0.0).powf(self.feed_exponent)
    }

    /// Sudhakara eq (6): the feed per revolution that makes Sudhakara eq (1) produce `force`, m.
    pub fn feed_for_force(&self, cutting_speed: f64, force: f64) -> f64 {
        (force.max(0.0) / self.static_gain(cutting_speed)).powf(1.0 / self.feed_exponent)
    }

    /// Sudhakara eq (2) in the time domain: τ_i ḟ_i = f_ci − f_i, m/(rev·s).
    pub fn feed_rate(&self, feed_per_rev: f64, commanded_feed: f64) -> f64 {
        (commanded_feed - feed_per_rev) / self.feed_time_constant
    }

    /// Sudhakara eq (3): τ_i Ḟ_i = K̄_i f_ci^α − F_i, the force lag the paper uses in place of
    /// Sudhakara eqs (1)+(2), N/s.
    pub fn force_rate(&self, cutting_speed: f64, force: f64, commanded_feed: f64) -> f64 {
        (self.cutting_force(cutting_speed, commanded_feed) - force) / self.feed_time_constant
    }
}

/// The parallel lathe: two tools on one spindle, power-limited (Table 1 defaults, SI).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LatheParams {
    /// Cutting process and feed servo of tool 1 and tool 2.
    pub tools: [ToolParams; TOOLS],
    /// Spindle speed, rad/s (Table 1: 1500 rpm).
    pub spindle_speed: f64,
    /// P_max, the spindle's maximum continuous power the loop regulates to, W.
    pub max_spindle_power: f64,
    /// Upper limit of the commanded feed, Sudhakara eq (20), m/rev (paper: 1.5 mm).
    pub max_feed: f64,
}

impl Default for LatheParams {
    /// Table 1: D = 0.05 / 0.10 m, d = 3 / 1 mm, τ = 0.05 / 0.049 s, 1500 rpm, 20 kW, and the
    /// 1.5 mm feed limit of the simulation section.
    fn default() -> Self {
        Self {
            tools: [
                ToolParams::table1(0.05, 3e-3, 0.05),
                ToolParams::table1(0.10, 1e-3, 0.049),
            ],
            spindle_speed: 1500.0 * std::f64::consts::TAU / 60.0,
            max_spindle_power: 20e3,
            max_feed: 1.5e-3,
        }
    }
}

/// Sudhakara eq (4): P = Σ V_i F_i, W.
pub fn spindle_power(cutting_speeds: [f64; TOOLS], forces: [f64; TOOLS]) -> f64 {
    cutting_speeds[0] * forces[0] + cutting_speeds[1] * forces[1]
}

/// Sudhakara eq (5): each tool takes half of P_max, F_ri = P_max / (2 V_i), N.
pub fn reference_forces(max_spindle_power: f64, cutting_speeds: [f64; TOOLS]) -> [f64; TOOLS] {
    cutting_speeds.map(|speed| 0.5 * max_spindle_power / speed)
}

/// Why a lathe, a gain set or an analysis request was rejected. Tools are numbered 1 and 2 as
/// in the paper.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum LatheError {
    /// A quantity that must be positive (a lathe parameter, an integration step or duration, a
    /// window width, a count) is zero, negative or not finite.
    #[error("lathe: {name} must be finite and > 0 (got {value})")]
    NonPositive {
        /// What the quantity is, e.g. `tool 1 diameter`.
        name: String,
        /// The rejected value, in the quantity's SI unit.
        value: f64,
    },
    /// A cutting exponent or a power gain is infinite or NaN.
    #[error("lathe: {name} must be finite (got {value})")]
    NotFinite {
        /// What the quantity is, e.g. `power gain h_1`.
        name: String,
        /// The rejected value.
        value: f64,
    },
    /// A tool's feed exponent α is outside (0, 1].
    #[error("lathe: tool {tool} feed exponent α = {value} is outside (0, 1]")]
    FeedExponentOutOfRange {
        /// 1 or 2.
        tool: usize,
        /// The rejected α.
        value: f64,
    },
    /// A tool cannot take its half of P_max without a feed above the limit, so the loop could
    /// never regulate the spindle to P_max.
    #[error(
        "lathe: tool {tool} must take {required} W (half of P_max) but reaches only {reachable} W \
         at the {max_feed} m/rev feed limit"
    )]
    PowerUnreachable {
        /// 1 or 2.
        tool: usize,
        /// Power the tool must take, P_max/2, W.
        required: f64,
        /// Power the tool takes at the feed limit, W.
        reachable: f64,
        /// Feed limit f_max, m/rev.
        max_feed: f64,
    },
    /// A trajectory or phase portrait needs more RK4 steps than the cap that keeps a bad request
    /// from exhausting memory.
    #[error("lathe: the analysis asks for {steps:.3e} integration steps, more than {limit:.0e} (shorten the duration or use fewer grid points)")]
    TooManySteps {
        /// Steps the request needs (for a portrait, summed over the whole grid).
        steps: f64,
        /// The cap on steps.
        limit: f64,
    },
    /// Reverse trajectories were asked from an equilibrium that is not a saddle.
    #[error(
        "lathe: the equilibrium at {forces:?} N is not a saddle, so it has no stable manifold"
    )]
    NotASaddle {
        /// F_1, F_2 at that equilibrium, N.
        forces: [f64; TOOLS],
    },
}

pub(crate) fn require_positive(name: impl Into<String>, value: f64) -> Result<(), LatheError> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(LatheError::NonPositive {
            name: name.into(),
            value,
        })
    }
}

fn require_finite(name: impl Into<String>, value: f64) -> Result<(), LatheError> {
    if value.is_finite() {
        Ok(())
    } else {
        Err(LatheError::NotFinite {
            name: name.into(),
            value,
        })
    }
}

/// A validated lathe with its operating point (Sudhakara eqs (4)–(6)) worked out.
#[derive(Debug, Clone, PartialEq)]
pub struct Lathe {
    params: LatheParams,
    cutting_speeds: [f64; TOOLS],
    static_gains: [f64; TOOLS],
    reference_forces: [f64; TOOLS],
    nominal_feeds: [f64; TOOLS],
}

impl Lathe {
    /// Checks the parameters and solves for the operating point; each tool must be able to take
    /// its half of P_max without exceeding the feed limit, or regulating to P_max is impossible.
    pub fn new(params: LatheParams) -> Result<Self, LatheError> {
        require_positive("spindle_speed", params.spindle_speed)?;
        require_positive("max_spindle_power", params.max_spindle_power)?;
        require_positive("max_feed", params.max_feed)?;
        for (index, tool) in params.tools.iter().enumerate() {
            let name = |field: &str| format!("tool {} {field}", index + 1);
            require_positive(name("diameter"), tool.diameter)?;
            require_positive(name("depth_of_cut"), tool.depth_of_cut)?;
            require_positive(name("cutting_coefficient"), tool.cutting_coefficient)?;
            require_positive(name("feed_time_constant"), tool.feed_time_constant)?;
            require_finite(name("depth_exponent"), tool.depth_exponent)?;
            require_finite(name("speed_exponent"), tool.speed_exponent)?;
            if !(tool.feed_exponent > 0.0 && tool.feed_exponent <= 1.0) {
                return Err(LatheError::FeedExponentOutOfRange {
                    tool: index + 1,
                    value: tool.feed_exponent,
                });
            }
        }
        let cutting_speeds = params
            .tools
            .map(|tool| tool.cutting_speed(params.spindle_speed));
        let static_gains = [0, 1].map(|i| params.tools[i].static_gain(cutting_speeds[i]));
        let reference_forces = reference_forces(params.max_spindle_power, cutting_speeds);
        let nominal_feeds =
            [0, 1].map(|i| params.tools[i].feed_for_force(cutting_speeds[i], reference_forces[i]));
        for i in 0..TOOLS {
            let reachable = cutting_speeds[i]
                * params.tools[i].cutting_force(cutting_speeds[i], params.max_feed);
            if nominal_feeds[i].is_nan() || nominal_feeds[i] > params.max_feed {
                return Err(LatheError::PowerUnreachable {
                    tool: i + 1,
                    required: 0.5 * params.max_spindle_power,
                    reachable,
                    max_feed: params.max_feed,
                });
            }
        }
        Ok(Self {
            params,
            cutting_speeds,
            static_gains,
            reference_forces,
            nominal_feeds,
        })
    }

    /// The parameters the lathe was built from.
    pub fn params(&self) -> &LatheParams {
        &self.params
    }

    /// V_i, m/s.
    pub fn cutting_speeds(&self) -> [f64; TOOLS] {
        self.cutting_speeds
    }

    /// K̄_i of Sudhakara eq (1), N · m^−α.
    pub fn static_gains(&self) -> [f64; TOOLS] {
        self.static_gains
    }

    /// F_ri of Sudhakara eq (5), N.
    pub fn reference_forces(&self) -> [f64; TOOLS] {
        self.reference_forces
    }

    /// f_ni of Sudhakara eq (6), m/rev.
    pub fn nominal_feeds(&self) -> [f64; TOOLS] {
        self.nominal_feeds
    }

    /// τ_i of Sudhakara eq (2), s.
    pub fn feed_time_constants(&self) -> [f64; TOOLS] {
        self.params.tools.map(|tool| tool.feed_time_constant)
    }

    /// Sudhakara eq (4) at this spindle speed, W.
    pub fn spindle_power(&self, forces: [f64; TOOLS]) -> f64 {
        spindle_power(self.cutting_speeds, forces)
    }

    /// Sudhakara eq (1) for both tools, N.
    pub fn cutting_forces(&self, feeds_per_rev: [f64; TOOLS]) -> [f64; TOOLS] {
        [0, 1].map(|i| self.params.tools[i].cutting_force(self.cutting_speeds[i], feeds_per_rev[i]))
    }

    /// Sudhakara eq (3) for both tools, N/s.
    pub fn force_rates(&self, forces: [f64; TOOLS], commanded_feeds: [f64; TOOLS]) -> [f64; TOOLS] {
        [0, 1].map(|i| {
            self.params.tools[i].force_rate(self.cutting_speeds[i], forces[i], commanded_feeds[i])
        })
    }

    /// K̄_iα of Sudhakara eq (7a): ∂F_i/∂f_i at the nominal feed, α_i K̄_i f_ni^(α−1) = α_i F_ri /
    /// f_ni, N/m. (The paper prints K_i for K̄_i in this definition; only K̄_i makes it the slope
    /// of Sudhakara eq (1).)
    pub fn force_feed_slopes(&self) -> [f64; TOOLS] {
        [0, 1].map(|i| {
            self.params.tools[i].feed_exponent * self.reference_forces[i] / self.nominal_feeds[i]
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(actual: f64, expected: f64, relative: f64) -> bool {
        (actual - expected).abs() <= relative * expected.abs()
    }

    #[test]
    fn table1_operating_point_matches_the_paper() {
        let lathe = Lathe::new(LatheParams::default()).unwrap();
        let [v1, v2] = lathe.cutting_speeds();
        // π D N_s: 235.6 and 471.2 m/min.
        assert!(close(v1, 3.926_990_8, 1e-7) && close(v2, 7.853_981_6, 1e-7));
        // Sudhakara eq (5): 20 kW split evenly, 2.546 and 1.273 kN.
        let [fr1, fr2] = lathe.reference_forces();
        assert!(close(fr1, 2546.479, 1e-6) && close(fr2, 1273.240, 1e-6));
        assert!(close(lathe.spindle_power([fr1, fr2]), 20e3, 1e-12));
        // Sudhakara eq (6): Table 1 prints 0.528 and 0.875 mm.
        let [fn1, fn2] = lathe.nominal_feeds();
        assert!((fn1 - 0.528e-3).abs() < 0.5e-6, "f_n1 = {fn1}");
        assert!((fn2 - 0.875e-3).abs() < 0.5e-6, "f_n2 = {fn2}");
        // Sudhakara eq (1) at the nominal feed gives back the reference force.
        let forces = lathe.cutting_forces([fn1, fn2]);
        assert!(close(forces[0], fr1, 1e-12) && close(forces[1], fr2, 1e-12));
    }

    #[test]
    fn paper_units_conversion_agrees_with_evaluating_eq1_in_paper_units() {
        let tool = LatheParams::default().tools[0];
        let (speed, feed): (f64, f64) = (3.2, 0.4e-3);
        // Sudhakara eq (1) as the paper evaluates it: kN from mm and km/min.
        let paper_kn = 1.17
            * (tool.depth_of_cut * 1e3).powf(0.87)
            * (speed * 0.06).powf(-0.27)
            * (feed * 1e3).powf(0.89);
        assert!(close(
            tool.cutting_force(speed, feed),
            paper_kn * 1e3,
            1e-12
        ));
        assert!(close(tool.cutting_coefficient, 4.765_242_7e8, 1e-7));
    }

    #[test]
    fn servo_and_force_lag_follow_eqs_2_and_3() {
        let lathe = Lathe::new(LatheParams::default()).unwrap();
        let tool = lathe.params().tools[1];
        assert_eq!(tool.feed_rate(0.2e-3, 0.7e-3), 0.5e-3 / 0.049);
        let [_, fr2] = lathe.reference_forces();
        let [_, fn2] = lathe.nominal_feeds();
        // At the nominal feed the reference force is a rest point of Sudhakara eq (3).
        assert!(lathe.force_rates([0.0, fr2], [0.0, fn2])[1].abs() < 1e-9);
        assert!(close(
            lathe.force_rates([0.0, 0.0], [0.0, fn2])[1],
            fr2 / 0.049,
            1e-12
        ));
        // A withdrawn tool cuts nothing rather than producing NaN.
        assert_eq!(tool.cutting_force(7.0, -1e-4), 0.0);
    }

    #[test]
    fn force_feed_slope_is_the_derivative_of_eq1() {
        let lathe = Lathe::new(LatheParams::default()).unwrap();
        let nominal = lathe.nominal_feeds();
        let slopes = lathe.force_feed_slopes();
        for i in 0..TOOLS {
            let h = 1e-9;
            let mut up = nominal;
            let mut down = nominal;
            up[i] += h;
            down[i] -= h;
            let numeric = (lathe.cutting_forces(up)[i] - lathe.cutting_forces(down)[i]) / (2.0 * h);
            assert!(
                close(slopes[i], numeric, 1e-6),
                "{} vs {numeric}",
                slopes[i]
            );
        }
    }

    #[test]
    fn each_invalid_parameter_is_rejected() {
        let base = LatheParams::default();
        let with_tool = |edit: fn(&mut ToolParams)| {
            let mut params = base;
            edit(&mut params.tools[1]);
            Lathe::new(params)
        };
        assert!(matches!(
            with_tool(|t| t.feed_time_constant = 0.0),
            Err(LatheError::NonPositive { ref name, .. }) if name == "tool 2 feed_time_constant"
        ));
        assert!(matches!(
            with_tool(|t| t.feed_time_constant = -0.05),
            Err(LatheError::NonPositive { .. })
        ));
        assert_eq!(
            with_tool(|t| t.feed_exponent = 1.2),
            Err(LatheError::FeedExponentOutOfRange {
                tool: 2,
                value: 1.2
            })
        );
        assert!(matches!(
            with_tool(|t| t.feed_exponent = 0.0),
            Err(LatheError::FeedExponentOutOfRange { tool: 2, .. })
        ));
        assert!(matches!(
            with_tool(|t| t.diameter = 0.0),
            Err(LatheError::NonPositive { ref name, .. }) if name == "tool 2 diameter"
        ));
        assert!(matches!(
            with_tool(|t| t.depth_of_cut = -1e-3),
            Err(LatheError::NonPositive { ref name, .. }) if name == "tool 2 depth_of_cut"
        ));
        assert!(matches!(
            with_tool(|t| t.speed_exponent = f64::NAN),
            Err(LatheError::NotFinite { .. })
        ));
        let mut slow = base;
        slow.spindle_speed = 0.0;
        assert!(matches!(
            Lathe::new(slow),
            Err(LatheError::NonPositive { ref name, .. }) if name == "spindle_speed"
        ));
        // 60 kW needs 30 kW per tool; at 1.5 mm tool 1 reaches ~25.3 kW (tool 2 ~16.2 kW).
        let greedy = LatheParams {
            max_spindle_power: 60e3,
            ..base
        };
        match Lathe::new(greedy) {
            Err(LatheError::PowerUnreachable {
                tool: 1,
                required,
                reachable,
                ..
            }) => {
                assert_eq!(required, 30e3);
                assert!(reachable < required);
            }
            other => panic!("expected PowerUnreachable, got {other:?}"),
        }
    }

    #[test]
    fn params_deserialize_with_table1_defaults() {
        // Unset fields come from Table 1. Fed through serde's own value deserializers so models
        // keeps no format dependency.
        use serde::de::value::{Error, MapDeserializer};
        use serde::de::IntoDeserializer;
        let entries = vec![("max_spindle_power", 15e3_f64.into_deserializer())];
        let deserializer = MapDeserializer::<_, Error>::new(
            entries.into_iter().map(|(k, v)| (k.into_deserializer(), v)),
        );
        let params = LatheParams::deserialize(deserializer).unwrap();
        assert_eq!(params.max_spindle_power, 15e3);
        assert_eq!(params.tools, LatheParams::default().tools);
    }
}
