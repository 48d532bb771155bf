//! `twin reproduce arm`: Ilyukhin, Poduraev & Tatarintseva (DAAAM 2014), adaptive correction of the
//! continuous path speed of a machining robot from its motor currents, on the twin's arm.
//!
//! Runs `arm-milling` three times — `path-speed-adaptive`, `path-speed-constant` at the paper's
//! V0 = 20 mm/s, and `path-speed-constant` at [`SAFE_PATH_SPEED`], the fastest constant speed at
//! which no motor current exceeds the tolerance on this contour (found by stepping the speed by
//! 0.5 mm/s) — and sets the paper's claims (its Figs. 2–4) next to the twin's figures. A
//! [`Probe`] around the controller watches `V_K` and the overload flag `R` (internal signals the
//! machine cannot see) for the oscillation of `V_K` in the correction mode.

use super::{Claim, Report, ReproduceError, Verdict};
use crate::run::{RunSummary, Twin};
use crate::scenario::{load, Overrides};
use controllers::filters::FirstOrderFilter;
use controllers::{Controller, ControllerError, Measurement, PlantInterface, Registry};
use serde_json::json;
use std::path::Path;
use std::sync::{Arc, Mutex, PoisonError};

const SCENARIO: &str = "arm-milling";
/// The paper's V0 and current tolerance (Figs. 2–3), mm/s and A.
const V0_MM_S: f64 = 20.0;
const TOLERANCE: f64 = 18.0;
/// The safe constant path speed, m/s (14 mm/s: peak 17.9 A; 14.5 mm/s already gives 18.1 A).
pub const SAFE_PATH_SPEED: f64 = 0.014;
/// Targets: peak current within 5 % of the tolerance, deviation within 0.1 mm.
const CURRENT_MARGIN: f64 = 1.05;
const DEVIATION_BOUND: f64 = 1e-4;
/// Time constant of the trend the V_K oscillation is measured about, s.
const TREND: f64 = 0.1;
/// The correction mode lasts this long after the last overload, s.
const MODE_HOLD: f64 = 0.5;

/// What the probe saw of V_K in the correction mode.
#[derive(Debug, Clone, Default)]
struct Oscillation {
    squares: f64,
    samples: usize,
}

impl Oscillation {
    /// √2·RMS of V_K about its trend, m/s (the amplitude of an equivalent sine).
    fn amplitude(&self) -> f64 {
        std::f64::consts::SQRT_2 * (self.squares / self.samples.max(1) as f64).sqrt()
    }
}

/// Wraps a path-speed controller and watches its `path_speed` and `overload` signals.
struct Probe {
    inner: Box<dyn Controller>,
    seen: Arc<Mutex<Oscillation>>,
    indices: Option<(usize, usize)>,
    values: Vec<f64>,
    trend: FirstOrderFilter,
    last_overload: f64,
}

impl Controller for Probe {
    fn name(&self) -> &str {
        self.inner.name()
    }

    fn reset(&mut self, plant: &PlantInterface) -> Result<(), ControllerError> {
        self.inner.reset(plant)?;
        let names = self.inner.internal_names();
        let find = |name: &str| names.iter().position(|n| n == name);
        self.indices = find("path_speed").zip(find("overload"));
        self.values = vec![0.0; names.len()];
        Ok(())
    }

    fn update(&mut self, measurement: &Measurement, period: f64, efforts: &mut [f64]) {
        self.inner.update(measurement, period, efforts);
        self.inner.internal_values(&mut self.values);
        let Some((speed, overload)) = self.indices else {
            return;
        };
        let v = self.values[speed];
        let trend = self.trend.update(v, period);
        if self.values[overload] > 0.5 {
            self.last_overload = measurement.time;
        }
        if measurement.time - self.last_overload < MODE_HOLD {
            let mut seen = self.seen.lock().unwrap_or_else(PoisonError::into_inner);
            seen.squares += (v - trend).powi(2);
            seen.samples += 1;
        }
    }

    fn internal_names(&self) -> Vec<String> {
        self.inner.internal_names()
    }

