//! Start states from what a run logs. A segment starts where the data place the mechanism: the
//! logged joint positions (any subset that fixes the configuration: a linkage's crank alone, or
//! its ram alone) fitted by the independent coordinates (the split `twin linearize` makes), the
//! dependent joints solved by closing the loops, and the rates from local polynomial fits of the
//! positions (or the logged velocities), weighted by the noise. Along a run with closed loops the
//! configuration is tracked sample by sample from the scenario's assembly, so that every segment
//! starts on the branch the machine is on; where the logged positions leave the configuration
//! ambiguous at the run's start (a ram's position is met twice per crank turn), the candidates
//! are handed back for the replay to choose between.

use super::local_fit::{fit_adaptive, through, LocalValue};
use super::replay::PlantShape;
use crate::data::Trace;
use crate::mechanism::JointMotion;
use crate::physics::{MechanismState, ReducedDynamics, ReducedError};
use crate::run::ModelParts;
use crate::sensors::SensorSpec;
use nalgebra::{DMatrix, DVector};
use std::collections::BTreeMap;

/// Widest half-width of a local fit, s: long enough to average the noise, short enough that a
/// cubic follows a linkage's positions (narrower where the rows say it does not).
const FIT_HALF_WIDTH: f64 = 0.02;
/// Fewest rows on each side of a local fit (a cubic through five).
const FIT_MIN_ROWS: f64 = 2.0;
/// Gauss–Newton iterations per placement.
const PLACE_ITERATIONS: usize = 8;
/// Forward-difference step of a coordinate, rad or m.
const PLACE_STEP: f64 = 1e-7;
/// Points of the scan for the assemblies that fit the first samples, over a turn.
const SCAN_POINTS: usize = 72;
/// A candidate whose misfit exceeds the best one's by more than this (in σ², summed over the
/// logged positions) is not the machine's.
const CANDIDATE_MISFIT: f64 = 25.0;

/// A logged joint signal and what it reads.
#[derive(Debug, Clone)]
pub struct Probe {
    /// The plant signal.
    pub signal: usize,
    /// The tree joint it reads.
    pub joint: usize,
    /// Its sensor's gain and bias (reading = gain·true + bias).
    pub gain: f64,
    pub bias: f64,
    /// Its noise σ, SI.
    pub sigma: f64,
    /// Whether its rows are smoothed (their noise is known or resolved) or taken as they are.
    pub smoothed: bool,
}

/// Where the data place the mechanism at one sample.
#[derive(Debug, Clone, PartialEq)]
pub struct Placement {
    /// The independent coordinates' positions, then their velocities (URDF sense).
    pub x: Vec<f64>,
    /// Every tree joint's position there: the branch later loop closures start from.
    pub anchor: Vec<f64>,
}

/// The mechanism reduced to its independent coordinates, to place it where the data say.
#[derive(Clone)]
pub struct Assembly {
    reduced: ReducedDynamics,
    state: MechanismState,
    /// The tree joint of each independent coordinate.
    pub coordinates: Vec<usize>,
    /// Every tree joint's name, and whether it moves.
    names: Vec<String>,
    movable: Vec<bool>,
    revolute: Vec<bool>,
    /// The scenario's initial state, reduced.
    pub x0: Vec<f64>,
    anchor0: Vec<f64>,
    /// Whether the mechanism closes loops (its placements then follow the run).
    pub loops: bool,
    /// The scenario's sensors (their gain and bias read the joints).
    sensors: BTreeMap<String, SensorSpec>,
}

