//! Peripheral milling by a robot-held spindle: the stock left on a cast part along its contour and
//! the cutting load it puts on the tool — the process of Ilyukhin, Poduraev & Tatarintseva
//! (DAAAM 2014, §1: a casting's deviations change the depth of cut and so the cutting force).
//!
//! # Cutting force
//!
//! The mechanistic form of Rubio, Ibeas & Luo (Rubio eqs (2)–(4)) (see
//! [`crate::feed_axis::micromilling`] for the micro-scale version with run-out), at machining-robot
//! scale: per tooth `F_t = K_t·h·a`, `F_n = K_n·h·a` (Rubio eqs (2)–(3), straight flutes, `a` the
//! axial depth — here the part's thickness across the arm's plane), projected with Rubio eq (4) on
//! the feed direction x and its normal y, `F_x = −F_t cos φ − F_n sin φ`, `F_y = F_t sin φ − F_n
//! cos φ` (φ from +y, in the cutter's sense of rotation). The chip is `h = f_z·sin φ` with the feed
//! per tooth `f_z = V/(N·n)` — path speed over teeth times spindle revolutions per second — and no
//! run-out: a robot-held macro cutter has run-out far below its 0.1 mm chips.
//!
//! The twin steps at 1 ms, slower than the teeth pass (200 Hz at 6,000 rpm with two teeth), so it
//! applies the force **averaged over a tooth period**: `N/2π` times the integral of Rubio eq (4)
//! over the engaged arc. With radial depth `a_e` on a cutter of radius `R`, the arc spans
//! `φ_e = acos(1 − a_e/R)`: `[0, φ_e]` in up (conventional) milling, `[π − φ_e, π]` in down
//! (climb) milling. With `S₁ = [sin²φ/2]` and `S₂ = [φ/2 − sin 2φ/4]` over the arc:
//! `F̄_x = −(N·a·f_z/2π)(K_t·S₁ + K_n·S₂)`, `F̄_y = (N·a·f_z/2π)(K_t·S₂ − K_n·S₁)`, and the
//! torque resisting the spindle `T̄ = R·(N·a·f_z/2π)·K_t·[−cos φ]`. A full slot gives the familiar
//! `F̄_x = −N·a·K_n·f_z/4`, `F̄_y = N·a·K_t·f_z/4`; the spindle power `T̄·Ω = K_t·a·a_e·V`.
//!
//! Which mode cuts follows from the geometry: with the stock on the right of the direction of
//! travel, a cutter turning counter-clockwise mills up, clockwise down.
//!
//! # Cutting coefficients
//!
//! Defaults for a cast aluminium alloy: `K_t` = 700 N/mm², `K_n` = 210 N/mm² (0.3·K_t), the order
//! Altintas tabulates for aluminium alloys (*Manufacturing Automation*, 2nd ed., 2012, ch. 2).

use serde::Deserialize;
use std::f64::consts::{PI, TAU};
use thiserror::Error;

/// The cutter and the material (SI units: m, N/m²).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CutterParams {
    /// Number of teeth N.
    pub teeth: u32,
    /// Cutter diameter, m.
    pub diameter: f64,
    /// Axial depth of cut a (the part's thickness across the plane), m.
    pub axial_depth: f64,
    /// Tangential cutting coefficient K_t, N/m².
    pub tangential_coefficient: f64,
    /// Normal cutting coefficient K_n, N/m².
    pub normal_coefficient: f64,
}

impl Default for CutterParams {
    /// A two-flute 10 mm end mill cutting 5 mm deep in cast aluminium.
    fn default() -> Self {
        Self {
            teeth: 2,
            diameter: 0.010,
            axial_depth: 0.005,
            tangential_coefficient: 700.0e6,
            normal_coefficient: 210.0e6,
        }
    }
}

/// Why a cutter or a stock profile is rejected.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum MillingError {
    /// A [`CutterParams`] dimension or coefficient is zero, negative or not finite; holds its name.
    #[error("milling: {0} must be finite and > 0")]
    NotPositive(&'static str),
    /// The cutter has no teeth.
    #[error("milling: teeth must be at least 1")]
    NoTeeth,
    /// The [`Stock`] profile is unusable; holds what is wrong and where.
    #[error("stock: {0}")]
    BadStock(String),
}

