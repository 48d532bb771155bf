//! Tests of the task-space frame the Whitworth laws share ([`super::task`]), run under one concrete
//! law, OSMC: a sibling of both, so that neither imports the other.

use super::osmc::{build, Osmc, OsmcParams};
use super::task::*;
use super::test_plant::Plant;
use framework::{Controller, ControllerError, Event};
use models::reference::Reference;

fn osmc(task: TaskParams) -> Result<Osmc, ControllerError> {
    build(OsmcParams {
        task,
        ..Default::default()
    })
}

#[test]
fn task_errors_name_the_task_entry() {
    let task = |change: fn(&mut TaskParams)| {
        let mut task = TaskParams::default();
        change(&mut task);
        task
    };
    let huge = "-1e308";
    let cases = [
        (
            task(|t| t.workpiece_length = 0.5),
            "task.workpiece_length",
            "0.5",
            "must be shorter than the stroke",
        ),
        (
            task(|t| t.cutting_velocity = -1e308),
            "task.cutting_velocity",
            huge,
            "must leave a usable blend (t_a",
        ),
        (
            task(|t| t.cutting_velocity = 1.25),
            "task.cutting_velocity",
            "1.25",
            "must point along the cutting stroke",
        ),
        (
            task(|t| t.return_drive_torque = 0.0),
            "task.return_drive_torque",
            "0",
            "must be > 0",
        ),
        (
            task(|t| t.gravity = f64::INFINITY),
            "task.gravity",
            "inf",
            "must be a finite number",
        ),
        (
            task(|t| t.masses.crank.mass = -1.0),
            "task.masses.crank.mass",
            "-1",
            "must be finite and ≥ 0",
        ),
        (
            task(|t| t.geometry.coupler_length = 0.1),
            "task.geometry.coupler_length",
            "0.1",
            "must be > ",
        ),
    ];
    for (task, key, value, reason) in cases {
        let err = osmc(task).err().unwrap();
        assert!(
            matches!(
                &err,
                ControllerError::BadParameter { controller, key: k, value: Some(v), reason: r }
                    if controller == "osmc" && k == key && v == value && r.starts_with(reason)
            ),
            "{err}"
        );
    }
}

#[test]
fn return_torque_beyond_the_actuator_is_an_error_at_reset() {
    let mut controller = osmc(TaskParams {
        return_drive_torque: 400.0,
        ..Default::default()
    })
    .unwrap();
    let err = controller.reset(&Plant::twin().interface()).unwrap_err();
    assert!(
        matches!(&err, ControllerError::BadParameter { key, value: Some(value), reason, .. }
            if key == "task.return_drive_torque" && value == "400"
                && reason.contains("return stroke part 1")),
        "{err}"
    );
}

#[test]
fn reference_choice_follows_the_plant() {
    let mut tracking = Plant::twin();
    tracking.reference = Some(Reference::Constant { value: -0.1 });
    let mut controller = osmc(TaskParams::default()).unwrap();
    controller.reset(&tracking.interface()).unwrap();
    tracking.run(&mut controller, 0.002, 1e-3);
    let mut events = Vec::new();
    controller.drain_events(&mut events);
    assert_eq!(
        events,
        [Event::mode(
            "tracking",
            "tracking the scenario reference: OSMC"
        )]
    );

    let mut controller = osmc(TaskParams::default()).unwrap();
    controller.reset(&Plant::twin().interface()).unwrap();
    Plant::twin().run(&mut controller, 0.002, 1e-3);
    controller.drain_events(&mut events);
    assert_eq!(
        events.last().map(|e| (e.mode_entered(), e.text.as_str())),
        Some((Some("cutting_stroke"), "cutting stroke: OSMC"))
    );

    let mut controller = osmc(TaskParams {
        reference: ReferenceChoice::Scenario,
        ..Default::default()
    })
    .unwrap();
    let err = controller.reset(&Plant::twin().interface()).unwrap_err();
    assert!(
        matches!(err, ControllerError::MissingSignal { ref signal, .. } if signal == "reference"),
        "{err}"
    );
}

#[test]
fn internals_cover_the_shared_signals_and_the_law() {
    let mut controller = osmc(TaskParams::default()).unwrap();
    controller.reset(&Plant::twin().interface()).unwrap();
    let names = framework::signal_names(&controller.internals());
    for name in [
        "mode",
        "reference",
        "u",
        "rho_hat",
        "s",
        "sigma",
        "k_x",
        "s_x",
    ] {
        assert!(
            names.iter().any(|n| n == name),
            "{name} missing from {names:?}"
        );
    }
    Plant::twin().run(&mut controller, 0.01, 1e-3);
    let mut values = vec![0.0; names.len()];
    controller.internal_values(&mut values);
    assert_eq!(values[0], 1.0, "cutting");
    let rho_hat = values[names.iter().position(|n| n == "rho_hat").unwrap()];
    assert_eq!(rho_hat, controller.design().slider.jacobian_gain());
}
