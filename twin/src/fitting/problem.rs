//! A calibration laid out: the unknowns (shared parameters, per-run parameters and each
//! segment's start state) with their scales and bounds, the segments, the fitted signals and
//! their noise; the weighted residuals and their forward-difference Jacobian, rolled out in
//! parallel.

use super::metrics::noise_level;
use super::replay::{PlantShape, Replayer, Segment};
use super::DEFAULT_SEGMENT;
use super::{parallel, thread_count, CalibrationError, CalibrationOptions, StartStates};
use crate::run::Simulator;
use crate::run_data::{RunData, Trace};
use crate::scenario::ScenarioBuilder;
use framework::Registry;
use nalgebra::DMatrix;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Fewest samples a segment may have: a start state and its first moves.
const MIN_SEGMENT_SAMPLES: usize = 10;
/// Forward-difference step, relative to an unknown's scale.
const DIFFERENCE_STEP: f64 = 1e-6;

/// What an unknown belongs to.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Scope {
    /// Every run.
    Shared,
    /// One run.
    Run(usize),
    /// One segment's start state.
    Segment(usize),
}

/// One value the solve adjusts.
#[derive(Debug, Clone)]
pub struct Unknown {
    /// The scenario key it sets.
    pub key: String,
    /// How messages name it: the key, with its run or segment.
    pub label: String,
    pub scope: Scope,
    pub start: f64,
    pub bounds: [f64; 2],
    /// Its size: steps and the solver's scaling are relative to it.
    pub scale: f64,
}

/// The calibration's data and unknowns (see the module doc).
pub struct Problem<'a> {
    pub replayer: Replayer<'a>,
    pub traces: Vec<Trace>,
    pub segments: Vec<Segment>,
    /// The fitted plant signals' indices.
    pub outputs: Vec<usize>,
    /// Per fitted signal, the noise σ its residuals are divided by, SI.
    pub sigma: Vec<f64>,
    pub unknowns: Vec<Unknown>,
    /// Per segment, its start state as the data give it (the states not fitted stay there).
    pub starts: Vec<Vec<(String, f64)>>,
    threads: usize,
    rollouts: AtomicUsize,
}

/// The replayer of a scenario: its sensors made ideal apart from gain, bias and delay (noise
/// and quantisation belong to the data, not to the model fitted to it) and its faults dropped.
pub fn replayer<'a>(
    builder: &ScenarioBuilder,
    registry: &'a Registry,
    closed_loop: bool,
) -> Result<Replayer<'a>, CalibrationError> {
    let loaded = builder.clone().build(registry)?;
    let sensors: Vec<String> = loaded.scenario.sensors.keys().cloned().collect();
    let shape = PlantShape::of(&Simulator::new(loaded)?);
    let mut base = builder.clone().set("faults", Vec::<f64>::new())?;
    for name in sensors {
        base = base.set(&format!("sensors.\"{name}\".noise"), 0.0)?;
        base = base.set(&format!("sensors.\"{name}\".resolution"), 0.0)?;
    }
    Ok(Replayer {
        base,
        registry,
        shape,
        closed_loop,
    })
}

/// `data` bound to the plant; open loop, every actuator's command must be logged.
pub fn bind(
    replayer: &Replayer,
    data: &RunData,
    min_samples: usize,
) -> Result<Trace, CalibrationError> {
    let shape = &replayer.shape;
    let trace = data.bind(&shape.columns, shape.period, min_samples)?;
    if !replayer.closed_loop {
        let missing: Vec<String> = (shape.columns.actuators.iter().zip(&trace.commands))
            .filter(|(_, logged)| logged.is_none())
            .map(|((joint, unit), _)| format!("effort.{joint} [{unit}]"))
            .collect();
        if !missing.is_empty() {
            return Err(CalibrationError::Options(format!(
                "{}: no column {}: replaying the run open loop needs every actuator's command (or replay it closed loop, with the scenario's controller)",
                data.source,
                missing.join(", ")
            )));
        }
    }
    Ok(trace)
}