    fn internal_values(&self, values: &mut [f64]) {
        self.inner.internal_values(values);
    }

    fn drain_events(&mut self, events: &mut Vec<String>) {
        self.inner.drain_events(events);
    }
}

/// One run: its summary, recording and V_K oscillation.
struct Run {
    label: &'static str,
    summary: RunSummary,
    oscillation: f64,
    file: String,
}

impl Run {
    fn metric(&self, name: &str) -> f64 {
        self.summary.metric(name).unwrap_or(f64::NAN)
    }

    /// The largest peak current over all motors, A, and the motor.
    fn peak_current(&self) -> (f64, &'static str) {
        ["shoulder", "elbow", "wrist", "spindle"]
            .into_iter()
            .map(|m| (self.metric(&format!("peak_current/{m}")), m))
            .fold((0.0, "none"), |a, b| if b.0 > a.0 { b } else { a })
    }
}

fn run_one(
    out_dir: &Path,
    registry: &Registry,
    label: &'static str,
    set: &[String],
) -> Result<Run, ReproduceError> {
    let loaded = load(
        SCENARIO,
        &Overrides {
            set: set.to_vec(),
            ..Default::default()
        },
    )
    .map_err(crate::run::TwinError::from)?;
    let spec = &loaded.scenario.controller;
    let inner = registry.build(&spec.name, &spec.params).map_err(|source| {
        crate::run::TwinError::Controller {
            context: loaded.source.clone(),
            source,
        }
    })?;
    let seen = Arc::new(Mutex::new(Oscillation::default()));
    let probe = Probe {
        inner,
        seen: Arc::clone(&seen),
        indices: None,
        values: Vec::new(),
        trend: FirstOrderFilter::low_pass(TREND).expect("a positive constant"),
        last_overload: f64::NEG_INFINITY,
    };
    let file = format!("{SCENARIO}-{label}.rrd");
    let summary =
        Twin::with_controller(loaded, Box::new(probe))?.run(Some(&out_dir.join(&file)))?;
    let oscillation = seen
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .amplitude();
    Ok(Run {
        label,
        summary,
        oscillation,
        file,
    })
}

fn verdict(full: bool, partly: bool) -> Verdict {
    if full {
        Verdict::Reproduced
    } else if partly {
        Verdict::Partly
    } else {
        Verdict::NotReproduced
    }
}

