//! `calibrate`: the parameters and their starts made from the options, the check, the solve
//! (from one or several starts), then the estimates with their standard errors, 95 % intervals
//! and correlations, the fit before and after on every run and on the validation runs, and the
//! calibrated scenario.

use super::check;
use super::compare::{fit_states, rate_json, replay, Overlay, RunReplay, SegmentFit};
use super::error::CalibrationError;
use super::metrics::{t_quantile_95, SignalFit};
use super::options::{CalibrationOptions, FitParameter};
use super::problem::{self, Problem, Scope, Unknown};
use super::solve::{solve, Iteration, Linearised, Solution};
use super::verdict::{judge, sandwich, Verdict};
use crate::data::{DataRate, RunData, Trace};
use crate::mechanism::Mechanism;
use crate::plant::PlantValues;
use crate::scenario::ScenarioBuilder;
use crate::sensors::Noise;
use framework::Registry;
use nalgebra::{DMatrix, DVector};
use serde::Serialize;
use serde_json::{json, Value};

/// One fitted value.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Estimate {
    /// The scenario key.
    pub key: String,
    /// The run it belongs to, for a per-run parameter.
    pub run: Option<String>,
    /// Where the fit started.
    pub start: f64,
    /// The fitted value.
    pub estimate: f64,
    /// Its standard error, σ̂·√((JᵀWJ)⁻¹)ᵢᵢ.
    pub standard_error: f64,
    /// Its 95 % interval: the estimate ± Student's t quantile × the standard error.
    pub interval: [f64; 2],
    /// Its bounds.
    pub bounds: [f64; 2],
    /// Whether it ended at a bound (its interval then means little).
    pub at_bound: bool,
    /// Whether its interval was widened because the model does not fit the data (it is then
    /// not to be trusted: the estimate may be biased).
    pub widened: bool,
}

/// One run's fit, before and after the calibration.
#[derive(Debug, Clone)]
pub struct RunFit {
    /// The data file.
    pub source: String,
    /// Its SHA-256.
    pub digest: String,
    /// Its own sampling.
    pub rate: DataRate,
    /// Per fitted signal with the start values.
    pub before: Vec<SignalFit>,
    /// Per fitted signal with the fitted values.
    pub after: Vec<SignalFit>,
    /// Per fitted signal: name, SI unit, measured, twin before, twin after.
    pub overlays: Vec<(String, String, [Vec<f64>; 3])>,
    /// Per segment, per fitted signal, with the fitted values.
    pub segments: Vec<SegmentFit>,
    /// Sample k is at `start_time + k·period`, s.
    pub start_time: f64,
    /// Control period, s.
    pub period: f64,
}

/// What a calibration found.
#[derive(Debug, Clone)]
pub struct Calibration {
    /// Whether the fitted model explains the data (apart from whether the solve converged).
    pub verdict: Verdict,
    /// What the layout decided that the user should hear (a run replayed whole, and why).
    pub notes: Vec<String>,
    /// Segment length, s; 0: whole runs.
    pub segment: f64,
    /// The mechanism's independent coordinates whose start states are fitted.
    pub coordinates: Vec<String>,
    /// The parameters (shared, then per run), without the segments' start states.
    pub estimates: Vec<Estimate>,
    /// The estimates' correlation matrix, in their order.
    pub correlation: Vec<Vec<f64>>,
    /// The fitted runs.
    pub runs: Vec<RunFit>,
    /// The validation runs, replayed with the fitted values (per-run ones at their mean).
    pub validation: Vec<RunFit>,
    /// The accepted steps of every start.
    pub iterations: Vec<Iteration>,
    /// Which start won.
    pub best_start: usize,
    /// Whether the winning solve met its tolerance.
    pub converged: bool,
    /// What the check and the solve warn of.
    pub warnings: Vec<String>,
    /// Per fitted signal, the noise σ its residuals were weighted by, SI.
    pub noise: Vec<(String, f64)>,
    /// σ̂² = Σ(weighted residual)² / (N − p): 1 when the noise was estimated right.
    pub residual_variance: f64,
    /// N − p.
    pub degrees_of_freedom: usize,
    /// Segments simulated, and start states fitted with them.
    pub segments: usize,
    /// Start states fitted (two per joint and segment).
    pub start_states: usize,
    /// Rollouts made.
    pub rollouts: usize,
    /// The scenario with the shared values fitted, commented with their intervals and the data.
    pub calibrated_toml: String,
}

