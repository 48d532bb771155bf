//! `[actuators.<joint>] kind = "effort"`, ideal drives chosen by the scenario: the arm applies
//! the commanded torque bit for bit (as the same torque from outside the machine does), per
//! joint or for all, shows N·m wherever the command's unit shows (the simulator, the run CSV,
//! the recording's plots), reports no current; what cannot be is refused in one line naming the
//! key.

use twin::recordings::SeriesRole;
use twin::RunTable;
use twin::{ScenarioBuilder, Simulator, Twin};
use twin_tests::{builtin, refusal, scratch, Configure};

/// The arm's three joint torques, N·m: within every effort limit (84 / 60 / 20 N·m).
const TORQUES: [f64; 3] = [30.0, -12.5, 3.0];
/// Control periods stepped.
const PERIODS: usize = 100;

fn arm() -> ScenarioBuilder {
    builtin("arm-milling").duration(0.2)
}

fn ideal(builder: ScenarioBuilder) -> ScenarioBuilder {
    builder
        .assign("actuators.\"*\".kind=effort")
        .unwrap_or_else(|e| panic!("{e}"))
}

/// The true signals over [`PERIODS`] control periods of the arm's plant, `efforts` commanded
/// through its actuators, and of the arm under `passive` (no command) with [`TORQUES`] put on
/// its joints from outside the machine, past its drives.
fn commanded_and_outside(builder: ScenarioBuilder, efforts: [f64; 3]) -> [Vec<Vec<f64>>; 2] {
    let mut commanded = Simulator::new(builder.clone().loaded()).unwrap();
    let registry = controllers::builtin();
    let passive = builder.controller("passive").loaded();
    let mut outside = Simulator::with_controller(passive, &registry).unwrap();
    let disturbances: Vec<f64> = (outside.joints().iter())
        .map(|(joint, _)| match *joint {
            "shoulder" => TORQUES[0],
            "elbow" => TORQUES[1],
            "wrist" => TORQUES[2],
            _ => 0.0,
        })
        .collect();
    let mut runs = [Vec::new(), Vec::new()];
    for _ in 0..PERIODS {
        commanded.step(&efforts).unwrap();
        runs[0].push(commanded.true_signals().to_vec());
        outside.step_closed_loop(&disturbances, [0.0; 3]).unwrap();
        runs[1].push(outside.true_signals().to_vec());
    }
    runs
}

#[test]
fn an_ideal_drive_applies_the_commanded_torque_exactly() {
    let [commanded, outside] = commanded_and_outside(ideal(arm()), TORQUES);
    assert_eq!(
        commanded, outside,
        "the commanded torques are not those applied"
    );
    let plant = Simulator::new(ideal(arm()).loaded()).unwrap();
    assert_eq!(plant.command_units(), ["N·m"; 3]);
    assert_eq!(plant.command_limits(), [84.0, 60.0, 20.0]);
    // No drive, no current: the joints' currents read 0 all along (the spindle's drive stays).
    let specs = plant.signal_specs();
    for joint in ["shoulder", "elbow", "wrist"] {
        let i = (specs
            .iter()
            .position(|s| s.name == format!("{joint}_current")))
        .unwrap();
        assert!(commanded.iter().all(|signals| signals[i] == 0.0), "{joint}");
    }
    // Through the machine's drives the same torques (as currents, G·k_t = 4.2 / 3 / 1 N·m/A)
    // arrive late and changed: the comparison can fail.
    let currents = [TORQUES[0] / 4.2, TORQUES[1] / 3.0, TORQUES[2] / 1.0];
    let [driven, outside] = commanded_and_outside(arm(), currents);
    assert_ne!(driven, outside);
}

