//! `compare`: the twin replaying a measured run in the segments a calibration uses, each from
//! the start state the data give (estimated from the logged positions, fitted to its segment
//! with the parameters held), open loop on the logged commands (or closed loop on the logged
//! reference); per signal how far apart they are, over the run and per segment. The same
//! figures, from the same replays, are a calibration's fit before and after.

use super::error::CalibrationError;
use super::metrics::{signal_fit, SignalFit};
use super::options::CalibrationOptions;
use super::problem::{self, Problem, Scope};
use super::solve::solve;
use crate::data::{DataRate, RunData};
use crate::scenario::ScenarioBuilder;
use framework::Registry;
use serde::Serialize;
use serde_json::{json, Value};

/// Most Levenberg–Marquardt iterations fitting start states alone.
const STATE_ITERATIONS: usize = 5;

/// One signal measured and replayed, on the control-period grid.
#[derive(Debug, Clone, PartialEq)]
pub struct Overlay {
    /// The plant signal.
    pub signal: String,
    /// Its SI unit.
    pub unit: String,
    /// The run's values.
    pub measured: Vec<f64>,
    /// The twin's values (its segments' replays joined).
    pub simulated: Vec<f64>,
}

/// The figures of one segment's replay.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SegmentFit {
    /// Its first compared time, s (the data's clock).
    pub start_time: f64,
    /// Its last compared time, s.
    pub end_time: f64,
    /// Per compared signal.
    pub signals: Vec<SignalFit>,
}

/// One run's replays and their figures.
#[derive(Debug, Clone)]
pub struct RunReplay {
    /// Per compared signal over the whole run, at the data's own rows.
    pub signals: Vec<SignalFit>,
    /// Per segment.
    pub segments: Vec<SegmentFit>,
    /// Per compared signal, the two series on the control period's grid.
    pub overlays: Vec<Overlay>,
}

/// How far the twin is from one measured run.
#[derive(Debug, Clone)]
pub struct Comparison {
    /// The data file.
    pub source: String,
    /// SHA-256 of the data file.
    pub digest: String,
    /// The data's own sampling.
    pub rate: DataRate,
    /// Whether the twin ran its own controller on the logged reference.
    pub closed_loop: bool,
    /// The data's first time, s; sample k is at `start_time + k·period`.
    pub start_time: f64,
    /// Control period, s.
    pub period: f64,
    /// Segment length, s; 0: the run replayed whole.
    pub segment: f64,
    /// Whether each segment started where the data place the mechanism (`false`: at the
    /// scenario's initial state).
    pub placed: bool,
    /// What the replay had to decide (a run replayed whole, and why).
    pub notes: Vec<String>,
    /// Per compared signal, over the run.
    pub signals: Vec<SignalFit>,
    /// Per segment, per compared signal.
    pub segments: Vec<SegmentFit>,
    /// Per compared signal, the two series.
    pub overlays: Vec<Overlay>,
}

/// Replays the run in `data` on the scenario of `builder` in the segments `options` give (the
/// calibration's default: 1 s from states estimated from the data; `segment` 0: whole) and
/// compares every measured signal (or those of `options.signals`).
pub fn compare(
    builder: &ScenarioBuilder,
    registry: &Registry,
    data: &RunData,
    options: &CalibrationOptions,
) -> Result<Comparison, CalibrationError> {
    let replayer = problem::replayer(builder, registry, options.closed_loop)?;
    let trace = problem::bind(&replayer, data, 2)?;
    let mut problem = Problem::new(replayer, vec![trace], options, Vec::new())?;
    let theta = fit_states(&mut problem, &[])?;
    let mut replays = replay(&problem, &theta)?;
    let run = replays.remove(0);
    let trace = &problem.traces[0];
    Ok(Comparison {
        source: trace.source.clone(),
        digest: trace.digest.clone(),
        rate: trace.rate.clone(),
        closed_loop: options.closed_loop,
        start_time: trace.start_time,
        period: trace.period,
        segment: problem.length,
        placed: problem.starts.iter().all(Option::is_some),
        notes: problem.notes.clone(),
        signals: run.signals,
        segments: run.segments,
        overlays: run.overlays,
    })
}