/// Fits `options.parameters` of the scenario of `builder` to the runs in `data`, checked first,
/// then replays the `validate` runs. Each accepted step goes to `progress`.
pub fn calibrate(
    builder: &ScenarioBuilder,
    registry: &Registry,
    data: &[RunData],
    validate: &[RunData],
    options: &CalibrationOptions,
    progress: &mut dyn FnMut(&Iteration),
) -> Result<Calibration, CalibrationError> {
    if data.is_empty() || options.parameters.is_empty() {
        return Err(CalibrationError::Options(
            "give at least one run (--data) and one parameter (--fit)".into(),
        ));
    }
    let mechanism = plant_mechanism(builder, registry)?;
    let builder = &with_whole_arrays(builder, &mechanism, &options.parameters)?;
    let replayer = problem::replayer(builder, registry, options.closed_loop)?;
    let parameters = unknowns(builder, &mechanism, data, &options.parameters)?;
    check::bounds(&parameters)?;
    let min_samples = parameters.len() + 2;
    let traces = (data.iter())
        .map(|run| problem::bind(&replayer, run, min_samples))
        .collect::<Result<Vec<Trace>, _>>()?;
    let mut problem = Problem::new(replayer, traces, options, parameters)?;
    for run in validate {
        // A validation run that does not fit the plant is refused before the fit, not after.
        problem::bind(&problem.replayer, run, 2)?;
    }
    let (first, mut warnings) = checked(&mut problem)?;
    let start = problem.start();
    let (best_start, solution, iterations) = solve_all(&problem, options, Some(first), progress)?;
    if !solution.converged {
        warnings.push(format!(
            "the solve stopped after {} iterations without meeting its tolerance; raise --max-iterations or check the starts",
            options.max_iterations
        ));
    }
    let runs = run_fits(&mut problem, &start, &solution.theta)?;
    let mut statistics = Statistics::of(&problem, &solution);
    let verdict = judge(
        &problem,
        &solution.residuals,
        statistics.variance,
        &worst(&runs),
    );
    if !verdict.fits {
        statistics.widen(&problem, &solution);
    }
    let estimates = estimates(&problem, &solution.theta, &statistics);
    warnings.extend(bound_warnings(&estimates));
    warnings.extend(precision_warnings(&estimates));
    let validation = validation_fits(builder, registry, validate, options, &estimates)?;
    let calibrated_toml = calibrated(builder, registry, data, &estimates)?;
    Ok(Calibration {
        verdict,
        notes: problem.notes.clone(),
        segment: problem.length,
        coordinates: fitted_coordinates(&problem),
        correlation: statistics.correlation(&problem),
        estimates,
        runs,
        validation,
        iterations,
        best_start,
        converged: solution.converged,
        warnings,
        noise: (problem.outputs.iter().zip(&problem.sigma))
            .map(|(&i, &s)| (problem.replayer.shape.columns.signals[i].0.clone(), s))
            .collect(),
        residual_variance: statistics.variance,
        degrees_of_freedom: statistics.dof,
        segments: problem.segments.len(),
        start_states: (problem.unknowns.iter())
            .filter(|u| matches!(u.scope, Scope::Segment(_)))
            .count(),
        rollouts: problem.rollouts(),
        calibrated_toml,
    })
}

/// The check before the solve: enough data, start states without effect dropped, the
/// parameters' identifiability (refused or warned); the residuals and Jacobian at the start.
fn checked(problem: &mut Problem) -> Result<(Linearised, Vec<String>), CalibrationError> {
    let rows: usize = (0..problem.segments.len()).map(|s| problem.rows(s)).sum();
    check::samples(rows, problem.unknowns.len())?;
    let start = problem.start();
    let residuals = problem.residuals(&start)?;
    finite_cost(problem, &residuals)?;
    let mut jacobian = problem.jacobian(&start, &residuals)?;
    let idle = check::idle_states(&problem.unknowns, &jacobian);
    for &j in idle.iter().rev() {
        problem.unknowns.remove(j);
    }
    jacobian = jacobian.remove_columns_at(&idle);
    let warnings = check::identifiable(&problem.unknowns, &jacobian)?;
    Ok(((residuals, jacobian), warnings))
}

