//! A calibration laid out: the unknowns (shared parameters, per-run parameters and each
//! segment's start state in the mechanism's independent coordinates) with their scales and
//! bounds, the segments, the fitted signals and their noise; the weighted residuals at the
//! data's own rows and their forward-difference Jacobian, rolled out in parallel.

use super::error::CalibrationError;
use super::metrics::{noise_level, noise_resolved};
use super::options::{CalibrationOptions, StartStates};
use super::replay::{PlantShape, Replayer, Segment};
use super::segments::{lay_out, Setting};
use super::start::{Assembly, Placement, Probe};
use super::threads::{parallel, thread_count};
use crate::data::{RunData, Trace};
use crate::run::{Simulator, Twin};
use crate::scenario::ScenarioBuilder;
use framework::Registry;
use nalgebra::DMatrix;
use std::ops::Range;
use std::sync::atomic::{AtomicUsize, Ordering};

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
    /// For a segment's start state, its place in the segment's reduced state (the independent
    /// coordinates' positions, then velocities).
    pub coordinate: Option<usize>,
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
    /// Per segment, where the data place the mechanism at its begin (the coordinates not fitted
    /// stay there); `None`: the scenario's initial state.
    pub starts: Vec<Option<Placement>>,
    /// Segment length, s; 0: whole runs.
    pub length: f64,
    /// What the layout decided that the user should hear (a run replayed whole, and why).
    pub notes: Vec<String>,
    /// Values set in every segment besides the unknowns (parameters held while the start states
    /// are fitted alone).
    pub held: Vec<(String, f64)>,
    /// Per segment, the data rows it compares (indices into its run's rows).
    observations: Vec<Range<usize>>,
    /// The mechanism at the scenario's initial state, copied afresh for every start it places:
    /// a copy's history never reaches a rollout (Rapier poses a joint by moving it from where it
    /// was, to rounding), so the rollouts' results do not depend on which thread made them.
    assembly: Assembly,
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

impl Replayer<'_> {
    /// The scenario's mechanism as an assembly, to place it where the data say.
    pub fn assembly(&self) -> Result<Assembly, CalibrationError> {
        let loaded = self.base.clone().build(self.registry)?;
        let parts = Twin::new(loaded)?.start_parts().map_err(|e| match e {
            crate::run::LinearizeError::Twin(e) => CalibrationError::Twin(e),
            other => CalibrationError::Options(other.to_string()),
        })?;
        Ok(Assembly::new(&parts))
    }
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

/// A plant signal's noise σ: given, or estimated from the rows the runs log, pooled over the
/// runs; never below a billionth of the signal's size, so noise-free data still weigh finitely.
pub fn noise_of(shape: &PlantShape, traces: &[Trace], i: usize, given: &[(String, f64)]) -> f64 {
    let name = &shape.columns.signals[i].0;
    if let Some((_, sigma)) = given.iter().find(|(n, _)| n == name) {
        return *sigma;
    }
    let series: Vec<&[f64]> = (traces.iter())
        .filter_map(|t| t.observed(i).map(|(_, values)| values))
        .collect();
    let variance =
        series.iter().map(|v| noise_level(v).powi(2)).sum::<f64>() / series.len().max(1) as f64;
    let size = (series.iter().copied().flatten()).fold(0.0f64, |m, v| m.max(v.abs()));
    variance.sqrt().max(1e-9 * size).max(1e-15)
}

/// The start states fitted: every coordinate the data place (`auto`), none, or the joints
/// named, each an independent coordinate.
fn fitted_coordinates(
    coordinates: &[String],
    placed: &[bool],
    states: &StartStates,
) -> Result<Vec<usize>, CalibrationError> {
    match states {
        StartStates::Fixed => Ok(Vec::new()),
        StartStates::Automatic => Ok((0..coordinates.len()).filter(|&c| placed[c]).collect()),
        StartStates::Joints(joints) => joints
            .iter()
            .map(|joint| {
                coordinates.iter().position(|c| c == joint).ok_or_else(|| {
                    CalibrationError::Options(format!(
                        "--states {joint}: not one of the mechanism's independent coordinates ({}); the others follow from them through the loops",
                        coordinates.join(", ")
                    ))
                })
            })
            .collect(),
    }
}

