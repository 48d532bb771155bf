//! The run's figures for its recording: the amplitude spectrum of every signal a spectral
//! `[[metrics]]` entry judges (over that entry's window, from the very samples its figure is
//! computed from), with a machine's tooth-passing harmonics and the chatter frequency marked, and
//! a milling run's operating point on the stability lobes of its tool and cut.
//!
//! **Harmonics and chatter.** A machine with an [`Excitation`] (a mill: flutes per spindle
//! revolution) excites the tooth-passing frequency `f_t = N·|Ω|/2π` and its harmonics `k·f_t`;
//! a stable cut vibrates at those alone (its motion repeats every tooth). Over the window `f_t`
//! ranges from the slowest to the fastest speed; harmonic `k` covers `[k·f_t,min − w,
//! k·f_t,max + w]` with `w = 3/T` (T the window's length: the Hann window's main lobe is `±2/T`
//! wide). The strongest bin outside every harmonic band (and above `w`) is the chatter candidate;
//! the run chatters when it reaches [`CHATTER_RATIO`] of the strongest harmonic's amplitude.

use super::evaluate::Evaluator;
use super::layout::SignalLayout;
use super::observer::Observer;
use super::observer::{ObserverError, StepView};
use crate::machines::{Excitation, Stability};
use crate::recording::{Plot2D, PlotAxis, PlotGeometry, PlotLayer};
use crate::scenario::{MetricKind, MetricSpec};
use crate::spectrum::Spectrum;
use framework::Unit;
use models::milling::stability::{lobe_diagram, LobePoint, SemiDiscretization, StabilityError};
use std::f64::consts::TAU;
use std::thread::JoinHandle;

/// A non-harmonic peak of at least this share of the strongest harmonic's amplitude is chatter.
/// A stable cut's non-harmonic content is the skirt of its harmonics and its decayed entry
/// transient (at 15,000 rpm and a_p = 0.05 mm: 0.017 µm against the first harmonic's 2.0 µm, under
/// 1 %); a chattering one's peak towers over them (366 µm at 795 Hz at a_p = 0.5 mm).
pub(super) const CHATTER_RATIO: f64 = 0.1;
/// Most points of a drawn spectrum: beyond, each point is the strongest bin of its stretch.
const MAX_SPECTRUM_POINTS: usize = 4000;
/// Most tooth-passing harmonics marked.
const MAX_HARMONICS: usize = 20;
/// Speeds of the lobe diagram.
const LOBE_SPEEDS: usize = 61;
/// Intervals per tooth period of the lobes' semi-discretization: half the analysis's 40, for a
/// fourteenth of its cost; the limiting depths move by about 1 % (the error falls as 1/m²).
const LOBE_INTERVALS: usize = 20;
/// The diagram spans this factor below and above the run's starting speed.
const LOBE_SPAN: [f64; 2] = [0.6, 1.6];
/// Its depth axis reaches this multiple of the run's depth.
const LOBE_DEPTH_SPAN: f64 = 2.0;
/// Height / width of the figures.
const ASPECT: f64 = 0.45;
const RPM: f64 = 60.0 / TAU;
const SPECTRUM_COLOR: [u8; 3] = [86, 180, 233];
const HARMONIC_COLOR: [u8; 3] = [150, 150, 150];
const CHATTER_COLOR: [u8; 3] = [230, 60, 50];
const STABLE_COLOR: [u8; 3] = [60, 190, 90];
const LOBE_COLOR: [u8; 3] = [230, 159, 0];

/// What the run's figures are made of, before the run.
pub(super) struct SpectraPlan {
    /// The scenario's `[[metrics]]` (the spectral ones are drawn).
    pub metrics: Vec<MetricSpec>,
    pub excitation: Option<Excitation>,
    pub stability: Option<Stability>,
    /// Physics step and control period, s: the sample periods of true and measured signals.
    pub dt: f64,
    pub control_period: f64,
    /// The excitation joint's initial speed, rad/s (0: none given).
    pub initial_speed: f64,
}

/// One spectrum figure, collecting its samples.
struct SpectrumWatch {
    name: String,
    signal: Evaluator,
    /// The speed of the excitation's joint over the same window.
    speed: Option<Evaluator>,
    /// Display unit: factor from the judged value and its label.
    unit: (f64, String),
    frame: Plot2D,
}

