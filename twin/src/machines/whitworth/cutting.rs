//! The shaper's cutting process: the contact force of Perrusquía eq (40) and the figures a
//! cutting run is judged by (velocity over the workpiece, stroke times, quick-return ratio).
//!
//! The workpiece sits where Algorithm 1 puts it: `[x_a, x_b]` of Perrusquía eqs (4)–(5) on the
//! linkage's stroke, entered at x_a. While the ram moves the cutting way inside it, the tool meets
//! the contact force, of constant magnitude, against the motion (Perrusquía eq (40): 400 N up while
//! ẏ < 0).

use models::velocity_profile::{ProfileParams, VelocityProfile};
use models::whitworth::Geometry;
use serde::Deserialize;

/// `[process.workpiece]` of a Whitworth scenario.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Workpiece {
    /// `L_d`, m.
    pub length: f64,
    /// `v`, m/s, signed (the twin cuts downward: v < 0); the velocity the figures compare with.
    pub cutting_velocity: f64,
    /// `|f_y|` of Perrusquía eq (40), N.
    pub contact_force: f64,
}

/// Dead band on the ram speed when telling the strokes apart, m/s.
const STROKE_SPEED_DEAD_BAND: f64 = 0.01;

/// Squared-error sums of one pass over the workpiece.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
struct Pass {
    samples: usize,
    sum_squares: f64,
    max: f64,
}

impl Pass {
    fn add(&mut self, error: f64) {
        self.samples += 1;
        self.sum_squares += error * error;
        self.max = self.max.max(error.abs());
    }

    fn merge(&mut self, other: &Pass) {
        self.samples += other.samples;
        self.sum_squares += other.sum_squares;
        self.max = self.max.max(other.max);
    }

    fn rms(&self) -> f64 {
        (self.sum_squares / self.samples.max(1) as f64).sqrt()
    }
}

pub struct Cutting {
    workpiece: Workpiece,
    /// Sign of the cutting velocity.
    direction: f64,
    /// Where the tool enters and leaves the workpiece (x_a, x_b), m.
    entry: f64,
    exit: f64,
    current: Option<Pass>,
    /// Passes that crossed the whole workpiece.
    passes: Vec<Pass>,
    /// Last stroke seen: +1 cutting way, −1 return way.
    stroke: Option<f64>,
    cut_starts: Vec<f64>,
    return_starts: Vec<f64>,
    /// Cutting over return stroke time at constant crank speed, from the geometry alone.
    geometric_quick_return_ratio: f64,
}

impl Cutting {
    pub fn new(geometry: &Geometry, workpiece: Workpiece) -> Result<Self, String> {
        if !(workpiece.contact_force.is_finite() && workpiece.contact_force >= 0.0) {
            return Err(format!(
                "workpiece.contact_force must be ≥ 0 and finite, got {}",
                workpiece.contact_force
            ));
        }
        let stroke = geometry.stroke().map_err(|e| e.to_string())?;
        let profile = VelocityProfile::new(&ProfileParams {
            x_min: stroke.top,
            x_max: stroke.bottom,
            workpiece_length: workpiece.length,
            velocity: workpiece.cutting_velocity,
        })
        .map_err(|e| format!("workpiece: {e}"))?;
        Ok(Self {
            workpiece,
            direction: workpiece.cutting_velocity.signum(),
            entry: profile.x_a(),
            exit: profile.x_b(),
            current: None,
            passes: Vec::new(),
            stroke: None,
            cut_starts: Vec::new(),
            return_starts: Vec::new(),
            geometric_quick_return_ratio: stroke.quick_return_ratio(),
        })
    }

    fn on_workpiece(&self, y: f64) -> bool {
        (y - self.entry) * self.direction >= 0.0 && (self.exit - y) * self.direction >= 0.0
    }

    /// Perrusquía eq (40): the vertical force on the ram at height y moving at ẏ, N (+ up).
    /// The ram positions where the tool enters and leaves the workpiece, m.
    pub fn zone(&self) -> [f64; 2] {
        [self.entry, self.exit]
    }

    pub fn contact_force(&self, y: f64, ram_velocity: f64) -> f64 {
        if ram_velocity * self.direction > 0.0 && self.on_workpiece(y) {
            -self.direction * self.workpiece.contact_force
        } else {
            0.0
        }
    }

    /// Takes one sample of the ram.
    pub fn observe(&mut self, time: f64, y: f64, ram_velocity: f64) {
        let cutting = ram_velocity * self.direction > 0.0 && self.on_workpiece(y);
        match (&mut self.current, cutting) {
            (Some(pass), true) => pass.add(ram_velocity - self.workpiece.cutting_velocity),
            (None, true) => {
                let mut pass = Pass::default();
                pass.add(ram_velocity - self.workpiece.cutting_velocity);
                self.current = Some(pass);
            }
            (Some(pass), false) => {
                if (y - self.exit) * self.direction > 0.0 {
                    self.passes.push(*pass);
                }
                self.current = None;
            }
            (None, false) => {}
        }
        let along = ram_velocity * self.direction;
        let stroke = if along > STROKE_SPEED_DEAD_BAND {
            Some(1.0)
        } else if along < -STROKE_SPEED_DEAD_BAND {
            Some(-1.0)
        } else {
            self.stroke
        };
        if let (Some(before), Some(now)) = (self.stroke, stroke) {
            if before != now {
                if now > 0.0 {
                    self.cut_starts.push(time);
                } else {
                    self.return_starts.push(time);
                }
            }
        }
        self.stroke = stroke;
    }

