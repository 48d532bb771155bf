//! The scenario's parsing, checks and builder, against the built-in scenarios.

use super::*;

fn load(name: &str, overrides: &Overrides) -> Result<LoadedScenario, ScenarioError> {
    super::builder::load(name, overrides, &controllers::builtin())
}

fn build(builder: ScenarioBuilder) -> Result<LoadedScenario, ScenarioError> {
    builder.build(&controllers::builtin())
}

#[test]
fn builtins_load() {
    for (name, _) in BUILTIN {
        let loaded = load(name, &Overrides::default()).unwrap();
        assert_eq!(&loaded.scenario.name, name);
    }
}

fn set(assignments: &[&str]) -> Overrides {
    Overrides {
        set: assignments.iter().map(|s| s.to_string()).collect(),
        ..Default::default()
    }
}

#[test]
fn overrides_reach_nested_keys() {
    let loaded = load(
        "whitworth-crank-pi",
        &set(&["controller.params.crank_speed=-3.5", "duration=0.5"]),
    )
    .unwrap();
    assert_eq!(loaded.scenario.duration, 0.5);
    assert_eq!(
        loaded.scenario.controller.params["crank_speed"].as_float(),
        Some(-3.5)
    );
    assert!(loaded.toml.contains("-3.5"));
}

#[test]
fn another_controller_drops_the_old_parameters() {
    let overrides = Overrides {
        controller: Some("passive".into()),
        duration: Some(2.0),
        ..Default::default()
    };
    let loaded = load("whitworth-crank-pi", &overrides).unwrap();
    assert_eq!(loaded.scenario.controller.name, "passive");
    assert!(loaded.scenario.controller.params.is_empty());
    assert_eq!(loaded.scenario.duration, 2.0);
}

#[test]
fn bad_inputs_name_the_problem() {
    let err = load("no-such-scenario", &Overrides::default()).unwrap_err();
    assert!(err.to_string().contains("no-such-scenario"), "{err}");
    let err = load("whitworth-crank-pi", &set(&["dt=0"])).unwrap_err();
    assert!(err.to_string().contains("dt must be > 0"), "{err}");
    let err = load("whitworth-crank-pi", &set(&["duration=-1"])).unwrap_err();
    assert!(err.to_string().contains("duration must be > 0"), "{err}");
    let err = load("whitworth-crank-pi", &set(&["bogus_key=1"])).unwrap_err();
    assert!(err.to_string().contains("bogus_key"), "{err}");
    let err = load(
        "whitworth-crank-pi",
        &set(&["sensors.\"crank.position\".noise=-1"]),
    )
    .unwrap_err();
    assert!(err.to_string().contains("noise must be"), "{err}");
    let err = load("whitworth-crank-pi", &set(&["novalue"])).unwrap_err();
    assert!(err.to_string().contains("key=value"), "{err}");
    let err = load("whitworth-crank-pi", &set(&["dt=\"fast\""])).unwrap_err();
    assert!(err.to_string().contains("dt"), "{err}");
    let err = load("whitworth-crank-pi", &set(&["control_period=0.0015"])).unwrap_err();
    assert!(err.to_string().contains("whole multiple"), "{err}");
}

fn builder() -> ScenarioBuilder {
    Scenario::builtin("whitworth-crank-pi").unwrap()
}

#[test]
fn typed_values_reach_the_scenario() {
    let mut detector = toml::Table::new();
    detector.insert("resolution".into(), 1e-3.into());
    let loaded = builder()
        .set("controller.params.crank_speed", -3.5)
        .and_then(|b| b.set("substeps", 2))
        .and_then(|b| b.set("max_steps", 20_000_usize))
        .and_then(|b| b.set("process.cutting", false))
        .and_then(|b| b.set("description", "typed"))
        .and_then(|b| b.set("name", String::from("typed-run")))
        .and_then(|b| b.set("gravity", [0.0, -1.62]))
        .and_then(|b| b.set("sensors.\"crank.velocity\"", detector))
        .and_then(|b| b.set("sensors.\"crank.velocity\".noise", 0.5_f32))
        .map(|b| b.seed(7).duration(0.5))
        .and_then(build)
        .unwrap();
    let scenario = &loaded.scenario;
    assert_eq!(
        scenario.controller.params["crank_speed"].as_float(),
        Some(-3.5)
    );
    assert_eq!((scenario.substeps, scenario.max_steps), (2, 20_000));
    assert_eq!(scenario.process["cutting"].as_bool(), Some(false));
    assert_eq!(scenario.description, "typed");
    assert_eq!(scenario.name, "typed-run");
    assert_eq!(scenario.gravity, [0.0, -1.62]);
    let sensor = &scenario.sensors["crank.velocity"];
    assert_eq!((sensor.resolution, sensor.noise), (1e-3, 0.5));
    assert_eq!((scenario.seed, scenario.duration), (7, 0.5));
    assert!(loaded.toml.contains("typed-run"), "{}", loaded.toml);
}

#[test]
fn unchanged_builders_keep_the_text_as_written() {
    let loaded = build(builder()).unwrap();
    let loaded_again = load("whitworth-crank-pi", &Overrides::default()).unwrap();
    assert_eq!(
        (&loaded.scenario, &loaded.toml),
        (&loaded_again.scenario, &loaded_again.toml)
    );
    assert!(loaded.toml.starts_with("# Inverted Whitworth"));
}

#[test]
fn builder_controller_drops_the_old_parameters() {
    let loaded = build(builder().controller("passive")).unwrap();
    assert_eq!(loaded.scenario.controller.name, "passive");
    assert!(loaded.scenario.controller.params.is_empty());
}

