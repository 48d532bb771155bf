//! `Twin::with_setpoints`, a whole run's reference offset from outside: a zero offset leaves the
//! run bit for bit as it is, a changing one agrees bit for bit with the same offsets given to
//! `Simulator::step_closed_loop`, and a scenario whose reference an offset cannot reach is
//! refused.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use twin::{
    LoadedScenario, Observer, ObserverError, Scenario, SetpointSource, Simulator, StepView, Twin,
};

const BLOCK: usize = 20;
const OFFSETS: [[f64; 3]; 3] = [[0.0; 3], [2.0e-6, 0.0, 0.0], [-1.0e-6, 3.0e-5, 1.0e-4]];

fn loaded(name: &str, duration: f64) -> LoadedScenario {
    Scenario::builtin(name)
        .and_then(|s| s.duration(duration).build(&controllers::builtin()))
        .unwrap_or_else(|e| panic!("{e}"))
}

/// The offsets by control update: `OFFSETS[k / BLOCK]`, the update counted by the observer.
#[derive(Default)]
struct Schedule(AtomicUsize);

impl SetpointSource for Schedule {
    fn offset(&self) -> [f64; 3] {
        let k = self.0.load(Ordering::Relaxed);
        OFFSETS[(k / BLOCK).min(OFFSETS.len() - 1)]
    }
}

/// Counts the control updates for the schedule and keeps the measured signals at each.
struct Updates(Arc<Schedule>, Vec<Vec<f64>>);

impl Observer for Updates {
    fn observe(&mut self, view: &StepView) -> Result<(), ObserverError> {
        if view.control_update {
            self.1.push(view.measured.to_vec());
            self.0 .0.fetch_add(1, Ordering::Relaxed);
        }
        Ok(())
    }
}

#[test]
fn a_zero_offset_leaves_the_run_bit_for_bit() {
    let plain = Twin::new(loaded("feed-axis-micromilling", 0.02)).unwrap();
    let plain = plain.run(None).unwrap();
    let zero = Twin::new(loaded("feed-axis-micromilling", 0.02)).unwrap();
    let zero = zero.with_setpoints(Arc::new(Schedule::default())).unwrap();
    assert_eq!(zero.run(None).unwrap().series_digest, plain.series_digest);
}

#[test]
fn a_run_with_setpoints_is_the_closed_loop_stepped_with_them() {
    let schedule = Arc::new(Schedule::default());
    let twin = Twin::new(loaded("feed-axis-micromilling", 0.01))
        .unwrap()
        .with_setpoints(schedule.clone())
        .unwrap();
    let mut updates = Updates(schedule, Vec::new());
    twin.run_with(None, &mut [&mut updates]).unwrap();
    let registry = controllers::builtin();
    let mut simulator =
        Simulator::with_controller(loaded("feed-axis-micromilling", 0.01), &registry).unwrap();
    let zeros = vec![0.0; simulator.joints().len()];
    for k in 1..updates.1.len() {
        let offset = OFFSETS[((k - 1) / BLOCK).min(OFFSETS.len() - 1)];
        let measured = simulator.step_closed_loop(&zeros, offset).unwrap();
        // At a block's first update the run's reference already has the new offset.
        if k % BLOCK != 0 {
            assert_eq!(measured, &updates.1[k][..], "update {k}");
        }
    }
}

#[test]
fn a_scenario_without_a_reference_is_refused() {
    let twin = Twin::new(loaded("whitworth-crank-pi", 0.01)).unwrap();
    let error = twin
        .with_setpoints(Arc::new(Schedule::default()))
        .err()
        .unwrap()
        .to_string();
    assert!(error.contains("no [reference]"), "{error}");
    assert_eq!(error.lines().count(), 1);
}
