//! Evaluators: the figures a scenario is judged by, declared in its `[[metrics]]` tables and
//! computed by observers of the run, apart from the machine that is simulated.
//!
//! Each entry names a signal `x` (and optionally a `reference` `r`, making the judged value the
//! error `e = scale·(r − x)`, else `e = scale·x`), a window `from ≤ t ≤ to` and a kind:
//!
//! | kind          | figure                                            | unit             |
//! |---------------|---------------------------------------------------|------------------|
//! | `mse`         | (1/N) Σ e²                                        | (scale·unit of x)² |
//! | `rms`         | √((1/N) Σ e²)                                     | scale·unit of x  |
//! | `mean`        | (1/N) Σ e                                         | scale·unit of x  |
//! | `std`         | √((1/N) Σ (e − ē)²) (population σ, Welford)       | scale·unit of x  |
//! | `max_abs`     | max \|e\| (a peak)                                | scale·unit of x  |
//! | `max`, `min`  | max e, min e                                      | scale·unit of x  |
//! | `final`       | e at the window's last sample                     | scale·unit of x  |
//! | `settle_time` | t₁ − from, t₁ the first sample from which \|e\| ≤ `band` to the window's end (NaN if \|e\| > band at the end) | s |
//! | `spectrum_peak` | largest amplitude of e's one-sided amplitude spectrum within `frequencies = [low, high]` Hz (default: all), see the run's spectrum | scale·unit of x |
//! | `spectrum_peak_frequency` | the frequency of that peak | Hz |
//!
//! Signals are named as in the run's signal layout: a plant signal by its name is its true
//! value (`ram_position`, `table.position`, `reference`); `measured/<signal>` is what the
//! controller measured (sampled only at control updates); `controller/<internal>`,
//! `diagnostics/<name>`, `effort/commanded/<joint>`, `effort/applied/<joint>`, and
//! `saturated/<joint>` (1 while the joint's effort is clipped, else 0: its `mean` is the
//! saturation share). Samples are every physics step in the window.

use serde::{Deserialize, Serialize};

/// One `[[metrics]]` entry of a scenario.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct MetricSpec {
    /// The figure's name in the summary.
    pub name: String,
    /// Which figure of the judged value over the window.
    pub kind: MetricKind,
    /// The signal judged (see the module's naming).
    pub signal: String,
    /// When given, the figure is of `reference − signal`.
    pub reference: Option<String>,
    /// Window start, s.
    #[serde(default)]
    pub from: f64,
    /// Window end, s (default: the run's end).
    pub to: Option<f64>,
    /// Factor on the judged value (a change of unit, e.g. 100 for m → cm).
    #[serde(default = "unit_scale")]
    pub scale: f64,
    /// `settle_time`: the band |e| must stay within.
    pub band: Option<f64>,
    /// `spectrum_peak…`: the frequency range searched, Hz.
    pub frequencies: Option<[f64; 2]>,
    /// The figure's unit, for the reader (documentation only).
    #[serde(default)]
    pub unit: String,
}

fn unit_scale() -> f64 {
    1.0
}

/// What figure a metric takes of its judged value (the signal, or `reference − signal`, times
/// `scale`) over its window's samples.
#[derive(Debug, Clone, Copy, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum MetricKind {
    /// Mean square, in the judged value's unit squared.
    Mse,
    /// Root mean square.
    Rms,
    /// Arithmetic mean of the samples.
    Mean,
    /// Population standard deviation (about the window's mean).
    Std,
    /// Largest |value|.
    MaxAbs,
    /// Largest value.
    Max,
    /// Smallest value.
    Min,
    /// The last sample's value.
    Final,
    /// Time from the window's start until |value| entered `band` for good, s; NaN if it ends
    /// outside.
    SettleTime,
    /// Largest amplitude of the one-sided spectrum within `frequencies`.
    SpectrumPeak,
    /// Frequency of that largest amplitude, Hz.
    SpectrumPeakFrequency,
}

impl MetricKind {
    pub(crate) fn is_spectral(self) -> bool {
        matches!(self, Self::SpectrumPeak | Self::SpectrumPeakFrequency)
    }
}

impl MetricSpec {
    /// A figure of `kind` over the whole run of `signal`, unscaled.
    pub fn new(name: &str, kind: MetricKind, signal: &str) -> Self {
        Self {
            name: name.into(),
            kind,
            signal: signal.into(),
            reference: None,
            from: 0.0,
            to: None,
            scale: 1.0,
            band: None,
            frequencies: None,
            unit: String::new(),
        }
    }

    /// Checks what can be checked before the run (names are checked against the run's layout).
    pub fn validate(&self) -> Result<(), String> {
        let at = |what: String| format!("metrics `{}`: {what}", self.name);
        if self.name.is_empty() {
            return Err("metrics: every entry needs a name".into());
        }
        if !(self.from.is_finite() && self.from >= 0.0) {
            return Err(at(format!(
                "from must be finite and ≥ 0, got {}",
                self.from
            )));
        }
        if let Some(to) = self.to {
            if !(to.is_finite() && to >= self.from) {
                return Err(at(format!("to must be finite and ≥ from, got {to}")));
            }
        }
        if !(self.scale.is_finite() && self.scale != 0.0) {
            return Err(at(format!(
                "scale must be finite and ≠ 0, got {}",
                self.scale
            )));
        }
        if let Some([low, high]) = self.frequencies {
            if !self.kind.is_spectral() {
                return Err(at("frequencies is only for the spectrum_peak kinds".into()));
            }
            if !(low.is_finite() && high.is_finite() && 0.0 <= low && low < high) {
                return Err(at(format!(
                    "frequencies must be [low, high] Hz with 0 ≤ low < high, got [{low}, {high}]"
                )));
            }
        }
        match (self.kind, self.band) {
            (MetricKind::SettleTime, Some(band)) if band.is_finite() && band > 0.0 => Ok(()),
            (MetricKind::SettleTime, _) => Err(at("settle_time needs a band > 0".into())),
            (_, Some(_)) => Err(at("band is only for kind = \"settle_time\"".into())),
            (_, None) => Ok(()),
        }
    }
}