#[test]
fn bad_keys_are_named() {
    for (key, reason) in [
        ("sensors.\"crank.position.noise", "unbalanced quotes"),
        ("controller..params", "empty key"),
        ("a.b.c.d.e.f.g.h.i", "deeper than 8"),
        ("dt.value", "`dt` is not a table"),
        ("controller.name.first", "`name` is not a table"),
    ] {
        let err = builder().set(key, 1.0).unwrap_err().to_string();
        assert!(err.contains(key) && err.contains(reason), "{err}");
    }
    let long = "a".repeat(300);
    let err = builder().set(&long, 1.0).unwrap_err().to_string();
    assert!(err.contains("longer than 256"), "{err}");
}

#[test]
fn numbers_beyond_toml_integers_are_errors_not_panics() {
    let err = builder()
        .set("max_steps", usize::MAX)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("max_steps") && err.contains("largest TOML integer"),
        "{err}"
    );
    let err = builder()
        .set("gravity", vec![u64::MAX, 0])
        .unwrap_err()
        .to_string();
    assert!(err.contains("gravity"), "{err}");
    let err = build(builder().seed(u64::MAX)).unwrap_err().to_string();
    assert!(
        err.contains("seed") && err.contains("largest TOML integer"),
        "{err}"
    );
}

#[test]
fn builder_and_assignments_give_the_same_scenario() {
    let typed = builder()
        .controller("passive")
        .set("controller.params", toml::Table::new())
        .and_then(|b| b.set("sensors.\"crank.position\".noise", 1e-4))
        .and_then(|b| b.set("gravity", vec![0.0, -9.0]))
        .and_then(|b| b.set("substeps", 3))
        .map(|b| b.duration(0.5))
        .and_then(build)
        .unwrap();
    let overrides = Overrides {
        controller: Some("passive".into()),
        duration: Some(0.5),
        set: [
            "controller.params={}",
            "sensors.\"crank.position\".noise=1e-4",
            "gravity=[0.0, -9.0]",
            "substeps=3",
        ]
        .map(String::from)
        .into(),
    };
    let assigned = load("whitworth-crank-pi", &overrides).unwrap();
    assert_eq!(
        (&typed.scenario, &typed.toml, typed.controller.name()),
        (
            &assigned.scenario,
            &assigned.toml,
            assigned.controller.name()
        )
    );
}

#[test]
fn wrong_types_fail_at_build_naming_the_key() {
    let fast = builder().set("dt", "fast").unwrap();
    let err = fast.build(&controllers::builtin()).unwrap_err().to_string();
    assert!(err.contains("`dt`"), "{err}");
    let err = builder()
        .set("sensors.\"crank.position\".noise", true)
        .and_then(build)
        .unwrap_err()
        .to_string();
    assert!(err.contains("noise"), "{err}");
}

#[test]
fn metrics_are_replaced_by_name_or_added() {
    let loaded = Scenario::builtin("whitworth-tracking")
        .unwrap()
        .metric(&MetricSpec {
            from: 3.0,
            ..MetricSpec::new("tracking_mse", MetricKind::Mse, "ram_position")
        })
        .metric(&MetricSpec::new("peak", MetricKind::MaxAbs, "ram_velocity"))
        .build(&controllers::builtin())
        .unwrap();
    let metrics = &loaded.scenario.metrics;
    assert_eq!(metrics.len(), 2);
    assert_eq!(
        (metrics[0].name.as_str(), metrics[0].from),
        ("tracking_mse", 3.0)
    );
    assert_eq!(metrics[0].reference, None);
    assert_eq!(
        metrics[1],
        MetricSpec::new("peak", MetricKind::MaxAbs, "ram_velocity")
    );
    let bad = Scenario::builtin("whitworth-tracking")
        .unwrap()
        .metric(&MetricSpec {
            scale: f64::NAN,
            ..MetricSpec::new("peak", MetricKind::MaxAbs, "ram_velocity")
        })
        .build(&controllers::builtin())
        .unwrap_err();
    assert!(bad.to_string().contains("`metrics.1.scale`"), "{bad}");
}

#[test]
fn controller_parameters_are_refused_at_build_with_their_key_path() {
    let typed = builder()
        .set("controller.params.natural_frequency", -1.0)
        .unwrap();
    let err = build(typed).unwrap_err().to_string();
    assert_eq!(
        err,
        "built-in scenario whitworth-crank-pi: \
         controller.params.natural_frequency = -1: must be > 0"
    );
    let err = load(
        "whitworth-crank-pi",
        &set(&["controller.params.natural_frequency=-1"]),
    )
    .unwrap_err()
    .to_string();
    assert!(
        err.ends_with("controller.params.natural_frequency = -1: must be > 0"),
        "{err}"
    );
    let err = load(
        "whitworth-crank-pi",
        &set(&["controller.params.natural_frequency=\"fast\""]),
    )
    .unwrap_err()
    .to_string();
    assert!(
        err.contains("controller.params.natural_frequency: invalid type"),
        "{err}"
    );
    let err = load("whitworth-crank-pi", &set(&["controller.params.gain=1"]))
        .unwrap_err()
        .to_string();
    assert!(err.contains("unknown field `gain`"), "{err}");
}

#[test]
fn a_controller_for_another_machine_is_refused_at_build() {
    let err = build(builder().controller("p-pi")).unwrap_err().to_string();
    assert!(
        err.contains("p-pi") && err.contains("whitworth") && err.contains("feed_axis"),
        "{err}"
    );
    let err = build(builder().controller("no-such-controller"))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("unknown controller `no-such-controller`"),
        "{err}"
    );
}
