//! Anomaly detection on the filter's normalised innovations, with thresholds set from a stated
//! false-alarm rate and the healthy data's own statistics:
//!
//! - **learning:** over the first seconds (healthy by assumption) each signal's normalised
//!   innovation z = ν/√S is measured: its mean, spread and lag-1 correlation ρ, and so is the
//!   NIS. A model that fits gives z white with unit spread; a real one departs from that, and
//!   the tests below are set on what was measured, not on the ideal;
//! - **CUSUM per signal, two-sided**, on block means of z (blocks of ⌈(1 + ρ)/(1 − ρ)⌉
//!   samples, so that they are nearly independent), standardised, with reference k = ½ (a
//!   shift of one standard deviation of a block mean) and threshold h from Siegmund's
//!   average-run-length formula so that the false alarms over all tests together do not
//!   exceed the stated rate. It alarms above h and releases below h/2 (hysteresis);
//! - **χ² on the NIS** (νᵀS⁻¹ν) summed over windows of one second, standardised by its
//!   learnt mean and spread: the test of all signals together. Its threshold is Student's t
//!   quantile for the learnt quarter windows (a prediction bound from n of them: n − 1
//!   degrees of freedom, scaled by √(1 + 1/n)), as mean and spread are estimates;
//! - **parameter drift:** each tracked parameter's estimate against its value at the end of
//!   learning, in standard deviations of their difference.
//!
//! An anomaly opens when any test alarms and closes when every test has been released for one
//! second; it carries the signals that alarmed, its start (the CUSUM's change-point estimate),
//! its end and its size (the largest standardised shift).

use super::anomaly::{Anomaly, Attribution};
use super::student::student_quantile;
use std::collections::VecDeque;

/// Seconds every test must stay released before an anomaly closes.
const RELEASE_HOLD: f64 = 1.0;
/// Window of the NIS test, s.
const NIS_WINDOW: f64 = 1.0;
/// A parameter is named as the cause when it moved by more than this many standard deviations.
const ATTRIBUTION_SIGMAS: f64 = 3.0;
/// Seconds after its end during which an anomaly's attribution is still updated, as the
/// parameters settle on their new values.
const ATTRIBUTION_SETTLE: f64 = 10.0;
/// Seconds the tests wait at least after a gap in the samples while the filter takes the state
/// up again.
pub(super) const REACQUIRE: f64 = 2.0;
/// Seconds every innovation must stay in its learnt band before the tests resume after a gap.
const SETTLED: f64 = 0.5;
/// A normalised innovation is in its learnt band within this many learnt spreads of its mean.
const BAND: f64 = 4.0;
/// Seconds after a gap at most that the tests wait for the innovations to settle: a machine
/// that changed while it was out of sight is tested again, its parameters freed.
const REACQUIRE_LIMIT: f64 = 10.0;
/// CUSUM reference value, in standard deviations of a block mean.
const REFERENCE: f64 = 0.5;
/// The least learnt spread of the NIS per degree of freedom the NIS test standardises by: a
/// tenth of the smallest a χ² per degree of freedom has (√(2/m) for m ≤ 200 signals). A signal
/// that hardly moved while learning (a held axis read through a quantised encoder) learns a
/// spread near zero, and the test would then alarm on the filter's own settling.
const LEAST_NIS_SPREAD: f64 = 0.01;
/// Quarter windows: the NIS window's spread is also learnt from the NIS summed over these.
const BATCHES_PER_WINDOW: f64 = 4.0;
/// The least number of learnt quarter windows the batch-means spread is taken from.
const LEAST_BATCHES: usize = 8;

/// Running sums of one statistic: mean, spread and lag-1 correlation.
#[derive(Debug, Clone, Default)]
struct Moments {
    count: f64,
    sum: f64,
    squares: f64,
    lagged: f64,
    last: Option<f64>,
}

