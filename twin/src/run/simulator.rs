//! `Simulator`: the plant without its controller, stepped from outside one control period at a
//! time (an FMU, a control engineer's own loop). It runs the run loop's own stages
//! ([`Session::hold`]); whole runs keep their one door, [`Twin::run_with`].

use super::session::Session;
use super::{Divergence, Twin, TwinError};
use crate::scenario::{LoadedScenario, Scenario};
use controllers::{Actuator, Controller, ControllerError, Measurement, PlantInterface, SignalSpec};
use thiserror::Error;

/// Why a step was refused or failed.
#[derive(Debug, Error)]
pub enum StepError {
    #[error("efforts: {given} values given for {expected} actuators ({names}); give one per actuator in that order")]
    Length {
        given: usize,
        expected: usize,
        names: String,
    },
    #[error("effort of actuator `{actuator}` is {value}: must be a finite number")]
    NotFinite { actuator: String, value: f64 },
    #[error("the plant diverged at step {} (t = {} s): {} = {}; reset it", .0.step, .0.time, .0.signal, .0.value)]
    Diverged(Divergence),
}

/// The twin's scenario without its controller, stepped from outside.
pub struct Simulator {
    /// The scenario as loaded, without its controller, to build the plant again on a reset.
    recipe: LoadedScenario,
    session: Session<Box<Twin>>,
    /// The physics step reached (a control update).
    step: usize,
    failure: Option<Divergence>,
}

/// The controller slot of a twin stepped from outside: its efforts come with each step.
struct Outside;

impl Controller for Outside {
    fn name(&self) -> &str {
        "outside"
    }

    fn reset(&mut self, _plant: &PlantInterface) -> Result<(), ControllerError> {
        Ok(())
    }

    fn update(&mut self, _measurement: &Measurement, _period: f64, _efforts: &mut [f64]) {}
}

impl Simulator {
    /// The scenario's plant at its start (t = 0, the scenario's seed), its controller left out.
    pub fn new(loaded: LoadedScenario) -> Result<Self, TwinError> {
        let recipe = LoadedScenario {
            controller: Box::new(Outside),
            ..loaded
        };
        let seed = recipe.scenario.seed;
        let (session, failure) = Self::build(&recipe, seed)?;
        Ok(Self {
            recipe,
            session,
            step: 0,
            failure,
        })
    }

    fn build(
        recipe: &LoadedScenario,
        seed: u64,
    ) -> Result<(Session<Box<Twin>>, Option<Divergence>), TwinError> {
        let mut scenario = recipe.scenario.clone();
        scenario.seed = seed;
        let loaded = LoadedScenario {
            scenario,
            toml: recipe.toml.clone(),
            source: recipe.source.clone(),
            urdf_text: recipe.urdf_text.clone(),
            urdf_source: recipe.urdf_source.clone(),
            controller: Box::new(Outside),
        };
        let mut session = Session::new(Box::new(Twin::new(loaded)?));
        let failure = session.begin()?;
        Ok((session, failure))
    }

    /// Back to t = 0 with the sensor noise and fault draws of `seed`.
    pub fn reset(&mut self, seed: u64) -> Result<(), TwinError> {
        let (session, failure) = Self::build(&self.recipe, seed)?;
        (self.session, self.step, self.failure) = (session, 0, failure);
        Ok(())
    }

    /// One control period with `efforts` (one per actuator, in [`Simulator::actuators`]' order,
    /// SI: N or N·m) held, clipped to the actuators' limits as in a run; the measured signals
    /// at its end. After a divergence every step is refused until a reset.
    pub fn step(&mut self, efforts: &[f64]) -> Result<&[f64], StepError> {
        let actuators = self.actuators();
        if efforts.len() != actuators.len() {
            return Err(StepError::Length {
                given: efforts.len(),
                expected: actuators.len(),
                names: names(actuators),
            });
        }
        if let Some((actuator, &value)) = actuators
            .iter()
            .zip(efforts)
            .find(|(_, value)| !value.is_finite())
        {
            return Err(StepError::NotFinite {
                actuator: actuator.joint.clone(),
                value,
            });
        }
        if let Some(failure) = &self.failure {
            return Err(StepError::Diverged(failure.clone()));
        }
        match self.session.hold(self.step, efforts) {
            Ok(step) => self.step = step,
            Err(failure) => {
                self.step = failure.step;
                self.failure = Some(failure.clone());
                return Err(StepError::Diverged(failure));
            }
        }
        Ok(self.session.measured())
    }

    /// The simulated time, s.
    pub fn time(&self) -> f64 {
        self.step as f64 * self.scenario().dt
    }

    /// The scenario stepped (its `dt`, `control_period`, `duration`, `seed`).
    pub fn scenario(&self) -> &Scenario {
        &self.session.twin().loaded.scenario
    }

    /// The actuators, in the order of a step's efforts, with their limits.
    pub fn actuators(&self) -> &[Actuator] {
        &self.session.twin().plant.actuators
    }

    /// The plant's signals (names, display units, plots), in the order of the measured and the
    /// true values.
    pub fn signal_specs(&self) -> &[SignalSpec] {
        &self.session.twin().layout.specs.signals
    }

    /// The SI unit of each signal's values (`m`, `rad/s`, `N·m`, …).
    pub fn signal_units(&self) -> Vec<&'static str> {
        self.signal_specs()
            .iter()
            .map(|s| s.unit.si_label())
            .collect()
    }

    /// Per signal: whether a sensor (quantisation, noise, delay) stands between it and its
    /// measurement.
    pub fn sensed(&self) -> Vec<bool> {
        self.session
            .twin()
            .sensors
            .iter()
            .map(Option::is_some)
            .collect()
    }

    /// What the sensors read at the last control update (SI).
    pub fn measured(&self) -> &[f64] {
        self.session.measured()
    }

    /// The plant's true signals now (SI).
    pub fn true_signals(&self) -> &[f64] {
        self.session.signals()
    }

    /// The model checks' names and units: the machine's own figures (a tool's distance from
    /// its path, a pose), one `loop_gap/<loop>` per loop closure, and `mechanical_energy`.
    pub fn diagnostic_specs(&self) -> &[SignalSpec] {
        &self.session.twin().layout.specs.diagnostics
    }

    /// The model checks now (SI), in the order of [`Simulator::diagnostic_specs`].
    pub fn diagnostics(&self) -> &[f64] {
        self.session.diagnostics()
    }
}

fn names(actuators: &[Actuator]) -> String {
    let names: Vec<&str> = actuators.iter().map(|a| a.joint.as_str()).collect();
    names.join(", ")
}