/// The start-state unknowns: per placed segment, the fitted coordinates' positions and
/// velocities.
fn state_unknowns(
    traces: &[Trace],
    layout: &super::segments::Layout,
    coordinates: &[String],
    fitted: &[usize],
) -> Vec<Unknown> {
    let k = coordinates.len();
    let mut unknowns = Vec::new();
    for (index, (segment, start)) in layout.segments.iter().zip(&layout.starts).enumerate() {
        let Some(placement) = start else { continue };
        let trace = &traces[segment.run];
        let at = trace.start_time + segment.begin() as f64 * trace.period;
        for &c in fitted {
            for (offset, what) in [(c, "position"), (k + c, "velocity")] {
                let key = format!("initial.{}.{what}", coordinates[c]);
                let value = placement.x[offset];
                unknowns.push(Unknown {
                    label: format!("{key} at t = {at} s of {}", trace.source),
                    key,
                    scope: Scope::Segment(index),
                    start: value,
                    bounds: [f64::NEG_INFINITY, f64::INFINITY],
                    scale: value.abs().max(1e-3),
                    coordinate: Some(offset),
                });
            }
        }
    }
    unknowns
}

/// The rows of a segment's run that it compares: those within its samples.
fn observations(trace: &Trace, segment: &Segment) -> Range<usize> {
    let (first, last) = (segment.start, segment.start + segment.len - 1);
    match &trace.rows {
        None => first..last + 1,
        Some(rows) => {
            let begin = rows.partition_point(|&p| p < first as f64 - 1e-9);
            let end = rows.partition_point(|&p| p <= last as f64 + 1e-9);
            begin..end
        }
    }
}