/// The plant signals compared: those asked for (each must be logged in every run), or every
/// logged signal but the reference.
pub fn outputs(
    shape: &PlantShape,
    traces: &[Trace],
    asked: &[String],
) -> Result<Vec<usize>, CalibrationError> {
    let logged = |i: usize| traces.iter().all(|t| t.measured[i].is_some());
    if asked.is_empty() {
        let all: Vec<usize> = (0..shape.columns.signals.len())
            .filter(|&i| logged(i) && !shape.reference.contains(&i))
            .collect();
        if all.is_empty() {
            let file = traces.first().map_or("", |t| t.source.as_str());
            return Err(CalibrationError::Options(format!(
                "{file}: no measured signal of the scenario in the data (its signals: {})",
                signal_names(shape)
            )));
        }
        return Ok(all);
    }
    asked
        .iter()
        .map(|name| {
            let index = shape.signal(name).ok_or_else(|| {
                CalibrationError::Options(format!(
                    "--signal {name}: no such signal (known: {})",
                    signal_names(shape)
                ))
            })?;
            match traces.iter().find(|t| t.measured[index].is_none()) {
                Some(trace) => Err(CalibrationError::Options(format!(
                    "{}: no column `{name}`: the fitted signal must be logged in every run",
                    trace.source
                ))),
                None => Ok(index),
            }
        })
        .collect()
}

fn signal_names(shape: &PlantShape) -> String {
    let names: Vec<&str> = (shape.columns.signals.iter())
        .map(|(n, _)| n.as_str())
        .collect();
    framework::shortened(&names.join(", "), 300)
}

/// Per fitted signal, the noise σ: given, or estimated from the data pooled over the runs;
/// never below a billionth of the signal's size, so noise-free data still weigh finitely.
pub fn noise(
    shape: &PlantShape,
    traces: &[Trace],
    outputs: &[usize],
    given: &[(String, f64)],
) -> Vec<f64> {
    outputs
        .iter()
        .map(|&i| {
            let name = &shape.columns.signals[i].0;
            if let Some((_, sigma)) = given.iter().find(|(n, _)| n == name) {
                return *sigma;
            }
            let series = traces.iter().filter_map(|t| t.measured[i].as_deref());
            let variance = series.clone().map(|v| noise_level(v).powi(2)).sum::<f64>()
                / traces.len().max(1) as f64;
            let size = series.flatten().fold(0.0f64, |m, v| m.max(v.abs()));
            variance.sqrt().max(1e-9 * size).max(1e-15)
        })
        .collect()
}

/// The segment length asked for, or the default: [`DEFAULT_SEGMENT`] where every run logs every
/// moving joint's position, else whole runs (a segment could not start where its run is).
pub fn segment_length(shape: &PlantShape, traces: &[Trace], asked: Option<f64>) -> f64 {
    asked.unwrap_or_else(|| {
        let placed = |joint: &String| {
            let index = shape.signal(&format!("{joint}.position"));
            index.is_some_and(|i| traces.iter().all(|t| t.measured[i].is_some()))
        };
        match shape.joints.iter().all(placed) {
            true => DEFAULT_SEGMENT,
            false => 0.0,
        }
    })
}

/// The segments of the runs: stretches of `seconds` (a last stretch shorter than half of one
/// joins the one before), or whole runs for 0.
pub fn segments(
    traces: &[Trace],
    seconds: f64,
    period: f64,
) -> Result<Vec<Segment>, CalibrationError> {
    let mut segments = Vec::new();
    for (run, trace) in traces.iter().enumerate() {
        let length = match seconds {
            0.0 => trace.samples,
            s if s.is_finite() && s > 0.0 => ((s / period).round() as usize).max(1),
            s => {
                let reason =
                    format!("--segment {s}: must be a duration > 0 s, or 0 for whole runs");
                return Err(CalibrationError::Options(reason));
            }
        };
        if trace.samples < MIN_SEGMENT_SAMPLES {
            return Err(CalibrationError::Options(format!(
                "{}: {} samples at the control period {period} s; a fit needs at least {MIN_SEGMENT_SAMPLES}: give a longer run",
                trace.source, trace.samples
            )));
        }
        let length = length.min(trace.samples);
        if length < MIN_SEGMENT_SAMPLES {
            return Err(CalibrationError::Options(format!(
                "--segment: {length} samples per segment at the control period {period} s; give at least {MIN_SEGMENT_SAMPLES}"
            )));
        }
        let mut start = 0;
        while start < trace.samples {
            let mut len = length.min(trace.samples - start);
            if trace.samples - start - len < length / 2 {
                len = trace.samples - start;
            }
            // A tenth of a segment settles the machine's own states (a drive's current lag is
            // well under a millisecond; the lead is 0.1 s of a 1 s segment).
            let lead = start.min((length / 10).max(MIN_SEGMENT_SAMPLES));
            segments.push(Segment {
                run,
                start,
                len,
                lead,
            });
            start += len;
        }
    }
    Ok(segments)
}

