//! What a shadow is asked to do, and its binding to the model: the watched signals, the tracked
//! parameters as the filter's knobs, and the filter's noise in SI.

use super::error::ShadowError;
use super::filter::Tuning;
use super::model::{Knob, Model};
use crate::scenario::Scenario;

/// Share of the largest acceleration an actuator can give that the model may be off by, per
/// √s, when no `process_noise` is given.
pub const DEFAULT_PROCESS_NOISE: f64 = 1e-3;

/// A scenario value the filter estimates as it goes: `urdf.link.<link>.mass`,
/// `urdf.joint.<joint>.damping`, `urdf.joint.<joint>.friction` or `sensors.<signal>.bias`.
#[derive(Debug, Clone, PartialEq)]
pub struct TrackedParameter {
    /// The scenario key.
    pub key: String,
    /// How fast it may change: its random walk's standard deviation per √s, SI (`None`: 2 % of
    /// a mass, of a friction or of a tenth of the joint's effort limit, of a damping or of the
    /// damping taking that at a tenth of its velocity limit, whichever is larger, and three
    /// times a biased signal's noise σ).
    pub drift: Option<f64>,
}

/// What a shadow watches and how it decides.
#[derive(Debug, Clone, PartialEq)]
pub struct ShadowOptions {
    /// The measured signals the filter corrects the model with.
    pub signals: Vec<String>,
    /// The parameters tracked as states.
    pub parameters: Vec<TrackedParameter>,
    /// False alarms per hour of healthy operation the tests may give together.
    pub false_alarms_per_hour: f64,
    /// Seconds at the start taken as healthy, to learn the innovations' statistics.
    pub learn: f64,
    /// Seconds a sample may arrive behind its slowest live stream and still be processed in
    /// order.
    pub latency: f64,
    /// Measurement noise σ per signal, SI (default: the scenario's sensor: noise and
    /// quantisation).
    pub noise: Vec<(String, f64)>,
    /// The model's acceleration noise, as a share of the largest acceleration an actuator
    /// gives, per √s.
    pub process_noise: f64,
}

impl Default for ShadowOptions {
    fn default() -> Self {
        Self {
            signals: Vec::new(),
            parameters: Vec::new(),
            false_alarms_per_hour: 0.1,
            learn: 5.0,
            latency: 0.25,
            noise: Vec::new(),
            process_noise: DEFAULT_PROCESS_NOISE,
        }
    }
}

impl ShadowOptions {
    /// Checks the numbers.
    pub(super) fn check(&self) -> Result<(), ShadowError> {
        let positive = [
            ("--false-alarms", self.false_alarms_per_hour),
            ("--learn", self.learn),
            ("--process-noise", self.process_noise),
        ];
        for (name, value) in positive {
            if !(value.is_finite() && value > 0.0) {
                return Err(ShadowError::Option(format!(
                    "{name} {value}: must be a positive number"
                )));
            }
        }
        if !(self.latency.is_finite() && self.latency >= 0.0) {
            return Err(ShadowError::Option(format!(
                "--latency {}: must be ≥ 0 s",
                self.latency
            )));
        }
        for parameter in &self.parameters {
            if let Some(drift) = parameter.drift.filter(|d| !(d.is_finite() && *d > 0.0)) {
                return Err(ShadowError::Option(format!(
                    "--track {}={drift}: the drift must be a positive number (σ per √s, SI)",
                    parameter.key
                )));
            }
        }
        if self.signals.is_empty() {
            return Err(ShadowError::Option(
                "no measured signal to watch: map at least one of the machine's signals".into(),
            ));
        }
        Ok(())
    }
}

