//! Observers: whatever watches a run (the recording, the figures a scenario is judged by, a
//! user's own probe) sees each step through the same read-only [`StepView`].

use super::layout::SignalLayout;
use crate::mechanism::Pose2;
use crate::physics::{Collision, MechanismState};
use framework::Event;

/// What an observer may fail with; the run stops and returns it.
pub type ObserverError = Box<dyn std::error::Error + Send + Sync>;

/// One step of a run, read-only. Slices follow the [`SignalLayout`]'s lists.
#[derive(Debug, Clone, Copy)]
pub struct StepView<'a> {
    /// Physics step index: 0 at the start, time = step·dt.
    pub step: usize,
    /// Simulated time, s.
    pub time: f64,
    /// The names behind every slice here, the same at every step.
    pub layout: &'a SignalLayout,
    /// Every joint's position and velocity, every link's pose, the loop gaps.
    pub state: &'a MechanismState,
    /// The plant's signals, true values (before the sensors).
    pub signals: &'a [f64],
    /// The signals as the controller last measured them (through the sensors); renewed at each
    /// control update, held in between.
    pub measured: &'a [f64],
    /// Efforts the controller asked for, N·m or N (held between control updates).
    pub commanded: &'a [f64],
    /// Efforts the joints receive over the coming step (after the limits and drives).
    pub applied: &'a [f64],
    /// Whether each commanded effort was clipped to its actuator limit.
    pub saturated: &'a [bool],
    /// The controller's internal signals after its last update.
    pub internals: &'a [f64],
    /// Model checks: the machine's, the loop gaps, the mechanical energy.
    pub diagnostics: &'a [f64],
    /// Where the scenario's `[[bodies]]` are, in its order.
    pub bodies: &'a [Pose2],
    /// The pairs of links or bodies that started to touch at this step (each also an event).
    pub collisions: &'a [Collision],
    /// Events raised at this step (by the controller, the limits, the twin).
    pub events: &'a [Event],
    /// Whether the controller ran at this step (`measured` is fresh).
    pub control_update: bool,
    /// Whether the recording samples this step (every `recording.every`-th and the last).
    pub sampled: bool,
    /// Whether this is the run's last step (its end, a divergence or an interruption).
    pub last: bool,
}

impl StepView<'_> {
    /// A plant signal's true value by name.
    pub fn signal(&self, name: &str) -> Option<f64> {
        self.layout.signal(name).map(|i| self.signals[i])
    }
}

/// What an observer hands back at the end of a run.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Findings {
    /// Figures for the run's summary, by name (SI units unless the name says otherwise).
    pub metrics: Vec<(String, f64)>,
    /// What went wrong beside the run without failing it.
    pub warnings: Vec<String>,
}

/// Watches a run step by step. The twin calls `start` once, `observe` at every physics step
/// (step 0 included, after the efforts of the step are known) and `finish` once at the end, also
/// after a divergence or an interruption. An error from any of them stops the run.
pub trait Observer {
    /// Called once before step 0, with the run's names; does nothing unless implemented.
    fn start(&mut self, _layout: &SignalLayout) -> Result<(), ObserverError> {
        Ok(())
    }

    /// Called at every physics step with what the step holds.
    fn observe(&mut self, view: &StepView) -> Result<(), ObserverError>;

    /// Called once after the last step; hands back metrics and warnings for the summary (none
    /// unless implemented).
    fn finish(&mut self) -> Result<Findings, ObserverError> {
        Ok(Findings::default())
    }
}