impl Moments {
    fn add(&mut self, value: f64) {
        self.count += 1.0;
        self.sum += value;
        self.squares += value * value;
        if let Some(last) = self.last {
            self.lagged += last * value;
        }
        self.last = Some(value);
    }

    fn mean(&self) -> f64 {
        self.sum / self.count.max(1.0)
    }

    fn spread(&self) -> f64 {
        let mean = self.mean();
        (self.squares / self.count.max(1.0) - mean * mean)
            .max(0.0)
            .sqrt()
    }

    /// Lag-1 correlation, clipped to [0, 0.98] (a negative one is taken as none).
    fn correlation(&self) -> f64 {
        let mean = self.mean();
        let variance = self.spread().powi(2);
        if variance <= 0.0 || self.count < 3.0 {
            return 0.0;
        }
        let covariance = self.lagged / (self.count - 1.0) - mean * mean;
        (covariance / variance).clamp(0.0, 0.98)
    }
}

/// A two-sided CUSUM on one signal's block means.
#[derive(Debug, Clone, Default)]
struct SignalTest {
    learnt: Moments,
    mean: f64,
    /// Spread of a block mean.
    scale: f64,
    block: usize,
    filling: (usize, f64),
    high: f64,
    low: f64,
    /// Times the sums were last zero: the change-point estimates.
    high_zero: f64,
    low_zero: f64,
    alarm: bool,
    /// The largest standardised block mean while alarmed.
    peak: f64,
}

/// A tracked parameter's drift test.
#[derive(Debug, Clone, Default)]
struct KnobTest {
    reference: (f64, f64),
    alarm: bool,
    /// (time, estimate) over the last seconds, to read the value at an anomaly's start.
    history: VecDeque<(f64, f64)>,
    calm_since: f64,
    /// The largest drift while alarmed, in standard deviations.
    peak: f64,
}

/// The statistics a step shows, per test.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DetectorView {
    /// Per watched signal: the larger of its two CUSUM sums, in units of its threshold.
    pub cusum: Vec<f64>,
    /// The last NIS window's statistic, in units of its threshold.
    pub nis: f64,
    /// Per tracked parameter: its drift in units of its threshold.
    pub drift: Vec<f64>,
    /// Whether an anomaly is open.
    pub alarm: bool,
}

/// What the detector was told at setup.
pub(super) struct DetectorSetup {
    pub signals: Vec<String>,
    pub knobs: Vec<String>,
    pub false_alarms_per_hour: f64,
    pub learn: f64,
}

/// All tests and the anomalies found.
pub(super) struct Detector {
    setup: DetectorSetup,
    start: Option<f64>,
    learning: bool,
    signals: Vec<SignalTest>,
    knobs: Vec<KnobTest>,
    nis_learnt: Moments,
    /// While learning: the NIS summed over quarter windows (start, sum, count), for the
    /// window's spread by batch means.
    nis_batches: Vec<(f64, f64, usize)>,
    nis_window: (f64, f64, usize),
    nis_scale: (f64, f64),
    nis_threshold: f64,
    cusum_threshold: f64,
    drift_threshold: f64,
    released_since: f64,
    /// After a gap: since when the tests wait, and since when the innovations are in band.
    reacquiring: Option<(f64, Option<f64>)>,
    /// Seconds the tests wait at least after the reacquisition began.
    wait: f64,
    open: Option<Anomaly>,
    pub closed: Vec<Anomaly>,
    pub view: DetectorView,
}

impl Detector {
    /// A detector for these signals and parameters, learning first.
    pub fn new(setup: DetectorSetup) -> Self {
        Self {
            signals: vec![SignalTest::default(); setup.signals.len()],
            knobs: vec![KnobTest::default(); setup.knobs.len()],
            view: DetectorView {
                cusum: vec![0.0; setup.signals.len()],
                drift: vec![0.0; setup.knobs.len()],
                ..DetectorView::default()
            },
            setup,
            start: None,
            learning: true,
            nis_learnt: Moments::default(),
            nis_batches: Vec::new(),
            nis_window: (0.0, 0.0, 0),
            nis_scale: (0.0, 1.0),
            nis_threshold: f64::INFINITY,
            cusum_threshold: f64::INFINITY,
            drift_threshold: f64::INFINITY,
            released_since: 0.0,
            reacquiring: None,
            wait: 0.0,
            open: None,
            closed: Vec::new(),
        }
    }