#[test]
fn ideal_drives_are_chosen_per_joint() {
    let units = |builder: ScenarioBuilder| {
        let plant = Simulator::new(builder.loaded()).unwrap();
        (plant.command_units(), plant.command_limits().to_vec())
    };
    let elbow = arm().assign("actuators.elbow.kind=effort").unwrap();
    assert_eq!(
        units(elbow),
        (vec!["A", "N·m", "A"], vec![20.0, 60.0, 20.0])
    );
    // A joint's own entry overrides "*".
    let but_shoulder = ideal(arm()).with("actuators.shoulder.kind", "drive");
    assert_eq!(
        units(but_shoulder),
        (vec!["A", "N·m", "N·m"], vec![20.0, 60.0, 20.0])
    );
    // The table absent, or every entry `drive`: the machine's drives, as ever.
    assert_eq!(units(arm()), (vec!["A"; 3], vec![20.0; 3]));
    let drives = arm().with("actuators.\"*\".kind", "drive");
    assert_eq!(units(drives), (vec!["A"; 3], vec![20.0; 3]));
}

#[test]
fn a_run_csv_and_the_recording_show_the_torque_commands_in_n_m() {
    let dir = scratch("actuators-csv");
    let csv = dir.join("run.csv");
    let twin = Twin::new(ideal(arm()).loaded()).unwrap();
    let (plots, _) = twin.recording_plan();
    let torque = (plots.iter().find(|p| p.title() == "shoulder torque [N·m]")).unwrap();
    let commanded = |s: &twin::recordings::SeriesSpec| {
        s.name == "shoulder commanded" && s.role == SeriesRole::Commanded
    };
    assert!(torque.series.iter().any(commanded), "{:?}", torque.series);
    let mut table = RunTable::new(Some(csv.clone()), None);
    twin.run_with(None, &mut [&mut table]).unwrap();
    let text = std::fs::read_to_string(&csv).unwrap();
    let header = text.lines().next().unwrap();
    for joint in ["shoulder", "elbow", "wrist"] {
        let column = format!("effort.{joint} [N·m]");
        assert!(header.split(',').any(|c| c == column), "{header}");
    }
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn the_feed_axis_drive_made_ideal_has_no_current() {
    let current = |builder: ScenarioBuilder| {
        let mut plant = Simulator::new(builder.loaded()).unwrap();
        plant.step(&[100.0]).unwrap();
        let i = (plant.signal_specs().iter())
            .position(|s| s.name == "table_current")
            .unwrap();
        (plant.command_units(), plant.true_signals()[i])
    };
    let axis = || builtin("feed-axis-micromilling").duration(0.1);
    // 100 N at K_a = 50 N/A: 2 A through the amplifier, none without it.
    assert_eq!(current(axis()), (vec!["N"], 2.0));
    let ideal = axis().with("actuators.table.kind", "effort");
    assert_eq!(current(ideal), (vec!["N"], 0.0));
}

#[test]
fn what_cannot_be_is_refused_naming_the_key() {
    let refused = |builder: ScenarioBuilder, expected: &[&str]| {
        let error = refusal(builder).expect("refused");
        println!("{error}");
        assert!(!error.contains('\n'), "{error}");
        for part in expected {
            assert!(error.contains(part), "{error} (expected {part})");
        }
    };
    let set = |key: &str, value: &str| arm().with(key, value);
    refused(
        set("actuators.elbow.kind", "torque"),
        &["actuators.elbow.kind", "`torque`", "`drive`", "`effort`"],
    );
    refused(
        arm().with("actuators.elbow.gain", 1.0),
        &["actuators.elbow", "`gain`", "`kind`"],
    );
    refused(
        set("actuators.elbo.kind", "effort"),
        &[
            "actuators.elbo:",
            "no joint `elbo`",
            "shoulder, elbow, wrist",
        ],
    );
    refused(
        set("actuators.spindle.kind", "effort"),
        &[
            "actuators.spindle:",
            "not an actuator",
            "shoulder, elbow, wrist",
        ],
    );
    let platform = builtin("platform-path").with("actuators.\"*\".kind", "effort");
    refused(
        platform,
        &["actuators.\"*\":", "left_wheel", "kind = \"drive\""],
    );
    let wheel = builtin("platform-path").with("actuators.right_wheel.kind", "effort");
    refused(wheel, &["actuators.right_wheel:", "right_wheel"]);
    // The command line's `--set` takes the same keys.
    let error = arm()
        .assign("actuators.wrist.kind=ideal")
        .and_then(|b| b.build(&controllers::builtin()))
        .unwrap_err()
        .to_string();
    assert!(error.contains("actuators.wrist.kind"), "{error}");
}
