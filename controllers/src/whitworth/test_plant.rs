//! A small stand-in for the twin in the controllers' tests: the reduced model of
//! `models::whitworth::dynamics` integrated with RK4, the crank torque held over each control
//! period, the contact force of Perrusquía eq (40) on the ram, and the twin's signal names.

use framework::{Actuator, Controller, EffortKind, Measurement, PlantInterface};
use models::reference::Reference;
use models::whitworth::dynamics::{Dynamics, LinkMasses};
use models::whitworth::Geometry;
use std::f64::consts::FRAC_PI_2;

/// Perrusquía eq (40): `force` N upwards while the ram moves down inside `[y_b, y_a]`.
#[derive(Debug, Clone, Copy)]
pub struct Contact {
    pub force: f64,
    pub y_a: f64,
    pub y_b: f64,
}

impl Contact {
    /// The paper's 400 N (Perrusquía eq (40)) over the twin's workpiece: Algorithm 1's y_a, y_b for
    /// L_d = 0.3 m.
    pub const WORKPIECE: Contact = Contact {
        force: 400.0,
        y_a: -0.02907,
        y_b: -0.32907,
    };
}

/// One control period of a run.
#[derive(Debug, Clone, Copy)]
pub struct Sample {
    pub time: f64,
    pub crank_speed: f64,
    pub ram_position: f64,
    pub ram_velocity: f64,
    /// Applied (clipped) crank torque, N·m.
    pub torque: f64,
}

pub struct Plant {
    pub dynamics: Dynamics,
    /// Simulated time, s.
    pub time: f64,
    pub q: f64,
    pub crank_speed: f64,
    pub contact: Option<Contact>,
    pub reference: Option<Reference>,
    /// RK4 steps per control period.
    pub substeps: usize,
}

impl Plant {
    /// The twin's linkage at rest in the URDF pose (crank at π/2).
    pub fn twin() -> Self {
        Self {
            dynamics: Dynamics::new(Geometry::default(), LinkMasses::default(), 9.81).unwrap(),
            time: 0.0,
            q: FRAC_PI_2,
            crank_speed: 0.0,
            contact: None,
            reference: None,
            substeps: 4,
        }
    }

    pub fn interface(&self) -> PlantInterface {
        let mut signals: Vec<String> = [
            "crank.position",
            "crank.velocity",
            "crank_angle",
            "ram_position",
            "ram_velocity",
        ]
        .map(String::from)
        .to_vec();
        if self.reference.is_some() {
            signals.extend(
                ["reference", "reference_rate", "reference_acceleration"].map(String::from),
            );
        }
        PlantInterface {
            machine: "whitworth".into(),
            signals,
            actuators: vec![Actuator {
                joint: "crank".into(),
                kind: EffortKind::Torque,
                effort_limit: 300.0,
            }],
            ..Default::default()
        }
    }

    fn ram_force(&self, q: f64, crank_speed: f64) -> f64 {
        let geometry = self.dynamics.geometry();
        let y = geometry.ram_position(q);
        let v = geometry.ram_jacobian(q) * crank_speed;
        match self.contact {
            Some(c) if v < 0.0 && c.y_b <= y && y <= c.y_a => c.force,
            _ => 0.0,
        }
    }

    fn step(&mut self, torque: f64, dt: f64) {
        let f = |q: f64, w: f64| {
            let force = self.ram_force(q, w);
            (w, self.dynamics.crank_acceleration(q, w, torque, force))
        };
        let (q, w) = (self.q, self.crank_speed);
        let k1 = f(q, w);
        let k2 = f(q + 0.5 * dt * k1.0, w + 0.5 * dt * k1.1);
        let k3 = f(q + 0.5 * dt * k2.0, w + 0.5 * dt * k2.1);
        let k4 = f(q + dt * k3.0, w + dt * k3.1);
        self.q += dt / 6.0 * (k1.0 + 2.0 * k2.0 + 2.0 * k3.0 + k4.0);
        self.crank_speed += dt / 6.0 * (k1.1 + 2.0 * k2.1 + 2.0 * k3.1 + k4.1);
    }

    /// Runs `controller` (already reset on [`interface`](Self::interface)) for `duration` more
    /// seconds.
    pub fn run(
        &mut self,
        controller: &mut dyn Controller,
        duration: f64,
        period: f64,
    ) -> Vec<Sample> {
        let steps = (duration / period).round() as usize;
        let mut samples = Vec::with_capacity(steps);
        let mut effort = [0.0];
        for _ in 0..steps {
            let time = self.time;
            let geometry = self.dynamics.geometry();
            let y = geometry.ram_position(self.q);
            let v = geometry.ram_jacobian(self.q) * self.crank_speed;
            let mut signals = vec![self.q - FRAC_PI_2, self.crank_speed, self.q, y, v];
            if let Some(reference) = &self.reference {
                let r = reference.sample(time);
                signals.extend([r.position, r.rate, r.acceleration]);
            }
            effort[0] = 0.0;
            controller.update(
                &Measurement {
                    time,
                    signals: &signals,
                },
                period,
                &mut effort,
            );
            // The twin clips the command to the actuator's limit.
            effort[0] = effort[0].clamp(-300.0, 300.0);
            samples.push(Sample {
                time,
                crank_speed: self.crank_speed,
                ram_position: y,
                ram_velocity: v,
                torque: effort[0],
            });
            for _ in 0..self.substeps {
                self.step(effort[0], period / self.substeps as f64);
            }
            self.time += period;
        }
        samples
    }
}

/// RMS and largest |ẏ − v| over each cut through `[y_b, y_a]` (ram moving down), in order.
pub fn cut_velocity_errors(
    samples: &[Sample],
    velocity: f64,
    contact: &Contact,
) -> Vec<(f64, f64)> {
    let mut cuts: Vec<Vec<f64>> = Vec::new();
    let mut inside = false;
    for s in samples {
        let now =
            s.ram_velocity < 0.0 && contact.y_b <= s.ram_position && s.ram_position <= contact.y_a;
        if now {
            if !inside {
                cuts.push(Vec::new());
            }
            if let Some(cut) = cuts.last_mut() {
                cut.push(s.ram_velocity - velocity);
            }
        }
        inside = now;
    }
    cuts.iter()
        .map(|errors| {
            let rms = (errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt();
            (rms, errors.iter().fold(0.0, |m: f64, e| m.max(e.abs())))
        })
        .collect()
}