impl Assembly {
    /// The assembly of a scenario's mechanism at its initial state.
    pub fn new(parts: &ModelParts) -> Self {
        let mechanism = &parts.mechanism;
        let reduced = ReducedDynamics::new(
            mechanism,
            parts.scenario.gravity,
            &parts.state,
            &[],
            &parts.actuated,
        );
        let coordinates = reduced.coordinates();
        let movable = (mechanism.joints.iter())
            .map(|j| !matches!(j.motion, JointMotion::Fixed))
            .collect::<Vec<bool>>();
        let tree_coordinates = movable.iter().filter(|m| **m).count();
        Self {
            x0: reduced.operating_state(),
            anchor0: parts.state.joint_positions.clone(),
            loops: coordinates.len() < tree_coordinates,
            names: mechanism.joints.iter().map(|j| j.name.clone()).collect(),
            revolute: (mechanism.joints.iter())
                .map(|j| matches!(j.motion, JointMotion::Revolute { .. }))
                .collect(),
            movable,
            coordinates,
            state: parts.state.clone(),
            sensors: parts.scenario.sensors.clone(),
            reduced,
        }
    }

    /// The joints of the independent coordinates, by name.
    pub fn coordinate_names(&self) -> Vec<String> {
        (self.coordinates.iter())
            .map(|&j| self.names[j].clone())
            .collect()
    }

    /// The whole mechanism at `x`, its loops closed from `anchor`.
    pub fn place(&mut self, anchor: &[f64], x: &[f64]) -> Result<&MechanismState, ReducedError> {
        self.reduced.anchor(anchor);
        self.reduced.read_state(x, &mut self.state)?;
        Ok(&self.state)
    }

    /// The scenario values that start the twin at `x` (closed from `anchor`): every moving
    /// joint's `initial.<joint>.position` and `.velocity`.
    pub fn initial_values(
        &mut self,
        anchor: &[f64],
        x: &[f64],
    ) -> Result<Vec<(String, f64)>, ReducedError> {
        self.place(anchor, x)?;
        let mut values = Vec::with_capacity(4 * self.names.len());
        for (j, name) in self.names.iter().enumerate() {
            if self.movable[j] {
                let (q, v) = (
                    self.state.joint_positions[j],
                    self.state.joint_velocities[j],
                );
                values.push((format!("initial.{name}.position"), q));
                values.push((format!("initial.{name}.velocity"), v));
            }
        }
        Ok(values)
    }

    /// The logged joint positions and velocities of `trace` as probes, with their sensors'
    /// gain and bias and, from `sigma` (per plant signal), their noise σ and whether their rows
    /// are smoothed.
    pub fn probes(
        &self,
        shape: &PlantShape,
        trace: &Trace,
        sigma: &dyn Fn(usize) -> (f64, bool),
    ) -> [Vec<Probe>; 2] {
        let mut probes = [Vec::new(), Vec::new()];
        for (joint, name) in self.names.iter().enumerate() {
            if !self.movable[joint] {
                continue;
            }
            for (kind, suffix) in ["position", "velocity"].iter().enumerate() {
                let signal_name = format!("{name}.{suffix}");
                let Some(signal) = shape.signal(&signal_name) else {
                    continue;
                };
                if trace.measured[signal].is_none() {
                    continue;
                }
                let (gain, bias) = (self.sensors.get(&signal_name))
                    .map_or((1.0, 0.0), |sensor| (sensor.gain, sensor.bias));
                if gain == 0.0 || !gain.is_finite() {
                    continue;
                }
                let (sigma, smoothed) = sigma(signal);
                probes[kind].push(Probe {
                    signal,
                    joint,
                    gain,
                    bias,
                    sigma: sigma.max(f64::MIN_POSITIVE),
                    smoothed,
                });
            }
        }
        probes
    }

    /// Which independent coordinates the logged positions fix: those some probe moves with, at
    /// the scenario's initial state or at any of `placements`.
    pub fn observed(&mut self, positions: &[Probe], placements: &[Placement]) -> Vec<bool> {
        let k = self.coordinates.len();
        let mut seen = vec![false; k];
        let mut points: Vec<(Vec<f64>, Vec<f64>)> = vec![(self.anchor0.clone(), self.x0.clone())];
        points.extend(placements.iter().map(|p| (p.anchor.clone(), p.x.clone())));
        for (anchor, x) in points {
            if let Ok(jacobian) = self.position_jacobian(&anchor, &x, positions) {
                for (c, seen) in seen.iter_mut().enumerate() {
                    *seen |= jacobian.column(c).amax() > 1e-9;
                }
            }
        }
        seen
    }

