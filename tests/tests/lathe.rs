//! The parallel lathe (Sudhakara & Landers, ACC 2003) end to end: the rigid-body twin under the
//! `output-feedback-force` controller against the reduced model of Sudhakara eq (17), inside and
//! outside the region the slow design cannot recover from, and bad inputs refused before the run.

use twin::{ScenarioValue, Twin};
use twin_cli::analysis::lathe::{analyze, Gains, PhasePlane, PhasePlaneRequest};
use twin_cli::reproduce::lathe::{compare, Comparison, TwinStart, AGREEMENT};
use twin_tests::{builtin, run, scratch, Configure};

/// The reduced model's phase plane for a gain set, on a coarse grid (the twin runs need only its
/// lathe, gains and trajectories).
fn plane(gains: Gains) -> PhasePlane {
    analyze(&PhasePlaneRequest {
        gains,
        points_per_axis: 3,
        duration: 5.0,
        ..Default::default()
    })
    .unwrap()
}

const FAST: Gains = Gains::Design {
    time_constants: [0.5, 0.49],
};
const SLOW: Gains = Gains::Design {
    time_constants: [1.5, 1.49],
};

fn twin_from(plane: &PhasePlane, initial_forces: [f64; 2], duration: f64) -> Comparison {
    let start = TwinStart {
        label: "test",
        gains: plane.request.gains,
        initial_forces,
        duration,
    };
    let comparison = compare(plane, &start, &controllers::builtin(), None).unwrap();
    println!(
        "{:?} from {initial_forces:?}: met the part at {:?}, twin {:?}, model {:?}, {:.4} % of F_r",
        plane.request.gains,
        comparison.twin_initial,
        comparison.twin_settled,
        comparison.model_settled,
        100.0 * comparison.difference
    );
    comparison
}

fn reaches_reference(plane: &PhasePlane, forces: [f64; 2]) -> bool {
    let reference = plane.lathe.reference_forces();
    (0..2).all(|i| (forces[i] - reference[i]).abs() <= AGREEMENT * reference[i])
}

#[test]
fn twin_and_reduced_model_settle_at_the_same_forces_within_one_percent() {
    let fast = plane(FAST);
    let comparison = twin_from(&fast, [1000.0, 500.0], 3.0);
    assert!(comparison.difference <= AGREEMENT, "{comparison:?}");
    assert!(reaches_reference(&fast, comparison.twin_settled));
    // The tools met the part at the forces asked for (the approach feeds had settled).
    for (actual, asked) in comparison.twin_initial.iter().zip([1000.0, 500.0]) {
        assert!(
            (actual - asked).abs() < 0.005 * asked,
            "{actual} vs {asked}"
        );
    }
    let run = &comparison.run["metrics"];
    let power_error = run["power_error"].as_f64().unwrap();
    assert!(
        power_error.abs() < 0.01 * 20e3,
        "power error {power_error} W"
    );
    assert!(run["time_to_settle"].as_f64().unwrap() < 2.0);
    assert_eq!(run["feed_saturated_fraction/tool_2"].as_f64(), Some(0.0));
}

#[test]
fn slow_design_fails_inside_the_region_and_recovers_outside_it_as_the_model_says() {
    let slow = plane(SLOW);
    // Well inside (7.9 kW, below tool 2's zero-feed line), inside near the boundary (11.4 kW),
    // and outside it (12.6 and 15.7 kW); the reduced model's boundary is at 11.8–12.0 kW.
    for (start, duration, fails) in [
        ([1000.0, 500.0], 4.0, true),
        ([1500.0, 700.0], 4.0, true),
        ([1500.0, 850.0], 9.0, false),
        ([2000.0, 1000.0], 9.0, false),
    ] {
        let comparison = twin_from(&slow, start, duration);
        assert!(comparison.same_end, "{comparison:?}");
        assert!(comparison.difference <= AGREEMENT, "{comparison:?}");
        assert_eq!(
            !reaches_reference(&slow, comparison.twin_settled),
            fails,
            "{comparison:?}"
        );
        let metrics = &comparison.run["metrics"];
        if fails {
            // Tool 2 withdrawn to zero feed, tool 1 alone at the idle equilibrium.
            assert!(comparison.twin_settled[1] < 1.0);
            assert!((comparison.twin_settled[0] - 1809.7).abs() < 0.5);
            assert!(metrics["feed_saturated_fraction/tool_2"].as_f64().unwrap() > 0.5);
            assert!(
                metrics["time_to_settle"].is_null(),
                "never settles: {metrics}"
            );
        } else {
            assert!(metrics["time_to_settle"].as_f64().unwrap() < duration);
        }
    }
}

