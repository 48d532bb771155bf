//! Observers, evaluators, typed events and the signal layout, through the library's one door.

use framework::{EventKind, EventLevel};
use twin::BUILTIN_SCENARIOS as BUILTIN;
use twin::{
    Findings, LoadedScenario, Observer, ObserverError, RunSummary, Scenario, SignalLayout,
    StepView, Twin, TwinError,
};

fn builtin_text(name: &str) -> &'static str {
    BUILTIN.iter().find(|(n, _)| *n == name).unwrap().1
}

/// A built-in scenario with `extra` TOML appended (e.g. `[[metrics]]` tables).
fn with_extra(name: &str, extra: &str, duration: f64) -> Result<LoadedScenario, String> {
    let text = format!("{}\n{extra}", builtin_text(name));
    Scenario::from_toml(&text, name, None)
        .map(|s| s.duration(duration))
        .and_then(|s| s.build(&controllers::builtin()))
        .map_err(|e| e.to_string())
}

fn run_with(loaded: LoadedScenario, observers: &mut [&mut dyn Observer]) -> RunSummary {
    Twin::new(loaded)
        .and_then(|twin| twin.run_with(None, observers))
        .unwrap_or_else(|e| panic!("{e}"))
}

/// Keeps every sample of one signal (time, value, whether the controller measured it).
#[derive(Default)]
struct Samples {
    name: String,
    index: Option<usize>,
    values: Vec<(f64, f64)>,
    steps: usize,
    sampled: usize,
    last_seen: bool,
}

impl Observer for Samples {
    fn start(&mut self, layout: &SignalLayout) -> Result<(), ObserverError> {
        self.index = Some(layout.signal(&self.name).ok_or("no such signal")?);
        Ok(())
    }

    fn observe(&mut self, view: &StepView) -> Result<(), ObserverError> {
        let index = self.index.ok_or("not started")?;
        self.values.push((view.time, view.signals[index]));
        self.steps += 1;
        self.sampled += usize::from(view.sampled);
        assert!(!self.last_seen, "a step after the last one");
        self.last_seen = view.last;
        Ok(())
    }
}

#[test]
fn evaluators_follow_their_documented_formulas() {
    let kinds = [
        "mse", "rms", "mean", "std", "max_abs", "max", "min", "final",
    ];
    let mut extra = String::new();
    for kind in kinds {
        extra += &format!(
            "[[metrics]]\nname = \"{kind}\"\nkind = \"{kind}\"\nsignal = \"crank.velocity\"\n\
             from = 0.2\nto = 0.8\nscale = 2.0\n"
        );
    }
    extra +=
        "[[metrics]]\nname = \"settle\"\nkind = \"settle_time\"\nsignal = \"crank.velocity\"\n\
              reference = \"crank.velocity\"\nband = 1e-9\nfrom = 0.1\n";
    let loaded = with_extra("whitworth-crank-pi", &extra, 1.0).unwrap();
    let mut samples = Samples {
        name: "crank.velocity".into(),
        ..Samples::default()
    };
    let summary = run_with(loaded, &mut [&mut samples]);
    let e: Vec<f64> = samples
        .values
        .iter()
        .filter(|(t, _)| (0.2..=0.8).contains(t))
        .map(|(_, v)| 2.0 * v)
        .collect();
    let n = e.len() as f64;
    assert!((599..=601).contains(&e.len()), "{} samples", e.len());
    let mean = e.iter().sum::<f64>() / n;
    let mse = e.iter().map(|x| x * x).sum::<f64>() / n;
    let std = (e.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n).sqrt();
    let expected = [
        ("mse", mse),
        ("rms", mse.sqrt()),
        ("mean", mean),
        ("std", std),
        ("max_abs", e.iter().fold(0.0, |m, x| m.max(x.abs()))),
        ("max", e.iter().copied().fold(f64::NEG_INFINITY, f64::max)),
        ("min", e.iter().copied().fold(f64::INFINITY, f64::min)),
        ("final", *e.last().unwrap()),
        // The error against itself is zero from the window's start.
        ("settle", 0.0),
    ];
    for (name, value) in expected {
        let got = summary.metric(name).unwrap();
        assert!(
            (got - value).abs() <= 1e-12 * value.abs().max(1.0),
            "{name}: evaluator {got} vs by hand {value}"
        );
    }
    assert!(summary.metric("std").unwrap() > 0.0, "the crank speeds up");
    // Every step seen once, the last one flagged, the recording's samples counted.
    assert_eq!(samples.steps, summary.steps + 1);
    assert!(samples.last_seen);
    assert_eq!(samples.sampled, summary.steps + 1, "recording.every = 1");
}