    /// ∂(logged positions)/∂(coordinate positions) at `x`, each row divided by its probe's σ.
    fn position_jacobian(
        &mut self,
        anchor: &[f64],
        x: &[f64],
        probes: &[Probe],
    ) -> Result<DMatrix<f64>, ReducedError> {
        let k = self.coordinates.len();
        let base = self.readings(anchor, x, probes)?;
        let mut jacobian = DMatrix::zeros(probes.len(), k);
        for c in 0..k {
            let mut moved = x.to_vec();
            let h = PLACE_STEP * x[c].abs().max(1.0);
            moved[c] += h;
            let shifted = self.readings(anchor, &moved, probes)?;
            for (r, probe) in probes.iter().enumerate() {
                jacobian[(r, c)] = (shifted[r] - base[r]) / h / probe.sigma;
            }
        }
        Ok(jacobian)
    }

    /// The probes' readings (gain·q + bias) at `x`.
    fn readings(
        &mut self,
        anchor: &[f64],
        x: &[f64],
        probes: &[Probe],
    ) -> Result<Vec<f64>, ReducedError> {
        let state = self.place(anchor, x)?;
        Ok((probes.iter())
            .map(|p| p.gain * state.joint_positions[p.joint] + p.bias)
            .collect())
    }

    /// Gauss–Newton on the coordinates' positions of `x` (velocities kept) so that the probes
    /// read `targets`, held to `prior` (per coordinate: value and spread; an infinite spread
    /// holds nothing) where the readings say little. The misfit Σ((reading − target)/σ)².
    fn solve_positions(
        &mut self,
        anchor: &[f64],
        x: &mut [f64],
        probes: &[Probe],
        targets: &[f64],
        prior: &[(f64, f64)],
    ) -> Result<f64, ReducedError> {
        let k = self.coordinates.len();
        let mut misfit = f64::INFINITY;
        for _ in 0..PLACE_ITERATIONS {
            let readings = self.readings(anchor, x, probes)?;
            let jacobian = self.position_jacobian(anchor, x, probes)?;
            let r = DVector::from_iterator(
                probes.len(),
                (readings.iter().zip(targets).zip(probes)).map(|((y, t), p)| (y - t) / p.sigma),
            );
            misfit = r.norm_squared();
            let mut normal = jacobian.transpose() * &jacobian;
            let mut gradient = jacobian.transpose() * &r;
            for (c, &(value, spread)) in prior.iter().enumerate() {
                if spread.is_finite() && spread > 0.0 {
                    normal[(c, c)] += 1.0 / (spread * spread);
                    gradient[c] += (x[c] - value) / (spread * spread);
                }
            }
            // A coordinate neither the readings nor the prior see keeps its value.
            let seen: Vec<usize> = (0..k).filter(|&c| normal[(c, c)] > 0.0).collect();
            if seen.is_empty() {
                break;
            }
            let normal = normal.select_rows(&seen).select_columns(&seen);
            let gradient = gradient.select_rows(&seen);
            let step = normal.lu().solve(&(-gradient));
            let Some(step) = step.filter(|s| s.iter().all(|d| d.is_finite())) else {
                break;
            };
            for (i, &c) in seen.iter().enumerate() {
                x[c] += step[i];
            }
            if step.amax() <= 1e-13 * x[..k].iter().fold(1.0_f64, |m, v| m.max(v.abs())) {
                break;
            }
        }
        Ok(misfit)
    }