pub fn run(out_dir: &Path, registry: &Registry) -> Result<Report, ReproduceError> {
    let constant = |speed: f64| {
        vec![
            "controller.name=\"path-speed-constant\"".to_string(),
            format!("controller.params={{ path_speed = {speed} }}"),
            "duration=25".to_string(),
        ]
    };
    let adaptive = run_one(out_dir, registry, "adaptive", &[])?;
    let blind = run_one(out_dir, registry, "constant-v0", &constant(V0_MM_S * 1e-3))?;
    let safe = run_one(
        out_dir,
        registry,
        "constant-safe",
        &constant(SAFE_PATH_SPEED),
    )?;
    let mm = 1e3;

    let (a_peak, a_motor) = adaptive.peak_current();
    let (b_peak, b_motor) = blind.peak_current();
    let (s_peak, _) = safe.peak_current();
    let (b_limit, b_limited) = ["shoulder", "elbow", "wrist", "spindle"]
        .into_iter()
        .map(|m| (blind.metric(&format!("at_limit_fraction/{m}")), m))
        .fold((0.0, "none"), |a, b| if b.0 > a.0 { b } else { a });
    let current = Claim {
        claim: "motor current held near the tolerance".into(),
        paper: format!("current limited close to the set point −{TOLERANCE} A (Fig. 2)"),
        twin: format!(
            "adaptive: peak {a_peak:.2} A ({a_motor}); constant V0: {b_limited} at its 20 A \
             limit {:.0} % of the contour, peak {b_peak:.2} A ({b_motor}); safe {:.0} mm/s: \
             {s_peak:.2} A",
            100.0 * b_limit,
            SAFE_PATH_SPEED * mm
        ),
        verdict: verdict(
            (0.95 * TOLERANCE..=CURRENT_MARGIN * TOLERANCE).contains(&a_peak),
            a_peak <= CURRENT_MARGIN * TOLERANCE,
        ),
    };
    let outside = adaptive.metric("path_speed_mean_outside");
    let deep = adaptive.metric("path_speed_mean_deep_zone");
    let speed = Claim {
        claim: "V_K reaches V0 where no correction is needed".into(),
        paper: format!("V_K tends to {V0_MM_S} mm/s outside the corrected zones (Fig. 3)"),
        twin: format!(
            "adaptive: mean tool path speed {:.2} mm/s outside the deep zone, {:.2} mm/s inside",
            outside * mm,
            deep * mm
        ),
        verdict: verdict(
            outside >= 0.97 * V0_MM_S / mm && deep < 0.95 * outside,
            outside >= 0.9 * V0_MM_S / mm,
        ),
    };
    let oscillation = Claim {
        claim: "V_K oscillates with a small amplitude when corrected".into(),
        paper: "fast switching, V_K close to its mean (Fig. 3)".into(),
        twin: format!(
            "adaptive: V_K amplitude {:.2} mm/s about its trend in the correction mode; tool \
             path speed {:.2} mm/s in the deep zone",
            adaptive.oscillation * mm,
            adaptive.metric("path_speed_oscillation_deep_zone") * mm
        ),
        verdict: verdict(
            adaptive.oscillation < 0.1 * V0_MM_S / mm,
            adaptive.oscillation < 0.25 * V0_MM_S / mm,
        ),
    };
    let a_dev = adaptive.metric("path_deviation_max");
    let b_dev = blind.metric("path_deviation_max");
    let deviation = Claim {
        claim: "small deviation from the programmed path".into(),
        paper: "high accuracy of the tool on the path, drives in unison (Fig. 4)".into(),
        twin: format!(
            "max (RMS) deviation: adaptive {:.3} ({:.3}) mm; constant V0 {:.2} ({:.2}) mm; \
             safe {:.3} mm",
            a_dev * mm,
            adaptive.metric("path_deviation_rms") * mm,
            b_dev * mm,
            blind.metric("path_deviation_rms") * mm,
            safe.metric("path_deviation_max") * mm
        ),
        verdict: verdict(
            a_dev <= DEVIATION_BOUND && b_dev >= 5.0 * a_dev,
            a_dev <= 2.0 * DEVIATION_BOUND,
        ),
    };
    let a_time = adaptive.metric("contour_time");
    let s_time = safe.metric("contour_time");
    let productivity = Claim {
        claim: "the fastest path speed the drives allow".into(),
        paper: "machining at the largest speed without overloading a drive (§3, Conclusion)".into(),
        twin: format!(
            "contour in {a_time:.2} s adaptive vs {s_time:.2} s at the safe {:.0} mm/s",
            SAFE_PATH_SPEED * mm
        ),
        verdict: verdict(
            a_time < s_time && adaptive.metric("contour_finished") == 1.0,
            a_time <= s_time,
        ),
    };

    let runs = [&adaptive, &blind, &safe]
        .iter()
        .map(|r| {
            let metrics: serde_json::Map<String, serde_json::Value> = r
                .summary
                .metrics
                .iter()
                .map(|(k, v)| (k.clone(), json!(v)))
                .collect();
            json!({
                "scenario": SCENARIO,
                "label": r.label,
                "controller": r.summary.controller,
                "recording": r.file,
                "v_k_oscillation": r.oscillation,
                "status": if r.summary.failure.is_some() { "diverged" } else { "ok" },
                "metrics": metrics,
            })
        })
        .collect();
    Ok(Report {
        paper: "Ilyukhin, Poduraev & Tatarintseva 2014: adaptive correction of the continuous \
                path speed of a machining robot"
            .into(),
        claims: vec![current, speed, oscillation, deviation, productivity],
        runs,
    })
}
