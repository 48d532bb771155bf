//! `Twin::linearize` against closed forms and against the twin's own nonlinear runs: the feed
//! axis as 1/(m·s² + b·s), the Whitworth crank's reduced model of `models::whitworth::dynamics` at
//! several crank angles, a small effort step on the Whitworth linkage, an independent check of
//! linear.json with python-control, and the operating times and machines it refuses.

use framework::{Controller, ControllerError, Measurement, PlantInterface};
use models::whitworth::dynamics::{Dynamics, LinkMasses};
use models::whitworth::Geometry;
use std::f64::consts::FRAC_PI_2;
use twin::{
    LinearModel, LinearizeError, Observer, ObserverError, Scenario, ScenarioValue, StepView, Twin,
};

fn workspace(path: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join(path)
}

fn builtin(name: &str, sets: &[(&str, ScenarioValue)], controller: Option<&str>) -> Twin {
    let mut builder = Scenario::builtin(name).unwrap_or_else(|e| panic!("{e}"));
    if let Some(controller) = controller {
        builder = builder.controller(controller);
    }
    for (key, value) in sets {
        builder = builder
            .set(key, value.clone())
            .unwrap_or_else(|e| panic!("{e}"));
    }
    let loaded = builder
        .build(&controllers::builtin())
        .unwrap_or_else(|e| panic!("{e}"));
    Twin::new(loaded).unwrap_or_else(|e| panic!("{e}"))
}

fn names(model: &LinearModel) -> [Vec<&str>; 3] {
    [&model.states, &model.inputs, &model.outputs]
        .map(|list| list.iter().map(|c| c.name.as_str()).collect())
}

#[test]
fn the_feed_axis_is_a_mass_with_guide_way_damping() {
    // m and b from the URDF, read by the twin's loader.
    let mechanism = twin::engine::load_urdf_file(&workspace("urdf/feed_axis.urdf"))
        .unwrap_or_else(|e| panic!("{e}"));
    let table = mechanism.joint_index("table").expect("joint table");
    let joint = &mechanism.joints[table];
    let m = mechanism.links[joint.child].inertial.expect("mass").mass;
    let b = joint.damping;
    assert_eq!((m, b), (10.0, 250.0));
    // The air run: the cut's force declares no slope ∂F/∂v, so it would be a held force.
    let sets = [("process.cutting", ScenarioValue::from(false))];
    let model = builtin("feed-axis-micromilling", &sets, None)
        .linearize(0.0)
        .unwrap_or_else(|e| panic!("{e}"));
    let [states, inputs, outputs] = names(&model);
    assert_eq!(states, ["table.position", "table.velocity"]);
    assert_eq!(inputs, ["table"]);
    assert_eq!(outputs, ["table.position", "table.velocity"]);
    let close = |got: f64, want: f64| (got - want).abs() <= 1e-12 * want.abs().max(1.0);
    let a = [[0.0, 1.0], [0.0, -b / m]];
    for (r, row) in a.iter().enumerate() {
        for (c, &want) in row.iter().enumerate() {
            assert!(
                close(model.a[r][c], want),
                "A[{r}][{c}] {} vs {want}",
                model.a[r][c]
            );
        }
    }
    assert!(
        close(model.b[0][0], 0.0) && close(model.b[1][0], 1.0 / m),
        "{:?}",
        model.b
    );
    assert_eq!(model.c, vec![vec![1.0, 0.0], vec![0.0, 1.0]]);
    assert!(model.poles[0][0] + b / m < 1e-9 && model.poles[1][0].abs() < 1e-9);
    // Force → position: 1/(m·s² + b·s) at s = jω.
    for omega in [0.5, 3.0, 25.0, 400.0, 1e4] {
        let g = model
            .frequency_response(omega)
            .expect("no pole on the axis")[0][0];
        let denominator = [-m * omega * omega, b * omega];
        let norm = denominator[0].powi(2) + denominator[1].powi(2);
        let want = [denominator[0] / norm, -denominator[1] / norm];
        let error = (g[0] - want[0]).hypot(g[1] - want[1]) / want[0].hypot(want[1]);
        assert!(
            error < 1e-12,
            "at {omega} rad/s: {g:?} vs {want:?} ({error:e})"
        );
    }
}

/// The Whitworth crank-pi scenario held passive from crank angle q (rad, the machine's; the
/// loops are closed from the URDF's pose, which moves the crank a little) at rest.
fn whitworth_at(crank_angle: f64) -> Twin {
    let sets = [("initial.crank.position", (crank_angle - FRAC_PI_2).into())];
    builtin("whitworth-crank-pi", &sets, Some("passive"))
}