/// The independent coordinates whose start states are fitted, in order.
fn fitted_coordinates(problem: &Problem) -> Vec<String> {
    let mut names: Vec<String> = Vec::new();
    for unknown in problem.unknowns.iter().filter(|u| u.coordinate.is_some()) {
        let name = unknown
            .key
            .split('.')
            .nth(1)
            .unwrap_or_default()
            .to_string();
        if !names.contains(&name) {
            names.push(name);
        }
    }
    names
}

/// Refuses a start whose weighted residuals are not finite (a noise σ so small that they
/// overflow), naming the signal and its σ.
fn finite_cost(problem: &Problem, residuals: &[Vec<f64>]) -> Result<(), CalibrationError> {
    let outputs = problem.outputs.len().max(1);
    for segment in residuals {
        let n = segment.len() / outputs;
        let cost: f64 = segment.iter().map(|r| r * r).sum();
        if cost.is_finite() {
            continue;
        }
        let o = (0..outputs)
            .find(|&o| {
                segment[o * n..(o + 1) * n]
                    .iter()
                    .any(|r| !(r * r).is_finite())
            })
            .unwrap_or(0);
        let name = &problem.replayer.shape.columns.signals[problem.outputs[o]].0;
        return Err(CalibrationError::Check(format!(
            "the cost is not finite at the start: {name}'s residuals divided by its noise σ = {:e} overflow; give the σ of the noise it carries (--noise {name}=SIGMA)",
            problem.sigma[o]
        )));
    }
    Ok(())
}

/// Per fitted signal, its figures on the run where it fits worst.
fn worst(runs: &[RunFit]) -> Vec<SignalFit> {
    let mut worst: Vec<SignalFit> = Vec::new();
    for run in runs {
        for (o, fit) in run.after.iter().enumerate() {
            match worst.get_mut(o) {
                None => worst.push(fit.clone()),
                Some(w) if fit.fit_percent < w.fit_percent => *w = fit.clone(),
                Some(_) => {}
            }
        }
    }
    worst
}

/// The parameters as unknowns: their starts (given, the scenario's, the URDF's or a sensor's
/// default), bounds and scales; one per run for a per-run parameter.
fn unknowns(
    builder: &ScenarioBuilder,
    mechanism: &Mechanism,
    data: &[RunData],
    parameters: &[FitParameter],
) -> Result<Vec<Unknown>, CalibrationError> {
    let mut unknowns = Vec::new();
    for (index, parameter) in parameters.iter().enumerate() {
        let key = &parameter.key;
        if parameters[..index].iter().any(|p| &p.key == key) {
            let reason = format!("--fit {key}: given twice");
            return Err(CalibrationError::Options(reason));
        }
        let start = match parameter.start {
            Some(start) => start,
            None => current_value(builder, mechanism, key).ok_or_else(|| {
                CalibrationError::Options(format!(
                    "--fit {key}: the scenario holds no number at this key; give a start (--fit {key}=VALUE)"
                ))
            })?,
        };
        let bounds = parameter
            .bounds
            .unwrap_or_else(|| default_bounds(key, start));
        let scale = if start != 0.0 {
            start.abs()
        } else if bounds.iter().all(|b| b.is_finite()) {
            (bounds[1] - bounds[0]) / 10.0
        } else {
            1.0
        };
        let unknown = |label: String, scope| Unknown {
            key: key.clone(),
            label,
            scope,
            start,
            bounds,
            scale,
            coordinate: None,
        };
        if parameter.per_run {
            for (run, file) in data.iter().enumerate() {
                unknowns.push(unknown(
                    format!("{key} of {}", file.source),
                    Scope::Run(run),
                ));
            }
        } else {
            unknowns.push(unknown(key.clone(), Scope::Shared));
        }
    }
    Ok(unknowns)
}

