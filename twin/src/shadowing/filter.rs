//! The shadow's extended Kalman filter on the twin's own model: the state is the mechanism's
//! independent positions and velocities with the tracked parameters appended (held as random
//! walks), propagated between sample times by [`Model::propagate`] and linearised by forward
//! differences of that same propagation, so that the transition matrix is the twin's Jacobian
//! over the actual span between two samples, however irregular.
//!
//! An extended filter rather than an unscented one: the twin's flow is smooth between samples
//! (dry friction enters by its sign at each substep) and an EKF needs n + 1 propagations per
//! sample where an unscented filter needs 2n + 1, for the same first-order accuracy in the
//! mean on these nearly linear spans of 1–100 ms. The update uses the Joseph form, which keeps
//! the covariance symmetric and positive through the parameters' small variances.

use super::error::ShadowError;
use super::model::{diverged, Knob, Model, Tape};
use crate::mechanism::Pose2;
use nalgebra::{DMatrix, DVector};

/// One measurement update's innovation, per observed signal.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Innovation {
    /// The watched signals observed (indices into the watched list).
    pub signals: Vec<usize>,
    /// What the model predicted, before the update, SI.
    pub predicted: Vec<f64>,
    /// Measured less predicted, SI.
    pub residual: Vec<f64>,
    /// The residual's predicted variance (the diagonal of S), SI².
    pub variance: Vec<f64>,
    /// νᵀ S⁻¹ ν: χ² with as many degrees of freedom as signals, for a model that fits.
    pub nis: f64,
}

/// The filter: the model, the state and its covariance, and the noise it assumes.
pub(super) struct Filter {
    pub model: Model,
    pub knobs: Vec<Knob>,
    /// Positions, velocities, then the knobs' values.
    pub x: Vec<f64>,
    pub p: DMatrix<f64>,
    /// Per independent coordinate: the acceleration noise's spectral density, (unit/s²)²·s.
    acceleration_noise: Vec<f64>,
    /// Per knob: its random walk's variance per second.
    drift: Vec<f64>,
    /// Per watched signal: the measurement noise's variance, SI².
    pub noise: Vec<f64>,
    /// The initial standard deviations, to loosen the state to after a gap.
    loose: Vec<f64>,
    /// The parameters held (after a gap, while the state is taken up again): the updates
    /// leave them and their variances as they are.
    pub hold: bool,
    tape: Tape,
}

/// The filter's tuning, in SI.
pub(super) struct Tuning {
    pub acceleration_noise: Vec<f64>,
    pub drift: Vec<f64>,
    pub noise: Vec<f64>,
    /// Initial standard deviations: per coordinate position and velocity, per knob.
    pub initial_sigma: Vec<f64>,
}

impl Filter {
    /// A filter at the model's initial state and the knobs' current values.
    pub fn new(model: Model, knobs: Vec<Knob>, tuning: Tuning) -> Self {
        let mut x = model.x0.clone();
        x.extend(knobs.iter().map(|k| model.knob(k)));
        let p = DMatrix::from_diagonal(&DVector::from_iterator(
            x.len(),
            tuning.initial_sigma.iter().map(|s| s * s),
        ));
        Self {
            model,
            knobs,
            x,
            p,
            acceleration_noise: tuning.acceleration_noise,
            drift: tuning.drift,
            noise: tuning.noise,
            loose: tuning.initial_sigma,
            hold: false,
            tape: Tape::default(),
        }
    }

    /// Independent coordinates.
    pub fn coordinates(&self) -> usize {
        self.model.coordinates.len()
    }

    /// Sets the model's knobs to the state's (or a perturbed state's) values.
    fn apply_knobs(&mut self, values: &[f64]) {
        let k = 2 * self.coordinates();
        for (knob, value) in self.knobs.iter().zip(&values[k..]) {
            self.model.set_knob(knob, *value);
        }
    }

    /// The forward-difference step of state component i.
    fn step(&self, i: usize) -> f64 {
        let sigma = self.p[(i, i)].max(0.0).sqrt();
        (1e-3 * sigma).max(1e-12 * (1.0 + self.x[i].abs()))
    }

