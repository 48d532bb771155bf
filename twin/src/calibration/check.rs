//! The check before any solve: bounds that exclude the start, too little data, a parameter with
//! no effect on the outputs, parameters the data cannot tell apart (near-singular directions of
//! JᵀWJ), and parameters the data determine only poorly. Refusals are one line naming the
//! parameters as the user wrote them; the rest are warnings.

use super::error::CalibrationError;
use super::problem::{Scope, Unknown};
use nalgebra::DMatrix;

/// A unit change of a parameter (100 % of its scale) moving the weighted outputs by less than
/// this, in noise σ over the whole data, has no effect.
const NO_EFFECT: f64 = 1e-6;
/// Smallest eigenvalue of the normalised information matrix, relative to its largest, below
/// which a direction is not determined at all (refused)…
const SINGULAR: f64 = 1e-10;
/// …and below which it is poorly determined (warned).
const ILL_CONDITIONED: f64 = 1e-6;

fn refuse(reason: String) -> CalibrationError {
    CalibrationError::Check(reason)
}

/// Bounds that exclude the start, or are empty.
pub fn bounds(unknowns: &[Unknown]) -> Result<(), CalibrationError> {
    for u in unknowns {
        let [lo, hi] = u.bounds;
        if lo.is_nan() || hi.is_nan() || lo >= hi {
            return Err(refuse(format!(
                "{}: bounds [{lo}, {hi}] are empty; give --bounds KEY=lo,hi with lo < hi",
                u.label
            )));
        }
        if !(lo..=hi).contains(&u.start) {
            return Err(refuse(format!(
                "{}: the start {} lies outside the bounds [{lo}, {hi}]; move the start (--fit KEY=start) or widen the bounds",
                u.label, u.start
            )));
        }
    }
    Ok(())
}

/// Fewer residuals than unknowns (plus one, for the noise): the data cannot determine them.
pub fn samples(rows: usize, unknowns: usize) -> Result<(), CalibrationError> {
    if rows <= unknowns {
        return Err(refuse(format!(
            "{rows} measured values for {unknowns} unknowns; the fit needs more samples than unknowns: give a longer run, more signals or fewer parameters"
        )));
    }
    Ok(())
}

/// The start states (unknowns the calibration added, not the user) that have no effect on the
/// fitted signals, such as a freely turning spindle's angle: they are dropped, not refused.
pub fn idle_states(unknowns: &[Unknown], jacobian: &DMatrix<f64>) -> Vec<usize> {
    (0..unknowns.len())
        .filter(|&j| matches!(unknowns[j].scope, Scope::Segment(_)))
        .filter(|&j| jacobian.column(j).norm() * unknowns[j].scale < NO_EFFECT)
        .collect()
}

/// From the Jacobian at the start: refuses a parameter with no effect and parameters the data
/// cannot separate; warns of poorly determined ones. `jacobian` is of the weighted residuals.
/// Directions among start states alone are the solve's business, not the user's.
pub fn identifiable(
    unknowns: &[Unknown],
    jacobian: &DMatrix<f64>,
) -> Result<Vec<String>, CalibrationError> {
    let effect: Vec<f64> = (0..unknowns.len())
        .map(|j| jacobian.column(j).norm() * unknowns[j].scale)
        .collect();
    if let Some(j) = (0..unknowns.len()).find(|&j| effect[j] < NO_EFFECT) {
        return Err(refuse(format!(
            "{} has no effect on the fitted signals of these runs (changing it by 100 % moves them by {:.1e} σ): is it applied to this machine, and excited by the runs?",
            unknowns[j].label, effect[j]
        )));
    }
    // The information matrix normalised to a unit diagonal: its eigenvalues measure how far
    // the data tell the unknowns apart, whatever their units.
    let normalised = DMatrix::from_fn(jacobian.ncols(), jacobian.ncols(), |i, k| {
        jacobian.column(i).dot(&jacobian.column(k)) * unknowns[i].scale * unknowns[k].scale
            / (effect[i] * effect[k])
    });
    let eigen = normalised.symmetric_eigen();
    let largest = eigen.eigenvalues.max();
    let mut warnings = Vec::new();
    for (index, &value) in eigen.eigenvalues.iter().enumerate() {
        let relative = value / largest;
        if relative >= ILL_CONDITIONED {
            continue;
        }
        let direction: Vec<f64> = eigen.eigenvectors.column(index).iter().copied().collect();
        let states_only = (direction.iter().zip(unknowns))
            .all(|(c, u)| c.abs() <= 0.1 || matches!(u.scope, Scope::Segment(_)));
        if states_only {
            continue;
        }
        let message = confounded(unknowns, &direction, relative);
        if relative < SINGULAR {
            return Err(refuse(message));
        }
        warnings.push(message);
    }
    Ok(warnings)
}

/// Names the unknowns a near-null direction moves together and the one combination of them
/// the data do determine (for two of them; the largest shares for more).
fn confounded(unknowns: &[Unknown], direction: &[f64], relative: f64) -> String {
    let mut involved: Vec<(usize, f64)> = direction
        .iter()
        .enumerate()
        .filter(|(_, c)| c.abs() > 0.1)
        .map(|(j, &c)| (j, c))
        .collect();
    involved.sort_by(|a, b| b.1.abs().total_cmp(&a.1.abs()));
    let name = |j: usize| short_label(&unknowns[j]);
    let names: Vec<String> = involved.iter().map(|&(j, _)| name(j)).collect();
    let verdict = if relative < SINGULAR {
        "cannot be told apart"
    } else {
        "are poorly told apart"
    };
    let determined = match involved.as_slice() {
        [(a, ca), (b, cb)] => {
            // The data see the combination orthogonal to the null direction.
            let (wa, wb) = (cb.abs(), ca.abs() * -(ca.signum() * cb.signum()));
            let norm = wa.abs().max(wb.abs());
            format!(
                ": only {:.2}·{} {} {:.2}·{} is determined (each in units of its effect on the outputs)",
                wa / norm,
                name(*a),
                if wb < 0.0 { "−" } else { "+" },
                wb.abs() / norm,
                name(*b)
            )
        }
        _ => String::new(),
    };
    format!(
        "{} {verdict} in these runs (information ratio {relative:.1e}){determined}; fix one of them, or add a run that excites them differently",
        names.join(" and ")
    )
}

/// An unknown's name for messages: its key, with its run for a per-run one.
fn short_label(unknown: &Unknown) -> String {
    match unknown.scope {
        Scope::Shared => unknown.key.clone(),
        _ => unknown.label.clone(),
    }
}