#[test]
fn gains_meeting_eq_23_bring_the_same_low_start_to_p_max() {
    let slow = plane(SLOW);
    let bounds = slow.global_stability.lower_bounds;
    let eq23 = plane(Gains::Given([slow.power_gains[0], bounds[1]]));
    assert!(eq23.global_stability.satisfied);
    let comparison = twin_from(&eq23, [1000.0, 500.0], 4.0);
    assert!(
        reaches_reference(&eq23, comparison.twin_settled),
        "{comparison:?}"
    );
    assert!(comparison.difference <= AGREEMENT, "{comparison:?}");
}

#[test]
fn the_scenario_records_and_reports_the_design() {
    let dir = scratch("lathe-recording");
    let out = dir.join("lathe.rrd");
    let summary = run(builtin("lathe-turning").duration(0.6).loaded(), Some(&out));
    assert!(summary.failure.is_none(), "{:?}", summary.failure);
    assert!(std::fs::metadata(&out).unwrap().len() > 10_000);
    let engaged = summary.metric("engaged_at").unwrap();
    assert!(engaged > 0.2 && engaged < 0.6, "engaged at {engaged} s");
    // The spindle turns at N_s and the slides carry the cutting forces.
    let peak = summary.metric("peak_effort/slide_1").unwrap();
    assert!(peak > 1000.0, "slide 1 peak force {peak} N");
}

#[test]
fn analysis_writes_its_tables_and_plot() {
    let dir = scratch("lathe-analysis");
    let slow = analyze(&PhasePlaneRequest {
        gains: SLOW,
        points_per_axis: 4,
        duration: 10.0,
        ..Default::default()
    })
    .unwrap();
    let files = slow.write(&dir).unwrap();
    assert_eq!(files.len(), 6);
    let read = |name: &str| std::fs::read_to_string(dir.join(name)).unwrap();
    let equilibria = read("equilibria.csv");
    assert_eq!(equilibria.lines().count(), 4, "{equilibria}");
    assert!(equilibria.contains("saddle"));
    let boundary = read("region_boundary.csv");
    assert!(boundary.lines().count() > 10);
    assert!(read("saturation_lines.csv").contains("2,zero_feed,7953.2"));
    assert!(read("phase_portrait.csv").starts_with("trajectory,"));
    assert!(
        std::fs::metadata(dir.join("phase_plane.rrd"))
            .unwrap()
            .len()
            > 10_000
    );
    let region = slow.region();
    let [low, high] = region.boundary_power_range.unwrap();
    assert!(low > 11.7e3 && high < 12.1e3, "boundary {low}..{high} W");
}

/// Loads `lathe-turning` with `key` set to `value` and builds the twin: the error it stops
/// with, as text.
fn refused(key: &str, value: impl Into<ScenarioValue>) -> String {
    let loaded = builtin("lathe-turning")
        .set(key, value)
        .and_then(|b| b.build(&controllers::builtin()));
    let error = match loaded {
        Err(e) => e.to_string(),
        Ok(loaded) => match Twin::new(loaded) {
            Err(e) => e.to_string(),
            Ok(_) => panic!("{key} must be refused"),
        },
    };
    println!("{key}: {error}");
    error
}

/// Table 1's tools, tool 2 with one field changed.
fn tools_with(tool_2_field: &str, value: f64) -> Vec<toml::Table> {
    let tool = |diameter: f64, depth: f64, tau: f64| -> toml::Table {
        [
            ("diameter", diameter),
            ("depth_of_cut", depth),
            ("cutting_coefficient", 4.765_242_7e8),
            ("feed_exponent", 0.89),
            ("depth_exponent", 0.87),
            ("speed_exponent", -0.27),
            ("feed_time_constant", tau),
        ]
        .into_iter()
        .map(|(name, value)| (name.to_string(), toml::Value::Float(value)))
        .collect()
    };
    let mut tools = vec![tool(0.05, 3e-3, 0.05), tool(0.1, 1e-3, 0.049)];
    let old = tools[1].insert(tool_2_field.into(), toml::Value::Float(value));
    assert!(old.is_some(), "a tool has no {tool_2_field}");
    tools
}