    /// After a gap in the samples (or a command that came too late to be used): the tests wait
    /// while the filter takes the state up again, at least `wait` s after `time` (after a gap,
    /// [`REACQUIRE`]) and until every innovation has been in its learnt band for [`SETTLED`] s
    /// (at most [`REACQUIRE_LIMIT`] s); the parameters keep their references.
    pub fn resume_after(&mut self, time: f64, wait: f64) {
        let since = match self.reacquiring {
            Some((since, _)) => since,
            None => time,
        };
        self.reacquiring = Some((since, None));
        self.wait = self.wait.max(wait + time - since);
    }

    /// Whether the tests are waiting for the state to be taken up again after a gap.
    pub fn reacquiring(&self) -> bool {
        self.reacquiring.is_some()
    }

    /// While reacquiring: whether the innovations `z` have now settled in their band (the tests
    /// then start afresh from `time`).
    fn reacquired(&mut self, time: f64, z: &[(usize, f64)]) -> bool {
        let Some((since, calm)) = self.reacquiring else {
            return true;
        };
        let in_band = z.iter().all(|&(s, value)| {
            let test = &self.signals[s];
            let (mean, spread) = match self.learning {
                true => (0.0, 1.0),
                false => (test.mean, test.learnt.spread().max(1e-12)),
            };
            (value - mean).abs() <= BAND * spread
        });
        let calm = if in_band { calm.or(Some(time)) } else { None };
        let settled = calm.is_some_and(|c| time - c >= SETTLED) && time - since >= self.wait;
        if !(settled || time - since >= REACQUIRE_LIMIT) {
            self.reacquiring = Some((since, calm));
            return false;
        }
        (self.reacquiring, self.wait) = (None, 0.0);
        for test in &mut self.signals {
            (test.high, test.low, test.filling) = (0.0, 0.0, (0, 0.0));
            (test.high_zero, test.low_zero) = (time, time);
        }
        self.nis_window = (time, 0.0, 0);
        true
    }

    /// Whether the detector is still learning the healthy statistics.
    pub fn learning(&self) -> bool {
        self.learning
    }

    /// The thresholds in use: CUSUM h (block-mean σ), NIS window and drift (σ).
    pub fn thresholds(&self) -> [f64; 3] {
        [
            self.cusum_threshold,
            self.nis_threshold,
            self.drift_threshold,
        ]
    }

    /// Takes one update: normalised innovations `z` of the signals observed, the NIS per degree
    /// of freedom and the parameters' estimates. Returns an anomaly that opened or closed now.
    pub fn observe(
        &mut self,
        time: f64,
        z: &[(usize, f64)],
        nis_per_dof: f64,
        knobs: &[(f64, f64)],
    ) -> Option<AnomalyChange> {
        // Learning starts once the state is acquired: the first samples' innovations, while
        // the filter finds the machine, say nothing of its health.
        if !self.reacquired(time, z) {
            return None;
        }
        let start = *self.start.get_or_insert(time);
        if self.learning {
            if time < start + self.setup.learn {
                for &(s, value) in z {
                    self.signals[s].learnt.add(value);
                }
                self.nis_learnt.add(nis_per_dof);
                self.batch_nis(nis_per_dof, time);
                return None;
            }
            self.end_learning(time, knobs);
        }
        for &(s, value) in z {
            self.signal_step(s, value, time);
        }
        self.nis_step(nis_per_dof, time);
        self.knob_step(knobs, time);
        self.transition(time, knobs)
    }

