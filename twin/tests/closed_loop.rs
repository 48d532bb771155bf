//! `Simulator::with_controller`, the twin's closed loop stepped from outside, against the twin's
//! own run of the scenario (`Twin::run_with`, an independent path) bit for bit: with no input,
//! with a disturbance (as `Twin::with_joint_effort` applies one), with a reference offset (as
//! `--set reference.offset` gives one); and its refusals.

use twin::{
    LoadedScenario, Observer, ObserverError, Scenario, Simulator, StepError, StepView, Twin,
};

fn loaded(name: &str, duration: f64, set: &[&str]) -> LoadedScenario {
    let builder = Scenario::builtin(name).map(|s| s.duration(duration));
    set.iter()
        .fold(builder, |b, assignment| {
            b.and_then(|b| b.assign(assignment))
        })
        .and_then(|s| s.build(&controllers::builtin()))
        .unwrap_or_else(|e| panic!("{e}"))
}

/// At every control update: time, measured and true signals, commanded efforts, internals.
#[derive(Default)]
struct Updates(Vec<[Vec<f64>; 5]>);

impl Observer for Updates {
    fn observe(&mut self, view: &StepView) -> Result<(), ObserverError> {
        if view.control_update {
            self.0.push([
                vec![view.time],
                view.measured.to_vec(),
                view.signals.to_vec(),
                view.commanded.to_vec(),
                view.internals.to_vec(),
            ]);
        }
        Ok(())
    }
}

fn run(twin: Twin) -> Updates {
    let mut updates = Updates::default();
    let summary = twin.run_with(None, &mut [&mut updates]).unwrap();
    assert!(summary.failure.is_none(), "{:?}", summary.failure);
    updates
}

/// Steps `simulator` through the run's updates with `inputs(k)` (disturbances, reference
/// offset) at period k and checks each against the run: the signals at the period's end, the
/// efforts and internals of its start's update.
fn check(
    name: &str,
    run: &Updates,
    simulator: &mut Simulator,
    inputs: impl Fn(usize) -> (Vec<f64>, [f64; 3]),
) {
    // An offset arrives with the first step: before it, the reference is the scenario's.
    if inputs(0).1 == [0.0; 3] {
        assert_eq!(simulator.measured(), &run.0[0][1][..], "{name} at t = 0");
    }
    for k in 1..run.0.len() {
        let (disturbances, offset) = inputs(k - 1);
        let measured = simulator
            .step_closed_loop(&disturbances, offset)
            .unwrap()
            .to_vec();
        let [time, run_measured, signals, _, _] = &run.0[k];
        let [_, _, _, commanded, internals] = &run.0[k - 1];
        assert_eq!(simulator.time().to_bits(), time[0].to_bits(), "{name} {k}");
        assert_eq!(
            &measured, run_measured,
            "{name} measured at t = {}",
            time[0]
        );
        assert_eq!(
            simulator.true_signals(),
            &signals[..],
            "{name} true at {}",
            time[0]
        );
        assert_eq!(
            simulator.commanded(),
            &commanded[..],
            "{name} efforts at {k}"
        );
        assert_eq!(
            simulator.internals(),
            &internals[..],
            "{name} internals at {k}"
        );
    }
    assert!(run.0.len() > 10, "{name}: {} control updates", run.0.len());
}

#[test]
fn the_closed_loop_of_every_machine_steps_as_its_run_bit_for_bit() {
    for (name, duration) in [
        ("whitworth-crank-pi", 0.3),
        ("whitworth-tracking", 0.3),
        ("feed-axis-micromilling", 0.05),
        ("arm-milling", 0.2),
        ("platform-path", 0.1),
        ("lathe-turning", 0.2),
        ("milling-constant-15000", 0.01),
    ] {
        let updates = run(Twin::new(loaded(name, duration, &[])).unwrap());
        let mut simulator =
            Simulator::with_controller(loaded(name, duration, &[]), &controllers::builtin())
                .unwrap();
        let joints = simulator.joints().len();
        assert_eq!(
            simulator.controller(),
            Scenario::builtin(name)
                .and_then(|s| s.build(&controllers::builtin()))
                .map(|l| l.scenario.controller.name)
                .unwrap()
        );
        check(name, &updates, &mut simulator, |_| {
            (vec![0.0; joints], [0.0; 3])
        });
        // A reset builds the controller afresh: the same loop again.
        let seed = simulator.scenario().seed;
        simulator.reset(seed).unwrap();
        check(name, &updates, &mut simulator, |_| {
            (vec![0.0; joints], [0.0; 3])
        });
    }
}