/// The scenario's mechanism: its URDF with the scenario's `[plant]` values written over it.
fn plant_mechanism(
    builder: &ScenarioBuilder,
    registry: &Registry,
) -> Result<Mechanism, CalibrationError> {
    let loaded = builder.clone().build(registry)?;
    let mut mechanism = crate::urdf::load_str(&loaded.urdf_text, &loaded.urdf_source)
        .map_err(|e| CalibrationError::Twin(e.into()))?;
    (loaded.scenario.plant.apply(&mut mechanism)).map_err(CalibrationError::Options)?;
    Ok(mechanism)
}

/// The scenario with a link's whole centre of mass written (the URDF's) wherever a parameter
/// is one of its two numbers (`urdf.link.<link>.com.0`) and the scenario gives none, so that
/// the number can be set alone.
fn with_whole_arrays(
    builder: &ScenarioBuilder,
    mechanism: &Mechanism,
    parameters: &[FitParameter],
) -> Result<ScenarioBuilder, CalibrationError> {
    let mut builder = builder.clone();
    for parameter in parameters {
        let parts: Vec<&str> = parameter.key.split('.').collect();
        let ["urdf" | "plant", "link", link, "com", _] = parts.as_slice() else {
            continue;
        };
        let whole = format!("urdf.link.{link}.com");
        if builder.number(&format!("{whole}.0")).is_some() {
            continue;
        }
        let com =
            [0, 1].map(|i| PlantValues::current(mechanism, &["link", link, "com", &i.to_string()]));
        if let [Some(x), Some(y)] = com {
            builder = builder.set(&whole, [x, y])?;
        }
    }
    Ok(builder)
}

/// The value a key has now: in the scenario's TOML, else the URDF's (`urdf.…`), else a sensor's
/// or a start state's default.
fn current_value(builder: &ScenarioBuilder, mechanism: &Mechanism, key: &str) -> Option<f64> {
    if let Some(value) = builder.number(key) {
        return Some(value);
    }
    let parts: Vec<&str> = key.split('.').collect();
    match parts.as_slice() {
        ["urdf" | "plant", rest @ ..] => PlantValues::current(mechanism, rest),
        ["sensors", .., "gain"] => Some(1.0),
        ["sensors", .., "bias" | "delay"] => Some(0.0),
        ["initial", _, "position" | "velocity"] => Some(0.0),
        _ => None,
    }
}

/// Physical magnitudes are ≥ 0 (a mass or an inertia > 0: a millionth of its start); anything
/// else is unbounded.
fn default_bounds(key: &str, start: f64) -> [f64; 2] {
    let last = key.rsplit('.').next().unwrap_or_default();
    match last {
        "mass" | "izz" => [start.abs() * 1e-6, f64::INFINITY],
        "damping" | "friction" | "stiffness" | "delay" => [0.0, f64::INFINITY],
        _ => [f64::NEG_INFINITY, f64::INFINITY],
    }
}

/// Solves from the given start, then from `options.starts − 1` draws within the bounds (each
/// parameter within its bounds where both are finite, else within a factor of two of its
/// start; a seeded draw, so a calibration repeats). The lowest cost wins.
fn solve_all(
    problem: &Problem,
    options: &CalibrationOptions,
    mut first: Option<Linearised>,
    progress: &mut dyn FnMut(&Iteration),
) -> Result<(usize, Solution, Vec<Iteration>), CalibrationError> {
    let mut iterations = Vec::new();
    let mut best: Option<(usize, Solution)> = None;
    let mut draws = Noise::new(0x5EED);
    for start in 0..options.starts.max(1) {
        let mut theta = problem.start();
        if start > 0 {
            for (value, unknown) in theta.iter_mut().zip(&problem.unknowns) {
                if matches!(unknown.scope, Scope::Segment(_)) {
                    continue;
                }
                let [lo, hi] = unknown.bounds;
                let u = draws.uniform();
                *value = if lo.is_finite() && hi.is_finite() {
                    lo + u * (hi - lo)
                } else {
                    (*value * 2f64.powf(2.0 * u - 1.0)).clamp(lo, hi)
                };
            }
        }
        let known = first.take();
        let solution = solve(
            problem,
            theta,
            start,
            options.max_iterations,
            known,
            progress,
        );
        let solution = match solution {
            Ok(solution) => solution,
            // A drawn start the twin cannot run from is skipped; the given one must run.
            Err(_) if start > 0 => continue,
            Err(error) => return Err(error),
        };
        iterations.extend(solution.iterations.iter().cloned());
        if best.as_ref().is_none_or(|(_, b)| solution.cost < b.cost) {
            best = Some((start, solution));
        }
    }
    let (index, solution) = best.ok_or_else(|| CalibrationError::Check("no start ran".into()))?;
    Ok((index, solution, iterations))
}

