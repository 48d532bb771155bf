//! `lqt`: the paper's linear-quadratic tracking baseline (§6.1): the feedforward of
//! Perrusquía eq (37) (with the model's gravity, as in [`ffc`](super::ffc)) plus the LQR feedback minimising
//! Perrusquía eq (39), `∫ eᵀQe + R·u_f² dt`, for the slider of Perrusquía eq (10); same
//! compensator, profile and switching.
//!
//! The paper prints neither Q nor R. Q defaults to the OSMC's `diag(1000, 1)`; R is given
//! relative to the slider's inertia, `R = r/m̄²` (a weight on the feedback's acceleration
//! `u_f/m̄`), with `r = 10⁻³`: then `K = m̄·[√(q_pos/r), √(q_vel/r + 2√(q_pos/r))]
//! = m̄·[1000, 54.8]`, the closed loop `λ² + 54.8λ + 1000` with the FFC's ω_n = 31.6 rad/s and
//! ξ = 0.87. As with the FFC, `u_f = +K·e` on `e = z_d − z` realises `A − BK`.

use super::ffc::FeedforwardFeedback;
use super::osmc::check_weights;
use super::slider::SliderModel;
use super::task::{TaskController, TaskDesign, TaskParams};
use crate::check::positive;
use crate::design::{lqr, SliderWeights};
use framework::ControllerError;
use framework::{parse_params, Entry};
use nalgebra::DMatrix;
use serde::Deserialize;

/// Parameters of `lqt` (SI units).
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct LqtParams {
    /// Q of Perrusquía eq (39).
    pub weights: SliderWeights,
    /// r, with `R = r/m̄²` in Perrusquía eq (39).
    pub input_weight: f64,
    /// The task: reference, stroke switching and the linkage's model,
    /// `[controller.params.task]`.
    pub task: TaskParams,
}

impl Default for LqtParams {
    fn default() -> Self {
        Self {
            weights: SliderWeights::default(),
            input_weight: 1e-3,
            task: TaskParams::default(),
        }
    }
}

/// The LQR gain `K` (N/m, N·s/m) for the slider with mass m̄.
pub fn design(params: &LqtParams, slider: &SliderModel) -> Result<[f64; 2], ControllerError> {
    let w = params.weights;
    check_weights("lqt", &w)?;
    let input_weight = positive("lqt", "input_weight", params.input_weight)?;
    let (a, b) = slider.state_space();
    let q = DMatrix::from_row_slice(2, 2, &[w.position, 0.0, 0.0, w.velocity]);
    let m = slider.nominal_mass();
    let r = DMatrix::from_element(1, 1, input_weight / (m * m));
    let design = lqr(&a, &b, &q, &r).map_err(|e| {
        ControllerError::parameter(
            "lqt",
            "input_weight",
            input_weight,
            format!("must give a solvable regulator with weights and the task's slider: {e}"),
        )
    })?;
    Ok([design.gain[(0, 0)], design.gain[(0, 1)]])
}

/// `lqt` as the twin builds it.
pub type Lqt = TaskController<FeedforwardFeedback>;

/// Designs and builds `lqt`.
pub fn build(params: LqtParams) -> Result<Lqt, ControllerError> {
    let task = TaskDesign::new("lqt", &params.task)?;
    let gain = design(&params, &task.slider)?;
    let law = FeedforwardFeedback::new("LQT", task.slider.nominal_mass(), gain);
    Ok(TaskController::new("lqt", params.task, task, law))
}

pub(crate) fn entry() -> Entry {
    Entry {
        name: "lqt",
        machine: "whitworth",
        summary: "feedforward + LQR feedback of the ram (OSMC paper's baseline)",
        build: |table| Ok(Box::new(build(parse_params("lqt", table)?)?)),
    }
}

#[cfg(test)]
mod tests {
    use super::super::test_plant::Plant;
    use super::*;
    use framework::Controller;
    use models::reference::Reference;

    #[test]
    fn gain_is_the_regulator_of_eq_39() {
        let lqt = build(LqtParams::default()).unwrap();
        let m = lqt.design().slider.nominal_mass();
        let [kp, kd] = lqt.law().gain();
        // K = m̄·[√(q₁/r), √(q₂/r + 2√(q₁/r))] with q₁ = 1000, q₂ = 1, r = 10⁻³.
        assert!((kp - m * 1000.0).abs() < 1e-6 * kp, "{kp}");
        assert!((kd - m * 3000f64.sqrt()).abs() < 1e-6 * kd, "{kd}");
    }

    #[test]
    fn bad_weights_are_rejected() {
        for (table, message) in [
            (
                "input_weight = 0.0",
                "controller `lqt`: params.input_weight = 0: must be > 0",
            ),
            (
                "weights = { position = -1.0, velocity = 1.0 }",
                "controller `lqt`: params.weights.position = -1: must be > 0",
            ),
        ] {
            let err = framework::Registry::with([super::entry()])
                .build("lqt", "whitworth", &table.parse::<toml::Table>().unwrap())
                .err()
                .unwrap();
            assert_eq!(err.to_string(), message);
        }
    }

    #[test]
    fn holds_a_constant_reference() {
        let mut plant = Plant::twin();
        plant.reference = Some(Reference::Constant { value: -0.2 });
        let mut lqt = build(LqtParams::default()).unwrap();
        lqt.reset(&plant.interface()).unwrap();
        let samples = plant.run(&mut lqt, 1.5, 1e-3);
        let last = samples.last().unwrap();
        // The gravity feedforward leaves only the model's variation to the feedback.
        assert!(
            (last.ram_position + 0.2).abs() < 2e-3,
            "y = {}",
            last.ram_position
        );
        assert!(last.ram_velocity.abs() < 1e-3);
    }
}