/// Whether the teeth enter the stock with a thin chip (up) or a thick one (down).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MillingMode {
    /// Up (conventional) milling: the chip grows from zero at entry to its thickest at exit.
    Up,
    /// Down (climb) milling: the chip is thickest at entry and thins to zero at exit.
    Down,
}

/// The tooth-period mean of the cut's load on the tool.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CutLoad {
    /// Force on the tool along the direction of travel, N.
    pub along: f64,
    /// Force on the tool towards the stock, N.
    pub towards_stock: f64,
    /// Torque resisting the spindle's rotation, N·m (≥ 0).
    pub torque: f64,
}

/// A validated cutter.
#[derive(Debug, Clone, PartialEq)]
pub struct Cutter {
    params: CutterParams,
}

/// Spindle speeds below this are taken as this when computing the feed per tooth, rad/s.
const SLOWEST_SPINDLE: f64 = 1.0;

impl Cutter {
    /// Checks the dimensions and coefficients are positive and the cutter has teeth.
    pub fn new(params: CutterParams) -> Result<Self, MillingError> {
        for (name, value) in [
            ("diameter", params.diameter),
            ("axial_depth", params.axial_depth),
            ("tangential_coefficient", params.tangential_coefficient),
            ("normal_coefficient", params.normal_coefficient),
        ] {
            if !(value > 0.0 && value.is_finite()) {
                return Err(MillingError::NotPositive(name));
            }
        }
        if params.teeth == 0 {
            return Err(MillingError::NoTeeth);
        }
        Ok(Self { params })
    }

    /// The parameters the cutter was built from.
    pub fn params(&self) -> &CutterParams {
        &self.params
    }

    /// Cutter radius R, m.
    pub fn radius(&self) -> f64 {
        self.params.diameter / 2.0
    }

    /// Feed per tooth f_z, m, at path speed `speed` (m/s) and spindle speed `spindle` (rad/s).
    pub fn feed_per_tooth(&self, speed: f64, spindle: f64) -> f64 {
        speed.max(0.0) * TAU / (f64::from(self.params.teeth) * spindle.abs().max(SLOWEST_SPINDLE))
    }

    /// Mean load of a cut `radial_depth` deep (m, clipped to the diameter) at path speed `speed`
    /// (m/s, along the path; nothing is cut moving backwards) with the spindle at `spindle` rad/s.
    pub fn load(&self, mode: MillingMode, radial_depth: f64, speed: f64, spindle: f64) -> CutLoad {
        let radius = self.radius();
        let depth = radial_depth.clamp(0.0, self.params.diameter);
        let feed = self.feed_per_tooth(speed, spindle);
        if depth == 0.0 || feed == 0.0 {
            return CutLoad::default();
        }
        let engaged = (1.0 - depth / radius).clamp(-1.0, 1.0).acos();
        let (entry, exit) = match mode {
            MillingMode::Up => (0.0, engaged),
            MillingMode::Down => (PI - engaged, PI),
        };
        let s1 = (exit.sin().powi(2) - entry.sin().powi(2)) / 2.0;
        let s2 =
            (exit / 2.0 - (2.0 * exit).sin() / 4.0) - (entry / 2.0 - (2.0 * entry).sin() / 4.0);
        let scale = f64::from(self.params.teeth) * self.params.axial_depth * feed / TAU;
        let (kt, kn) = (
            self.params.tangential_coefficient,
            self.params.normal_coefficient,
        );
        let fx = -scale * (kt * s1 + kn * s2);
        let fy = scale * (kt * s2 - kn * s1);
        // The stock lies on +y in up milling, on −y in down milling.
        let towards_stock = match mode {
            MillingMode::Up => fy,
            MillingMode::Down => -fy,
        };
        CutLoad {
            along: fx,
            towards_stock,
            torque: radius * scale * kt * (entry.cos() - exit.cos()),
        }
    }
}

