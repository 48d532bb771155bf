//! The runs cut into segments (multiple shooting) and where each segment starts: placed where
//! the data say ([`super::start`]), on the branch the machine is on, or, where the logged
//! positions cannot place the mechanism, each run whole from the scenario's initial state, said
//! in one line with the reason and what to log.

use super::error::CalibrationError;
use super::options::DEFAULT_SEGMENT;
use super::replay::{Replayer, Segment};
use super::start::{Assembly, Placement, Probe};
use crate::data::Trace;

/// Fewest samples a segment may have: a start state and its first moves.
pub const MIN_SEGMENT_SAMPLES: usize = 10;
/// A start moved by a small step whose replay has moved this many times as far has drifted: the
/// model amplifies what it is started with.
const DRIFT_GROWTH: f64 = 100.0;
/// The default segment lengths, s, longest first: the longest within the drift horizon is
/// taken.
const LENGTHS: [f64; 7] = [DEFAULT_SEGMENT, 0.5, 0.25, 0.1, 0.05, 0.025, 0.01];
/// Seconds of replay that choose between assemblies the first samples leave open.
const CHOICE_SPAN: f64 = 0.2;
/// A change of a coordinate's start (1 rad or m, 1 rad/s or m/s) that moves the fitted signals
/// by less than this many σ has no effect: the coordinate need not be placed.
const IDLE: f64 = 1e-6;

/// The segments and their starts.
pub struct Layout {
    /// Segment length, s; 0: whole runs.
    pub length: f64,
    pub segments: Vec<Segment>,
    /// Per segment, where the data place the mechanism at its begin sample; `None`: the
    /// scenario's initial state.
    pub starts: Vec<Option<Placement>>,
    /// Per independent coordinate, whether its start is read off the data (and may be fitted).
    pub placed: Vec<bool>,
    /// What the layout had to decide, for the user.
    pub notes: Vec<String>,
}

/// What the layout needs besides the traces.
pub struct Setting<'s> {
    /// Asked segment length, s (0: whole runs); `None`: the default.
    pub asked: Option<f64>,
    /// Per run, its logged positions and velocities.
    pub probes: &'s [[Vec<Probe>; 2]],
    /// The fitted signals and their σ.
    pub outputs: &'s [usize],
    pub sigma: &'s [f64],
    /// The parameters' start values, set in every replay.
    pub parameters: &'s [(String, f64)],
}

/// Lays the runs out in segments of the asked or default length, each placed where its data
/// say; refuses an asked length the data cannot start segments for, naming what to log.
pub fn lay_out(
    replayer: &Replayer,
    assembly: &mut Assembly,
    traces: &[Trace],
    setting: &Setting,
) -> Result<Layout, CalibrationError> {
    let (firsts, placed, unplaced) = firsts(replayer, assembly, traces, setting)?;
    let mut notes = Vec::new();
    let length = match (setting.asked, &unplaced) {
        (Some(s), Some(reason)) if s != 0.0 => {
            return Err(CalibrationError::Options(format!(
                "--segment {s}: a segment must start where the machine is, and {reason}; give --segment 0 to replay each run whole from the scenario's initial state"
            )));
        }
        (None, Some(reason)) => {
            notes.push(format!(
                "each run is replayed whole from the scenario's initial state, not in segments: {reason}"
            ));
            0.0
        }
        (Some(s), _) => s,
        (None, None) => {
            let horizon = (traces.iter().zip(&firsts))
                .filter_map(|(trace, first)| {
                    drift_horizon(replayer, assembly, trace, first.as_ref()?, setting)
                })
                .fold(f64::INFINITY, f64::min);
            let length = default_length(horizon, replayer.shape.period);
            if length < DEFAULT_SEGMENT {
                notes.push(format!(
                    "segments of {length} s, not {DEFAULT_SEGMENT} s: the model's replays part from a start {DRIFT_GROWTH}× as far within {horizon:.3} s, so a longer segment would not stay near its run (give --segment to choose)"
                ));
            }
            length
        }
    };
    let period = replayer.shape.period;
    let segments = segments(traces, length, period)?;
    // A run shorter than a segment is one segment of its own length.
    let longest = (traces.iter().map(|t| t.samples as f64 * period)).fold(0.0, f64::max);
    let length = if length > longest { 0.0 } else { length };
    let mut starts = vec![None; segments.len()];
    if unplaced.is_none() {
        for (run, trace) in traces.iter().enumerate() {
            let Some(first) = &firsts[run] else { continue };
            let index: Vec<usize> = (0..segments.len())
                .filter(|&s| segments[s].run == run)
                .collect();
            let begins: Vec<usize> = index.iter().map(|&s| segments[s].begin()).collect();
            let placements = (assembly.track(trace, &setting.probes[run], first, &begins))
                .map_err(|reason| placement_error(trace, reason))?;
            for (s, placement) in index.into_iter().zip(placements) {
                starts[s] = Some(placement);
            }
        }
    }
    Ok(Layout {
        length,
        segments,
        starts,
        placed,
        notes,
    })
}

