//! Fault injection (`[[faults]]`) and URDF values as scenario values (`[plant]`, `urdf.…`):
//! each fault's effect against what it is defined to do, measured on real runs.

use framework::{Event, EventKind};
use twin::{
    LoadedScenario, Observer, ObserverError, RunSummary, Scenario, SignalLayout, StepView, Twin,
};

/// At every control update: time, the true and measured crank speed and the crank's applied
/// effort; at every step the shaper's contact force (when it cuts); every event.
#[derive(Default)]
struct Trace {
    signal: usize,
    actuator: usize,
    rows: Vec<[f64; 4]>,
    contact: Option<usize>,
    contact_force: Vec<f64>,
    events: Vec<Event>,
}

impl Observer for Trace {
    fn start(&mut self, layout: &SignalLayout) -> Result<(), ObserverError> {
        self.signal = layout.signal("crank.velocity").ok_or("no crank.velocity")?;
        self.actuator = layout.actuator("crank").ok_or("no crank actuator")?;
        self.contact = layout.diagnostic("contact_force");
        Ok(())
    }

    fn observe(&mut self, view: &StepView) -> Result<(), ObserverError> {
        self.events.extend(view.events.iter().cloned());
        if let Some(contact) = self.contact {
            self.contact_force.push(view.diagnostics[contact]);
        }
        if view.control_update {
            self.rows.push([
                view.time,
                view.signals[self.signal],
                view.measured[self.signal],
                view.applied[self.actuator],
            ]);
        }
        Ok(())
    }
}

fn scenario(name: &str, faults: &str, duration: f64) -> LoadedScenario {
    let text = builtin_text(name);
    Scenario::from_toml(&format!("{text}\n{faults}"), name, None)
        .map(|s| s.duration(duration))
        .and_then(|s| s.build(&controllers::builtin()))
        .unwrap_or_else(|e| panic!("{e}"))
}

fn builtin_text(name: &str) -> &'static str {
    twin::BUILTIN_SCENARIOS
        .iter()
        .find(|(n, _)| *n == name)
        .unwrap()
        .1
}

fn traced(loaded: LoadedScenario) -> (RunSummary, Trace) {
    let mut trace = Trace::default();
    let summary = Twin::new(loaded)
        .and_then(|twin| twin.run_with(None, &mut [&mut trace]))
        .unwrap_or_else(|e| panic!("{e}"));
    (summary, trace)
}

fn fault(kind: &str, rest: &str) -> String {
    format!("[[faults]]\nkind = \"{kind}\"\nstart = 0.3\nend = 0.6\n{rest}\n")
}

fn window(trace: &Trace, from: f64, to: f64) -> Vec<[f64; 4]> {
    trace
        .rows
        .iter()
        .copied()
        .filter(|r| r[0] >= from - 1e-9 && r[0] < to - 1e-9)
        .collect()
}