#[test]
fn the_whitworth_linkage_reduces_to_its_crank_as_the_closed_form_model() {
    // Along a crank-pi run (−2π rad/s), at operating points over a turn with the PI's torque
    // held: q̈ = (τ − ∂V/∂q − ½·M′·q̇²)/M of the closed form, differentiated by differences.
    let reduced = Dynamics::new(Geometry::default(), LinkMasses::default(), 9.81)
        .unwrap_or_else(|e| panic!("{e}"));
    for at in [0.1, 0.3, 0.45, 0.6, 0.8, 0.95] {
        let model = builtin("whitworth-crank-pi", &[], None)
            .linearize(at)
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(names(&model)[0], ["crank.position", "crank.velocity"]);
        assert_eq!(model.poles.len(), 2, "no constraint modes");
        let point = &model.operating_point;
        let (q, rate, torque) = (point.state[0] + FRAC_PI_2, point.state[1], point.efforts[0]);
        let acceleration = |q: f64, w: f64| reduced.crank_acceleration(q, w, torque, 0.0);
        // Five points at 5 mrad: the closed form's M′ is itself a difference (1 µrad), whose
        // round-off a finer step would amplify.
        let h = 5e-3;
        let f = |k: f64| acceleration(q + k * h, rate);
        let d_position = (f(-2.0) - 8.0 * f(-1.0) + 8.0 * f(1.0) - f(2.0)) / (12.0 * h);
        // Quadratic in q̇: the central difference is exact whatever its step.
        let d_rate = (acceleration(q, rate + 1.0) - acceleration(q, rate - 1.0)) / 2.0;
        let checks = [
            ("A[1][0]", model.a[1][0], d_position, 1e-6),
            ("A[1][1]", model.a[1][1], d_rate, 1e-6),
            ("B[1][0]", model.b[1][0], 1.0 / reduced.inertia(q), 1e-8),
        ];
        for (what, got, want, tolerance) in checks {
            let error = (got - want).abs() / want.abs().max(1.0);
            println!("t = {at} s, q = {q:.4} rad, q̇ = {rate:.3} rad/s: {what} {got:.9} vs {want:.9} ({error:.1e})");
            assert!(
                error < tolerance,
                "q = {q}: {what} {got} vs {want} ({error:e})"
            );
        }
        assert_eq!(
            (model.a[0][0], model.a[0][1], model.b[0][0]),
            (0.0, 1.0, 0.0)
        );
    }
}

/// A controller that holds one effort on the crank.
struct Hold {
    effort: f64,
    crank: usize,
}

impl Controller for Hold {
    fn name(&self) -> &str {
        "hold"
    }

    fn reset(&mut self, plant: &PlantInterface) -> Result<(), ControllerError> {
        self.crank = plant.actuator("crank")?;
        Ok(())
    }

    fn update(&mut self, _measurement: &Measurement, _period: f64, efforts: &mut [f64]) {
        efforts[self.crank] = self.effort;
    }
}

/// Crank position and velocity at every step.
#[derive(Default)]
struct Crank(Vec<[f64; 2]>);

impl Observer for Crank {
    fn observe(&mut self, view: &StepView) -> Result<(), ObserverError> {
        let position = view.signal("crank.position").expect("crank.position");
        let velocity = view.signal("crank.velocity").expect("crank.velocity");
        self.0.push([position, velocity]);
        Ok(())
    }
}

fn crank_run(crank_angle: f64, effort: f64, duration: f64) -> Vec<[f64; 2]> {
    let loaded = Scenario::builtin("whitworth-crank-pi")
        .and_then(|b| b.set("initial.crank.position", crank_angle - FRAC_PI_2))
        .map(|b| b.duration(duration))
        .and_then(|b| b.build(&controllers::builtin()))
        .unwrap_or_else(|e| panic!("{e}"));
    let hold = Box::new(Hold { effort, crank: 0 });
    let twin = Twin::with_controller(loaded, hold).unwrap_or_else(|e| panic!("{e}"));
    let mut crank = Crank::default();
    twin.run_with(None, &mut [&mut crank])
        .unwrap_or_else(|e| panic!("{e}"));
    crank.0
}