impl<'a> Problem<'a> {
    /// Lays a calibration out: `unknowns` are the parameters (shared and per run) made by the
    /// caller; the runs are cut into segments, each placed where its data say, and the start
    /// states of `options.states` are appended per segment, in the independent coordinates.
    pub fn new(
        replayer: Replayer<'a>,
        traces: Vec<Trace>,
        options: &CalibrationOptions,
        parameters: Vec<Unknown>,
    ) -> Result<Self, CalibrationError> {
        let shape = &replayer.shape;
        if let Some((name, _)) = options
            .noise
            .iter()
            .find(|(n, _)| shape.signal(n).is_none())
        {
            return Err(CalibrationError::Options(format!(
                "--noise {name}: no such signal (known: {})",
                signal_names(shape)
            )));
        }
        let outputs = outputs(shape, &traces, &options.signals)?;
        let noise_of = |i: usize| noise_of(shape, &traces, i, &options.noise);
        let sigma: Vec<f64> = outputs.iter().map(|&i| noise_of(i)).collect();
        let smoothed = |i: usize| {
            let name = &shape.columns.signals[i].0;
            let given = options.noise.iter().any(|(n, _)| n == name);
            let resolved = (traces.iter())
                .filter_map(|t| t.observed(i))
                .all(|(_, values)| noise_resolved(values));
            (noise_of(i), given || resolved)
        };
        let threads = thread_count(options.threads);
        let template = replayer.assembly()?;
        let assembly = &mut template.clone();
        let probes: Vec<[Vec<Probe>; 2]> = (traces.iter())
            .map(|t| assembly.probes(shape, t, &smoothed))
            .collect();
        let starting: Vec<(String, f64)> = (parameters.iter())
            .map(|u| (u.key.clone(), u.start))
            .collect();
        let setting = Setting {
            asked: options.segment,
            probes: &probes,
            outputs: &outputs,
            sigma: &sigma,
            parameters: &starting,
        };
        let layout = lay_out(&replayer, assembly, &traces, &setting)?;
        let coordinates = assembly.coordinate_names();
        let fitted = fitted_coordinates(&coordinates, &layout.placed, &options.states)?;
        let mut unknowns = parameters;
        unknowns.extend(state_unknowns(&traces, &layout, &coordinates, &fitted));
        let observations = (layout.segments.iter())
            .map(|s| observations(&traces[s.run], s))
            .collect();
        Ok(Self {
            threads,
            rollouts: AtomicUsize::new(0),
            replayer,
            traces,
            segments: layout.segments,
            starts: layout.starts,
            length: layout.length,
            notes: layout.notes,
            held: Vec::new(),
            observations,
            outputs,
            sigma,
            unknowns,
            assembly: template,
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

    /// Residuals in a segment: outputs × the data rows it compares.
    pub fn rows(&self, segment: usize) -> usize {
        self.outputs.len() * self.observations[segment].len()
    }

    /// Whether unknown `j` acts on segment `s`.
    pub fn affects(&self, j: usize, s: usize) -> bool {
        match self.unknowns[j].scope {
            Scope::Shared => true,
            Scope::Run(run) => self.segments[s].run == run,
            Scope::Segment(segment) => segment == s,
        }
    }

    /// The scenario values of segment `s` at `theta`: its start (where the data place it, with
    /// its fitted coordinates from `theta`, the loops closed), then the parameters acting on it.
    pub fn values(&self, theta: &[f64], s: usize) -> Result<Vec<(String, f64)>, CalibrationError> {
        let mut values = match &self.starts[s] {
            None => Vec::new(),
            Some(placement) => {
                let mut x = placement.x.clone();
                for (j, unknown) in self.unknowns.iter().enumerate() {
                    if let (Some(c), Scope::Segment(t)) = (unknown.coordinate, unknown.scope) {
                        if t == s {
                            x[c] = theta[j];
                        }
                    }
                }
                let anchor = &placement.anchor;
                let closed = self.assembly.clone().initial_values(anchor, &x);
                closed.map_err(|e| {
                    let segment = self.segments[s];
                    let trace = &self.traces[segment.run];
                    CalibrationError::Diverged {
                        run: trace.source.clone(),
                        time: trace.start_time + segment.begin() as f64 * trace.period,
                        reason: format!("the start state does not close the loops: {e}"),
                    }
                })?
            }
        };
        values.extend(self.held.iter().cloned());
        for (j, unknown) in self.unknowns.iter().enumerate() {
            if unknown.coordinate.is_none() && self.affects(j, s) {
                values.push((unknown.key.clone(), theta[j]));
            }
        }
        Ok(values)
    }

    /// The fitted signals simulated over segment `s` at `theta`, one row per signal, one value
    /// per control period from the segment's start.
    pub fn simulate(&self, theta: &[f64], s: usize) -> Result<Vec<Vec<f64>>, CalibrationError> {
        self.rollouts.fetch_add(1, Ordering::Relaxed);
        let segment = self.segments[s];
        let trace = &self.traces[segment.run];
        let values = self.values(theta, s)?;
        (self.replayer).simulate(trace, segment, &values, &self.outputs)
    }

    /// The data rows segment `s` compares for output `o`, beside the replay `row` of that output
    /// (one value per control period from the segment's start): each row's place within the
    /// segment (in samples), its measured value and the replay there (interpolated between the
    /// replay's samples where the row falls between two).
    pub fn paired<'r>(
        &'r self,
        s: usize,
        o: usize,
        row: &'r [f64],
    ) -> impl Iterator<Item = (f64, f64, f64)> + 'r {
        let segment = self.segments[s];
        let trace = &self.traces[segment.run];
        let i = self.outputs[o];
        let places = trace.rows.as_deref();
        let values = match places {
            None => trace.measured[i].as_deref(),
            Some(_) => trace.logged[i].as_deref(),
        }
        .unwrap_or_default();
        self.observations[s].clone().map(move |r| {
            let place = places.map_or(r as f64, |p| p[r]) - segment.start as f64;
            (place, values[r], at_place(row, place))
        })
    }

    /// Segment `s`'s residuals at `theta`, each divided by its signal's noise: signal-major, at
    /// the data's own rows.
    fn residual(&self, theta: &[f64], s: usize) -> Result<Vec<f64>, CalibrationError> {
        let simulated = self.simulate(theta, s)?;
        let mut residual = Vec::with_capacity(self.rows(s));
        for (o, (row, sigma)) in simulated.iter().zip(&self.sigma).enumerate() {
            let pairs = self.paired(s, o, row);
            residual.extend(pairs.map(|(_, measured, replayed)| (measured - replayed) / sigma));
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

/// A sampled series' value at `place` (in samples, fractional between two): linear between
/// the samples around it.
fn at_place(series: &[f64], place: f64) -> f64 {
    let k = (place.floor().max(0.0) as usize).min(series.len().saturating_sub(1));
    let weight = place - k as f64;
    match series.get(k + 1) {
        Some(next) if weight > 0.0 => series[k] + weight * (next - series[k]),
        _ => series.get(k).copied().unwrap_or(f64::NAN),
    }
}