#[test]
fn sensor_faults_change_only_the_reading_as_defined() {
    let on = |kind: &str, value: &str| {
        let loaded = scenario(
            "whitworth-crank-pi",
            &fault(kind, &format!("signal = \"crank.velocity\"\n{value}")),
            0.8,
        );
        traced(loaded).1
    };
    let bias = on("sensor_bias", "value = 0.25");
    for [t, truth, measured, _] in bias.rows.iter().copied() {
        let expected = if (0.3..0.6 - 1e-9).contains(&t) {
            truth + 0.25
        } else {
            truth
        };
        assert_eq!(measured, expected, "bias at t = {t}");
    }
    let drift = on("sensor_drift", "value = 2.0");
    for [t, truth, measured, _] in window(&drift, 0.3, 0.6) {
        assert!(
            (measured - truth - 2.0 * (t - 0.3)).abs() < 1e-12,
            "drift at {t}"
        );
    }
    let stuck = on("sensor_stuck", "");
    let before = window(&stuck, 0.0, 0.3).last().unwrap()[2];
    assert!(window(&stuck, 0.3, 0.6).iter().all(|r| r[2] == before));
    assert!(
        window(&stuck, 0.3, 0.6).iter().any(|r| r[1] != before),
        "the crank moves on"
    );
    let stuck_at = on("sensor_stuck", "value = -1.5");
    assert!(window(&stuck_at, 0.3, 0.6).iter().all(|r| r[2] == -1.5));
    let dropout = on("sensor_dropout", "");
    assert!(window(&dropout, 0.3, 0.6).iter().all(|r| r[2] == before));
    let delay = on("sensor_delay", "value = 0.01");
    for [t, _, measured, _] in window(&delay, 0.31, 0.6) {
        let earlier = delay
            .rows
            .iter()
            .find(|r| (r[0] - (t - 0.01)).abs() < 1e-9)
            .unwrap();
        assert_eq!(measured, earlier[1], "delayed reading at {t}");
    }
    let noisy = on("sensor_noise", "value = 0.1");
    let errors: Vec<f64> = window(&noisy, 0.3, 0.6)
        .iter()
        .map(|r| r[2] - r[1])
        .collect();
    let sigma = (errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt();
    assert!((0.08..0.12).contains(&sigma), "extra noise σ {sigma}");
    // Onset and end are events, named after the kind and index.
    let names: Vec<String> = bias
        .events
        .iter()
        .filter_map(|e| match &e.kind {
            EventKind::FaultOnset { name } => Some(format!("onset {name}")),
            EventKind::FaultCleared { name } => Some(format!("end {name}")),
            _ => None,
        })
        .collect();
    assert_eq!(names, ["onset sensor_bias_0", "end sensor_bias_0"]);
}

#[test]
fn actuator_faults_act_between_the_limits_and_the_drive() {
    let on = |kind: &str, value: &str| {
        let text = fault(kind, &format!("joint = \"crank\"\n{value}"));
        traced(scenario("whitworth-crank-pi", &text, 0.8)).1
    };
    let healthy = traced(scenario("whitworth-crank-pi", "", 0.8)).1;
    let dead = on("actuator_effectiveness", "value = 0.0");
    assert!(window(&dead, 0.3, 0.6).iter().all(|r| r[3] == 0.0));
    assert_eq!(
        window(&dead, 0.0, 0.3),
        window(&healthy, 0.0, 0.3),
        "nothing before onset"
    );
    let limited = on("actuator_limit", "value = 0.5");
    assert!(window(&limited, 0.3, 0.6).iter().all(|r| r[3].abs() <= 0.5));
    assert!(window(&limited, 0.3, 0.6).iter().any(|r| r[3].abs() == 0.5));
    let stuck = on("actuator_stuck", "value = 2.0");
    assert!(window(&stuck, 0.3, 0.6).iter().all(|r| r[3] == 2.0));
}

#[test]
fn a_mass_fault_from_the_start_equals_the_same_mass_given_as_a_plant_value() {
    let faulted = scenario(
        "whitworth-crank-pi",
        "[[faults]]\nkind = \"link_mass\"\nlink = \"ram\"\nvalue = 6.5\nstart = 0.0\n",
        0.5,
    );
    let plant = Scenario::builtin("whitworth-crank-pi")
        .and_then(|s| s.duration(0.5).set("urdf.link.ram.mass", 6.5))
        .and_then(|s| s.build(&controllers::builtin()))
        .unwrap();
    let nominal = traced(scenario("whitworth-crank-pi", "", 0.5)).0;
    let (faulted, plant) = (traced(faulted).0, traced(plant).0);
    assert_eq!(faulted.series_digest, plant.series_digest);
    assert_ne!(
        faulted.series_digest, nominal.series_digest,
        "a heavier ram"
    );
}

#[test]
fn a_ramped_damping_fault_returns_to_the_urdf_value_at_its_end() {
    // Damping on the crank from 0 to 5 N·m·s/rad over 0.1 s, then back at 0.6 s.
    let text = fault(
        "joint_damping",
        "joint = \"crank\"\nvalue = 5.0\nramp = 0.1",
    );
    let (faulted, trace) = traced(scenario("whitworth-crank-pi", &text, 0.8));
    let healthy = traced(scenario("whitworth-crank-pi", "", 0.8)).1;
    let speed_at =
        |t: &Trace, time: f64| t.rows.iter().find(|r| (r[0] - time).abs() < 1e-9).unwrap()[1];
    assert_eq!(speed_at(&trace, 0.3), speed_at(&healthy, 0.3));
    assert!(
        speed_at(&trace, 0.6).abs() < speed_at(&healthy, 0.6).abs(),
        "damped"
    );
    assert_eq!(faulted.failure, None);
}

#[test]
fn tool_breakage_removes_the_cutting_force_and_a_hard_spot_scales_it() {
    let contact = |faults: &str| traced(scenario("whitworth-cutting", faults, 3.0)).1;
    let healthy = contact("");
    let broken = contact("[[faults]]\nkind = \"tool_breakage\"\nstart = 0.0\n");
    let peak = |t: &Trace| t.contact_force.iter().fold(0.0, |m: f64, f| m.max(f.abs()));
    assert!(peak(&healthy) > 100.0, "the ram cuts: {} N", peak(&healthy));
    assert_eq!(peak(&broken), 0.0);
    let hard = contact("[[faults]]\nkind = \"hard_spot\"\nvalue = 2.0\nstart = 0.0\n");
    assert!(
        peak(&hard) > 1.5 * peak(&healthy),
        "{} vs {}",
        peak(&hard),
        peak(&healthy)
    );
}

#[test]
fn bad_faults_and_plant_values_name_the_entry() {
    let error = |extra: &str| {
        let text = format!("{}\n{extra}", builtin_text("whitworth-crank-pi"));
        match Scenario::from_toml(&text, "s.toml", None)
            .and_then(|s| s.build(&controllers::builtin()))
        {
            Err(e) => e.to_string(),
            Ok(loaded) => match Twin::new(loaded) {
                Err(e) => e.to_string(),
                Ok(_) => panic!("accepted: {extra}"),
            },
        }
    };
    let cases = [
        ("[[faults]]\nkind = \"sensor_bias\"\nstart = 0.1\n", "needs `signal`"),
        ("[[faults]]\nkind = \"sensor_bias\"\nsignal = \"crank.velocity\"\nstart = 0.1\n", "needs a value"),
        ("[[faults]]\nkind = \"sensor_bias\"\nsignal = \"nope\"\nvalue = 1.0\nstart = 0.1\n", "no measured signal `nope`"),
        ("[[faults]]\nkind = \"link_mass\"\nlink = \"ram\"\nvalue = -1.0\nstart = 0.1\n", "must be finite and >"),
        ("[[faults]]\nkind = \"tool_breakage\"\nstart = 0.1\n", "no cutting process"),
        ("[[faults]]\nkind = \"hard_spot\"\nvalue = 2.0\nstart = 0.5\nend = 0.2\n", "must be after start"),
        ("[[faults]]\nkind = \"actuator_stuck\"\njoint = \"crank\"\nsignal = \"crank.velocity\"\nstart = 0.1\n", "`signal` does not apply"),
        ("[[faults]]\nkind = \"sensor_stuck\"\nsignal = \"crank.velocity\"\nstart = 99.0\n", "after the run's end"),
        ("[plant.link.nope]\nmass = 1.0\n", "plant.link.nope: the URDF has no such link"),
        ("[plant.joint.crank]\ndamping = -1.0\n", "damping must be ≥ 0"),
        ("[plant.joint.slot_pivot]\neffort_limit = 3.0\n", "does not drive this joint"),
    ];
    for (extra, expected) in cases {
        let message = error(extra);
        assert!(message.contains(expected), "{extra}: {message}");
        assert_eq!(message.lines().count(), 1, "{message}");
    }
}

#[test]
fn array_entries_are_addressable_by_index() {
    let text = format!(
        "{}\n{}",
        builtin_text("whitworth-crank-pi"),
        "[[faults]]\nkind = \"sensor_bias\"\nsignal = \"crank.velocity\"\nvalue = 1.0\nstart = 0.1\n"
    );
    let loaded = Scenario::from_toml(&text, "s", None)
        .and_then(|s| s.set("faults.0.start", 0.2))
        .and_then(|s| s.assign("faults.0.value=2.5"))
        .and_then(|s| s.build(&controllers::builtin()))
        .unwrap();
    assert_eq!(loaded.scenario.faults[0].start, 0.2);
    assert_eq!(loaded.scenario.faults[0].value, Some(2.5));
    let missing = Scenario::from_toml(&text, "s", None)
        .and_then(|s| s.set("faults.3.start", 0.2))
        .unwrap_err();
    assert!(missing.to_string().contains("has 1 entries"), "{missing}");
    let no_index = Scenario::from_toml(&text, "s", None)
        .and_then(|s| s.set("faults.start", 0.2))
        .unwrap_err();
    assert!(
        no_index.to_string().contains("give an entry's index"),
        "{no_index}"
    );
}

#[test]
fn a_fault_is_added_by_its_next_index() {
    let added = ["kind=link_mass", "link=ram", "value=6", "start=0.05"]
        .iter()
        .try_fold(
            Scenario::from_toml(builtin_text("whitworth-crank-pi"), "s", None).unwrap(),
            |s, part| s.assign(&format!("faults.0.{part}")),
        )
        .and_then(|s| s.assign("faults.1.kind=joint_friction"))
        .and_then(|s| s.assign("faults.1.joint=crank"))
        .and_then(|s| s.assign("faults.1.value=2"))
        .and_then(|s| s.assign("faults.1.start=1"))
        .and_then(|s| s.build(&controllers::builtin()))
        .unwrap();
    let faults = &added.scenario.faults;
    assert_eq!(faults.len(), 2);
    assert_eq!((faults[0].start, faults[0].value), (0.05, Some(6.0)));
    assert_eq!(faults[1].value, Some(2.0));
    let skipped = Scenario::from_toml(builtin_text("whitworth-crank-pi"), "s", None)
        .and_then(|s| s.assign("faults.1.kind=link_mass"))
        .unwrap_err();
    assert!(
        skipped.to_string().contains("a new one is `faults.0`"),
        "{skipped}"
    );
}