    /// Sets every threshold from the learnt statistics and the false-alarm rate.
    fn end_learning(&mut self, time: f64, knobs: &[(f64, f64)]) {
        self.learning = false;
        let learnt_for = (time - self.start.unwrap_or(time)).max(1e-9);
        let tests = (self.signals.len() + 1 + self.knobs.len()) as f64;
        // False alarms per hour each test may give.
        let share = self.setup.false_alarms_per_hour / tests;
        let mut blocks_per_second: f64 = 0.0;
        for test in &mut self.signals {
            let rho = test.learnt.correlation();
            let inflation = (1.0 + rho) / (1.0 - rho);
            test.block = (inflation.ceil() as usize).clamp(1, 50);
            test.mean = test.learnt.mean();
            let spread = test.learnt.spread().max(1e-12);
            test.scale = spread * (inflation / test.block as f64).sqrt();
            test.high_zero = time;
            test.low_zero = time;
            blocks_per_second =
                blocks_per_second.max(test.learnt.count / learnt_for / test.block as f64);
        }
        // Two one-sided sums: each may alarm half as often.
        let run_length = 2.0 * 3600.0 * blocks_per_second / share;
        self.cusum_threshold = siegmund_threshold(run_length);
        let per_window = share * NIS_WINDOW / 3600.0;
        // The NIS window is standardised by a mean and a spread learnt from the quarter
        // windows: a prediction bound from them is Student's, not the normal's.
        let batches = self.nis_batches.len().saturating_sub(1).max(2) as f64;
        self.nis_threshold =
            student_quantile(per_window, batches - 1.0) * (1.0 + 1.0 / batches).sqrt();
        self.drift_threshold = normal_quantile(1.0 - 0.5 * per_window);
        let rho = self.nis_learnt.correlation();
        let per_second = self.nis_learnt.count / learnt_for;
        let samples = (per_second * NIS_WINDOW).max(1.0);
        let spread = self.nis_learnt.spread().max(LEAST_NIS_SPREAD)
            * (samples * (1.0 + rho) / (1.0 - rho)).sqrt();
        let mean = self.nis_learnt.mean();
        let batched = self.batch_means_spread(mean).unwrap_or(0.0);
        self.nis_scale = (mean, spread.max(batched).max(1e-12));
        for (test, &estimate) in self.knobs.iter_mut().zip(knobs) {
            test.reference = estimate;
            test.calm_since = time;
        }
        self.nis_window = (time, 0.0, 0);
    }

    /// One signal's normalised innovation into its block and CUSUM.
    fn signal_step(&mut self, s: usize, value: f64, time: f64) {
        let threshold = self.cusum_threshold;
        let test = &mut self.signals[s];
        test.filling.0 += 1;
        test.filling.1 += value;
        if test.filling.0 < test.block {
            return;
        }
        let y = (test.filling.1 / test.filling.0 as f64 - test.mean) / test.scale;
        test.filling = (0, 0.0);
        test.high = (test.high + y - REFERENCE).max(0.0);
        test.low = (test.low - y - REFERENCE).max(0.0);
        if test.high == 0.0 {
            test.high_zero = time;
        }
        if test.low == 0.0 {
            test.low_zero = time;
        }
        let sum = test.high.max(test.low);
        if sum > threshold {
            test.alarm = true;
        } else if sum < 0.5 * threshold {
            test.alarm = false;
        }
        if test.alarm {
            test.peak = test.peak.max(y.abs());
        }
        self.view.cusum[s] = sum / threshold;
    }

    /// The NIS into its window; the window's test when it is full.
    /// While learning: adds the NIS to the quarter window it falls in.
    fn batch_nis(&mut self, nis_per_dof: f64, time: f64) {
        match self.nis_batches.last_mut() {
            Some((since, sum, count)) if time - *since < NIS_WINDOW / BATCHES_PER_WINDOW => {
                *sum += nis_per_dof;
                *count += 1;
            }
            _ => self.nis_batches.push((time, nis_per_dof, 1)),
        }
    }