/// Keeps the crank-speed PI's speed error at every step.
#[derive(Default)]
struct SpeedError {
    index: Option<usize>,
    values: Vec<(f64, f64)>,
}

impl Observer for SpeedError {
    fn start(&mut self, layout: &SignalLayout) -> Result<(), ObserverError> {
        self.index = Some(layout.internal("speed_error").ok_or("no speed_error")?);
        Ok(())
    }

    fn observe(&mut self, view: &StepView) -> Result<(), ObserverError> {
        let index = self.index.ok_or("not started")?;
        self.values.push((view.time, view.internals[index]));
        Ok(())
    }
}

/// The PI loop's speed error, with the linkage's load ripple, ends within ±0.33 rad/s: the band
/// of ±0.5 rad/s is entered for good within the run.
#[test]
fn settle_time_is_the_start_of_the_last_stretch_within_the_band() {
    let extra = "[[metrics]]\nname = \"settle\"\nkind = \"settle_time\"\n\
                 signal = \"controller/speed_error\"\nband = 0.5\n";
    let loaded = with_extra("whitworth-crank-pi", extra, 4.0).unwrap();
    let mut errors = SpeedError::default();
    let summary = run_with(loaded, &mut [&mut errors]);
    let window = errors.values;
    let last_outside = window.iter().rposition(|(_, e)| e.abs() > 0.5);
    let by_hand = match last_outside {
        None => 0.0,
        Some(i) => window.get(i + 1).map_or(f64::NAN, |(t, _)| *t),
    };
    let settle = summary.metric("settle").unwrap();
    assert!(last_outside.is_some(), "the PI starts outside the band");
    assert!(
        by_hand > 0.0 && by_hand < 3.5,
        "settles within the run: {by_hand}"
    );
    assert_eq!(settle, by_hand);
}

/// Collects the typed events of a run.
#[derive(Default)]
struct Events(Vec<(usize, framework::Event)>);

impl Observer for Events {
    fn observe(&mut self, view: &StepView) -> Result<(), ObserverError> {
        self.0
            .extend(view.events.iter().map(|e| (view.step, e.clone())));
        Ok(())
    }
}

#[test]
fn mode_switches_and_saturation_are_typed_events() {
    let loaded = Scenario::builtin("whitworth-cutting")
        .and_then(|s| s.build(&controllers::builtin()))
        .unwrap();
    let mut events = Events::default();
    let summary = run_with(loaded, &mut [&mut events]);
    assert!(summary.failure.is_none());
    let modes: Vec<&str> = events
        .0
        .iter()
        .filter_map(|(_, e)| e.mode_entered())
        .collect();
    for mode in ["cutting_stroke", "return_stroke_1", "return_stroke_2"] {
        let count = modes.iter().filter(|m| **m == mode).count();
        assert!(count >= 3, "{mode} entered {count} times: {modes:?}");
    }
    // The start from rest saturates the crank; each start of saturation is a warning naming it,
    // and starts and ends alternate.
    let mut open = false;
    for (_, event) in &events.0 {
        match &event.kind {
            EventKind::SaturationStart { subject } => {
                assert_eq!(
                    (subject.as_str(), event.level),
                    ("crank", EventLevel::Warning)
                );
                assert!(!open);
                open = true;
            }
            EventKind::SaturationEnd { subject } => {
                assert_eq!(subject, "crank");
                assert!(open);
                open = false;
            }
            _ => {}
        }
    }
    let starts = events
        .0
        .iter()
        .filter(|(_, e)| matches!(e.kind, EventKind::SaturationStart { .. }))
        .count();
    assert!(starts >= 1, "no saturation seen");
}

#[test]
fn a_divergence_is_the_last_steps_error_event() {
    let loaded = Scenario::builtin("whitworth-crank-pi")
        .and_then(|s| s.set("health.max_joint_speed", 0.5))
        .and_then(|s| s.build(&controllers::builtin()))
        .unwrap();
    let mut events = Events::default();
    let summary = run_with(loaded, &mut [&mut events]);
    let failure = summary.failure.expect("the crank passes 0.5 rad/s");
    let (step, last) = events.0.last().unwrap();
    assert_eq!(*step, failure.step);
    assert_eq!(last.kind, EventKind::Divergence);
    assert_eq!(last.level, EventLevel::Error);
    assert_eq!(last.text, failure.to_string());
}