/// The joints whose start states are fitted.
pub fn state_joints(shape: &PlantShape, states: &StartStates) -> Result<Vec<String>, String> {
    match states {
        StartStates::Fixed => Ok(Vec::new()),
        StartStates::Automatic if shape.has_loops => Ok(shape.actuated.clone()),
        StartStates::Automatic => Ok(shape.joints.clone()),
        StartStates::Joints(joints) => joints
            .iter()
            .map(|joint| match shape.joints.contains(joint) {
                true => Ok(joint.clone()),
                false => Err(format!(
                    "--states {joint}: no such moving joint (known: {})",
                    shape.joints.join(", ")
                )),
            })
            .collect(),
    }
}

impl<'a> Problem<'a> {
    /// Lays a calibration out: `unknowns` are the parameters (shared and per run) made by the
    /// caller; the start states of `options.states` are appended per segment.
    pub fn new(
        replayer: Replayer<'a>,
        traces: Vec<Trace>,
        options: &CalibrationOptions,
        parameters: Vec<Unknown>,
    ) -> Result<Self, CalibrationError> {
        let shape = &replayer.shape;
        let outputs = outputs(shape, &traces, &options.signals)?;
        let sigma = noise(shape, &traces, &outputs, &options.noise);
        let length = segment_length(shape, &traces, options.segment);
        let segments = segments(&traces, length, shape.period)?;
        let joints = state_joints(shape, &options.states).map_err(CalibrationError::Options)?;
        let starts: Vec<Vec<(String, f64)>> = segments
            .iter()
            .map(|s| replayer.start_state(&traces[s.run], s.begin()))
            .collect();
        let mut unknowns = parameters;
        for (index, (segment, start)) in segments.iter().zip(&starts).enumerate() {
            let trace = &traces[segment.run];
            let at = trace.start_time + segment.begin() as f64 * trace.period;
            for (key, value) in start {
                let joint = key.split('.').nth(1).unwrap_or_default();
                if !joints.iter().any(|j| j == joint) {
                    continue;
                }
                unknowns.push(Unknown {
                    label: format!("{key} at t = {at} s of {}", trace.source),
                    key: key.clone(),
                    scope: Scope::Segment(index),
                    start: *value,
                    bounds: [f64::NEG_INFINITY, f64::INFINITY],
                    scale: value.abs().max(1e-3),
                });
            }
        }
        Ok(Self {
            threads: thread_count(options.threads),
            rollouts: AtomicUsize::new(0),
            replayer,
            traces,
            segments,
            outputs,
            sigma,
            unknowns,
            starts,
        })
    }

    /// The start values of the unknowns.
    pub fn start(&self) -> Vec<f64> {
        self.unknowns.iter().map(|u| u.start).collect()
    }

    /// Rollouts made so far.
    pub fn rollouts(&self) -> usize {
        self.rollouts.load(Ordering::Relaxed)
    }

    /// Residuals in a segment: outputs × samples.
    pub fn rows(&self, segment: usize) -> usize {
        self.outputs.len() * self.segments[segment].len
    }

    /// Whether unknown `j` acts on segment `s`.
    pub fn affects(&self, j: usize, s: usize) -> bool {
        match self.unknowns[j].scope {
            Scope::Shared => true,
            Scope::Run(run) => self.segments[s].run == run,
            Scope::Segment(segment) => segment == s,
        }
    }

