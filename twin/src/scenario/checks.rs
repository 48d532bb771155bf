//! What a valid scenario is: names, timing, sensors, reference, limits, faults and metrics that
//! can be checked before the run (names of signals are checked against the run's layout).

use super::spec::Scenario;
use crate::physics::MAX_SUBSTEPS;

/// Longest scenario name (it names the default recording file).
const MAX_NAME_CHARS: usize = 100;

impl Scenario {
    pub(super) fn validate(&self) -> Result<(), String> {
        check_name(&self.name)?;
        self.validate_timing()?;
        if self.recording.every == 0 {
            return Err("recording.every must be ≥ 1".into());
        }
        if (self.health.max_joint_speed.is_nan() || self.health.max_joint_speed <= 0.0)
            || (self.health.max_loop_gap.is_nan() || self.health.max_loop_gap <= 0.0)
        {
            return Err("health limits must be > 0".into());
        }
        for (signal, spec) in &self.sensors {
            spec.validate()
                .map_err(|reason| format!("sensors.\"{signal}\": {reason}"))?;
            if spec.delay > self.duration {
                return Err(format!(
                    "sensors.\"{signal}\": delay ({} s) must not exceed the run's duration ({} s)",
                    spec.delay, self.duration
                ));
            }
        }
        if let Some(reference) = &self.reference {
            reference.validate()?;
            if reference.table_file().is_some() {
                return Err("reference: a table is read per joint ([controller.params.joints.<joint>] reference = { kind = \"table\", … }); give [reference] another kind".into());
            }
        }
        self.plant.validate()?;
        for (joint, state) in &self.initial {
            if !(state.position.is_finite() && state.velocity.is_finite()) {
                return Err(format!(
                    "initial.{joint}: position and velocity must be finite, got {} and {}",
                    state.position, state.velocity
                ));
            }
        }
        for (i, fault) in self.faults.iter().enumerate() {
            fault.validate(i, self.duration)?;
        }
        self.solver.validate()?;
        self.contact.validate()?;
        for (i, body) in self.bodies.iter().enumerate() {
            body.validate(i)?;
            if self.bodies[..i].iter().any(|b| b.name == body.name) {
                return Err(format!("bodies `{}`: named twice", body.name));
            }
        }
        for (i, metric) in self.metrics.iter().enumerate() {
            metric.validate()?;
            if self.metrics[..i].iter().any(|m| m.name == metric.name) {
                return Err(format!("metrics `{}`: named twice", metric.name));
            }
        }
        Ok(())
    }

    /// dt, duration, control period, substeps and the step cap.
    fn validate_timing(&self) -> Result<(), String> {
        if !(self.dt.is_finite() && self.dt > 0.0) {
            return Err(format!("dt must be > 0, got {}", self.dt));
        }
        if !(self.duration.is_finite() && self.duration > 0.0) {
            return Err(format!("duration must be > 0, got {}", self.duration));
        }
        let period = self.control_period();
        let ratio = period / self.dt;
        if !(period.is_finite() && period > 0.0)
            || (ratio - ratio.round()).abs() > 1e-9
            || ratio.round() < 1.0
        {
            return Err(format!(
                "control_period ({period} s) must be a whole multiple of dt ({} s)",
                self.dt
            ));
        }
        if period > self.duration {
            return Err(format!(
                "control_period ({period} s) must not exceed the duration ({} s)",
                self.duration
            ));
        }
        if !(1..=MAX_SUBSTEPS).contains(&self.substeps) {
            return Err(format!(
                "substeps must be between 1 and {MAX_SUBSTEPS}, got {}",
                self.substeps
            ));
        }
        let steps = self.duration / self.dt;
        if steps > self.max_steps as f64 {
            return Err(format!(
                "duration / dt = {steps:.3e} steps exceeds max_steps = {}; shorten the run, \
                 enlarge dt, or raise the cap (max_steps = … in the scenario, --set max_steps=…)",
                self.max_steps
            ));
        }
        Ok(())
    }
}

/// A scenario name names files (`<name>.rrd`): letters, digits, `_`, `-`, `.`, not leading `.`.
fn check_name(name: &str) -> Result<(), String> {
    let allowed = |c: char| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.');
    if name.is_empty()
        || name.len() > MAX_NAME_CHARS
        || name.starts_with('.')
        || !name.chars().all(allowed)
    {
        return Err(format!(
            "name {name:?}: use 1 to {MAX_NAME_CHARS} letters, digits, `_`, `-` or `.`, \
             not starting with `.` (it names the recording file)"
        ));
    }
    Ok(())
}