/// The lobe diagram, computed on a thread of its own while the run steps.
struct LobeWatch {
    stability: Stability,
    frame: Plot2D,
    lobes: Option<JoinHandle<Result<Vec<LobePoint>, StabilityError>>>,
}

/// The run's figures: bound at the run's start, fed every step, drawn at its end.
pub(super) struct Spectra {
    plan: SpectraPlan,
    per_revolution: usize,
    watches: Vec<SpectrumWatch>,
    lobes: Option<LobeWatch>,
}

impl Spectra {
    pub fn new(plan: SpectraPlan) -> Self {
        Self {
            per_revolution: plan.excitation.as_ref().map_or(0, |e| e.per_revolution),
            plan,
            watches: Vec::new(),
            lobes: None,
        }
    }

    /// Binds the spectra to the run's signals (one per signal, reference, window, scale and
    /// band) and starts the lobes: the figures' frames, by name, for the recording's layout.
    pub fn start(&mut self, layout: &SignalLayout) -> Result<Vec<(String, Plot2D)>, ObserverError> {
        let mut specs: Vec<MetricSpec> = Vec::new();
        for spec in self.plan.metrics.iter().filter(|m| m.kind.is_spectral()) {
            if !specs.iter().any(|s| same_spectrum(s, spec)) {
                specs.push(spec.clone());
            }
        }
        if let (true, Some(excitation)) = (specs.is_empty(), &self.plan.excitation) {
            let signal = &excitation.vibration_signal;
            specs.push(MetricSpec::new(signal, MetricKind::SpectrumPeak, signal));
        }
        for spec in &specs {
            let mut watch = self.watch(spec, layout)?;
            // Two windows of one signal are two figures.
            let taken = |name: &str| self.watches.iter().any(|w| w.name == name);
            if taken(&watch.name) {
                let base = watch.name.clone();
                let free = (2..).map(|k| format!("{base} {k}")).find(|n| !taken(n));
                watch.name = free.unwrap_or(base);
            }
            self.watches.push(watch);
        }
        self.lobes = self.plan.stability.map(|s| self.start_lobes(s));
        let mut frames: Vec<(String, Plot2D)> = self
            .watches
            .iter()
            .map(|w| (w.name.clone(), w.frame.clone()))
            .collect();
        frames.extend(self.lobes.iter().map(|l| ("lobes".into(), l.frame.clone())));
        Ok(frames)
    }

    fn watch(
        &self,
        spec: &MetricSpec,
        layout: &SignalLayout,
    ) -> Result<SpectrumWatch, ObserverError> {
        let signal = Evaluator::bind(spec, layout)?;
        // The excitation's speed over the same window (none when the run does not sense it).
        let speed = self.plan.excitation.as_ref().and_then(|excitation| {
            let mut speed = spec.clone();
            speed.kind = MetricKind::Mean;
            speed.signal.clone_from(&excitation.speed_signal);
            (speed.reference, speed.scale, speed.frequencies) = (None, 1.0, None);
            Evaluator::bind(&speed, layout).ok()
        });
        let unit = display_unit(spec, layout);
        let measured = spec.signal.starts_with("measured/")
            || spec
                .reference
                .as_deref()
                .is_some_and(|r| r.starts_with("measured/"));
        let period = if measured {
            self.plan.control_period
        } else {
            self.plan.dt
        };
        let band = spec.frequencies.unwrap_or([0.0, 0.5 / period]);
        let name = format!("spectrum {}", spec.signal);
        let frame = Plot2D {
            title: spectrum_title(spec),
            x: axis("frequency [Hz]", band),
            y: axis(&format!("amplitude [{}]", unit.1), [0.0, 1.0]),
            aspect: Some(ASPECT),
            ..Plot2D::default()
        };
        Ok(SpectrumWatch {
            name,
            signal,
            speed,
            unit,
            frame,
        })
    }