    /// The spread of a window's NIS sum about `mean` from the learnt quarter windows (batch
    /// means: it holds whatever correlation is shorter than a quarter window, where the lag-1
    /// correlation alone misses a longer one, as a held axis's quantised readings have), or
    /// from whole windows sliding by a quarter, whichever is larger; `None` with fewer than
    /// [`LEAST_BATCHES`] quarters.
    fn batch_means_spread(&self, mean: f64) -> Option<f64> {
        // The last quarter is cut short by the end of learning.
        let whole = &self.nis_batches[..self.nis_batches.len().saturating_sub(1)];
        if whole.len() < LEAST_BATCHES {
            return None;
        }
        let squares = (whole.iter())
            .map(|&(_, sum, count)| (sum - count as f64 * mean).powi(2))
            .sum::<f64>();
        let batch_means = (BATCHES_PER_WINDOW * squares / whole.len() as f64).sqrt();
        // Whole windows sliding by a quarter: their sums' spread about the mean holds what
        // drifts slower than a window (the level of the NIS wandering with the machine's
        // operating point, or an encoder's quantisation beating with the sampling).
        let quarters = BATCHES_PER_WINDOW as usize;
        let windows: Vec<f64> = (whole.windows(quarters))
            .map(|w| {
                let (sum, count) =
                    (w.iter()).fold((0.0, 0), |(s, c), &(_, sum, count)| (s + sum, c + count));
                (sum - count as f64 * mean).powi(2)
            })
            .collect();
        let sliding = (windows.iter().sum::<f64>() / windows.len().max(1) as f64).sqrt();
        Some(batch_means.max(sliding))
    }

    fn nis_step(&mut self, nis_per_dof: f64, time: f64) {
        let (since, sum, count) = &mut self.nis_window;
        *sum += nis_per_dof;
        *count += 1;
        if time - *since < NIS_WINDOW {
            return;
        }
        let (mean, spread) = self.nis_scale;
        let statistic = (*sum - *count as f64 * mean) / spread;
        self.view.nis = statistic / self.nis_threshold;
        self.nis_window = (time, 0.0, 0);
    }

    /// Each parameter's drift from its reference.
    fn knob_step(&mut self, knobs: &[(f64, f64)], time: f64) {
        let threshold = self.drift_threshold;
        for ((test, &(value, sigma)), view) in
            self.knobs.iter_mut().zip(knobs).zip(&mut self.view.drift)
        {
            let drift = (value - test.reference.0).abs() / sigma.max(1e-300);
            if drift > threshold {
                test.alarm = true;
            } else if drift < 0.5 * threshold {
                test.alarm = false;
            }
            if test.alarm {
                test.peak = test.peak.max(drift);
            }
            if drift < 1.0 {
                test.calm_since = time;
            }
            *view = drift / threshold;
            test.history.push_back((time, value));
            while test.history.front().is_some_and(|(t, _)| time - t > 60.0) {
                test.history.pop_front();
            }
        }
    }
}

/// An anomaly that opened or closed at an update.
#[derive(Debug, Clone, PartialEq)]
pub enum AnomalyChange {
    /// Detected now.
    Opened(Anomaly),
    /// Every test has been released long enough.
    Closed(Anomaly),
}