    /// The coordinates' velocities at `x` (positions placed) that best give the probes' rates:
    /// `position_rates` (per position probe, a local fit's rate) and `velocities` (per velocity
    /// probe, a local fit's value); a coordinate no probe sees keeps its velocity.
    fn solve_velocities(
        &mut self,
        anchor: &[f64],
        x: &mut [f64],
        probes: &[Vec<Probe>; 2],
        position_rates: &[LocalValue],
        velocities: &[LocalValue],
    ) -> Result<(), ReducedError> {
        let k = self.coordinates.len();
        let mut rows: Vec<(Vec<f64>, f64)> = Vec::new();
        let mut unit = x.to_vec();
        let mut columns = vec![vec![0.0; self.names.len()]; k];
        for (c, column) in columns.iter_mut().enumerate() {
            unit[k..].fill(0.0);
            unit[k + c] = 1.0;
            let state = self.place(anchor, &unit)?;
            column.copy_from_slice(&state.joint_velocities);
        }
        let groups = [
            (&probes[0], position_rates, true),
            (&probes[1], velocities, false),
        ];
        for (group, fits, rate) in groups {
            for (probe, fit) in group.iter().zip(fits) {
                // A joint whose velocity is logged takes it from there, not from its positions.
                if rate && probes[1].iter().any(|v| v.joint == probe.joint) {
                    continue;
                }
                let (target, error) = match rate {
                    true => (fit.rate, fit.rate_error),
                    false => (fit.value, fit.value_error),
                };
                let weight = 1.0 / error.max(1e-12 * target.abs()).max(f64::MIN_POSITIVE);
                let row = (0..k)
                    .map(|c| probe.gain * columns[c][probe.joint] * weight)
                    .collect();
                let reading = match rate {
                    true => target,
                    false => target - probe.bias,
                };
                rows.push((row, reading * weight));
            }
        }
        let a = DMatrix::from_fn(rows.len(), k, |r, c| rows[r].0[c]);
        let b = DVector::from_iterator(rows.len(), rows.iter().map(|r| r.1));
        let seen: Vec<usize> = (0..k).filter(|&c| a.column(c).amax() > 1e-12).collect();
        if seen.is_empty() {
            return Ok(());
        }
        let a = a.select_columns(&seen);
        let solution = (a.transpose() * &a).lu().solve(&(a.transpose() * b));
        if let Some(solution) = solution.filter(|s| s.iter().all(|v| v.is_finite())) {
            for (i, &c) in seen.iter().enumerate() {
                x[k + c] = solution[i];
            }
        }
        Ok(())
    }
}

/// The local fits of the probes at sample `at` of `trace` (positions: value and rate;
/// velocities: value), or `None` where a probe has too few rows there.
fn local_fits(trace: &Trace, probes: &[Probe], at: usize) -> Option<Vec<LocalValue>> {
    probes
        .iter()
        .map(|p| {
            let (places, values) = trace.observed(p.signal)?;
            if !p.smoothed {
                if let Some(row) = through(&places, values, at as f64, trace.period) {
                    return Some(row);
                }
            }
            let least = FIT_MIN_ROWS * row_spacing(&places).max(1.0);
            let most = (FIT_HALF_WIDTH / trace.period).max(least);
            fit_adaptive(
                &places,
                values,
                at as f64,
                [least, most],
                p.sigma,
                trace.period,
            )
        })
        .collect()
}

/// The data's mean spacing between rows, in samples.
fn row_spacing(places: &[f64]) -> f64 {
    match places {
        [first, .., last] => (last - first) / (places.len() - 1) as f64,
        _ => 1.0,
    }
}

/// A measured signal's value at grid sample `k` (interpolated between the data's rows).
fn grid_value(trace: &Trace, probe: &Probe, k: usize) -> f64 {
    trace.measured[probe.signal]
        .as_ref()
        .map_or(f64::NAN, |v| v[k.min(v.len() - 1)])
}

