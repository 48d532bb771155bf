//! `smc2`: the paper's second-order SMC baseline (§6.1): the law of Perrusquía eqs (27)–(30),
//! exactly as in [`osmc`](super::osmc), on a hand-set hyperplane `s = m̄·(ė + c·e)` instead of the
//! Riccati-optimal one, with the same compensator, profile and switching criterion.
//!
//! The paper does not print the baseline's surface. For the slider of Perrusquía eq (10) every
//! hyperplane with `C·B = 1` has the form `m̄·[c, 1]`, and the optimal one of
//! Perrusquía eqs (14)–(26) is `c = √(q_pos/q_vel)`: an SMC2 with slope c *is* the OSMC for `Q = diag(c², 1)`.
//! What the comparison can show is therefore what the Riccati design's choice of slope buys over a
//! hand-set one; the default `c = 10 s⁻¹` stands for a conventional hand tuning (a sliding motion
//! about three times slower than the OSMC's −31.6 rad/s). Gains k₁, k₂, λ default to the OSMC's.

use super::osmc::{second_order_gains, SecondOrderGains, SecondOrderSliding};
use super::slider::SliderModel;
use super::task::{TaskController, TaskDesign, TaskParams};
use crate::check::positive;
use framework::ControllerError;
use framework::{parse_params, Entry};
use serde::Deserialize;

/// Parameters of `smc2` (SI units).
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct Smc2Params {
    /// c of `s = m̄·(ė + c·e)`, 1/s.
    pub surface_slope: f64,
    /// k₁ of Perrusquía eq (27), 1/s.
    pub k1: f64,
    /// k₂ of Perrusquía eq (30), N.
    pub k2: f64,
    /// λ of Perrusquía eq (29), 1/s.
    pub reaching_rate: f64,
    /// The task: reference, stroke switching and the linkage's model,
    /// `[controller.params.task]`.
    pub task: TaskParams,
}

impl Default for Smc2Params {
    fn default() -> Self {
        Self {
            surface_slope: 10.0,
            k1: 400.0,
            k2: 15.0,
            reaching_rate: 20.0,
            task: TaskParams::default(),
        }
    }
}

/// The hand-set hyperplane and the checked law gains.
pub fn design(
    params: &Smc2Params,
    slider: &SliderModel,
) -> Result<SecondOrderGains, ControllerError> {
    let c = positive("smc2", "surface_slope", params.surface_slope)?;
    let m = slider.nominal_mass();
    second_order_gains(
        "smc2",
        [m * c, m],
        params.k1,
        params.k2,
        params.reaching_rate,
    )
}

/// `smc2` as the twin builds it.
pub type Smc2 = TaskController<SecondOrderSliding>;

/// Designs and builds `smc2`.
pub fn build(params: Smc2Params) -> Result<Smc2, ControllerError> {
    let task = TaskDesign::new("smc2", &params.task)?;
    let gains = design(&params, &task.slider)?;
    Ok(TaskController::new(
        "smc2",
        params.task,
        task,
        SecondOrderSliding::new("SMC2", gains),
    ))
}

pub(crate) fn entry() -> Entry {
    Entry {
        name: "smc2",
        machine: "whitworth",
        summary: "second-order SMC of the ram on a hand-set surface (OSMC paper's baseline)",
        build: |table| Ok(Box::new(build(parse_params("smc2", table)?)?)),
    }
}

#[cfg(test)]
mod tests {
    use super::super::test_plant::{cut_velocity_errors, Contact, Plant};
    use super::*;
    use framework::Controller;

    #[test]
    fn surface_is_hand_set() {
        let smc2 = build(Smc2Params::default()).unwrap();
        let m = smc2.design().slider.nominal_mass();
        assert_eq!(smc2.law().gains().surface, [m * 10.0, m]);
        for table in ["surface_slope = 0.0", "k1 = 0.0", "reaching_rate = -2.0"] {
            let err = framework::Registry::with([super::entry()])
                .build("smc2", "whitworth", &table.parse::<toml::Table>().unwrap())
                .err()
                .unwrap();
            assert!(err.to_string().contains("must be > 0"), "{err}");
        }
    }

    #[test]
    fn cuts_through_the_singular_points() {
        let mut plant = Plant::twin();
        let contact = Contact::WORKPIECE;
        plant.contact = Some(contact);
        let mut smc2 = build(Smc2Params::default()).unwrap();
        smc2.reset(&plant.interface()).unwrap();
        let samples = plant.run(&mut smc2, 2.0, 1e-3);
        assert!(cut_velocity_errors(&samples, -1.25, &contact).len() >= 2);
        assert!(samples[100..].iter().all(|s| s.crank_speed < 0.0));
    }
}