    /// Propagates the state and its covariance from `time` over `span` under `commands`.
    pub fn predict(&mut self, commands: &[f64], time: f64, span: f64) -> Result<(), ShadowError> {
        if span <= 0.0 {
            return Ok(());
        }
        let n = self.x.len();
        let k = 2 * self.coordinates();
        let start = self.x.clone();
        self.apply_knobs(&start);
        let mut end = start[..k].to_vec();
        let mut tape = std::mem::take(&mut self.tape);
        let result = self
            .model
            .propagate(&mut end, commands, time, span, &mut tape);
        result.map_err(|e| diverged(time, e))?;
        let mut f = DMatrix::identity(n, n);
        for i in 0..n {
            let delta = self.step(i);
            let mut perturbed = start.clone();
            perturbed[i] += delta;
            if i >= k {
                self.apply_knobs(&perturbed);
            }
            let mut moved = perturbed[..k].to_vec();
            let result = self.model.replay(&mut moved, &tape);
            if i >= k {
                self.apply_knobs(&start);
            }
            result.map_err(|e| diverged(time, e))?;
            for r in 0..k {
                f[(r, i)] = (moved[r] - end[r]) / delta;
            }
        }
        self.tape = tape;
        self.x[..k].copy_from_slice(&end);
        self.p = &f * &self.p * f.transpose() + self.process_noise(span);
        self.check_finite(time + span)?;
        self.model.recenter(&end).map_err(|e| diverged(time, e))
    }

    /// The process noise over `span`: white acceleration per coordinate (position and velocity
    /// correlated as its integrals are), a random walk per knob.
    fn process_noise(&self, span: f64) -> DMatrix<f64> {
        let n = self.x.len();
        let c = self.coordinates();
        let mut q = DMatrix::zeros(n, n);
        for (i, density) in self.acceleration_noise.iter().enumerate() {
            q[(i, i)] = density * span.powi(3) / 3.0;
            q[(i, c + i)] = density * span.powi(2) / 2.0;
            q[(c + i, i)] = q[(i, c + i)];
            q[(c + i, c + i)] = density * span;
        }
        if !self.hold {
            for (j, rate) in self.drift.iter().enumerate() {
                q[(2 * c + j, 2 * c + j)] = rate * span;
            }
        }
        q
    }

    /// The watched signals `signals` at state `x` and `time`.
    fn measure(
        &mut self,
        x: &[f64],
        time: f64,
        signals: &[usize],
    ) -> Result<Vec<f64>, ShadowError> {
        let k = 2 * self.coordinates();
        let mut all = vec![0.0; self.model.watched.len()];
        self.apply_knobs(x);
        self.model
            .measure(&x[..k], time, &mut all)
            .map_err(|e| diverged(time, e))?;
        Ok(signals.iter().map(|&s| all[s]).collect())
    }