    /// The diagram's frame, and its lobes started on a thread.
    fn start_lobes(&self, stability: Stability) -> LobeWatch {
        let speeds = match self.plan.initial_speed.abs() {
            n if n > 0.0 && n.is_finite() => LOBE_SPAN.map(|k| k * n),
            _ => stability.speeds,
        };
        let max_depth = LOBE_DEPTH_SPAN * stability.axial_depth;
        let frame = Plot2D {
            title: "stability lobes (semi-discretization) and this run".into(),
            x: axis("spindle speed [rpm]", speeds.map(|n| n * RPM)),
            y: axis("axial depth of cut [mm]", [0.0, max_depth * 1e3]),
            aspect: Some(ASPECT),
            ..Plot2D::default()
        };
        let grid: Vec<f64> = (0..LOBE_SPEEDS)
            .map(|k| speeds[0] + (speeds[1] - speeds[0]) * k as f64 / (LOBE_SPEEDS - 1) as f64)
            .collect();
        let (tool, cut) = (stability.tool, stability.cut);
        let lobes = std::thread::spawn(move || {
            let sd = SemiDiscretization {
                intervals: LOBE_INTERVALS,
            };
            lobe_diagram(&tool, &cut, &grid, max_depth, &sd)
        });
        LobeWatch {
            stability,
            frame,
            lobes: Some(lobes),
        }
    }

    /// The figures drawn from the run, by name (the lobes after the spectra, with the first
    /// spectrum's verdict and speeds).
    pub fn figures(&mut self) -> Vec<(String, Plot2D)> {
        let mut figures = Vec::with_capacity(self.watches.len() + 1);
        let mut verdict = None;
        for watch in &self.watches {
            let analysis = analyse(watch, self.per_revolution);
            verdict = verdict.or(analysis.speeds.map(|s| (s, analysis.chatter)));
            figures.push((watch.name.clone(), spectrum_figure(watch, &analysis)));
        }
        if let Some(lobes) = self.lobes.as_mut() {
            let points = lobes.lobes.take().map(|h| h.join());
            let points = match points {
                Some(Ok(Ok(points))) => Ok(points),
                Some(Ok(Err(e))) => Err(e.to_string()),
                _ => Err("the lobes were not computed".to_owned()),
            };
            figures.push(("lobes".into(), lobe_figure(lobes, points, verdict)));
        }
        figures
    }
}

impl Observer for Spectra {
    fn observe(&mut self, view: &StepView) -> Result<(), ObserverError> {
        for watch in &mut self.watches {
            watch.signal.observe(view)?;
            if let Some(speed) = watch.speed.as_mut() {
                speed.observe(view)?;
            }
        }
        Ok(())
    }
}

/// Two spectral entries draw the same spectrum (they differ at most in kind, name and unit).
fn same_spectrum(a: &MetricSpec, b: &MetricSpec) -> bool {
    (
        &a.signal,
        &a.reference,
        a.from,
        a.to,
        a.scale,
        a.frequencies,
    ) == (
        &b.signal,
        &b.reference,
        b.from,
        b.to,
        b.scale,
        b.frequencies,
    )
}

fn axis(title: &str, range: [f64; 2]) -> PlotAxis {
    PlotAxis {
        title: title.into(),
        range,
    }
}

fn spectrum_title(spec: &MetricSpec) -> String {
    let judged = match &spec.reference {
        Some(reference) => format!("{reference} − {}", spec.signal),
        None => spec.signal.clone(),
    };
    let to = spec.to.map_or("end".to_owned(), |t| format!("{t} s"));
    format!("spectrum of {judged}, {} s to {to}", spec.from)
}

/// The unit the spectrum is drawn in: the signal's display unit when unscaled, else the entry's
/// own `unit` (the scale is the user's change of unit).
fn display_unit(spec: &MetricSpec, layout: &SignalLayout) -> (f64, String) {
    let (prefix, rest) = spec.signal.split_once('/').unwrap_or(("", &spec.signal));
    let specs = &layout.specs;
    let unit: Option<Unit> = match prefix {
        "measured" => layout.signal(rest).map(|k| specs.signals[k].unit),
        "controller" => layout.internal(rest).map(|k| specs.internals[k].unit),
        "diagnostics" => layout.diagnostic(rest).map(|k| specs.diagnostics[k].unit),
        "" => layout.signal(rest).map(|k| specs.signals[k].unit),
        _ => None,
    };
    match unit {
        Some(unit) if spec.scale == 1.0 => {
            (unit.from_si(1.0) - unit.from_si(0.0), unit.label().into())
        }
        _ if spec.unit.is_empty() => (1.0, format!("×{} SI", spec.scale)),
        _ => (1.0, spec.unit.clone()),
    }
}

