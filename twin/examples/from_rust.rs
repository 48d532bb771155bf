//! Using the twin from Rust: build a scenario from typed values, run it with your own controller
//! and your own observer, read the figures the scenario declares and your observer's.
//!
//! Run: `cargo run --release -p twin --example from_rust` (CI runs it; it fails loudly if a
//! figure is missing).

use framework::{Controller, ControllerError, EventKind, Measurement, PlantInterface};
use models::whitworth::Geometry;
use twin::{Findings, Observer, ObserverError, Scenario, SignalLayout, StepView, Twin};

/// A proportional-derivative law on the ram's tracking error: a force on the ram, turned into
/// crank torque through the linkage's Jacobian (τ = (dy/dq)·F, by virtual work).
struct RamPd {
    stiffness: f64,
    damping: f64,
    geometry: Geometry,
    crank_angle: usize,
    reference: usize,
    reference_rate: usize,
    ram_position: usize,
    ram_velocity: usize,
    crank: usize,
}

impl Controller for RamPd {
    fn name(&self) -> &str {
        "ram-pd"
    }

    fn reset(&mut self, plant: &PlantInterface) -> Result<(), ControllerError> {
        self.crank_angle = plant.signal("crank_angle")?;
        self.reference = plant.signal("reference")?;
        self.reference_rate = plant.signal("reference_rate")?;
        self.ram_position = plant.signal("ram_position")?;
        self.ram_velocity = plant.signal("ram_velocity")?;
        self.crank = plant.actuator("crank")?;
        Ok(())
    }

    fn update(&mut self, m: &Measurement, _period: f64, efforts: &mut [f64]) {
        let error = m.get(self.reference) - m.get(self.ram_position);
        let rate_error = m.get(self.reference_rate) - m.get(self.ram_velocity);
        let force = self.stiffness * error + self.damping * rate_error;
        let jacobian = self.geometry.ram_jacobian(m.get(self.crank_angle));
        efforts[self.crank] = jacobian * force;
    }
}

/// Counts the twin's saturation events and keeps the largest |ram position error| it sees.
#[derive(Default)]
struct Watch {
    indices: Option<(usize, usize)>,
    saturations: usize,
    largest_error: f64,
}

impl Observer for Watch {
    fn start(&mut self, layout: &SignalLayout) -> Result<(), ObserverError> {
        let reference = layout.signal("reference").ok_or("no reference")?;
        let ram = layout.signal("ram_position").ok_or("no ram position")?;
        self.indices = Some((reference, ram));
        Ok(())
    }

    fn observe(&mut self, step: &StepView) -> Result<(), ObserverError> {
        let (reference, ram) = self.indices.ok_or("not started")?;
        let error = step.signals[reference] - step.signals[ram];
        self.largest_error = self.largest_error.max(error.abs());
        self.saturations += step
            .events
            .iter()
            .filter(|e| matches!(e.kind, EventKind::SaturationStart { .. }))
            .count();
        Ok(())
    }

    fn finish(&mut self) -> Result<Findings, ObserverError> {
        Ok(Findings {
            metrics: vec![
                ("watch/largest_error".into(), self.largest_error),
                ("watch/saturations".into(), self.saturations as f64),
            ],
            warnings: Vec::new(),
        })
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // A built-in scenario, changed through typed values (checked as a TOML file would be).
    let scenario = Scenario::builtin("whitworth-tracking")?
        .duration(3.0)
        .set("sensors.ram_position.noise", 1e-5)?
        .build(&controllers::builtin())?;
    let controller = RamPd {
        stiffness: 100000.0,
        damping: 3000.0,
        geometry: Geometry::default(),
        crank_angle: 0,
        reference: 0,
        reference_rate: 0,
        ram_position: 0,
        ram_velocity: 0,
        crank: 0,
    };
    let mut watch = Watch::default();
    let summary =
        Twin::with_controller(scenario, Box::new(controller))?.run_with(None, &mut [&mut watch])?;
    print!("{}", twin::summary::to_table(&summary));

    // The scenario's own figure (its [[metrics]]) and the observer's, side by side.
    let mse = summary.metric("tracking_mse").ok_or("no tracking_mse")?;
    let largest = summary
        .metric("watch/largest_error")
        .ok_or("no watch figure")?;
    println!(
        "tracking MSE of the last second {mse:.3e} cm², largest error {:.2} mm, {} saturations",
        largest * 1e3,
        watch.saturations
    );
    Ok(())
}