#[test]
fn bad_inputs_are_refused_before_the_run() {
    // Design time constants m_i.
    let error = refused("controller.params.time_constants", [0.5, 0.0]);
    assert!(error.contains("m_2") && error.contains("> 0"), "{error}");
    // Servo time constants τ_i, in the controller's model and in the machine.
    for table in ["controller.params.lathe.tools", "process.lathe.tools"] {
        let error = refused(table, tools_with("feed_time_constant", -0.049));
        assert!(error.contains("tool 2 feed_time_constant"), "{error}");
        let error = refused(table, tools_with("feed_exponent", 1.2));
        assert!(error.contains("α = 1.2 is outside (0, 1]"), "{error}");
        let error = refused(table, tools_with("feed_exponent", 0.0));
        assert!(error.contains("outside (0, 1]"), "{error}");
    }
    // A power the tools cannot reach within the 1.5 mm feed limit.
    for key in ["controller.params.lathe", "process.lathe"] {
        let error = refused(&format!("{key}.max_spindle_power"), 60000.0);
        assert!(
            error.contains("reaches only") && error.contains("feed limit"),
            "{error}"
        );
    }
    let error = refused("controller.params.lathe.max_feed", 0.5e-3);
    assert!(error.contains("tool 1 must take 10000 W"), "{error}");
    // An initial force beyond the feed limit, a negative air gap, a stray key.
    let error = refused("controller.params.initial_forces", [9000.0, 500.0]);
    assert!(error.contains("feed limit"), "{error}");
    let error = refused("process.approach_gaps", [-1e-3, 1e-3]);
    assert!(error.contains("approach_gaps[0]"), "{error}");
    let error = refused("process.chuck", 1.0);
    assert!(error.contains("chuck"), "{error}");
}

#[test]
fn analyze_command_names_bad_requests() {
    use twin_cli::analyze::{run as analyze_command, AnalyzeArgs};
    let dir = scratch("lathe-analyze-command");
    let args = AnalyzeArgs {
        machine: "lathe".into(),
        m1: 1.5,
        m2: 1.49,
        h1: None,
        h2: None,
        max_force: 5000.0,
        grid: 2,
        duration: 5.0,
        out_dir: Some(dir.to_path_buf()),
        scenario: "milling-constant-15000".into(),
        values: twin_cli::flags::SetFlag { set: Vec::new() },
        rpm: vec![10_000.0, 25_000.0],
        speeds: 151,
        max_depth: 3e-3,
        check: vec![12, 8],
        check_duration: 0.6,
        frf_x: None,
        frf_y: None,
    };
    let registry = controllers::builtin();
    let summary = analyze_command(&args, &registry).unwrap();
    assert!(summary.contains("saddle at (2086.5, 470.2) N"), "{summary}");
    assert!(summary.contains("NOT met"), "{summary}");
    for (bad, expected) in [
        (
            AnalyzeArgs {
                machine: "mill".into(),
                ..args.clone()
            },
            "unknown analysis `mill`",
        ),
        (
            AnalyzeArgs {
                m1: 0.0,
                ..args.clone()
            },
            "m_1 must be finite and > 0",
        ),
        (
            AnalyzeArgs {
                grid: 0,
                ..args.clone()
            },
            "points per axis",
        ),
        (
            AnalyzeArgs {
                h1: Some(f64::NAN),
                h2: Some(0.0),
                ..args.clone()
            },
            "power gain h_1",
        ),
    ] {
        let error = analyze_command(&bad, &registry).unwrap_err().to_string();
        assert!(error.contains(expected), "{error}");
    }
}

#[test]
fn the_paper_sample_period_or_a_late_force_sensor_change_little() {
    // The paper samples its controller every 4 ms: here the whole controller, servos included,
    // runs at that period. Separately, tool 1's force reaches the 1 ms controller 4 ms late.
    for key in ["control_period", "sensors.cutting_force_1.delay"] {
        let summary = run(builtin("lathe-turning").with(key, 0.004).loaded(), None);
        assert!(summary.failure.is_none(), "{:?}", summary.failure);
        for (tool, reference) in [(1, 2546.479), (2, 1273.240)] {
            let settled = summary
                .metric(&format!("settled_force/tool_{tool}"))
                .unwrap();
            assert!(
                (settled - reference).abs() < AGREEMENT * reference,
                "{key}: tool {tool} at {settled} N"
            );
        }
    }
}