/// What a spectrum shows: its marks and the run's verdict.
struct Analysis {
    spectrum: Spectrum,
    band: [f64; 2],
    /// Tooth-passing frequency over the window: slowest, mean, fastest, Hz.
    speeds: Option<[f64; 3]>,
    harmonics: Vec<f64>,
    /// The strongest peak outside the harmonics (with an excitation) or overall: Hz, amplitude.
    peak: Option<(f64, f64)>,
    /// With an excitation: whether that peak is chatter.
    chatter: Option<bool>,
}

fn analyse(watch: &SpectrumWatch, per_revolution: usize) -> Analysis {
    let spectrum = watch.signal.spectrum();
    let band = watch.frame.x.range;
    let tooth = |speed: f64| per_revolution as f64 * speed.abs() / TAU;
    let speeds = watch
        .speed
        .as_ref()
        .and_then(Evaluator::extremes)
        .map(|[low, mean, high]| {
            let (a, b) = (tooth(low), tooth(high));
            [a.min(b), tooth(mean), a.max(b)]
        });
    let (count, [first, last]) = watch.signal.window();
    let span = (last - first) + watch.signal.sample_period();
    let Some(tooth) = speeds.filter(|s| s[1] > 0.0 && count > 1) else {
        let peak = spectrum.peak(band);
        return Analysis {
            spectrum,
            band,
            speeds: None,
            harmonics: Vec::new(),
            peak,
            chatter: None,
        };
    };
    let w = 3.0 / span.max(f64::MIN_POSITIVE);
    let harmonic = |f: f64| {
        let nearest = (f / tooth[1]).round();
        f <= w
            || [nearest - 1.0, nearest, nearest + 1.0]
                .iter()
                .any(|&k| k >= 1.0 && f >= k * tooth[0] - w && f <= k * tooth[2] + w)
    };
    let strongest = |keep: &dyn Fn(f64) -> bool| {
        bins(&spectrum, band).filter(|&(f, _)| keep(f)).fold(
            None,
            |best: Option<(f64, f64)>, (f, a)| match best {
                Some((_, b)) if b >= a => best,
                _ => Some((f, a)),
            },
        )
    };
    let peak = strongest(&|f| !harmonic(f));
    let forced = strongest(&|f| f > w && harmonic(f)).map_or(0.0, |(_, a)| a);
    let chatter = peak.is_some_and(|(_, a)| a > 0.0 && a >= CHATTER_RATIO * forced);
    let harmonics = (1..=MAX_HARMONICS)
        .map(|k| k as f64 * tooth[1])
        .filter(|f| (band[0]..=band[1]).contains(f))
        .collect();
    Analysis {
        spectrum,
        band,
        speeds,
        harmonics,
        peak,
        chatter: Some(chatter),
    }
}

/// The spectrum's bins within `band`: frequency, amplitude.
fn bins(spectrum: &Spectrum, [low, high]: [f64; 2]) -> impl Iterator<Item = (f64, f64)> + '_ {
    let width = spectrum.bin_width;
    spectrum
        .amplitudes
        .iter()
        .enumerate()
        .map(move |(k, &a)| (k as f64 * width, a))
        .filter(move |&(f, _)| f >= low && f <= high)
}

/// The spectrum as a polyline of at most [`MAX_SPECTRUM_POINTS`] points, each the strongest bin
/// of its stretch (so no peak is lost), in display units.
fn spectrum_line(analysis: &Analysis, factor: f64) -> Vec<[f64; 2]> {
    let all: Vec<(f64, f64)> = bins(&analysis.spectrum, analysis.band).collect();
    let stretch = all.len().div_ceil(MAX_SPECTRUM_POINTS).max(1);
    all.chunks(stretch)
        .filter_map(|chunk| chunk.iter().copied().max_by(|a, b| a.1.total_cmp(&b.1)))
        .map(|(f, a)| [f, factor * a])
        .collect()
}

