//! The OSMC paper (Perrusquía et al. 2022) on the twin's Whitworth shaper: constant cutting
//! velocity against the 400 N contact force with full crank turns, and the tracking comparison of
//! its Fig. 8.

use twin::{Observer, ObserverError, SignalLayout, StepView, Twin};
use twin_tests::{builtin, run, Configure};

#[test]
fn osmc_cuts_at_constant_velocity_against_the_contact_force() {
    let summary = run(builtin("whitworth-cutting").loaded(), None);
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

/// The scenario's `tracking_mse`: the mean of (L·(y_d − y))² over the run's last 2 s, L = 100
/// (the paper's §6.1 MSE), from the signals the controller measured.
fn tracking_mse(controller: &str) -> f64 {
    let loaded = builtin("whitworth-tracking")
        .controller(controller)
        .loaded();
    let summary = run(loaded, None);
    assert!(
        summary.failure.is_none(),
        "{controller}: {:?}",
        summary.failure
    );
    summary
        .metric("tracking_mse")
        .expect("declared in the scenario")
}

/// The same figure by hand, from an observer of the measured reference and ram position: the
/// scenario's evaluator agrees with it to the bit.
#[derive(Default)]
struct MseByHand {
    indices: Option<(usize, usize)>,
    sum: f64,
    samples: usize,
}

impl Observer for MseByHand {
    fn start(&mut self, layout: &SignalLayout) -> Result<(), ObserverError> {
        self.indices = layout
            .signal("reference")
            .zip(layout.signal("ram_position"));
        Ok(())
    }

    fn observe(&mut self, view: &StepView) -> Result<(), ObserverError> {
        let (r, y) = self.indices.ok_or("no reference or ram position")?;
        if view.control_update && view.time >= 2.0 {
            let error = 100.0 * (view.measured[r] - view.measured[y]);
            self.sum += error * error;
            self.samples += 1;
        }
        Ok(())
    }
}

#[test]
fn the_declared_tracking_mse_is_the_papers_formula() {
    let loaded = builtin("whitworth-tracking").duration(2.5).loaded();
    let mut by_hand = MseByHand::default();
    let summary = Twin::new(loaded)
        .and_then(|twin| twin.run_with(None, &mut [&mut by_hand]))
        .unwrap();
    let declared = summary.metric("tracking_mse").unwrap();
    assert_eq!(by_hand.samples, 501, "2.0 s to 2.5 s at 1 kHz");
    assert_eq!(declared, by_hand.sum / by_hand.samples as f64);
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