/// The noise variance and the covariance of the unknowns at the solution.
struct Statistics {
    variance: f64,
    dof: usize,
    covariance: DMatrix<f64>,
    /// Whether the covariance was widened (the model does not fit).
    widened: bool,
}

impl Statistics {
    /// σ̂² = 2·cost/(N − p) and σ̂²(JᵀWJ)⁻¹, computed in the unknowns' scaled coordinates; a
    /// direction the data do not determine has an infinite variance.
    fn of(problem: &Problem, solution: &Solution) -> Self {
        let jacobian = &solution.jacobian;
        let (rows, p) = jacobian.shape();
        let dof = rows.saturating_sub(p).max(1);
        let variance = 2.0 * solution.cost / dof as f64;
        let scale = DVector::from_iterator(p, problem.unknowns.iter().map(|u| u.scale));
        let scaled = jacobian * DMatrix::from_diagonal(&scale);
        let normal = scaled.transpose() * scaled;
        let inverse = normal
            .clone()
            .cholesky()
            .map(|c| c.inverse())
            .unwrap_or_else(|| {
                let tolerance = 1e-14 * normal.diagonal().max();
                normal
                    .pseudo_inverse(tolerance)
                    .unwrap_or_else(|_| DMatrix::from_element(p, p, f64::INFINITY))
            });
        let covariance = DMatrix::from_fn(p, p, |i, k| {
            variance * inverse[(i, k)] * scale[i] * scale[k]
        });
        Self {
            variance,
            dof,
            covariance,
            widened: false,
        }
    }

    /// Widens the covariance to the Newey–West sandwich where that is larger (per unknown), for
    /// residuals that are not the noise alone.
    fn widen(&mut self, problem: &Problem, solution: &Solution) {
        self.widened = true;
        let Some(sandwich) = sandwich(problem, &solution.residuals, &solution.jacobian) else {
            return;
        };
        let p = self.covariance.nrows();
        let factor: Vec<f64> = (0..p)
            .map(|i| {
                let ratio = sandwich[(i, i)] / self.covariance[(i, i)];
                match ratio.is_finite() {
                    true => ratio.max(1.0).sqrt(),
                    false => 1.0,
                }
            })
            .collect();
        self.covariance =
            DMatrix::from_fn(p, p, |i, k| self.covariance[(i, k)] * factor[i] * factor[k]);
    }

    /// The correlations among the parameters (not the start states).
    fn correlation(&self, problem: &Problem) -> Vec<Vec<f64>> {
        let chosen = parameter_indices(problem);
        let c = &self.covariance;
        (chosen.iter())
            .map(|&i| {
                (chosen.iter())
                    .map(|&k| c[(i, k)] / (c[(i, i)] * c[(k, k)]).sqrt())
                    .collect()
            })
            .collect()
    }
}

fn parameter_indices(problem: &Problem) -> Vec<usize> {
    (0..problem.unknowns.len())
        .filter(|&j| !matches!(problem.unknowns[j].scope, Scope::Segment(_)))
        .collect()
}