/// The spectrum with its harmonics (grey, `k×` at their top) and its chatter or dominant peak
/// (a line from the top down, labelled with its frequency).
fn spectrum_figure(watch: &SpectrumWatch, analysis: &Analysis) -> Plot2D {
    let (factor, _) = &watch.unit;
    let line = spectrum_line(analysis, *factor);
    let top = 1.1 * line.iter().map(|p| p[1]).fold(0.0, f64::max);
    let top = if top > 0.0 && top.is_finite() {
        top
    } else {
        1.0
    };
    let mut plot = watch.frame.clone();
    plot.y.range = [0.0, top];
    let vertical = |f: f64, upward: bool| {
        if upward {
            vec![[f, 0.0], [f, top]]
        } else {
            vec![[f, top], [f, 0.0]]
        }
    };
    let harmonics = analysis
        .harmonics
        .iter()
        .map(|&f| vertical(f, true))
        .collect();
    let marks = (1..=analysis.harmonics.len())
        .map(|k| format!("{k}×"))
        .collect();
    plot.layers.push(PlotLayer::new(
        "harmonics",
        HARMONIC_COLOR,
        1.0,
        PlotGeometry::Lines(harmonics),
        marks,
    ));
    plot.layers.push(PlotLayer::new(
        "spectrum",
        SPECTRUM_COLOR,
        1.5,
        PlotGeometry::Lines(vec![line]),
        Vec::new(),
    ));
    let mut notes = Vec::new();
    if let Some([_, mean, _]) = analysis.speeds {
        notes.push(format!("tooth passing {mean:.1} Hz"));
    }
    if let Some((f, a)) = analysis.peak {
        let (word, color) = match analysis.chatter {
            Some(true) => ("chatter", CHATTER_COLOR),
            Some(false) => ("largest non-harmonic peak", HARMONIC_COLOR),
            None => ("peak", CHATTER_COLOR),
        };
        let label = format!("{word} {f:.1} Hz");
        notes.push(format!("{label}, {:.3} {}", factor * a, watch.unit.1));
        if analysis.chatter != Some(false) {
            plot.layers.push(PlotLayer::new(
                "peak",
                color,
                1.5,
                PlotGeometry::Lines(vec![vertical(f, false)]),
                vec![label],
            ));
        }
    }
    if analysis.chatter == Some(false) {
        notes.push("stable: no chatter".into());
    }
    // The view's title is fixed before the run; the findings go under the frequency axis.
    notes.insert(0, plot.x.title.clone());
    plot.x.title = notes.join(" · ");
    plot
}

/// The lobes (the limiting depth against speed; a speed stable to the top breaks the curve)
/// with the run's point: its mean speed (and the range it swept) at its depth, red if it
/// chattered, green if not.
fn lobe_figure(
    watch: &LobeWatch,
    points: Result<Vec<LobePoint>, String>,
    verdict: Option<([f64; 3], Option<bool>)>,
) -> Plot2D {
    let mut plot = watch.frame.clone();
    let per_revolution = watch.stability.cut.flutes as f64;
    let depth = watch.stability.axial_depth * 1e3;
    let mut curves = vec![Vec::new()];
    match &points {
        Ok(points) => {
            for p in points {
                match p.boundary {
                    Some(b) => curves
                        .last_mut()
                        .map_or((), |c| c.push([p.spindle_speed * RPM, b.depth * 1e3])),
                    None => curves.push(Vec::new()),
                }
            }
        }
        Err(reason) => plot.x.title = format!("{} · no lobes: {reason}", plot.x.title),
    }
    curves.retain(|c| c.len() > 1);
    plot.layers.push(PlotLayer::new(
        "lobes",
        LOBE_COLOR,
        2.0,
        PlotGeometry::Lines(curves),
        vec!["stability limit".into()],
    ));
    let Some((tooth, chatter)) = verdict else {
        return plot;
    };
    let rpm = tooth.map(|f| f / per_revolution * 60.0);
    let (word, color) = match chatter {
        Some(true) => ("chatter", CHATTER_COLOR),
        _ => ("stable", STABLE_COLOR),
    };
    if rpm[2] - rpm[0] > 1.0 {
        let range = vec![vec![[rpm[0], depth], [rpm[2], depth]]];
        plot.layers.push(PlotLayer::new(
            "run/speed_range",
            color,
            2.0,
            PlotGeometry::Lines(range),
            Vec::new(),
        ));
    }
    let label = format!("this run: {:.0} rpm, {depth:.3} mm, {word}", rpm[1]);
    plot.layers.push(PlotLayer::new(
        "run/operating_point",
        color,
        10.0,
        PlotGeometry::Points(vec![[rpm[1], depth]]),
        vec![label],
    ));
    plot
}