/// The knob a tracked parameter's key names in `model`.
pub(super) fn knob(model: &Model, key: &str) -> Result<Knob, ShadowError> {
    let refuse = |what: String| {
        ShadowError::Option(format!(
            "--track {key}: {what}; tracked: urdf.link.<link>.mass, urdf.joint.<joint>.damping, \
             urdf.joint.<joint>.friction, sensors.<signal>.bias"
        ))
    };
    let parts: Vec<&str> = key.split('.').collect();
    match parts.as_slice() {
        ["urdf", "link", link, "mass"] => {
            let index = model.mechanism.links.iter().position(|l| l.name == *link);
            let index = index.ok_or_else(|| refuse(format!("the URDF has no link `{link}`")))?;
            let nominal = model.mechanism.links[index]
                .inertial
                .ok_or_else(|| refuse(format!("link `{link}` has no mass")))?;
            Ok(Knob::LinkMass {
                link: index,
                nominal,
            })
        }
        ["urdf", "joint", joint, kind @ ("damping" | "friction")] => {
            let index = model
                .mechanism
                .joint_index(joint)
                .ok_or_else(|| refuse(format!("the URDF has no joint `{joint}`")))?;
            Ok(if *kind == "damping" {
                Knob::JointDamping { joint: index }
            } else {
                Knob::JointFriction { joint: index }
            })
        }
        ["sensors", signal @ .., "bias"] => {
            let signal = signal.join(".");
            let watched = model
                .watched
                .iter()
                .position(|&i| model.layout.signals[i] == signal)
                .ok_or_else(|| refuse(format!("`{signal}` is not a watched signal")))?;
            Ok(Knob::SensorBias { watched })
        }
        _ => Err(refuse("not a parameter the shadow can track".into())),
    }
}

/// Measurement noise variance per watched signal: the option's, else the sensor's noise and
/// quantisation; a signal with neither is refused (a filter told of no noise trusts every
/// reading exactly and alarms on the first quantisation step).
pub(super) fn noise(
    options: &ShadowOptions,
    scenario: &Scenario,
    names: &[String],
) -> Result<Vec<f64>, ShadowError> {
    for (name, sigma) in &options.noise {
        if !names.contains(name) {
            return Err(ShadowError::Option(format!(
                "--noise {name}={sigma}: `{name}` is not a watched signal"
            )));
        }
        if !(sigma.is_finite() && *sigma > 0.0) {
            return Err(ShadowError::Option(format!(
                "--noise {name}={sigma}: σ must be a positive number"
            )));
        }
    }
    names
        .iter()
        .map(|name| {
            let given = options.noise.iter().find(|(n, _)| n == name);
            let sensor = scenario.sensors.get(name);
            let declared = sensor.map_or(0.0, |s| {
                (s.noise * s.noise + s.resolution * s.resolution / 12.0).sqrt()
            });
            let sigma = given.map_or(declared, |(_, s)| *s);
            if sigma > 0.0 {
                return Ok(sigma * sigma);
            }
            Err(ShadowError::Option(format!(
                "signal `{name}`: no noise σ: its sensor in the scenario declares neither noise \
                 nor resolution; give --noise {name}=SIGMA (SI), or `noise` under \
                 [sensors.\"{name}\"] in the scenario"
            )))
        })
        .collect()
}

/// The knobs' drift variance per second and initial σ: the option's, else `defaults`.
pub(super) fn drifts(options: &ShadowOptions, defaults: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let sigmas: Vec<f64> = (options.parameters.iter().zip(defaults))
        .map(|(p, default)| p.drift.unwrap_or(*default))
        .collect();
    let variances = sigmas.iter().map(|s| s * s).collect();
    (variances, sigmas)
}

/// The filter's tuning from its parts.
pub(super) fn tuning(
    acceleration_noise: Vec<f64>,
    drift: Vec<f64>,
    knob_sigmas: Vec<f64>,
    noise: Vec<f64>,
) -> Tuning {
    let coordinates = acceleration_noise.len();
    // Positions and velocities start loose: the first samples set them.
    let mut initial_sigma = vec![1.0; 2 * coordinates];
    initial_sigma.extend(knob_sigmas);
    Tuning {
        acceleration_noise,
        drift,
        noise,
        initial_sigma,
    }
}