/// Fails at a given step.
struct FailAt(usize);

impl Observer for FailAt {
    fn observe(&mut self, view: &StepView) -> Result<(), ObserverError> {
        if view.step == self.0 {
            return Err(format!("gave up at step {}", view.step).into());
        }
        Ok(())
    }

    fn finish(&mut self) -> Result<Findings, ObserverError> {
        panic!("finish is not called after a failed step");
    }
}

#[test]
fn an_observers_error_stops_the_run_and_keeps_no_recording() {
    let folder = std::env::temp_dir().join(format!("twin-observers-{}", std::process::id()));
    std::fs::create_dir_all(&folder).unwrap();
    let path = folder.join("stopped.rrd");
    let loaded = Scenario::builtin("whitworth-crank-pi")
        .and_then(|s| s.build(&controllers::builtin()))
        .unwrap();
    let error = Twin::new(loaded)
        .and_then(|twin| twin.run_with(Some(&path), &mut [&mut FailAt(10)]))
        .unwrap_err();
    assert!(matches!(error, TwinError::Observer(_)), "{error}");
    assert_eq!(error.to_string(), "observer: gave up at step 10");
    let left: Vec<_> = std::fs::read_dir(&folder).unwrap().collect();
    assert!(left.is_empty(), "{left:?}");
    std::fs::remove_dir_all(&folder).ok();
}

#[test]
fn metrics_naming_what_the_run_lacks_are_refused_before_it_starts() {
    let metric = |body: &str| format!("[[metrics]]\nname = \"m\"\n{body}\n");
    let unknown = with_extra(
        "whitworth-crank-pi",
        &metric("kind = \"rms\"\nsignal = \"ram_speed\""),
        1.0,
    )
    .unwrap();
    let error = Twin::new(unknown).err().unwrap();
    let text = error.to_string();
    assert!(
        text.contains("metrics `m`: no signal `ram_speed`"),
        "{text}"
    );
    assert!(text.contains("ram_velocity"), "lists the signals: {text}");

    let refused = [
        ("kind = \"median\"\nsignal = \"ram_position\"", "median"),
        (
            "kind = \"settle_time\"\nsignal = \"ram_position\"",
            "needs a band",
        ),
        (
            "kind = \"rms\"\nsignal = \"ram_position\"\nband = 1.0",
            "only for",
        ),
        (
            "kind = \"rms\"\nsignal = \"ram_position\"\nfrom = -1.0",
            "from must be",
        ),
        (
            "kind = \"rms\"\nsignal = \"ram_position\"\nscale = 0.0",
            "scale must be",
        ),
        (
            "kind = \"rms\"\nsignal = \"ram_position\"\nfrom = 2.0\nto = 1.0",
            "to must be",
        ),
    ];
    for (body, expected) in refused {
        let error = with_extra("whitworth-crank-pi", &metric(body), 1.0).unwrap_err();
        assert!(error.contains(expected), "{body}: {error}");
    }
    let twice = metric("kind = \"rms\"\nsignal = \"ram_position\"").repeat(2);
    let error = with_extra("whitworth-crank-pi", &twice, 1.0).unwrap_err();
    assert!(error.contains("metrics `m`: named twice"), "{error}");
}

#[test]
fn the_layout_names_every_slice_a_step_carries() {
    struct Check;
    impl Observer for Check {
        fn observe(&mut self, view: &StepView) -> Result<(), ObserverError> {
            let layout = view.layout;
            assert_eq!(view.signals.len(), layout.signals.len());
            assert_eq!(view.measured.len(), layout.signals.len());
            assert_eq!(view.applied.len(), layout.actuators.len());
            assert_eq!(view.internals.len(), layout.internals.len());
            assert_eq!(view.diagnostics.len(), layout.diagnostics.len());
            let crank = layout.joints.iter().position(|j| j == "crank").unwrap();
            let tree = layout.movable_joints()[crank];
            assert_eq!(
                view.signal("crank.position"),
                Some(view.state.joint_positions[tree])
            );
            assert_eq!(layout.diagnostics.last().unwrap(), "mechanical_energy");
            Ok(())
        }
    }
    let loaded = Scenario::builtin("whitworth-tracking")
        .and_then(|s| s.duration(0.05).build(&controllers::builtin()))
        .unwrap();
    run_with(loaded, &mut [&mut Check]);
}
