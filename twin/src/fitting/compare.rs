//! `compare`: the twin replaying a measured run from the run's start state, open loop on its
//! logged commands (or closed loop on its logged reference), and per signal how far apart they
//! are.

use super::metrics::{signal_fit, SignalFit};
use super::problem::{self, Problem};
use super::replay::{Replayer, Segment};
use super::solve::solve;
use super::{CalibrationError, CalibrationOptions};
use crate::run_data::{DataRate, RunData, Trace};
use crate::scenario::ScenarioBuilder;
use framework::Registry;
use serde_json::{json, Value};

/// One signal measured and replayed, on the control-period grid.
#[derive(Debug, Clone, PartialEq)]
pub struct Overlay {
    /// The plant signal.
    pub signal: String,
    /// Its SI unit.
    pub unit: String,
    /// The run's values.
    pub measured: Vec<f64>,
    /// The twin's values.
    pub simulated: Vec<f64>,
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
    /// Per compared signal, the figures.
    pub signals: Vec<SignalFit>,
    /// Per compared signal, the two series.
    pub overlays: Vec<Overlay>,
}

/// Replays the run in `data` on the scenario of `builder` and compares every measured signal.
pub fn compare(
    builder: &ScenarioBuilder,
    registry: &Registry,
    data: &RunData,
    closed_loop: bool,
) -> Result<Comparison, CalibrationError> {
    let replayer = problem::replayer(builder, registry, closed_loop)?;
    let trace = problem::bind(&replayer, data, 2)?;
    let (replayer, trace, start) = start_state(replayer, trace, closed_loop)?;
    let traces = std::slice::from_ref(&trace);
    let outputs = problem::outputs(&replayer.shape, traces, &[])?;
    let segment = Segment {
        run: 0,
        start: 0,
        len: trace.samples,
        lead: 0,
    };
    let simulated = replayer.simulate(&trace, segment, &start, &outputs)?;
    let overlays: Vec<Overlay> = outputs
        .iter()
        .zip(simulated)
        .map(|(&i, simulated)| {
            let (signal, unit) = replayer.shape.columns.signals[i].clone();
            let measured = trace.measured[i].clone().unwrap_or_default();
            Overlay {
                signal,
                unit,
                measured,
                simulated,
            }
        })
        .collect();
    Ok(Comparison {
        signals: overlays.iter().map(Overlay::fit).collect(),
        source: trace.source.clone(),
        digest: trace.digest.clone(),
        rate: trace.rate.clone(),
        closed_loop,
        start_time: trace.start_time,
        period: trace.period,
        overlays,
    })
}

/// A replayer with its run and the run's start state.
type Started<'a> = (Replayer<'a>, Trace, Vec<(String, f64)>);

/// The run's start state estimated from its first samples (5 % of the run, 20 to 200 of them):
/// the start states a calibration would fit, fitted to that window alone, so that the noise of
/// one sample does not set the whole replay off.
fn start_state(
    replayer: Replayer,
    trace: Trace,
    closed_loop: bool,
) -> Result<Started, CalibrationError> {
    let window = (trace.samples / 20).clamp(20, 200);
    if trace.samples < 2 * window {
        let start = replayer.start_state(&trace, 0);
        return Ok((replayer, trace, start));
    }
    let options = CalibrationOptions {
        segment: Some(window as f64 * trace.period),
        closed_loop,
        ..CalibrationOptions::default()
    };
    let mut problem = Problem::new(replayer, vec![trace], &options, Vec::new())?;
    problem.keep_first_segment();
    let mut theta = problem.start();
    if !theta.is_empty() {
        theta = solve(&problem, theta, 0, 20, None, &mut |_| {})?.theta;
    }
    let start = problem.values(&theta, 0);
    let Problem {
        replayer,
        mut traces,
        ..
    } = problem;
    Ok((replayer, traces.remove(0), start))
}

impl Overlay {
    /// The figures of this signal.
    pub fn fit(&self) -> SignalFit {
        signal_fit(&self.signal, &self.unit, &self.measured, &self.simulated)
    }
}

impl Comparison {
    /// The report as JSON: the data file and its rate, and per signal fit %, RMS and largest
    /// error and the whiteness test.
    pub fn to_json(&self) -> Value {
        json!({
            "data": self.source,
            "sha256": self.digest,
            "closed_loop": self.closed_loop,
            "samples": self.overlays.first().map_or(0, |o| o.measured.len()),
            "control_period_s": self.period,
            "data_rate": rate_json(&self.rate),
            "signals": self.signals,
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