    /// Drops every segment but the first, and the unknowns of the others.
    pub fn keep_first_segment(&mut self) {
        self.segments.truncate(1);
        self.starts.truncate(1);
        (self.unknowns)
            .retain(|u| matches!(u.scope, Scope::Shared | Scope::Run(0) | Scope::Segment(0)));
    }

    /// The scenario values of segment `s` at `theta`: its data start state, then the unknowns
    /// acting on it.
    pub fn values(&self, theta: &[f64], s: usize) -> Vec<(String, f64)> {
        let mut values = self.starts[s].clone();
        for (j, unknown) in self.unknowns.iter().enumerate() {
            if self.affects(j, s) {
                values.push((unknown.key.clone(), theta[j]));
            }
        }
        values
    }

    /// The fitted signals simulated over segment `s` at `theta`, one row per signal.
    pub fn simulate(&self, theta: &[f64], s: usize) -> Result<Vec<Vec<f64>>, CalibrationError> {
        self.rollouts.fetch_add(1, Ordering::Relaxed);
        let segment = self.segments[s];
        let trace = &self.traces[segment.run];
        (self.replayer).simulate(trace, segment, &self.values(theta, s), &self.outputs)
    }

    /// Segment `s`'s residuals at `theta`, each divided by its signal's noise: signal-major.
    fn residual(&self, theta: &[f64], s: usize) -> Result<Vec<f64>, CalibrationError> {
        let simulated = self.simulate(theta, s)?;
        let segment = self.segments[s];
        let trace = &self.traces[segment.run];
        let mut residual = Vec::with_capacity(self.rows(s));
        for ((row, &i), sigma) in simulated.iter().zip(&self.outputs).zip(&self.sigma) {
            let measured = trace.measured[i].as_deref().unwrap_or_default();
            let measured = &measured[segment.start..segment.start + segment.len];
            residual.extend(measured.iter().zip(row).map(|(y, s)| (y - s) / sigma));
        }
        Ok(residual)
    }

    /// Every segment's residuals at `theta`, the segments rolled out in parallel.
    pub fn residuals(&self, theta: &[f64]) -> Result<Vec<Vec<f64>>, CalibrationError> {
        parallel(self.segments.len(), self.threads, |s| {
            self.residual(theta, s)
        })
        .into_iter()
        .collect()
    }

    /// The Jacobian of the stacked residuals (segments in order) at `theta`, by forward
    /// differences from `base` (the residuals there): one rollout per unknown and segment it
    /// acts on, in parallel. A step leans away from a bound it would cross.
    pub fn jacobian(
        &self,
        theta: &[f64],
        base: &[Vec<f64>],
    ) -> Result<DMatrix<f64>, CalibrationError> {
        let jobs: Vec<(usize, usize)> = (0..self.unknowns.len())
            .flat_map(|j| (0..self.segments.len()).map(move |s| (j, s)))
            .filter(|&(j, s)| self.affects(j, s))
            .collect();
        let columns = parallel(jobs.len(), self.threads, |k| {
            let (j, s) = jobs[k];
            let unknown = &self.unknowns[j];
            let mut h = DIFFERENCE_STEP * unknown.scale;
            if theta[j] + h > unknown.bounds[1] {
                h = -h;
            }
            let mut moved = theta.to_vec();
            moved[j] += h;
            let residual = self.residual(&moved, s)?;
            let column: Vec<f64> = (residual.iter().zip(&base[s]))
                .map(|(r, r0)| (r - r0) / h)
                .collect();
            Ok::<_, CalibrationError>(column)
        });
        let offsets: Vec<usize> = (0..self.segments.len())
            .scan(0, |at, s| {
                let offset = *at;
                *at += self.rows(s);
                Some(offset)
            })
            .collect();
        let rows: usize = (0..self.segments.len()).map(|s| self.rows(s)).sum();
        let mut jacobian = DMatrix::zeros(rows, self.unknowns.len());
        for (&(j, s), column) in jobs.iter().zip(columns) {
            for (i, value) in column?.into_iter().enumerate() {
                jacobian[(offsets[s] + i, j)] = value;
            }
        }
        Ok(jacobian)
    }
}
