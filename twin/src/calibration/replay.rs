//! One rollout of the twin against a measured run: the scenario with some keys set, started from
//! a state read off the data, driven open loop by the run's logged commands (or closed loop by
//! its own controller following the logged reference), sampled at the control period.

use super::error::CalibrationError;
use crate::data::{PlantColumns, Trace};
use crate::run::Simulator;
use crate::scenario::ScenarioBuilder;
use framework::Registry;
use std::ops::Range;

/// What the nominal scenario's plant reads and writes, learnt once from one simulator.
#[derive(Debug, Clone)]
pub struct PlantShape {
    /// Names and SI units, as the data's columns are bound to them.
    pub columns: PlantColumns,
    /// The movable joints.
    pub joints: Vec<String>,
    /// The reference signals' indices among the plant's signals.
    pub reference: Range<usize>,
    /// Control period, s.
    pub period: f64,
}

impl PlantShape {
    /// The shape of `simulator`'s plant.
    pub fn of(simulator: &Simulator) -> Self {
        Self {
            columns: PlantColumns::of_simulator(simulator),
            joints: simulator
                .joints()
                .iter()
                .map(|(name, _)| name.to_string())
                .collect(),
            reference: simulator.reference_signals(),
            period: simulator.scenario().control_period(),
        }
    }

    /// The index of a plant signal.
    pub fn signal(&self, name: &str) -> Option<usize> {
        self.columns.signals.iter().position(|(s, _)| s == name)
    }
}

/// A stretch of one run simulated from its own start state: samples `start..start + len`
/// compared, the simulation begun `lead` samples earlier so that the machine's own states that
/// no start state sets (a drive's current, a filter) have settled on the logged commands.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Segment {
    /// The run (index into the traces).
    pub run: usize,
    /// First sample compared.
    pub start: usize,
    /// Samples compared.
    pub len: usize,
    /// Samples simulated before `start`, not compared; the start state is at `start − lead`.
    pub lead: usize,
}

impl Segment {
    /// The sample the simulation starts at.
    pub fn begin(&self) -> usize {
        self.start - self.lead
    }
}

/// Everything a rollout needs besides the values it tries.
pub struct Replayer<'a> {
    /// The scenario, its sensors' noise and quantisation off and its faults dropped.
    pub base: ScenarioBuilder,
    /// Builds the scenario's controller (closed loop) and checks its parameters.
    pub registry: &'a Registry,
    /// The plant's shape.
    pub shape: PlantShape,
    /// Drive the twin with its own controller following the logged reference.
    pub closed_loop: bool,
}

impl Replayer<'_> {
    /// The plant signals `outputs` simulated over `segment` with `values` set (later entries
    /// win), one row per sample.
    pub fn simulate(
        &self,
        trace: &Trace,
        segment: Segment,
        values: &[(String, f64)],
        outputs: &[usize],
    ) -> Result<Vec<Vec<f64>>, CalibrationError> {
        let mut builder = self.base.clone();
        for (key, value) in values {
            builder = builder.set(key, *value)?;
        }
        let loaded = builder.build(self.registry)?;
        let mut simulator = if self.closed_loop {
            Simulator::with_controller(loaded, self.registry)?
        } else {
            Simulator::new(loaded)?
        };
        let mut rows = vec![Vec::with_capacity(segment.len); outputs.len()];
        let mut sample = segment.begin();
        let mut take = |measured: &[f64]| {
            if sample >= segment.start {
                for (row, &i) in rows.iter_mut().zip(outputs) {
                    row.push(measured[i]);
                }
            }
            sample += 1;
        };
        take(simulator.measured());
        let mut drive = Drive::new(self, trace, &simulator);
        for k in segment.begin()..segment.start + segment.len - 1 {
            let measured = drive.step(&mut simulator, trace, k).map_err(|reason| {
                CalibrationError::Diverged {
                    run: trace.source.clone(),
                    time: trace.start_time + (k + 1) as f64 * trace.period,
                    reason,
                }
            })?;
            take(measured);
        }
        Ok(rows)
    }
}

/// How a rollout is driven each period: the logged commands, or the controller with the
/// logged reference.
struct Drive {
    commands: Vec<f64>,
    closed_loop: bool,
    disturbances: Vec<f64>,
    /// The reference signals' indices and whether the data log them all.
    reference: Option<Range<usize>>,
    offset: [f64; 3],
}

impl Drive {
    fn new(replayer: &Replayer, trace: &Trace, simulator: &Simulator) -> Self {
        let range = replayer.shape.reference.clone();
        let logged = !range.is_empty()
            && range.len() <= 3
            && range.clone().all(|i| trace.measured[i].is_some())
            && simulator.reference_inputs().is_ok();
        Self {
            commands: vec![0.0; trace.commands.len()],
            closed_loop: replayer.closed_loop,
            disturbances: vec![0.0; replayer.shape.joints.len()],
            reference: logged.then_some(range),
            offset: [0.0; 3],
        }
    }

    /// One control period from sample `k`; the measurement at its end.
    fn step<'s>(
        &mut self,
        simulator: &'s mut Simulator,
        trace: &Trace,
        k: usize,
    ) -> Result<&'s [f64], String> {
        if !self.closed_loop {
            for (command, logged) in self.commands.iter_mut().zip(&trace.commands) {
                *command = logged.as_ref().map_or(0.0, |values| values[k]);
            }
            return simulator.step(&self.commands).map_err(|e| e.to_string());
        }
        if let Some(range) = self.reference.clone() {
            // The scenario's own reference now is what the twin senses less the offset it holds.
            let now = simulator.true_signals();
            for (slot, i) in range.enumerate() {
                let own = now[i] - self.offset[slot];
                self.offset[slot] = trace.measured[i].as_ref().map_or(0.0, |v| v[k]) - own;
            }
        }
        simulator
            .step_closed_loop(&self.disturbances, self.offset)
            .map_err(|e| e.to_string())
    }
}