impl Detector {
    /// Opens, extends or closes the anomaly after an update's tests.
    fn transition(&mut self, time: f64, knobs: &[(f64, f64)]) -> Option<AnomalyChange> {
        let nis_alarm = self.view.nis > 1.0;
        let mut names: Vec<String> = self
            .signals
            .iter()
            .zip(&self.setup.signals)
            .filter(|(test, _)| test.alarm)
            .map(|(_, name)| name.clone())
            .collect();
        names.extend(
            (self.knobs.iter().zip(&self.setup.knobs))
                .filter(|(test, _)| test.alarm)
                .map(|(_, name)| name.clone()),
        );
        if nis_alarm && names.is_empty() {
            // The joint test alone: every signal together departs from the model.
            names.clone_from(&self.setup.signals);
        }
        let alarming = nis_alarm || !names.is_empty();
        self.view.alarm = alarming || self.open.is_some();
        if alarming {
            self.released_since = time;
        }
        let start = self.change_point(time);
        let size = (self.signals.iter().map(|t| t.peak))
            .chain(self.knobs.iter().map(|t| t.peak))
            .fold(0.0, f64::max);
        if self.open.is_none() {
            self.settle(time, knobs);
        }
        match &mut self.open {
            None if alarming => {
                let mut anomaly = Anomaly {
                    signals: names,
                    start,
                    detected: time,
                    end: None,
                    size,
                    attribution: None,
                };
                anomaly.attribution = self.attribute(anomaly.start, knobs);
                self.open = Some(anomaly.clone());
                Some(AnomalyChange::Opened(anomaly))
            }
            None => None,
            Some(anomaly) => {
                for name in names {
                    if !anomaly.signals.contains(&name) {
                        anomaly.signals.push(name);
                    }
                }
                anomaly.size = anomaly.size.max(size);
                let since = anomaly.start;
                let attribution = self.attribute(since, knobs);
                let anomaly = self.open.as_mut()?;
                // Until it ends, the parameter that explains it is the one that moved most so
                // far; when it ends, that is what it is put on.
                anomaly.attribution = attribution;
                if alarming || time - self.released_since < RELEASE_HOLD {
                    return None;
                }
                let mut closed = self.open.take()?;
                closed.end = Some(self.released_since);
                for test in &mut self.signals {
                    test.peak = 0.0;
                }
                for test in &mut self.knobs {
                    test.peak = 0.0;
                }
                self.closed.push(closed.clone());
                Some(AnomalyChange::Closed(closed))
            }
        }
    }

    /// Updates the last closed anomaly's estimate of the parameter that explains it while the
    /// parameters settle; which parameter that is (or that none does) was said when it closed.
    fn settle(&mut self, time: f64, knobs: &[(f64, f64)]) {
        let Some(last) = self.closed.last() else {
            return;
        };
        if last.end.is_some_and(|end| time - end < ATTRIBUTION_SETTLE) {
            let attribution = self.attribute(last.start, knobs);
            if let (Some(last), Some(new)) = (self.closed.last_mut(), attribution) {
                if last
                    .attribution
                    .as_ref()
                    .is_some_and(|a| a.parameter == new.parameter)
                {
                    last.attribution = Some(new);
                }
            }
        }
    }

    /// Where the alarming tests say the change began: the earliest change point of an alarmed
    /// CUSUM, or of a drifting parameter (when it last was within a standard deviation).
    fn change_point(&self, time: f64) -> f64 {
        let signals = self.signals.iter().filter(|t| t.alarm).map(|t| {
            if t.high >= t.low {
                t.high_zero
            } else {
                t.low_zero
            }
        });
        let knobs = self.knobs.iter().filter(|t| t.alarm).map(|t| t.calm_since);
        signals.chain(knobs).fold(time, f64::min)
    }

    /// The parameter whose estimate moved most since `since`, if by more than
    /// [`ATTRIBUTION_SIGMAS`] of its present standard deviation.
    fn attribute(&self, since: f64, knobs: &[(f64, f64)]) -> Option<Attribution> {
        let moved = self.knobs.iter().zip(knobs).zip(&self.setup.knobs).map(
            |((test, &(value, sigma)), name)| {
                let before = test
                    .history
                    .iter()
                    .rev()
                    .find(|(t, _)| *t <= since)
                    .or(test.history.front())
                    .map_or(value, |(_, v)| *v);
                let shift = (value - before) / sigma.max(1e-300);
                (name, before, value, sigma, shift)
            },
        );
        let (name, before, value, sigma, shift) =
            moved.max_by(|a, b| a.4.abs().total_cmp(&b.4.abs()))?;
        (shift.abs() > ATTRIBUTION_SIGMAS).then(|| Attribution {
            parameter: name.clone(),
            before,
            estimate: value,
            interval: [value - 1.96 * sigma, value + 1.96 * sigma],
            shift_sigmas: shift,
        })
    }