impl Assembly {
    /// The assemblies that fit the first samples of `trace`: one where the logged positions fix
    /// every coordinate near the scenario's assembly, several where they leave it ambiguous
    /// (scanned over a turn of a one-coordinate linkage).
    pub fn candidates(
        &mut self,
        trace: &Trace,
        probes: &[Vec<Probe>; 2],
    ) -> Result<Vec<Placement>, String> {
        let positions = &probes[0];
        let fits = local_fits(trace, positions, 0).ok_or("too few rows at the run's start")?;
        let targets: Vec<f64> = fits.iter().map(|f| f.value).collect();
        let mut starts = vec![self.x0.clone()];
        if self.coordinates.len() == 1 && self.revolute[self.coordinates[0]] {
            starts = self.scan(positions, &targets);
        }
        let mut found: Vec<(f64, Placement)> = Vec::new();
        for start in starts {
            let anchor = self.anchor_along(&self.x0.clone(), &start)?;
            let mut x = start;
            let free = vec![(0.0, f64::INFINITY); self.coordinates.len()];
            let Ok(misfit) = self.solve_positions(&anchor, &mut x, positions, &targets, &free)
            else {
                continue;
            };
            let anchor = self.anchor_along(&self.x0.clone(), &x)?;
            if found.iter().any(|(_, p)| distance(&p.x, &x) < 1e-6) {
                continue;
            }
            found.push((misfit, Placement { x, anchor }));
        }
        let best = found.iter().map(|(m, _)| *m).fold(f64::INFINITY, f64::min);
        let mut kept: Vec<Placement> = (found.into_iter())
            .filter(|(m, _)| *m <= best + CANDIDATE_MISFIT)
            .map(|(_, p)| p)
            .collect();
        let velocities = local_fits(trace, &probes[1], 0).ok_or("too few rows")?;
        for placement in &mut kept {
            let (anchor, mut x) = (placement.anchor.clone(), placement.x.clone());
            (self.solve_velocities(&anchor, &mut x, probes, &fits, &velocities))
                .map_err(|e| e.to_string())?;
            placement.x = x;
        }
        match kept.is_empty() {
            true => Err("no assembly of the mechanism reads the logged positions".into()),
            false => Ok(kept),
        }
    }

    /// Starting points over a turn of the one coordinate, at the local minima of the misfit.
    fn scan(&mut self, positions: &[Probe], targets: &[f64]) -> Vec<Vec<f64>> {
        let x0 = self.x0.clone();
        let mut misfits = Vec::with_capacity(SCAN_POINTS);
        let mut anchor = self.anchor0.clone();
        let mut previous = x0.clone();
        for i in 0..SCAN_POINTS {
            let mut x = x0.clone();
            x[0] += std::f64::consts::TAU * i as f64 / SCAN_POINTS as f64;
            let misfit = self.anchor_along(&previous, &x).ok().and_then(|a| {
                anchor = a;
                previous.clone_from(&x);
                let readings = self.readings(&anchor, &x, positions).ok()?;
                let terms = readings.iter().zip(targets).zip(positions);
                Some(
                    terms
                        .map(|((y, t), p)| ((y - t) / p.sigma).powi(2))
                        .sum::<f64>(),
                )
            });
            misfits.push((x, misfit.unwrap_or(f64::INFINITY)));
        }
        let n = misfits.len();
        (0..n)
            .filter(|&i| {
                let m = misfits[i].1;
                m.is_finite() && m <= misfits[(i + n - 1) % n].1 && m <= misfits[(i + 1) % n].1
            })
            .map(|i| misfits[i].0.clone())
            .collect()
    }

    /// The joint positions at `to`, reached from the scenario's assembly by way of `from` in
    /// small steps (the loops' branch kept).
    fn anchor_along(&mut self, from: &[f64], to: &[f64]) -> Result<Vec<f64>, String> {
        self.reduced.anchor(&self.anchor0);
        self.reduced
            .recenter_along(&self.x0, from)
            .and_then(|()| self.reduced.recenter_along(from, to))
            .map_err(|e| e.to_string())?;
        let x = to.to_vec();
        self.reduced
            .read_state(&x, &mut self.state)
            .map_err(|e| e.to_string())?;
        Ok(self.state.joint_positions.clone())
    }
}