/// The stock along the contour: radial depth of cut against path length, piecewise linear
/// between the given points, no stock before the first or after the last.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Stock {
    /// `[path length, radial depth]` pairs, m, path lengths increasing.
    pub depth: Vec<[f64; 2]>,
}

impl Default for Stock {
    /// A casting with 1 mm of stock on its finished contour and one deviation 3.5 mm deep between
    /// 60 and 100 mm of path (ramps of 15 mm), entered after a 10 mm lead-in.
    fn default() -> Self {
        Self {
            depth: vec![
                [0.010, 0.0],
                [0.015, 1.0e-3],
                [0.045, 1.0e-3],
                [0.060, 3.5e-3],
                [0.100, 3.5e-3],
                [0.115, 1.0e-3],
                [0.205, 1.0e-3],
                [0.210, 0.0],
            ],
        }
    }
}

impl Stock {
    /// Checks there are at least two points, path lengths increase and every depth lies within
    /// 0…`diameter` (the cutter's, m).
    pub fn validate(&self, diameter: f64) -> Result<(), MillingError> {
        let bad = |reason: String| MillingError::BadStock(reason);
        if self.depth.len() < 2 {
            return Err(bad(
                "depth needs at least two [path length, depth] points".into()
            ));
        }
        for (i, [along, depth]) in self.depth.iter().enumerate() {
            if !(along.is_finite() && depth.is_finite() && *depth >= 0.0 && *depth <= diameter) {
                return Err(bad(format!(
                    "depth[{i}] = [{along}, {depth}]: path length finite, depth within 0…{diameter} m"
                )));
            }
            if i > 0 && *along <= self.depth[i - 1][0] {
                return Err(bad(format!("depth[{i}]: path lengths must increase")));
            }
        }
        Ok(())
    }

    /// Radial depth of the stock at path length `along`, m.
    pub fn depth_at(&self, along: f64) -> f64 {
        let points = &self.depth;
        let (first, last) = (points[0], points[points.len() - 1]);
        if along < first[0] || along > last[0] {
            return 0.0;
        }
        let i = points
            .partition_point(|p| p[0] <= along)
            .clamp(1, points.len() - 1);
        let ([s0, d0], [s1, d1]) = (points[i - 1], points[i]);
        d0 + (d1 - d0) * (along - s0) / (s1 - s0)
    }

