//! `Simulator`, the plant stepped from outside, against the twin's own run of the same efforts
//! (through a controller that commands them), bit for bit; and its refusals.

use framework::{Controller, ControllerError, Measurement, PlantInterface};
use twin::BUILTIN_SCENARIOS as BUILTIN;
use twin::{
    LoadedScenario, Observer, ObserverError, Scenario, Simulator, StepError, StepView, Twin,
};

const STEP_AT: f64 = 0.01;

fn loaded(name: &str, duration: f64) -> LoadedScenario {
    Scenario::builtin(name)
        .map(|s| s.duration(duration))
        .and_then(|s| s.build(&controllers::builtin()))
        .unwrap_or_else(|e| panic!("{e}"))
}

/// A step input: zero, then a fifth of each actuator's limit (or 1 N / N·m without one) from
/// `STEP_AT` on.
fn step_input(plant: &[framework::Actuator], time: f64) -> Vec<f64> {
    plant
        .iter()
        .map(|a| {
            let size = if a.effort_limit.is_finite() {
                0.2 * a.effort_limit
            } else {
                1.0
            };
            if time >= STEP_AT - 1e-12 {
                size
            } else {
                0.0
            }
        })
        .collect()
}

struct StepController {
    actuators: Vec<framework::Actuator>,
}

impl Controller for StepController {
    fn name(&self) -> &str {
        "step-input"
    }
    fn reset(&mut self, plant: &PlantInterface) -> Result<(), ControllerError> {
        self.actuators = plant.actuators.clone();
        Ok(())
    }
    fn update(&mut self, m: &Measurement, _period: f64, efforts: &mut [f64]) {
        efforts.copy_from_slice(&step_input(&self.actuators, m.time));
    }
}

/// The measured and true signals at every control update.
#[derive(Default)]
struct Updates(Vec<(f64, Vec<f64>, Vec<f64>)>);

impl Observer for Updates {
    fn observe(&mut self, view: &StepView) -> Result<(), ObserverError> {
        if view.control_update {
            let sample = (view.time, view.measured.to_vec(), view.signals.to_vec());
            self.0.push(sample);
        }
        Ok(())
    }
}

fn same_as_the_run(name: &str, duration: f64) {
    let controller = Box::new(StepController { actuators: vec![] });
    let twin = Twin::with_controller(loaded(name, duration), controller).unwrap();
    let mut run = Updates::default();
    let summary = twin.run_with(None, &mut [&mut run]).unwrap();
    assert!(summary.failure.is_none(), "{name}: {:?}", summary.failure);
    let mut simulator = Simulator::new(loaded(name, duration)).unwrap();
    let actuators = simulator.actuators().to_vec();
    assert_eq!(simulator.measured(), &run.0[0].1[..], "{name} at t = 0");
    for (k, (time, measured, signals)) in run.0.iter().enumerate().skip(1) {
        let efforts = step_input(&actuators, simulator.time());
        let stepped = simulator.step(&efforts).unwrap().to_vec();
        assert_eq!(
            simulator.time().to_bits(),
            time.to_bits(),
            "{name} update {k}"
        );
        assert_eq!(&stepped, measured, "{name} measured at t = {time}");
        assert_eq!(
            simulator.true_signals(),
            &signals[..],
            "{name} true at t = {time}"
        );
    }
    assert!(run.0.len() > 10, "{name}: {} control updates", run.0.len());
}

#[test]
fn stepping_the_feed_axis_matches_its_run_bit_for_bit() {
    same_as_the_run("feed-axis-micromilling", 0.05);
}

#[test]
fn stepping_the_whitworth_linkage_matches_its_run_bit_for_bit() {
    same_as_the_run("whitworth-crank-pi", 0.3);
}

#[test]
fn a_reset_repeats_the_run_and_another_seed_draws_other_noise() {
    let text = format!(
        "{}\n[sensors.\"crank.velocity\"]\nnoise = 0.01\n",
        BUILTIN
            .iter()
            .find(|(n, _)| *n == "whitworth-crank-pi")
            .unwrap()
            .1
    );
    let noisy = Scenario::from_toml(&text, "noisy", None)
        .and_then(|s| s.build(&controllers::builtin()))
        .unwrap();
    let mut simulator = Simulator::new(noisy).unwrap();
    let efforts = vec![1.0; simulator.actuators().len()];
    let first: Vec<Vec<f64>> = (0..20)
        .map(|_| simulator.step(&efforts).unwrap().to_vec())
        .collect();
    let seed = simulator.scenario().seed;
    simulator.reset(seed).unwrap();
    assert_eq!(simulator.time(), 0.0);
    let again: Vec<Vec<f64>> = (0..20)
        .map(|_| simulator.step(&efforts).unwrap().to_vec())
        .collect();
    assert_eq!(first, again);
    simulator.reset(seed + 1).unwrap();
    let other: Vec<Vec<f64>> = (0..20)
        .map(|_| simulator.step(&efforts).unwrap().to_vec())
        .collect();
    assert!(simulator.sensed().contains(&true));
    assert_ne!(first, other, "noisy sensors with another seed");
}

#[test]
fn bad_efforts_are_refused_naming_the_actuator() {
    let mut simulator = Simulator::new(loaded("whitworth-crank-pi", 1.0)).unwrap();
    let name = simulator.actuators()[0].joint.clone();
    let error = simulator.step(&[]).unwrap_err();
    assert!(
        matches!(
            error,
            StepError::Length {
                given: 0,
                expected: 1,
                ..
            }
        ),
        "{error}"
    );
    assert!(error.to_string().contains(&name), "{error}");
    let error = simulator.step(&[f64::NAN]).unwrap_err();
    assert_eq!(
        error.to_string(),
        format!("effort of actuator `{name}` is NaN: must be a finite number")
    );
    assert_eq!(simulator.time(), 0.0, "a refused step does not advance");
    assert!(simulator.step(&[0.0]).is_ok());
}
