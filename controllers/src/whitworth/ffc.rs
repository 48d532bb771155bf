//! `ffc`: the paper's feedforward-feedback baseline (§6.1): `u = u_d + u_f` on the slider of
//! Perrusquía eq (10), with the Jacobian compensator, profile and switching criterion of the OSMC.
//!
//! **Feedforward (Perrusquía eq (37)).** `u_d = B†·(ż_d − A·z_d) = m̄·ÿ_d`, plus the model's
//! gravity carried to u ([`SliderModel::gravity_input`]): the paper's slider model
//! Perrusquía eq (36) carries its weight as a known offset, which Perrusquía eq (37) leaves out; the feedforward
//! here includes it, so that the baseline gets the model knowledge it is "designed in accordance
//! to".
//!
//! **Feedback (Perrusquía eq (38)).** `det(λI − A + BK) = λ² + 2ξω_nλ + ω_n²` with the paper's ω_n²
//! = 1000, ξ = 1, by Ackermann's formula: `K = m̄·[ω_n², 2ξω_n]`. The paper writes `u_f = −K·e`;
//! with its `e = z_d − z` that would place the roots of `det(λI − A − BK)`, so the feedback here is
//! `u_f = +K·e`, which realises Perrusquía eq (38) itself.

use super::slider::SliderModel;
use super::task::{LawInput, TaskController, TaskDesign, TaskLaw, TaskParams};
use crate::check::{non_negative, positive};
use crate::design::{ackermann, second_order_polynomial};
use framework::{parse_params, Entry};
use framework::{ControllerError, SignalSpec, Unit};
use serde::Deserialize;

/// Parameters of `ffc` (SI units).
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct FfcParams {
    /// ω_n of Perrusquía eq (38), rad/s.
    pub natural_frequency: f64,
    /// ξ of Perrusquía eq (38).
    pub damping_ratio: f64,
    /// The task: reference, stroke switching and the linkage's model,
    /// `[controller.params.task]`.
    pub task: TaskParams,
}

impl Default for FfcParams {
    fn default() -> Self {
        Self {
            natural_frequency: 1000f64.sqrt(),
            damping_ratio: 1.0,
            task: TaskParams::default(),
        }
    }
}

/// `K` of Perrusquía eq (38) for the slider with mass m̄: N/m, N·s/m.
pub fn design(params: &FfcParams, slider: &SliderModel) -> Result<[f64; 2], ControllerError> {
    let wn = positive("ffc", "natural_frequency", params.natural_frequency)?;
    let zeta = non_negative("ffc", "damping_ratio", params.damping_ratio)?;
    let polynomial = second_order_polynomial(wn, zeta)
        .map_err(|e| ControllerError::parameter_table("ffc", "", e.to_string()))?;
    let (a, b) = slider.state_space();
    let k = ackermann(&a, &b, &polynomial).map_err(|e| {
        ControllerError::parameter_table(
            "ffc",
            "task",
            format!("must give a slider whose poles eq (38) can place: {e}"),
        )
    })?;
    Ok([k[0], k[1]])
}

/// `u = m̄·ÿ_d + u_g + K·e`: the law of the FFC and LQT baselines.
#[derive(Debug, Clone, PartialEq)]
pub struct FeedforwardFeedback {
    label: &'static str,
    mass: f64,
    gain: [f64; 2],
    feedforward: f64,
    feedback: f64,
}

impl FeedforwardFeedback {
    /// `mass` is m̄ (kg), `gain` K on `e = [y_d − y, ẏ_d − ẏ]`.
    pub fn new(label: &'static str, mass: f64, gain: [f64; 2]) -> Self {
        Self {
            label,
            mass,
            gain,
            feedforward: 0.0,
            feedback: 0.0,
        }
    }

    /// K on `e = [y_d − y, ẏ_d − ẏ]`: N/m, N·s/m.
    pub fn gain(&self) -> [f64; 2] {
        self.gain
    }
}

impl TaskLaw for FeedforwardFeedback {
    fn label(&self) -> &'static str {
        self.label
    }

    fn reset(&mut self) {
        self.feedforward = 0.0;
        self.feedback = 0.0;
    }

    fn restart(&mut self, _time: f64, _error: [f64; 2]) {}

    fn force(&mut self, input: &LawInput) -> f64 {
        self.feedforward = self.mass * input.reference.acceleration + input.gravity;
        self.feedback = self.gain[0] * input.error[0] + self.gain[1] * input.error[1];
        self.feedforward + self.feedback
    }

    fn internals(&self) -> Vec<SignalSpec> {
        vec![
            SignalSpec::new("feedforward", Unit::Newton, "slider force"),
            SignalSpec::new("feedback", Unit::Newton, "slider force"),
        ]
    }

    fn internal_values(&self, values: &mut [f64]) {
        values.copy_from_slice(&[self.feedforward, self.feedback]);
    }
}

/// `ffc` as the twin builds it.
pub type Ffc = TaskController<FeedforwardFeedback>;

/// Designs and builds `ffc`.
pub fn build(params: FfcParams) -> Result<Ffc, ControllerError> {
    let task = TaskDesign::new("ffc", &params.task)?;
    let gain = design(&params, &task.slider)?;
    let law = FeedforwardFeedback::new("FFC", task.slider.nominal_mass(), gain);
    Ok(TaskController::new("ffc", params.task, task, law))
}

pub(crate) fn entry() -> Entry {
    Entry {
        name: "ffc",
        machine: "whitworth",
        summary: "feedforward + pole-placement feedback of the ram (OSMC paper's baseline)",
        build: |table| Ok(Box::new(build(parse_params("ffc", table)?)?)),
    }
}

#[cfg(test)]
mod tests {
    use super::super::test_plant::Plant;
    use super::*;
    use framework::Controller;
    use models::reference::Reference;

    #[test]
    fn gain_realises_eq_38() {
        let ffc = build(FfcParams::default()).unwrap();
        let m = ffc.design().slider.nominal_mass();
        let [kp, kd] = ffc.law().gain();
        assert!((kp - m * 1000.0).abs() < 1e-6 * kp);
        assert!((kd - m * 2.0 * 1000f64.sqrt()).abs() < 1e-6 * kd);
    }

    #[test]
    fn bad_specifications_are_rejected() {
        for (table, message) in [
            (
                "natural_frequency = 0.0",
                "controller `ffc`: params.natural_frequency = 0: must be > 0",
            ),
            (
                "damping_ratio = -1.0",
                "controller `ffc`: params.damping_ratio = -1: must be ≥ 0",
            ),
        ] {
            let err = framework::Registry::with([super::entry()])
                .build("ffc", "whitworth", &table.parse::<toml::Table>().unwrap())
                .err()
                .unwrap();
            assert_eq!(err.to_string(), message);
        }
    }

    #[test]
    fn tracks_a_slow_sine_in_closed_loop() {
        let mut plant = Plant::twin();
        plant.reference = Some(Reference::Sine {
            offset: -0.2,
            amplitude: -0.1,
            angular_frequency: 2.0,
            phase: 0.0,
        });
        let mut ffc = build(FfcParams::default()).unwrap();
        ffc.reset(&plant.interface()).unwrap();
        let samples = plant.run(&mut ffc, 2.0, 1e-3);
        let last = samples.last().unwrap();
        let r = plant.reference.unwrap().sample(last.time).position;
        assert!(
            (r - last.ram_position).abs() < 5e-3,
            "error {}",
            r - last.ram_position
        );
    }
}
