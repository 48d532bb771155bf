//! What the shadow reports: an anomaly, the stretch of time in which the machine stopped
//! behaving like its model, and the tracked parameters it names as its cause.

/// A stretch of time in which the machine stopped behaving like its model.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Anomaly {
    /// The signals whose tests alarmed (and the parameters that drifted).
    pub signals: Vec<String>,
    /// Where the tests place its start, s since the first sample.
    pub start: f64,
    /// When it was detected, s since the first sample.
    pub detected: f64,
    /// When every test was released again; `None` while it lasts.
    pub end: Option<f64>,
    /// The largest standardised shift during it: of a signal's innovation, in standard
    /// deviations of a healthy block mean, or of a tracked parameter from its reference, in
    /// standard deviations of their difference.
    pub size: f64,
    /// The parameter that explains it, if one moved significantly.
    pub attribution: Option<Attribution>,
}

/// A tracked parameter named as the cause of an anomaly.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Attribution {
    /// Its scenario key.
    pub parameter: String,
    /// Its estimate at the anomaly's start, SI.
    pub before: f64,
    /// Its estimate now (or at the anomaly's end), SI.
    pub estimate: f64,
    /// The estimate's 95 % interval.
    pub interval: [f64; 2],
    /// How far it moved, in its standard deviations.
    pub shift_sigmas: f64,
}