    /// The largest radial depth, m.
    pub fn deepest(&self) -> f64 {
        self.depth.iter().fold(0.0, |m, p| m.max(p[1]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cutter() -> Cutter {
        Cutter::new(CutterParams::default()).unwrap()
    }

    /// The tooth-period mean by brute force: Rubio eq (4) summed over teeth at many cutter angles.
    fn averaged(mode: MillingMode, depth: f64, speed: f64, spindle: f64) -> (f64, f64, f64) {
        let c = cutter();
        let p = c.params;
        let feed = c.feed_per_tooth(speed, spindle);
        let engaged = (1.0 - depth / c.radius()).acos();
        let (entry, exit) = match mode {
            MillingMode::Up => (0.0, engaged),
            MillingMode::Down => (PI - engaged, PI),
        };
        let samples = 200_000;
        let (mut fx, mut fy, mut torque) = (0.0, 0.0, 0.0);
        for k in 0..samples {
            let turn = TAU * (k as f64 + 0.5) / samples as f64;
            for j in 0..p.teeth {
                let phi = (turn + TAU * f64::from(j) / f64::from(p.teeth)).rem_euclid(TAU);
                if phi < entry || phi > exit {
                    continue;
                }
                let h = feed * phi.sin();
                let (ft, fn_) = (
                    p.tangential_coefficient * h * p.axial_depth,
                    p.normal_coefficient * h * p.axial_depth,
                );
                fx += -ft * phi.cos() - fn_ * phi.sin();
                fy += ft * phi.sin() - fn_ * phi.cos();
                torque += ft * c.radius();
            }
        }
        let n = samples as f64;
        (fx / n, fy / n, torque / n)
    }

    #[test]
    fn closed_form_mean_matches_the_tooth_by_tooth_average() {
        let (speed, spindle) = (0.02, 200.0 * PI);
        for mode in [MillingMode::Up, MillingMode::Down] {
            for depth in [1e-3, 3.5e-3, 10e-3] {
                let load = cutter().load(mode, depth, speed, spindle);
                let (fx, fy, torque) = averaged(mode, depth, speed, spindle);
                let towards = if mode == MillingMode::Up { fy } else { -fy };
                for (a, b) in [
                    (load.along, fx),
                    (load.towards_stock, towards),
                    (load.torque, torque),
                ] {
                    assert!(
                        (a - b).abs() < 1e-3 * (1.0 + b.abs()),
                        "{mode:?} {depth}: {a} vs {b}"
                    );
                }
            }
        }
    }

    #[test]
    fn slot_and_power_identities() {
        let c = cutter();
        let (speed, spindle) = (0.02, 200.0 * PI);
        let feed = c.feed_per_tooth(speed, spindle);
        assert!(
            (feed - 1e-4).abs() < 1e-15,
            "0.1 mm per tooth at 20 mm/s, 6000 rpm"
        );
        let slot = c.load(MillingMode::Up, 0.010, speed, spindle);
        let p = c.params;
        assert!(
            (slot.along + 2.0 * p.axial_depth * p.normal_coefficient * feed / 4.0).abs() < 1e-9
        );
        assert!(
            (slot.towards_stock.abs()
                - 2.0 * p.axial_depth * p.tangential_coefficient * feed / 4.0)
                .abs()
                < 1e-9
        );
        let cut = c.load(MillingMode::Down, 2e-3, speed, spindle);
        let power = p.tangential_coefficient * p.axial_depth * 2e-3 * speed;
        assert!((cut.torque * spindle - power).abs() < 1e-9 * power);
    }

    #[test]
    fn up_milling_pulls_the_tool_in_and_resists_the_feed() {
        let c = cutter();
        let up = c.load(MillingMode::Up, 3.5e-3, 0.02, 200.0 * PI);
        assert!(up.along < 0.0 && up.towards_stock > 0.0, "{up:?}");
        let down = c.load(MillingMode::Down, 3.5e-3, 0.02, 200.0 * PI);
        assert!(down.along > 0.0 && down.towards_stock < 0.0, "{down:?}");
        // Twice the speed, twice the chip, twice the force; nothing when still or reversing.
        let fast = c.load(MillingMode::Up, 3.5e-3, 0.04, 200.0 * PI);
        assert!((fast.along - 2.0 * up.along).abs() < 1e-9);
        assert_eq!(
            c.load(MillingMode::Up, 3.5e-3, -0.01, 200.0 * PI),
            CutLoad::default()
        );
        assert_eq!(
            c.load(MillingMode::Up, 0.0, 0.02, 200.0 * PI),
            CutLoad::default()
        );
    }

    #[test]
    fn stock_profile() {
        let stock = Stock::default();
        stock.validate(0.01).unwrap();
        assert_eq!(stock.depth_at(0.005), 0.0);
        assert!((stock.depth_at(0.0125) - 0.5e-3).abs() < 1e-12);
        assert!((stock.depth_at(0.08) - 3.5e-3).abs() < 1e-12);
        assert!((stock.depth_at(0.0525) - 2.25e-3).abs() < 1e-12);
        assert_eq!(stock.depth_at(0.3), 0.0);
        assert_eq!(stock.deepest(), 3.5e-3);
        let unordered = Stock {
            depth: vec![[0.1, 0.001], [0.05, 0.001]],
        };
        assert!(unordered
            .validate(0.01)
            .unwrap_err()
            .to_string()
            .contains("increase"));
        let too_deep = Stock {
            depth: vec![[0.0, 0.001], [0.05, 0.02]],
        };
        assert!(too_deep.validate(0.01).is_err());
        assert!(Cutter::new(CutterParams {
            teeth: 0,
            ..Default::default()
        })
        .is_err());
        assert!(Cutter::new(CutterParams {
            diameter: -1.0,
            ..Default::default()
        })
        .unwrap_err()
        .to_string()
        .contains("diameter"));
    }
}