fn distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).fold(0.0, |m, (x, y)| m.max((x - y).abs()))
}

impl Assembly {
    /// The placements at the `begins` (sorted samples) of `trace`, tracked from `first` (a
    /// placement at sample 0): positions and rates from local fits of the logged signals, the
    /// loops closed on the branch followed sample by sample (a mechanism without loops is placed
    /// at each begin directly).
    pub fn track(
        &mut self,
        trace: &Trace,
        probes: &[Vec<Probe>; 2],
        first: &Placement,
        begins: &[usize],
    ) -> Result<Vec<Placement>, String> {
        let (mut anchor, mut x) = (first.anchor.clone(), first.x.clone());
        let mut placements = Vec::with_capacity(begins.len());
        let mut sample = 0;
        for &begin in begins {
            if self.loops {
                while sample < begin {
                    sample += 1;
                    self.follow(trace, &probes[0], sample, &mut anchor, &mut x)?;
                }
            }
            let placement = self.place_at(trace, probes, begin, &anchor, &x)?;
            (anchor, x) = (placement.anchor.clone(), placement.x.clone());
            placements.push(placement);
        }
        Ok(placements)
    }

    /// One sample on along the run: the positions predicted from the velocities, corrected to
    /// the logged ones (the prediction holds where they say little, at a dead point).
    fn follow(
        &mut self,
        trace: &Trace,
        positions: &[Probe],
        sample: usize,
        anchor: &mut Vec<f64>,
        x: &mut [f64],
    ) -> Result<(), String> {
        let k = self.coordinates.len();
        let before = x[..k].to_vec();
        for c in 0..k {
            x[c] += x[k + c] * trace.period;
        }
        let prior: Vec<(f64, f64)> = (0..k)
            .map(|c| (x[c], (x[k + c] * trace.period).abs().max(1e-6)))
            .collect();
        let targets: Vec<f64> = positions
            .iter()
            .map(|p| grid_value(trace, p, sample))
            .collect();
        let error = |e: ReducedError| format!("t = {} s: {e}", sample as f64 * trace.period);
        (self.solve_positions(anchor, x, positions, &targets, &prior)).map_err(error)?;
        for c in 0..k {
            // The velocity follows the tracked positions, smoothed.
            let rate = (x[c] - before[c]) / trace.period;
            x[k + c] = 0.8 * x[k + c] + 0.2 * rate;
        }
        let state = self.place(anchor, x).map_err(error)?;
        anchor.clone_from(&state.joint_positions);
        Ok(())
    }

    /// The placement at sample `at`, near `(anchor, x)`: positions and rates from local fits.
    fn place_at(
        &mut self,
        trace: &Trace,
        probes: &[Vec<Probe>; 2],
        at: usize,
        anchor: &[f64],
        x: &[f64],
    ) -> Result<Placement, String> {
        let error = |e: String| format!("t = {} s: {e}", at as f64 * trace.period);
        let fits = local_fits(trace, &probes[0], at).ok_or(error("too few rows".into()))?;
        let velocities = local_fits(trace, &probes[1], at).ok_or(error("too few rows".into()))?;
        let targets: Vec<f64> = fits.iter().map(|f| f.value).collect();
        let mut x = x.to_vec();
        let k = self.coordinates.len();
        let prior: Vec<(f64, f64)> = (0..k).map(|c| (x[c], 1.0)).collect();
        (self.solve_positions(anchor, &mut x, &probes[0], &targets, &prior))
            .map_err(|e| error(e.to_string()))?;
        (self.solve_velocities(anchor, &mut x, probes, &fits, &velocities))
            .map_err(|e| error(e.to_string()))?;
        let state = self.place(anchor, &x).map_err(|e| error(e.to_string()))?;
        Ok(Placement {
            anchor: state.joint_positions.clone(),
            x,
        })
    }
}