#[test]
fn a_small_effort_step_moves_the_linkage_as_the_linear_model_says() {
    // From rest at q = 1 rad, the crank torque stepped by 0.5 N·m: the twin's response
    // (the stepped run less the unstepped one: gravity's own fall cancels) against
    // x[k+1] = Ad·x[k] + Bd·δ, over 30 ms (30 control periods).
    let (q, step, duration) = (1.0, 0.5, 0.03);
    let model = whitworth_at(q)
        .linearize(0.0)
        .unwrap_or_else(|e| panic!("{e}"));
    let base = crank_run(q, 0.0, duration);
    let stepped = crank_run(q, step, duration);
    let mut x = [0.0, 0.0];
    let mut worst: f64 = 0.0;
    let mut largest: f64 = 0.0;
    for k in 0..base.len() {
        let twin = [stepped[k][0] - base[k][0], stepped[k][1] - base[k][1]];
        worst = worst.max((twin[0] - x[0]).abs());
        largest = largest.max(twin[0].abs());
        let ad = &model.ad;
        x = [
            ad[0][0] * x[0] + ad[0][1] * x[1] + model.bd[0][0] * step,
            ad[1][0] * x[0] + ad[1][1] * x[1] + model.bd[1][0] * step,
        ];
    }
    let final_twin = stepped.last().unwrap()[0] - base.last().unwrap()[0];
    println!(
        "step response over {duration} s: Δq {final_twin:.6e} rad, largest model error {worst:.2e}"
    );
    assert!(largest > 1e-4, "the step moves the crank: {largest:e}");
    // The linkage falls under gravity meanwhile (both runs): the model's error grows with that
    // drift, 0.11 % of the response here.
    assert!(worst < 3e-3 * largest, "{worst:e} against {largest:e}");
}

#[test]
fn python_control_agrees_with_linear_json() {
    // control.frequency_response of ss(A, B, C, D) against the twin's, and control.c2d(…, 'zoh')
    // against Ad, Bd: tests/python/check_linear.py, run by the tools' Python (scripts/test-tools).
    let folder = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let models = [
        (
            "feed-axis.json",
            builtin("feed-axis-micromilling", &[], None).linearize(0.0),
        ),
        (
            "whitworth.json",
            builtin("whitworth-crank-pi", &[], None).linearize(0.45),
        ),
        (
            "milling.json",
            builtin("milling-constant-15000", &[], None).linearize(0.0),
        ),
    ];
    let mut paths = Vec::new();
    for (name, model) in models {
        let model = model.unwrap_or_else(|e| panic!("{name}: {e}"));
        let path = folder.path().join(name);
        let text = serde_json::to_string(&model.to_json()).unwrap_or_else(|e| panic!("{e}"));
        std::fs::write(&path, text).unwrap_or_else(|e| panic!("{e}"));
        paths.push(path);
    }
    let python = std::env::var_os("TWIN_TOOLS_PYTHON").unwrap_or_else(|| "python3".into());
    let output = std::process::Command::new(&python)
        .arg(workspace("tests/python/check_linear.py"))
        .args(&paths)
        .output()
        .unwrap_or_else(|e| panic!("{}: {e}", python.to_string_lossy()));
    let text = String::from_utf8_lossy(&output.stdout);
    println!("{text}{}", String::from_utf8_lossy(&output.stderr));
    assert!(
        output.status.success(),
        "python-control disagrees (eval \"$(scripts/test-tools)\" first)"
    );
    assert_eq!(text.matches(": ok").count(), 3, "{text}");
}

#[test]
fn operating_times_outside_the_run_are_refused_by_value() {
    for (at, says) in [
        (-0.1, "must be ≥ 0"),
        (f64::NAN, "must be a finite time"),
        (f64::INFINITY, "must be a finite time"),
        (11.0, "is beyond the scenario's duration, 10 s"),
    ] {
        let error = builtin("whitworth-crank-pi", &[], None)
            .linearize(at)
            .unwrap_err();
        assert!(matches!(error, LinearizeError::At { .. }), "{error}");
        assert!(error.to_string().contains(says), "{at}: {error}");
    }
}

#[test]
fn a_run_that_diverges_before_the_operating_time_is_refused() {
    // The linkage passes 1 rad/s within milliseconds: the health limit stops the run.
    let sets = [("health.max_joint_speed", 1.0.into())];
    let error = builtin("whitworth-crank-pi", &sets, None)
        .linearize(1.0)
        .unwrap_err();
    assert!(matches!(error, LinearizeError::Diverged { .. }), "{error}");
    let text = error.to_string();
    assert!(
        text.contains("diverged before the operating time 1 s: run diverged at step"),
        "{text}"
    );
}

#[test]
fn a_machine_driving_through_its_own_states_is_refused_by_name() {
    let error = builtin("platform-path", &[], None)
        .linearize(0.0)
        .unwrap_err();
    assert!(
        matches!(error, LinearizeError::OwnActuators { .. }),
        "{error}"
    );
    assert!(
        error.to_string().contains("machine `platform` drives"),
        "{error}"
    );
}

#[test]
fn the_same_inputs_give_the_same_model_bit_for_bit() {
    let first = builtin("whitworth-crank-pi", &[], None)
        .linearize(0.3)
        .unwrap();
    let second = builtin("whitworth-crank-pi", &[], None)
        .linearize(0.3)
        .unwrap();
    assert_eq!(first.to_json().to_string(), second.to_json().to_string());
}