fn estimates(problem: &Problem, theta: &[f64], statistics: &Statistics) -> Vec<Estimate> {
    let t = t_quantile_95(statistics.dof);
    parameter_indices(problem)
        .into_iter()
        .map(|j| {
            let u = &problem.unknowns[j];
            let standard_error = statistics.covariance[(j, j)].max(0.0).sqrt();
            let near = |bound: f64| (theta[j] - bound).abs() <= 1e-9 * u.scale;
            Estimate {
                key: u.key.clone(),
                run: match u.scope {
                    Scope::Run(run) => Some(problem.traces[run].source.clone()),
                    _ => None,
                },
                start: u.start,
                estimate: theta[j],
                standard_error,
                interval: [theta[j] - t * standard_error, theta[j] + t * standard_error],
                bounds: u.bounds,
                at_bound: near(u.bounds[0]) || near(u.bounds[1]),
                widened: statistics.widened,
            }
        })
        .collect()
}

fn bound_warnings(estimates: &[Estimate]) -> Vec<String> {
    (estimates.iter().filter(|e| e.at_bound))
        .map(|e| {
            format!(
                "{} ended at its bound {} (bounds [{}, {}]): the solve cannot tell whether the data want it there or beyond; its interval is not meaningful (widen the bounds with --bounds to tell)",
                e.key, e.estimate, e.bounds[0], e.bounds[1]
            )
        })
        .collect()
}

/// Estimates whose 95 % interval holds zero: the data cannot even tell them from nothing, the
/// runs being too short or exciting them too little.
fn precision_warnings(estimates: &[Estimate]) -> Vec<String> {
    (estimates.iter())
        .filter(|e| !e.at_bound && e.interval[0] <= 0.0 && e.interval[1] >= 0.0)
        .map(|e| {
            format!(
                "{} is poorly determined: its 95 % interval [{}, {}] holds 0; the runs are too short or excite it too little",
                e.key, e.interval[0], e.interval[1]
            )
        })
        .collect()
}

/// Every run replayed at the start values (the start states fitted to them alone, as
/// `compare` does) and at the solution, segment by segment.
fn run_fits(
    problem: &mut Problem,
    start: &[f64],
    solution: &[f64],
) -> Result<Vec<RunFit>, CalibrationError> {
    let parameters: Vec<f64> = (problem.unknowns.iter().zip(start))
        .filter(|(u, _)| !matches!(u.scope, Scope::Segment(_)))
        .map(|(_, v)| *v)
        .collect();
    let before_theta = fit_states(problem, &parameters)?;
    let before = replay(problem, &before_theta)?;
    let after = replay(problem, solution)?;
    Ok((problem.traces.iter().zip(before.into_iter().zip(after)))
        .map(|(trace, (before, after))| run_fit(trace, before, after))
        .collect())
}

fn run_fit(trace: &Trace, before: RunReplay, after: RunReplay) -> RunFit {
    let overlays = (before.overlays.into_iter().zip(after.overlays))
        .map(|(b, a): (Overlay, Overlay)| {
            (a.signal, a.unit, [a.measured, b.simulated, a.simulated])
        })
        .collect();
    RunFit {
        source: trace.source.clone(),
        digest: trace.digest.clone(),
        rate: trace.rate.clone(),
        before: before.signals,
        after: after.signals,
        overlays,
        segments: after.segments,
        start_time: trace.start_time,
        period: trace.period,
    }
}

/// The validation runs replayed as `compare` replays them (in segments from the start states
/// their data give, fitted alone), with the start values and with the fitted ones; a per-run
/// parameter at the mean of its fitted values.
fn validation_fits(
    builder: &ScenarioBuilder,
    registry: &Registry,
    validate: &[RunData],
    options: &CalibrationOptions,
    estimates: &[Estimate],
) -> Result<Vec<RunFit>, CalibrationError> {
    let fitted = fitted_values(estimates);
    let mut fits = Vec::new();
    for run in validate {
        let replayer = problem::replayer(builder, registry, options.closed_loop)?;
        let trace = problem::bind(&replayer, run, 2)?;
        let parameters = (fitted.iter())
            .map(|(key, start, _)| Unknown {
                key: key.clone(),
                label: key.clone(),
                scope: Scope::Shared,
                start: *start,
                bounds: [f64::NEG_INFINITY, f64::INFINITY],
                scale: start.abs().max(1e-12),
                coordinate: None,
            })
            .collect();
        let mut problem = Problem::new(replayer, vec![trace], options, parameters)?;
        let starts: Vec<f64> = fitted.iter().map(|(_, start, _)| *start).collect();
        let after: Vec<f64> = fitted.iter().map(|(_, _, value)| *value).collect();
        let theta = fit_states(&mut problem, &starts)?;
        let before = replay(&problem, &theta)?.remove(0);
        let theta = fit_states(&mut problem, &after)?;
        let after = replay(&problem, &theta)?.remove(0);
        fits.push(run_fit(&problem.traces[0], before, after));
    }
    Ok(fits)
}

