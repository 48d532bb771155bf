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
    /// Per actuator, the effort commanded at each control update.
    commands: Vec<Vec<f64>>,
}

/// The high-frequency content of a command is what a centred moving average over this many
/// control periods leaves out: content above about 1/20 of the control rate.
const HF_WINDOW: usize = 21;
/// Above this ratio of high-frequency to total RMS, a command chatters: the summary warns.
const HF_WARNING_RATIO: f64 = 0.2;

/// RMS of `command` minus its centred moving average over [`HF_WINDOW`] samples, over the RMS of
/// `command`, both over the samples where the window fits: 0 for a smooth command, towards 1
/// for one switching every period. 0 when the command is too short or zero.
pub(super) fn high_frequency_ratio(command: &[f64]) -> f64 {
    let half = HF_WINDOW / 2;
    if command.len() < HF_WINDOW {
        return 0.0;
    }
    let mut prefix = Vec::with_capacity(command.len() + 1);
    prefix.push(0.0);
    for &value in command {
        prefix.push(prefix.last().copied().unwrap_or(0.0) + value);
    }
    let (mut residual, mut total) = (0.0, 0.0);
    for i in half..command.len() - half {
        let mean = (prefix[i + half + 1] - prefix[i - half]) / HF_WINDOW as f64;
        residual += (command[i] - mean).powi(2);
        total += command[i].powi(2);
    }
    if total > 0.0 {
        (residual / total).sqrt()
    } else {
        0.0
    }
}

impl Observer for RunStats {
    fn start(&mut self, layout: &SignalLayout) -> Result<(), ObserverError> {
        *self = Self {
            actuators: layout.actuators.clone(),
            internals: layout.internals.clone(),
            has_loops: layout.loop_count() > 0,
            peak_effort: vec![0.0; layout.actuators.len()],
            saturated_samples: vec![0; layout.actuators.len()],
            commands: vec![Vec::new(); layout.actuators.len()],
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
        if view.control_update {
            for (command, &effort) in self.commands.iter_mut().zip(view.commanded) {
                command.push(effort);
            }
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
        let mut warnings = Vec::new();
        for (a, joint) in self.actuators.iter().enumerate() {
            metrics.push((format!("peak_effort/{joint}"), self.peak_effort[a]));
            let ratio = high_frequency_ratio(&self.commands[a]);
            metrics.push((format!("effort_hf_ratio/{joint}"), ratio));
            if ratio > HF_WARNING_RATIO {
                warnings.push(format!(
                    "the command on {joint} chatters: {:.0} % of its RMS is above 1/20 of the \
                     control rate (effort_hf_ratio/{joint} = {ratio:.3})",
                    100.0 * ratio
                ));
            }
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
        Ok(Findings { metrics, warnings })
    }
}

/// 64-bit FNV-1a over the bit patterns of f64 values, taken a word at a time (not a byte: the
/// digest is on every step's path, and a byte at a time made it a twentieth of the run).
#[derive(Debug)]
pub(super) struct Digest(pub u64);

impl Default for Digest {
    fn default() -> Self {
        Self(0xcbf2_9ce4_8422_2325)
    }
}

impl Digest {
    pub fn add(&mut self, value: f64) {
        self.0 = (self.0 ^ value.to_bits()).wrapping_mul(0x0100_0000_01b3);
    }

    pub fn add_bytes(&mut self, bytes: &[u8]) {
        for &byte in bytes {
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

#[cfg(test)]
mod tests {
    use super::high_frequency_ratio;

    #[test]
    fn a_smooth_command_has_no_high_frequency_content_and_a_switching_one_has() {
        let smooth: Vec<f64> = (0..1000).map(|k| 5.0 + (k as f64 * 1e-3).sin()).collect();
        assert!(high_frequency_ratio(&smooth) < 1e-3);
        let switching: Vec<f64> = (0..1000)
            .map(|k| if k % 2 == 0 { 20.0 } else { -20.0 })
            .collect();
        assert!(high_frequency_ratio(&switching) > 0.9);
        // A ±40 % sawtooth of period 10 control periods on a steady command.
        let sawtooth: Vec<f64> = (0..1000)
            .map(|k| 1.0 + 0.4 * ((k % 10) as f64 / 5.0 - 1.0))
            .collect();
        let ratio = high_frequency_ratio(&sawtooth);
        assert!(ratio > 0.2 && ratio < 0.3, "{ratio}");
        assert_eq!(high_frequency_ratio(&[1.0; 5]), 0.0);
        assert_eq!(high_frequency_ratio(&[0.0; 100]), 0.0);
    }
}
