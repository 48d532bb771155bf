//! Evaluators: the scenario's `[[metrics]]` computed by observers of the run, beside the other
//! observers (the recording, the caller's); see `scenario::metrics` for the kinds.

use super::layout::SignalLayout;
use super::observer::{Findings, Observer, ObserverError, StepView};
use crate::scenario::{MetricKind, MetricSpec};
use crate::spectrum::Spectrum;

/// Where a named signal is found in a step.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Source {
    True(usize),
    Measured(usize),
    Internal(usize),
    Diagnostic(usize),
    Commanded(usize),
    Applied(usize),
    Saturated(usize),
}

impl Source {
    fn find(name: &str, layout: &SignalLayout) -> Option<Self> {
        let (prefix, rest) = name.split_once('/').unwrap_or(("", name));
        match prefix {
            "measured" => layout.signal(rest).map(Source::Measured),
            "controller" => layout.internal(rest).map(Source::Internal),
            "diagnostics" => layout.diagnostic(rest).map(Source::Diagnostic),
            "saturated" => layout.actuator(rest).map(Source::Saturated),
            "effort" => match rest.split_once('/') {
                Some(("commanded", joint)) => layout.actuator(joint).map(Source::Commanded),
                Some(("applied", joint)) => layout.actuator(joint).map(Source::Applied),
                _ => None,
            },
            _ => layout.signal(name).map(Source::True),
        }
    }

    fn value(self, view: &StepView) -> f64 {
        match self {
            Source::True(i) => view.signals[i],
            Source::Measured(i) => view.measured[i],
            Source::Internal(i) => view.internals[i],
            Source::Diagnostic(i) => view.diagnostics[i],
            Source::Commanded(i) => view.commanded[i],
            Source::Applied(i) => view.applied[i],
            Source::Saturated(i) => f64::from(u8::from(view.saturated[i])),
        }
    }
}

/// Running statistics of the judged value.
#[derive(Debug, Clone, Default)]
struct Statistics {
    count: usize,
    sum: f64,
    sum_of_squares: f64,
    mean: f64,
    deviation_squares: f64,
    max_abs: f64,
    max: f64,
    min: f64,
    last: f64,
    /// Start of the current stretch within the band, if inside it.
    settled_since: Option<f64>,
    /// Every value and the first and last times (spectral kinds only).
    samples: Vec<f64>,
    first_time: f64,
    last_time: f64,
}

impl Statistics {
    fn add(&mut self, time: f64, value: f64, band: Option<f64>) {
        if self.count == 0 {
            (self.max, self.min) = (value, value);
            self.first_time = time;
        }
        self.last_time = time;
        self.count += 1;
        self.sum += value;
        self.sum_of_squares += value * value;
        let delta = value - self.mean;
        self.mean += delta / self.count as f64;
        self.deviation_squares += delta * (value - self.mean);
        self.max_abs = self.max_abs.max(value.abs());
        self.max = self.max.max(value);
        self.min = self.min.min(value);
        self.last = value;
        if let Some(band) = band {
            self.settled_since = match (value.abs() <= band, self.settled_since) {
                (true, Some(since)) => Some(since),
                (true, None) => Some(time),
                (false, _) => None,
            };
        }
    }
}

/// A declared figure, bound to a run's layout.
#[derive(Debug, Clone)]
pub struct Evaluator {
    spec: MetricSpec,
    signal: Source,
    reference: Option<Source>,
    /// Sampled only when the controller measured (a `measured/` source).
    at_control_updates: bool,
    statistics: Statistics,
}

impl Evaluator {
    /// Binds `spec` to the run's signals; an unknown name is an error naming it.
    pub fn bind(spec: &MetricSpec, layout: &SignalLayout) -> Result<Self, String> {
        let find = |name: &str| {
            Source::find(name, layout).ok_or_else(|| {
                format!(
                    "metrics `{}`: no signal `{name}` in this run (plant signals: {}; or \
                     measured/…, controller/…, diagnostics/…, effort/commanded/…, \
                     effort/applied/…, saturated/…)",
                    spec.name,
                    layout.signals.join(", ")
                )
            })
        };
        let signal = find(&spec.signal)?;
        let reference = spec.reference.as_deref().map(find).transpose()?;
        let measured = |s: &Source| matches!(s, Source::Measured(_));
        Ok(Self {
            spec: spec.clone(),
            at_control_updates: measured(&signal) || reference.as_ref().is_some_and(measured),
            signal,
            reference,
            statistics: Statistics::default(),
        })
    }

    /// The figure, by the spec's kind (NaN when the window held no sample).
    pub fn value(&self) -> f64 {
        let s = &self.statistics;
        if s.count == 0 {
            return f64::NAN;
        }
        let n = s.count as f64;
        match self.spec.kind {
            MetricKind::Mse => s.sum_of_squares / n,
            MetricKind::Rms => (s.sum_of_squares / n).sqrt(),
            MetricKind::Mean => s.sum / n,
            MetricKind::Std => (s.deviation_squares / n).sqrt(),
            MetricKind::MaxAbs => s.max_abs,
            MetricKind::Max => s.max,
            MetricKind::Min => s.min,
            MetricKind::Final => s.last,
            MetricKind::SettleTime => s.settled_since.map_or(f64::NAN, |t| t - self.spec.from),
            MetricKind::SpectrumPeak | MetricKind::SpectrumPeakFrequency => {
                let band = self.spec.frequencies.unwrap_or([0.0, f64::INFINITY]);
                let peak = self.spectrum().peak(band);
                match (self.spec.kind, peak) {
                    (MetricKind::SpectrumPeak, Some((_, amplitude))) => amplitude,
                    (_, Some((frequency, _))) => frequency,
                    (_, None) => f64::NAN,
                }
            }
        }
    }
}

impl Evaluator {
    /// The spectrum of the judged values in the window (a spectral kind's; empty for the
    /// others, which keep no samples).
    pub(super) fn spectrum(&self) -> Spectrum {
        Spectrum::of(&self.statistics.samples, self.sample_period())
    }

    /// The time between the window's samples, s (0 with fewer than two).
    pub(super) fn sample_period(&self) -> f64 {
        let s = &self.statistics;
        if s.count < 2 {
            return 0.0;
        }
        (s.last_time - s.first_time) / (s.count - 1) as f64
    }

    /// The window's samples: how many and their first and last times, s.
    pub(super) fn window(&self) -> (usize, [f64; 2]) {
        let s = &self.statistics;
        (s.count, [s.first_time, s.last_time])
    }

    /// The judged value's smallest, mean and largest over the window (`None`: no sample).
    pub(super) fn extremes(&self) -> Option<[f64; 3]> {
        let s = &self.statistics;
        (s.count > 0).then(|| [s.min, s.sum / s.count as f64, s.max])
    }
}

impl Observer for Evaluator {
    fn observe(&mut self, view: &StepView) -> Result<(), ObserverError> {
        let within = view.time >= self.spec.from && self.spec.to.is_none_or(|to| view.time <= to);
        if !within || (self.at_control_updates && !view.control_update) {
            return Ok(());
        }
        let x = self.signal.value(view);
        let judged = match self.reference {
            Some(reference) => reference.value(view) - x,
            None => x,
        };
        let value = self.spec.scale * judged;
        self.statistics.add(view.time, value, self.spec.band);
        if self.spec.kind.is_spectral() {
            self.statistics.samples.push(value);
        }
        Ok(())
    }

    fn finish(&mut self) -> Result<Findings, ObserverError> {
        Ok(Findings {
            metrics: vec![(self.spec.name.clone(), self.value())],
            warnings: Vec::new(),
        })
    }
}