/// Each parameter's start and fitted value: a shared one's, a per-run one's mean.
fn fitted_values(estimates: &[Estimate]) -> Vec<(String, f64, f64)> {
    let mut values: Vec<(String, f64, f64, usize)> = Vec::new();
    for e in estimates {
        match values.iter_mut().find(|(key, ..)| key == &e.key) {
            Some((_, _, sum, count)) => (*sum, *count) = (*sum + e.estimate, *count + 1),
            None => values.push((e.key.clone(), e.start, e.estimate, 1)),
        }
    }
    (values.into_iter())
        .map(|(key, start, sum, count)| (key, start, sum / count as f64))
        .collect()
}

/// The scenario with the shared estimates set, headed by comments giving their intervals, the
/// per-run values and the data files' digests; without its `[calibration]` table (the runs it
/// names are relative to the scenario's own file).
fn calibrated(
    builder: &ScenarioBuilder,
    registry: &Registry,
    data: &[RunData],
    estimates: &[Estimate],
) -> Result<String, CalibrationError> {
    let mut changed = builder.clone().without("calibration");
    let nominal = builder.clone().build(registry)?;
    if !nominal.urdf_source.starts_with("built-in ") {
        // The calibrated file is read from elsewhere than the scenario: its URDF by full path.
        if let Ok(path) = std::fs::canonicalize(&nominal.urdf_source) {
            changed = changed.set("urdf", path.display().to_string())?;
        }
    }
    let mut header = vec!["# Calibrated by `twin calibrate` from:".to_string()];
    header.extend(
        data.iter()
            .map(|d| format!("#   {} (sha256 {})", d.source, d.digest)),
    );
    header.push("# Fitted values, 95 % intervals:".into());
    for e in estimates {
        let [lo, hi] = e.interval;
        match &e.run {
            None => {
                changed = changed.set(&e.key, e.estimate)?;
                header.push(format!(
                    "#   {} = {} (± {:.3e}: [{lo}, {hi}])",
                    e.key, e.estimate, e.standard_error
                ));
            }
            Some(run) => header.push(format!(
                "#   {} = {} for {run} only (± {:.3e}: [{lo}, {hi}]); not set below",
                e.key, e.estimate, e.standard_error
            )),
        }
    }
    let loaded = changed.build(registry)?;
    Ok(format!("{}\n\n{}", header.join("\n"), loaded.toml))
}

impl Calibration {
    /// The report as JSON (`calibration.json`).
    pub fn to_json(&self) -> Value {
        let fits = |runs: &[RunFit]| -> Vec<Value> {
            (runs.iter())
                .map(|r| {
                    json!({
                        "data": r.source, "sha256": r.digest, "data_rate": rate_json(&r.rate),
                        "before": r.before, "after": r.after, "segments": r.segments,
                    })
                })
                .collect()
        };
        json!({
            "verdict": self.verdict.word(),
            "fits": self.verdict.fits,
            "verdict_detail": self.verdict,
            "notes": self.notes,
            "segment_s": self.segment,
            "coordinates": self.coordinates,
            "parameters": self.estimates,
            "correlation": self.correlation,
            "runs": fits(&self.runs),
            "validation": fits(&self.validation),
            "iterations": self.iterations,
            "best_start": self.best_start,
            "converged": self.converged,
            "warnings": self.warnings,
            "noise": self.noise.iter().map(|(s, v)| json!({"signal": s, "sigma": v})).collect::<Vec<_>>(),
            "residual_variance": self.residual_variance,
            "degrees_of_freedom": self.degrees_of_freedom,
            "segments": self.segments,
            "start_states": self.start_states,
            "rollouts": self.rollouts,
        })
    }
}