#[test]
fn a_disturbance_acts_as_an_effort_from_outside_on_its_joint() {
    // The table (the drive's own joint) and the Whitworth ram (driven through the linkage).
    for (name, joint, load, duration) in [
        ("feed-axis-micromilling", "table", 5.0, 0.05),
        ("whitworth-crank-pi", "ram", -300.0, 0.3),
    ] {
        let scenario = loaded(name, duration, &[]);
        let every = scenario.scenario.control_every();
        let steps = scenario.scenario.steps();
        let from = 10;
        let efforts = (0..steps)
            .map(|k| if k / every >= from { load } else { 0.0 })
            .collect();
        let twin = Twin::new(scenario)
            .unwrap()
            .with_joint_effort(joint, efforts);
        let updates = run(twin.unwrap());
        let mut simulator =
            Simulator::with_controller(loaded(name, duration, &[]), &controllers::builtin())
                .unwrap();
        let joints: Vec<String> = simulator
            .joints()
            .iter()
            .map(|(n, _)| n.to_string())
            .collect();
        let at = joints.iter().position(|j| j == joint).unwrap();
        check(name, &updates, &mut simulator, |k| {
            let mut disturbances = vec![0.0; joints.len()];
            disturbances[at] = if k >= from { load } else { 0.0 };
            (disturbances, [0.0; 3])
        });
        let plain = run(Twin::new(loaded(name, duration, &[])).unwrap());
        let last = |u: &Updates| u.0.last().map(|u| u[1].clone());
        assert_ne!(
            last(&updates),
            last(&plain),
            "{name}: the load changed nothing"
        );
    }
}

#[test]
fn a_reference_offset_acts_as_the_scenarios_own_offset() {
    let offset = 2.5e-6;
    let set = format!("reference.offset={offset:?}");
    let name = "feed-axis-micromilling";
    let updates = run(Twin::new(loaded(name, 0.05, &[&set])).unwrap());
    let plain = run(Twin::new(loaded(name, 0.05, &[])).unwrap());
    assert_ne!(updates.0[5][1], plain.0[5][1], "the offset moved the table");
    let mut simulator =
        Simulator::with_controller(loaded(name, 0.05, &[]), &controllers::builtin()).unwrap();
    assert_eq!(simulator.reference_inputs(), Ok(()));
    check(name, &updates, &mut simulator, |_| {
        (vec![0.0], [offset, 0.0, 0.0])
    });
}

#[test]
fn closed_loop_inputs_are_checked_by_name() {
    let mut simulator = Simulator::with_controller(
        loaded("whitworth-crank-pi", 1.0, &[]),
        &controllers::builtin(),
    )
    .unwrap();
    let error = simulator.step(&[1.0]).unwrap_err();
    assert!(matches!(error, StepError::ControllerInLoop(_)), "{error}");
    assert!(error.to_string().contains("`crank-pi`"), "{error}");
    let error = simulator.step_closed_loop(&[0.0], [0.0; 3]).unwrap_err();
    assert_eq!(
        error.to_string(),
        "disturbances: 1 values given for 5 joints (crank, slot_pivot, ram, crank_pin, \
         coupler_pin); give one per joint in that order"
    );
    let error = simulator
        .step_closed_loop(&[0.0, 0.0, f64::INFINITY, 0.0, 0.0], [0.0; 3])
        .unwrap_err();
    assert_eq!(
        error.to_string(),
        "disturbance on joint `ram` is inf: must be a finite number"
    );
    let error = simulator
        .step_closed_loop(&[0.0; 5], [0.0, f64::NAN, 0.0])
        .unwrap_err();
    assert_eq!(
        error.to_string(),
        "reference offset `reference_rate` is NaN: must be a finite number"
    );
    let error = simulator
        .step_closed_loop(&[0.0; 5], [0.1, 0.0, 0.0])
        .unwrap_err();
    assert_eq!(
        error.to_string(),
        "reference offset: the scenario has no [reference] to offset; leave it at zero"
    );
    assert_eq!(simulator.time(), 0.0, "refused steps do not advance");
    let mut plant = Simulator::new(loaded("whitworth-crank-pi", 1.0, &[])).unwrap();
    assert_eq!(plant.controller(), "outside");
    let error = plant.step_closed_loop(&[0.0; 5], [0.0; 3]).unwrap_err();
    assert!(matches!(error, StepError::NoController), "{error}");
}