    /// The anomaly still open, if any (at the end of a run).
    pub fn open(&self) -> Option<&Anomaly> {
        self.open.as_ref()
    }
}

/// The CUSUM threshold h whose one-sided average run length, for a mean-zero unit-variance
/// input and reference [`REFERENCE`], is `run_length` samples (Siegmund's approximation
/// ARL = (e^{2kb} − 2kb − 1)/(2k²), b = h + 1.166), by bisection.
pub(super) fn siegmund_threshold(run_length: f64) -> f64 {
    let k = REFERENCE;
    let arl = |h: f64| {
        let b = 2.0 * k * (h + 1.166);
        (b.exp() - b - 1.0) / (2.0 * k * k)
    };
    let (mut low, mut high) = (0.0, 200.0);
    for _ in 0..200 {
        let mid = 0.5 * (low + high);
        if arl(mid) < run_length {
            low = mid;
        } else {
            high = mid;
        }
    }
    high
}

/// The standard normal quantile (Acklam's rational approximation, relative error < 1.2e-9),
/// for p in (0, 1).
pub(super) fn normal_quantile(p: f64) -> f64 {
    const A: [f64; 6] = [
        -3.969_683_028_665_376e1,
        2.209_460_984_245_205e2,
        -2.759_285_104_469_687e2,
        1.383_577_518_672_69e2,
        -3.066_479_806_614_716e1,
        2.506_628_277_459_239,
    ];
    const B: [f64; 5] = [
        -5.447_609_879_822_406e1,
        1.615_858_368_580_409e2,
        -1.556_989_798_598_866e2,
        6.680_131_188_771_972e1,
        -1.328_068_155_288_572e1,
    ];
    const C: [f64; 6] = [
        -7.784_894_002_430_293e-3,
        -3.223_964_580_411_365e-1,
        -2.400_758_277_161_838,
        -2.549_732_539_343_734,
        4.374_664_141_464_968,
        2.938_163_982_698_783,
    ];
    const D: [f64; 4] = [
        7.784_695_709_041_462e-3,
        3.224_671_290_700_398e-1,
        2.445_134_137_142_996,
        3.754_408_661_907_416,
    ];
    let p = p.clamp(1e-300, 1.0 - 1e-16);
    let tail = |q: f64| {
        (((((C[0] * q + C[1]) * q + C[2]) * q + C[3]) * q + C[4]) * q + C[5])
            / ((((D[0] * q + D[1]) * q + D[2]) * q + D[3]) * q + 1.0)
    };
    if p < 0.024_25 {
        tail((-2.0 * p.ln()).sqrt())
    } else if p > 1.0 - 0.024_25 {
        -tail((-2.0 * (1.0 - p).ln()).sqrt())
    } else {
        let q = p - 0.5;
        let r = q * q;
        (((((A[0] * r + A[1]) * r + A[2]) * r + A[3]) * r + A[4]) * r + A[5]) * q
            / (((((B[0] * r + B[1]) * r + B[2]) * r + B[3]) * r + B[4]) * r + 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_quantiles_match_the_tables() {
        assert!((normal_quantile(0.975) - 1.959_963_985).abs() < 1e-8);
        assert!((normal_quantile(0.5)).abs() < 1e-12);
        assert!((normal_quantile(1e-6) + 4.753_424_309).abs() < 1e-7);
    }

    #[test]
    fn siegmund_thresholds_give_their_run_lengths() {
        // Montgomery's table for k = 0.5: h = 4 gives ARL0 ≈ 336, h = 5 about 930 (Siegmund:
        // 336 and 938).
        assert!((siegmund_threshold(336.0) - 4.0).abs() < 0.01);
        assert!((siegmund_threshold(938.0) - 5.0).abs() < 0.02);
    }
}