/// Where each run starts (`None` where its data cannot place it), which coordinates the logged
/// positions place, and why the runs cannot be cut into segments, if they cannot.
type Firsts = (Vec<Option<Placement>>, Vec<bool>, Option<String>);

fn firsts(
    replayer: &Replayer,
    assembly: &mut Assembly,
    traces: &[Trace],
    setting: &Setting,
) -> Result<Firsts, CalibrationError> {
    let names = assembly.coordinate_names();
    let mut firsts = Vec::with_capacity(traces.len());
    let mut unplaced: Option<String> = None;
    for (run, trace) in traces.iter().enumerate() {
        match first_placement(replayer, assembly, trace, run, setting) {
            Ok(first) => firsts.push(Some(first)),
            Err(reason) => {
                unplaced.get_or_insert(format!("{}: {reason}", trace.source));
                firsts.push(None);
            }
        }
    }
    if unplaced.is_some() {
        return Ok((firsts, vec![false; names.len()], unplaced));
    }
    let all: Vec<Placement> = firsts.iter().flatten().cloned().collect();
    let positions: Vec<Probe> = setting.probes.iter().flat_map(|p| p[0].clone()).collect();
    let placed = assembly.observed(&positions, &all);
    let missing: Vec<&str> = (names.iter().zip(&placed))
        .filter(|(_, p)| !**p)
        .map(|(n, _)| n.as_str())
        .collect();
    if !missing.is_empty() && !idle(replayer, assembly, traces, &firsts, &placed, setting)? {
        let logs: Vec<String> = missing.iter().map(|m| format!("{m}.position")).collect();
        unplaced = Some(format!(
            "the logged positions do not fix {} (log {}, or a joint the loops tie to it)",
            missing.join(", "),
            logs.join(", ")
        ));
    }
    Ok((firsts, placed, unplaced))
}

/// The first `seconds` of run `run` (at least two samples, at most the run) as a segment.
fn opening(trace: &Trace, run: usize, seconds: f64) -> Segment {
    Segment {
        run,
        start: 0,
        len: ((seconds / trace.period).round() as usize).clamp(2, trace.samples),
        lead: 0,
    }
}

fn placement_error(trace: &Trace, reason: String) -> CalibrationError {
    CalibrationError::Options(format!(
        "{}: the logged positions cannot be followed along the run ({reason}); check their units and signs, or give --segment 0",
        trace.source
    ))
}

/// Where run `run` starts: the one assembly its first samples give, or of several, the one
/// whose replay over the first [`CHOICE_SPAN`] follows the data best.
fn first_placement(
    replayer: &Replayer,
    assembly: &mut Assembly,
    trace: &Trace,
    run: usize,
    setting: &Setting,
) -> Result<Placement, String> {
    let probes = &setting.probes[run];
    if probes[0].is_empty() {
        let joints = assembly.coordinate_names();
        return Err(format!(
            "no joint position is logged, and the mechanism's place is its joints' ({}): log them for segments",
            joints.join(", ")
        ));
    }
    let mut candidates = assembly.candidates(trace, probes)?;
    if candidates.len() == 1 {
        return Ok(candidates.remove(0));
    }
    let segment = opening(trace, run, CHOICE_SPAN);
    let mut best: Option<(f64, Placement)> = None;
    for candidate in candidates {
        let cost = replay_cost(replayer, assembly, trace, segment, &candidate, setting);
        if best.as_ref().is_none_or(|(c, _)| cost < *c) {
            best = Some((cost, candidate));
        }
    }
    best.map(|(_, p)| p)
        .ok_or_else(|| "no assembly reads the logged positions".into())
}

/// The fitted signals replayed over `segment` from `placement`, each divided by its noise σ
/// (`None` where the twin cannot run it).
fn replay(
    replayer: &Replayer,
    assembly: &mut Assembly,
    trace: &Trace,
    segment: Segment,
    placement: &Placement,
    setting: &Setting,
) -> Option<Vec<Vec<f64>>> {
    let mut values = assembly
        .initial_values(&placement.anchor, &placement.x)
        .ok()?;
    values.extend(setting.parameters.iter().cloned());
    let simulated = (replayer.simulate(trace, segment, &values, setting.outputs)).ok()?;
    let weighted = (simulated.into_iter().zip(setting.sigma))
        .map(|(row, sigma)| row.into_iter().map(|v| v / sigma).collect::<Vec<f64>>())
        .collect::<Vec<_>>();
    weighted
        .iter()
        .flatten()
        .all(|v| v.is_finite())
        .then_some(weighted)
}