    /// Corrects the state with the values `observed` (watched signal, SI value) taken at `time`.
    pub fn update(
        &mut self,
        time: f64,
        observed: &[(usize, f64)],
    ) -> Result<Innovation, ShadowError> {
        let n = self.x.len();
        let signals: Vec<usize> = observed.iter().map(|(s, _)| *s).collect();
        let x = self.x.clone();
        let predicted = self.measure(&x, time, &signals)?;
        let m = signals.len();
        let mut h = DMatrix::zeros(m, n);
        for i in 0..n {
            let delta = self.step(i);
            let mut perturbed = x.clone();
            perturbed[i] += delta;
            let moved = self.measure(&perturbed, time, &signals)?;
            for r in 0..m {
                h[(r, i)] = (moved[r] - predicted[r]) / delta;
            }
        }
        self.apply_knobs(&x);
        let residual =
            DVector::from_iterator(m, observed.iter().zip(&predicted).map(|((_, y), p)| y - p));
        let r = DMatrix::from_diagonal(&DVector::from_iterator(
            m,
            signals.iter().map(|&s| self.noise[s]),
        ));
        let s = &h * &self.p * h.transpose() + &r;
        let Some(s_inverse) = s.clone().try_inverse() else {
            return Err(ShadowError::Diverged {
                time,
                reason: "the innovation covariance is singular".into(),
            });
        };
        let mut gain = &self.p * h.transpose() * &s_inverse;
        if self.hold {
            // A consider (Schmidt) update: the parameters' rows of the gain are zero, and the
            // Joseph form below keeps the covariance right for any gain.
            let k = 2 * self.coordinates();
            gain.rows_mut(k, n - k).fill(0.0);
        }
        let correction = &gain * &residual;
        for (value, dx) in self.x.iter_mut().zip(correction.iter()) {
            *value += dx;
        }
        self.project();
        let keep = DMatrix::identity(n, n) - &gain * &h;
        self.p = &keep * &self.p * keep.transpose() + &gain * r * gain.transpose();
        self.check_finite(time)?;
        self.apply_knobs(&self.x.clone());
        let k = 2 * self.coordinates();
        let corrected = self.x[..k].to_vec();
        self.model
            .recenter_along(&x[..k], &corrected)
            .map_err(|e| diverged(time, e))?;
        Ok(Innovation {
            signals,
            predicted,
            nis: (residual.transpose() * &s_inverse * &residual)[(0, 0)],
            variance: (0..m).map(|i| s[(i, i)]).collect(),
            residual: residual.iter().copied().collect(),
        })
    }

    /// Keeps the physical parameters physical: a mass, a damping or a friction the update put
    /// below zero is set to zero (the estimate projected onto what a machine can have), so
    /// that noise cannot carry one where it would explain the data by a negative loss.
    fn project(&mut self) {
        let k = 2 * self.coordinates();
        for (knob, value) in self.knobs.iter().zip(&mut self.x[k..]) {
            if knob.is_physical() && *value < 0.0 {
                *value = 0.0;
            }
        }
    }

    /// Forgets the positions and velocities (after a gap in the samples): their variances are
    /// set loose again and their correlations with the parameters dropped.
    pub fn loosen(&mut self) {
        let k = 2 * self.coordinates();
        let n = self.x.len();
        for i in 0..k {
            for j in 0..n {
                self.p[(i, j)] = 0.0;
                self.p[(j, i)] = 0.0;
            }
            self.p[(i, i)] = self.loose[i] * self.loose[i];
        }
    }

    /// Fails when the state or its covariance is no longer finite.
    fn check_finite(&self, time: f64) -> Result<(), ShadowError> {
        if self.x.iter().chain(self.p.iter()).all(|v| v.is_finite()) {
            return Ok(());
        }
        Err(ShadowError::Diverged {
            time,
            reason: "the estimate is no longer finite".into(),
        })
    }

    /// A knob's estimate and standard deviation.
    pub fn knob_estimate(&self, j: usize) -> (f64, f64) {
        let i = 2 * self.coordinates() + j;
        (self.x[i], self.p[(i, i)].max(0.0).sqrt())
    }

    /// The watched signals at the current estimate.
    pub fn estimate(&mut self, time: f64) -> Result<Vec<f64>, ShadowError> {
        let all: Vec<usize> = (0..self.model.watched.len()).collect();
        let x = self.x.clone();
        self.measure(&x, time, &all)
    }

    /// The links' poses at the estimate (as [`Filter::estimate`] left the model), and where the
    /// joint positions `observed` at `time` put them, if they place the mechanism.
    pub fn poses(
        &mut self,
        time: f64,
        observed: &[(usize, f64)],
    ) -> Result<(Vec<Pose2>, Option<Vec<Pose2>>), ShadowError> {
        let estimated = self.model.link_poses().to_vec();
        let k = 2 * self.coordinates();
        let x = self.x[..k].to_vec();
        let measured = (self.model.measured_poses(&x, observed)).map_err(|e| diverged(time, e))?;
        Ok((estimated, measured))
    }
}
