//! Figures every run gets, whatever its scenario declares: effort peaks and saturation, loop
//! closure, energy drift and the controller's final internal values.

use super::layout::SignalLayout;
use super::observer::{Findings, Observer, ObserverError, StepView};

/// Running figures over every physics step.
#[derive(Debug, Default)]
pub(super) struct RunStats {
    actuators: Vec<String>,
    internals: Vec<String>,
    has_loops: bool,
    samples: usize,
    peak_effort: Vec<f64>,
    saturated_samples: Vec<usize>,
    loop_gap_max: f64,
    energy_start: Option<f64>,
    energy_drift_max: f64,
    final_internals: Vec<f64>,
}

impl Observer for RunStats {
    fn start(&mut self, layout: &SignalLayout) -> Result<(), ObserverError> {
        *self = Self {
            actuators: layout.actuators.clone(),
            internals: layout.internals.clone(),
            has_loops: layout.loop_count() > 0,
            peak_effort: vec![0.0; layout.actuators.len()],
            saturated_samples: vec![0; layout.actuators.len()],
            ..Self::default()
        };
        Ok(())
    }

    fn observe(&mut self, view: &StepView) -> Result<(), ObserverError> {
        self.samples += 1;
        for (a, effort) in view.applied.iter().enumerate() {
            self.peak_effort[a] = self.peak_effort[a].max(effort.abs());
            self.saturated_samples[a] += usize::from(view.saturated[a]);
        }
        for gap in &view.state.loop_gaps {
            self.loop_gap_max = self.loop_gap_max.max(*gap);
        }
        let energy = view.layout.mechanical_energy(view.diagnostics);
        let start = *self.energy_start.get_or_insert(energy);
        self.energy_drift_max = self.energy_drift_max.max((energy - start).abs());
        if view.last {
            self.final_internals = view.internals.to_vec();
        }
        Ok(())
    }

    fn finish(&mut self) -> Result<Findings, ObserverError> {
        let mut metrics = Vec::new();
        for (a, joint) in self.actuators.iter().enumerate() {
            metrics.push((format!("peak_effort/{joint}"), self.peak_effort[a]));
            metrics.push((
                format!("saturated_fraction/{joint}"),
                self.saturated_samples[a] as f64 / self.samples.max(1) as f64,
            ));
        }
        if self.has_loops {
            metrics.push(("loop_closure_error_max".into(), self.loop_gap_max));
        }
        metrics.push(("mechanical_energy_drift_max".into(), self.energy_drift_max));
        // The controller's estimates at the end (e.g. an odometry pose), by their internal names.
        metrics.extend(
            self.internals
                .iter()
                .zip(&self.final_internals)
                .map(|(name, value)| (format!("controller_final/{name}"), *value)),
        );
        Ok(Findings {
            metrics,
            warnings: Vec::new(),
        })
    }
}

/// 64-bit FNV-1a over the bit patterns of f64 values.
#[derive(Debug)]
pub(super) struct Digest(pub u64);

impl Default for Digest {
    fn default() -> Self {
        Self(0xcbf2_9ce4_8422_2325)
    }
}

impl Digest {
    pub fn add(&mut self, value: f64) {
        for byte in value.to_bits().to_le_bytes() {
            self.0 = (self.0 ^ u64::from(byte)).wrapping_mul(0x0100_0000_01b3);
        }
    }

    pub fn add_all(&mut self, values: &[f64]) {
        for &value in values {
            self.add(value);
        }
    }

    /// The samples a recording holds: time and every signal slice of the step.
    pub fn add_step(&mut self, view: &StepView) {
        self.add(view.time);
        self.add_all(view.signals);
        self.add_all(view.measured);
        self.add_all(view.commanded);
        self.add_all(view.applied);
        self.add_all(view.internals);
        self.add_all(view.diagnostics);
    }
}