/// The weighted squared residual of a replay of `segment` from `placement` (infinite where the
/// twin cannot run it).
fn replay_cost(
    replayer: &Replayer,
    assembly: &mut Assembly,
    trace: &Trace,
    segment: Segment,
    placement: &Placement,
    setting: &Setting,
) -> f64 {
    let Some(replayed) = replay(replayer, assembly, trace, segment, placement, setting) else {
        return f64::INFINITY;
    };
    let mut cost = 0.0;
    for ((row, &i), sigma) in replayed.iter().zip(setting.outputs).zip(setting.sigma) {
        let measured = trace.measured[i].as_deref().unwrap_or_default();
        let measured = &measured[segment.start..segment.start + segment.len];
        cost += (measured.iter().zip(row))
            .map(|(y, s)| (y / sigma - s).powi(2))
            .sum::<f64>();
    }
    match cost.is_finite() {
        true => cost,
        false => f64::INFINITY,
    }
}

/// Whether the coordinates the logged positions do not fix have no effect on the fitted
/// signals (a free spindle's angle): a replay of each run's start with them moved is the same.
fn idle(
    replayer: &Replayer,
    assembly: &mut Assembly,
    traces: &[Trace],
    firsts: &[Option<Placement>],
    placed: &[bool],
    setting: &Setting,
) -> Result<bool, CalibrationError> {
    let k = placed.len();
    for (run, trace) in traces.iter().enumerate() {
        let Some(first) = &firsts[run] else {
            return Ok(false);
        };
        let segment = opening(trace, run, CHOICE_SPAN);
        let Some(base) = replay(replayer, assembly, trace, segment, first, setting) else {
            return Ok(false);
        };
        for c in (0..k).filter(|&c| !placed[c]) {
            for offset in [c, k + c] {
                let mut moved = first.clone();
                moved.x[offset] += 1.0;
                let Some(other) = replay(replayer, assembly, trace, segment, &moved, setting)
                else {
                    return Ok(false);
                };
                let change = (base.iter().flatten().zip(other.iter().flatten()))
                    .fold(0.0_f64, |m, (a, b)| m.max((a - b).abs()));
                if change > IDLE {
                    return Ok(false);
                }
            }
        }
    }
    Ok(true)
}

/// The longest of [`LENGTHS`] within `horizon` (s), and at least [`MIN_SEGMENT_SAMPLES`]
/// control periods.
fn default_length(horizon: f64, period: f64) -> f64 {
    let shortest = MIN_SEGMENT_SAMPLES as f64 * period;
    (LENGTHS.iter().copied())
        .find(|&l| l <= horizon)
        .unwrap_or(shortest)
        .max(shortest)
}

/// How long the model's replay from `placement` (at the parameters' starts) takes to carry a
/// small step of one coordinate's start position [`DRIFT_GROWTH`] times as far, for the
/// independent coordinate that drifts first: an unstable motion, or one the process amplifies.
/// The step is a thousandth of the coordinate's travel over the replay. At most
/// [`DEFAULT_SEGMENT`]; `None` where the twin cannot replay it.
fn drift_horizon(
    replayer: &Replayer,
    assembly: &mut Assembly,
    trace: &Trace,
    placement: &Placement,
    setting: &Setting,
) -> Option<f64> {
    let names = assembly.coordinate_names();
    let outputs: Vec<usize> = (names.iter())
        .filter_map(|n| replayer.shape.signal(&format!("{n}.position")))
        .collect();
    if outputs.len() != names.len() {
        return None;
    }
    let segment = opening(trace, 0, DEFAULT_SEGMENT);
    let len = segment.len;
    let probe = |assembly: &mut Assembly, placement: &Placement| {
        let mut values = assembly
            .initial_values(&placement.anchor, &placement.x)
            .ok()?;
        values.extend(setting.parameters.iter().cloned());
        replayer.simulate(trace, segment, &values, &outputs).ok()
    };
    let base = probe(assembly, placement)?;
    let mut horizon: Option<usize> = None;
    for (c, series) in base.iter().enumerate() {
        let (low, high) = (series.iter()).fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
            (l.min(*v), h.max(*v))
        });
        let step = 1e-3 * (high - low);
        if !(step > 0.0 && step.is_finite()) {
            continue;
        }
        let mut moved = placement.clone();
        moved.x[c] += step;
        let other = probe(assembly, &moved)?;
        let drifted = (0..horizon.unwrap_or(len)).find(|&k| {
            let apart = (other[c][k] - series[k]).abs();
            apart.is_nan() || apart > DRIFT_GROWTH * step
        });
        horizon = drifted.or(horizon);
    }
    Some(horizon.map_or(DEFAULT_SEGMENT, |k| k as f64 * trace.period))
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