    /// (cutting-stroke time, return-stroke time) of each whole cycle: from one turn into the
    /// cutting stroke to the next.
    fn cycles(&self) -> Vec<(f64, f64)> {
        self.cut_starts
            .windows(2)
            .filter_map(|w| {
                let turn = self.return_starts.iter().find(|&&t| t > w[0] && t < w[1])?;
                Some((turn - w[0], w[1] - turn))
            })
            .collect()
    }

    pub fn metrics(&self) -> Vec<(String, f64)> {
        let mut metrics = vec![("cuts".to_string(), self.passes.len() as f64)];
        for (i, pass) in self.passes.iter().enumerate() {
            metrics.push((format!("velocity_error_rms/cut_{}", i + 1), pass.rms()));
            metrics.push((format!("velocity_error_max/cut_{}", i + 1), pass.max));
        }
        if self.passes.len() > 1 {
            let mut later = Pass::default();
            for pass in &self.passes[1..] {
                later.merge(pass);
            }
            // The headline figures: as a share of the cutting speed |v|, %.
            let percent = 100.0 / self.workpiece.cutting_velocity.abs();
            metrics.push(("velocity_error_rms/after_first_cut".into(), later.rms()));
            metrics.push(("velocity_error_max/after_first_cut".into(), later.max));
            metrics.push((
                "velocity_error_rms_percent/after_first_cut".into(),
                percent * later.rms(),
            ));
            metrics.push((
                "velocity_error_max_percent/after_first_cut".into(),
                percent * later.max,
            ));
        }
        let cycles = self.cycles();
        if !cycles.is_empty() {
            let n = cycles.len() as f64;
            let cutting = cycles.iter().map(|c| c.0).sum::<f64>() / n;
            let returning = cycles.iter().map(|c| c.1).sum::<f64>() / n;
            metrics.push(("cycles".into(), n));
            metrics.push(("cycle_time".into(), cutting + returning));
            metrics.push(("cutting_stroke_time".into(), cutting));
            metrics.push(("return_stroke_time".into(), returning));
            metrics.push(("quick_return_ratio".into(), cutting / returning));
        }
        metrics.push((
            "geometric_quick_return_ratio".into(),
            self.geometric_quick_return_ratio,
        ));
        metrics
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cutting() -> Cutting {
        Cutting::new(
            &Geometry::default(),
            Workpiece {
                length: 0.3,
                cutting_velocity: -1.25,
                contact_force: 400.0,
            },
        )
        .unwrap()
    }

    #[test]
    fn contact_force_follows_eq_40() {
        let c = cutting();
        assert!((c.entry + 0.02907).abs() < 1e-5 && (c.exit + 0.32907).abs() < 1e-5);
        assert_eq!(c.contact_force(-0.1, -1.2), 400.0);
        assert_eq!(c.contact_force(-0.1, 1.2), 0.0, "return stroke");
        assert_eq!(c.contact_force(-0.02, -1.2), 0.0, "above the workpiece");
        assert_eq!(c.contact_force(-0.35, -1.2), 0.0, "below it");
    }

    #[test]
    fn passes_and_cycles_are_measured() {
        let mut c = cutting();
        // Four synthetic cycles: down at −1.25 m/s (0.01 m/s slower each cycle), up at 2.5 m/s.
        let mut time = 0.0;
        let dt = 1e-3;
        let mut y = 0.05;
        for cycle in 0..4 {
            while y > -0.41 {
                let v = -1.25 + 0.01 * f64::from(cycle);
                c.observe(time, y, v);
                y += v * dt;
                time += dt;
            }
            while y < 0.05 {
                c.observe(time, y, 2.5);
                y += 2.5 * dt;
                time += dt;
            }
        }
        let metrics: std::collections::HashMap<_, _> = c.metrics().into_iter().collect();
        assert_eq!(metrics["cuts"], 4.0);
        assert!(metrics["velocity_error_rms/cut_1"] < 1e-12);
        assert!((metrics["velocity_error_max/cut_2"] - 0.01).abs() < 1e-12);
        let later = ((0.01f64.powi(2) + 0.02f64.powi(2) + 0.03f64.powi(2)) / 3.0).sqrt();
        assert!((metrics["velocity_error_rms/after_first_cut"] - later).abs() < 1e-3);
        assert_eq!(metrics["cycles"], 2.0);
        assert!(
            (metrics["quick_return_ratio"] - 2.0).abs() < 0.05,
            "{metrics:?}"
        );
    }

    #[test]
    fn bad_workpieces_are_rejected() {
        let bad = |length, force| {
            Cutting::new(
                &Geometry::default(),
                Workpiece {
                    length,
                    cutting_velocity: -1.25,
                    contact_force: force,
                },
            )
            .err()
            .unwrap()
        };
        assert!(bad(0.6, 400.0).contains("shorter than the stroke"));
        assert!(bad(0.3, -1.0).contains("contact_force"));
    }
}
