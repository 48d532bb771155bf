//! The OSMC paper (Perrusquía et al. 2022) on the twin's Whitworth shaper: constant cutting
//! velocity against the 400 N contact force with full crank turns, and the tracking comparison of
//! its Fig. 8.

use controllers::{Controller, ControllerError, Measurement, PlantInterface, Registry};
use std::sync::{Arc, Mutex};
use twin::{Overrides, Twin};
use twin_tests::{run, scenario};

#[test]
fn osmc_cuts_at_constant_velocity_against_the_contact_force() {
    let summary = run(scenario("whitworth-cutting", &[]), None);
    assert!(summary.failure.is_none(), "{:?}", summary.failure);
    let metric = |name: &str| summary.metric(name).unwrap_or_else(|| panic!("no {name}"));
    let cuts = metric("cuts");
    let rms = metric("velocity_error_rms/after_first_cut");
    let max = metric("velocity_error_max/after_first_cut");
    println!(
        "{cuts} cuts; velocity error after the first: RMS {rms:.4} m/s, max {max:.4} m/s; \
         quick-return ratio {:.3}, cycle {:.3} s",
        metric("quick_return_ratio"),
        metric("cycle_time")
    );
    assert!(cuts >= 3.0, "only {cuts} whole cuts");
    assert!(
        rms <= 0.02 * 1.25,
        "velocity error RMS {rms} m/s over the workpiece"
    );
    // The crank turns clockwise all the time, a whole turn per cycle.
    assert_eq!(metric("crank_reversals"), 0.0);
    assert!(
        metric("crank_turns") <= -cuts + 0.5,
        "{} turns",
        metric("crank_turns")
    );
}

/// Mean of (L·(y_d − y))² over the run's last `window` seconds, L = 100 (the paper's §6.1 MSE),
/// from the signals the controller measured.
struct MseProbe {
    inner: Box<dyn Controller>,
    window_start: f64,
    indices: (usize, usize),
    sum: Arc<Mutex<(f64, usize)>>,
}

impl Controller for MseProbe {
    fn name(&self) -> &str {
        self.inner.name()
    }

    fn reset(&mut self, plant: &PlantInterface) -> Result<(), ControllerError> {
        self.indices = (plant.signal("reference")?, plant.signal("ram_position")?);
        self.inner.reset(plant)
    }

    fn update(&mut self, measurement: &Measurement, period: f64, efforts: &mut [f64]) {
        if measurement.time >= self.window_start {
            let error = 100.0 * (measurement.get(self.indices.0) - measurement.get(self.indices.1));
            let mut sum = self.sum.lock().unwrap();
            sum.0 += error * error;
            sum.1 += 1;
        }
        self.inner.update(measurement, period, efforts);
    }
}

fn tracking_mse(controller: &str) -> f64 {
    let loaded = twin::load_scenario(
        "whitworth-tracking",
        &Overrides {
            controller: Some(controller.into()),
            ..Default::default()
        },
    )
    .unwrap();
    let inner = Registry::builtin()
        .build(controller, &loaded.scenario.controller.params)
        .unwrap();
    let sum = Arc::new(Mutex::new((0.0, 0)));
    let probe = MseProbe {
        inner,
        window_start: loaded.scenario.duration - 2.0,
        indices: (0, 0),
        sum: Arc::clone(&sum),
    };
    let summary = Twin::with_controller(loaded, Box::new(probe))
        .and_then(|t| t.run(None))
        .unwrap();
    assert!(
        summary.failure.is_none(),
        "{controller}: {:?}",
        summary.failure
    );
    let (total, samples) = *sum.lock().unwrap();
    total / samples as f64
}

#[test]
fn osmc_tracks_eq_35_with_the_smallest_mse() {
    let mse: Vec<(&str, f64)> = ["osmc", "ffc", "lqt", "smc2"]
        .into_iter()
        .map(|c| (c, tracking_mse(c)))
        .collect();
    println!("MSE of the last 2 s (cm²): {mse:?}");
    let osmc = mse[0].1;
    for (controller, value) in &mse[1..] {
        assert!(osmc < *value, "osmc {osmc} vs {controller} {value}");
    }
}
