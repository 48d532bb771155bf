//! Bounded Levenberg–Marquardt on the weighted residuals: steps in the unknowns' scaled
//! coordinates, Marquardt's diagonal damping, each trial point clipped into the bounds and kept
//! only when it lowers the cost.

use super::error::CalibrationError;
use super::problem::Problem;
use nalgebra::{DMatrix, DVector};
use serde::Serialize;

/// Converged when an accepted step lowers the cost by less than this share of it…
const COST_TOLERANCE: f64 = 1e-10;
/// …or by less than this much in all (the cost is half the squared residuals in noise σ: a
/// millionth of it moves the estimates by about a thousandth of their standard errors)…
const COST_NEGLIGIBLE: f64 = 1e-6;
/// …or moves no unknown by more than this share of its scale (a hundredth of the 1e-6 the
/// noise-free tests ask of the estimates).
const STEP_TOLERANCE: f64 = 1e-8;
/// Damping beyond which no step can lower the cost: the solve stops where it is.
const MAX_DAMPING: f64 = 1e12;

/// One accepted step of the solve, as the progress line and the report show it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Iteration {
    /// Which start (0: the given one).
    pub start: usize,
    /// Iteration within the start, from 0 (the start itself).
    pub iteration: usize,
    /// Half the sum of the squared weighted residuals.
    pub cost: f64,
    /// The step's largest move, relative to each unknown's scale.
    pub step: f64,
    /// Marquardt's damping when the step was taken.
    pub damping: f64,
}

/// Where a solve ended.
pub struct Solution {
    /// The unknowns.
    pub theta: Vec<f64>,
    /// The cost there.
    pub cost: f64,
    /// The Jacobian there.
    pub jacobian: DMatrix<f64>,
    /// The weighted residuals there, per segment.
    pub residuals: Vec<Vec<f64>>,
    /// The accepted steps.
    pub iterations: Vec<Iteration>,
    /// Whether a tolerance was met (not the iteration limit or the damping limit).
    pub converged: bool,
}

fn cost(residuals: &[Vec<f64>]) -> f64 {
    0.5 * residuals.iter().flatten().map(|r| r * r).sum::<f64>()
}

/// The cost at `theta`, or infinity where the twin diverges or refuses the values (a trial
/// point is then rejected, not the solve).
fn trial(problem: &Problem, theta: &[f64]) -> Option<(Vec<Vec<f64>>, f64)> {
    let residuals = problem.residuals(theta).ok()?;
    let c = cost(&residuals);
    c.is_finite().then_some((residuals, c))
}

/// The residuals and Jacobian at a solve's start, when the caller has them already.
pub type Linearised = (Vec<Vec<f64>>, DMatrix<f64>);

/// Solves from `theta` (whose residuals and Jacobian `first` may already hold), reporting each
/// accepted step to `progress`.
pub fn solve(
    problem: &Problem,
    mut theta: Vec<f64>,
    start: usize,
    max_iterations: usize,
    first: Option<Linearised>,
    progress: &mut dyn FnMut(&Iteration),
) -> Result<Solution, CalibrationError> {
    let scale: Vec<f64> = problem.unknowns.iter().map(|u| u.scale).collect();
    let (mut residuals, mut known) = match first {
        Some((residuals, jacobian)) => (residuals, Some(jacobian)),
        None => (problem.residuals(&theta)?, None),
    };
    let mut current = cost(&residuals);
    let mut damping = 1e-3;
    let mut iterations = vec![Iteration {
        start,
        iteration: 0,
        cost: current,
        step: 0.0,
        damping,
    }];
    progress(&iterations[0]);
    let mut converged = false;
    for iteration in 1..=max_iterations {
        let jacobian = match known.take() {
            Some(jacobian) => jacobian,
            None => problem.jacobian(&theta, &residuals)?,
        };
        let scaled = &jacobian * DMatrix::from_diagonal(&DVector::from_column_slice(&scale));
        let normal = scaled.transpose() * &scaled;
        let r = DVector::from_iterator(
            residuals.iter().map(Vec::len).sum(),
            residuals.iter().flatten().copied(),
        );
        let gradient = scaled.transpose() * r;
        let Some((next, step)) =
            step_down(problem, &theta, &normal, &gradient, &mut damping, current)
        else {
            converged = true;
            return finish(theta, (current, residuals), jacobian, iterations, converged);
        };
        let (new_theta, new_residuals, new_cost) = next;
        let decrease = current - new_cost;
        (theta, residuals, current) = (new_theta, new_residuals, new_cost);
        let record = Iteration {
            start,
            iteration,
            cost: current,
            step,
            damping,
        };
        progress(&record);
        iterations.push(record);
        let negligible = decrease <= COST_NEGLIGIBLE.max(COST_TOLERANCE * current);
        if negligible || step <= STEP_TOLERANCE {
            converged = true;
            break;
        }
    }
    let jacobian = problem.jacobian(&theta, &residuals)?;
    finish(theta, (current, residuals), jacobian, iterations, converged)
}

fn finish(
    theta: Vec<f64>,
    (cost, residuals): (f64, Vec<Vec<f64>>),
    jacobian: DMatrix<f64>,
    iterations: Vec<Iteration>,
    converged: bool,
) -> Result<Solution, CalibrationError> {
    Ok(Solution {
        theta,
        cost,
        jacobian,
        residuals,
        iterations,
        converged,
    })
}

type Accepted = (Vec<f64>, Vec<Vec<f64>>, f64);

/// Damped steps from `theta` until one lowers the cost (damping relaxed after it) or the
/// damping passes its limit (`None`: no step lowers the cost, the solve is done). Also the
/// accepted step's largest scaled move.
fn step_down(
    problem: &Problem,
    theta: &[f64],
    normal: &DMatrix<f64>,
    gradient: &DVector<f64>,
    damping: &mut f64,
    current: f64,
) -> Option<(Accepted, f64)> {
    let unknowns = &problem.unknowns;
    let largest = normal.diagonal().max().max(f64::MIN_POSITIVE);
    while *damping <= MAX_DAMPING {
        let mut damped = normal.clone();
        for i in 0..damped.nrows() {
            damped[(i, i)] += *damping * normal[(i, i)].max(1e-12 * largest);
        }
        let delta = damped.cholesky().map(|c| c.solve(&(-gradient)));
        let Some(delta) = delta else {
            *damping *= 10.0;
            continue;
        };
        let moved: Vec<f64> = (theta.iter().zip(unknowns).zip(delta.iter()))
            .map(|((t, u), d)| (t + d * u.scale).clamp(u.bounds[0], u.bounds[1]))
            .collect();
        let step = (moved.iter().zip(theta).zip(unknowns))
            .map(|((m, t), u)| ((m - t) / u.scale).abs())
            .fold(0.0, f64::max);
        if step == 0.0 {
            return None;
        }
        match trial(problem, &moved) {
            Some((residuals, c)) if c < current => {
                *damping = (*damping / 10.0).max(1e-15);
                return Some(((moved, residuals, c), step));
            }
            _ => *damping *= 10.0,
        }
    }
    None
}