/// The unknowns at `theta` with the start states fitted alone, the parameters held at
/// `parameters` (the values of the problem's non-state unknowns, in order): the replays
/// `compare` makes of the same values.
pub(super) fn fit_states(
    problem: &mut Problem,
    parameters: &[f64],
) -> Result<Vec<f64>, CalibrationError> {
    let is_state = |u: &problem::Unknown| matches!(u.scope, Scope::Segment(_));
    let all = std::mem::take(&mut problem.unknowns);
    let mut held = Vec::new();
    let mut states = Vec::new();
    let mut values = parameters.iter();
    for unknown in &all {
        if is_state(unknown) {
            states.push(unknown.clone());
        } else {
            held.push((
                unknown.key.clone(),
                values.next().copied().unwrap_or(unknown.start),
            ));
        }
    }
    let theta: Vec<f64> = states.iter().map(|u| u.start).collect();
    problem.unknowns = states;
    problem.held = held;
    let solved = match theta.is_empty() {
        true => Ok(theta),
        false => solve(problem, theta, 0, STATE_ITERATIONS, None, &mut |_| {}).map(|s| s.theta),
    };
    let (held, states) = (
        std::mem::take(&mut problem.held),
        std::mem::take(&mut problem.unknowns),
    );
    problem.unknowns = all;
    let solved = solved?;
    let (mut held, mut fitted) = (held.into_iter(), solved.into_iter().zip(states));
    let mut theta = Vec::with_capacity(problem.unknowns.len());
    for unknown in &problem.unknowns {
        theta.push(match is_state(unknown) {
            true => fitted.next().map_or(unknown.start, |(v, _)| v),
            false => held.next().map_or(unknown.start, |(_, v)| v),
        });
    }
    Ok(theta)
}

/// Every run replayed at `theta`, segment by segment: its figures over the run (at the data's
/// own rows) and per segment, and the series on the grid.
pub(super) fn replay(problem: &Problem, theta: &[f64]) -> Result<Vec<RunReplay>, CalibrationError> {
    let outputs = problem.outputs.len();
    let names = |o: usize| problem.replayer.shape.columns.signals[problem.outputs[o]].clone();
    let mut runs: Vec<RunReplay> = (0..problem.traces.len())
        .map(|_| RunReplay {
            signals: Vec::new(),
            segments: Vec::new(),
            overlays: Vec::new(),
        })
        .collect();
    let mut joined = vec![vec![(Vec::new(), Vec::new(), Vec::new()); outputs]; runs.len()];
    for (s, segment) in problem.segments.iter().enumerate() {
        let simulated = problem.simulate(theta, s)?;
        let trace = &problem.traces[segment.run];
        let mut signals = Vec::with_capacity(outputs);
        let mut times = (f64::INFINITY, f64::NEG_INFINITY);
        for (o, row) in simulated.iter().enumerate() {
            let (measured, replayed): (Vec<f64>, Vec<f64>) = problem
                .paired(s, o, row)
                .map(|(place, y, replayed)| {
                    let t = trace.start_time + (segment.start as f64 + place) * trace.period;
                    times = (times.0.min(t), times.1.max(t));
                    (y, replayed)
                })
                .unzip();
            let (name, unit) = names(o);
            signals.push(signal_fit(&name, &unit, &measured, &replayed));
            let all = &mut joined[segment.run][o];
            all.0.extend(measured);
            all.1.extend(replayed);
            all.2.extend(row.iter().copied());
        }
        runs[segment.run].segments.push(SegmentFit {
            start_time: times.0,
            end_time: times.1,
            signals,
        });
    }
    for ((run, series), trace) in runs.iter_mut().zip(joined).zip(&problem.traces) {
        for (o, (measured, replayed, grid)) in series.into_iter().enumerate() {
            let (name, unit) = names(o);
            run.signals
                .push(signal_fit(&name, &unit, &measured, &replayed));
            run.overlays.push(Overlay {
                signal: name,
                unit,
                measured: trace.measured[problem.outputs[o]]
                    .clone()
                    .unwrap_or_default(),
                simulated: grid,
            });
        }
    }
    Ok(runs)
}

impl Overlay {
    /// The figures of this signal on the grid.
    pub fn fit(&self) -> SignalFit {
        signal_fit(&self.signal, &self.unit, &self.measured, &self.simulated)
    }
}

impl Comparison {
    /// How the twin was replayed, in words: "1 s replays from start states estimated from the
    /// data", or "one replay of the whole run from the scenario's initial state".
    pub fn replays(&self) -> String {
        let start = match self.placed {
            true => "from start states estimated from the data",
            false => "from the scenario's initial state",
        };
        let drive = match self.closed_loop {
            true => "closed loop on the logged reference",
            false => "open loop on the logged commands",
        };
        match self.segment {
            0.0 => format!("one replay of the whole run {start}, {drive}"),
            s => format!(
                "{s} s replays ({} segments) {start}, {drive}",
                self.segments.len()
            ),
        }
    }

    /// The report as JSON: the data file and its rate, how it was replayed, and per signal fit
    /// %, RMS and largest error and the whiteness test, over the run and per segment.
    pub fn to_json(&self) -> Value {
        json!({
            "data": self.source,
            "sha256": self.digest,
            "closed_loop": self.closed_loop,
            "replays": self.replays(),
            "segment_s": self.segment,
            "placed": self.placed,
            "notes": self.notes,
            "samples": self.overlays.first().map_or(0, |o| o.measured.len()),
            "control_period_s": self.period,
            "data_rate": rate_json(&self.rate),
            "signals": self.signals,
            "segments": self.segments,
        })
    }
}

/// A data rate as JSON.
pub fn rate_json(rate: &DataRate) -> Value {
    json!({
        "mean_period_s": rate.mean_period,
        "min_period_s": rate.min_period,
        "max_period_s": rate.max_period,
        "resampled": rate.resampled,
    })
}
