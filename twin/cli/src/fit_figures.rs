//! The figures `twin compare` and `twin calibrate` record: a measured signal with the twin's
//! replays of it, the residuals, their spectra, the cost per iteration and the parameters with
//! their intervals, as 2D plots for [`twin::recordings::write_figures`].

use twin::recordings::{Plot2D, PlotAxis, PlotGeometry, PlotLayer};
use twin::signal::Spectrum;

/// Measured data, drawn first.
pub const MEASURED: [u8; 3] = [200, 200, 200];
/// The twin before a calibration (or the twin compared).
pub const BEFORE: [u8; 3] = [255, 127, 14];
/// The twin after a calibration.
pub const AFTER: [u8; 3] = [44, 160, 44];
/// Residuals.
pub const RESIDUAL: [u8; 3] = [214, 39, 40];

/// One curve: its label, colour and y values (x is the sample times).
pub type Curve<'a> = (&'a str, [u8; 3], &'a [f64]);

/// The range of the finite values, padded by 5 % (a flat series by ±1e-9 of itself, or ±1).
fn padded(values: impl Iterator<Item = f64>) -> [f64; 2] {
    let (low, high) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
            (l.min(v), h.max(v))
        });
    if !low.is_finite() {
        return [-1.0, 1.0];
    }
    let pad = 0.05 * (high - low).max(1e-9 * low.abs().max(1.0));
    [low - pad, high + pad]
}

/// A time plot of `curves` sampled at `start + k·period`.
pub fn time_plot(title: &str, unit: &str, start: f64, period: f64, curves: &[Curve]) -> Plot2D {
    let len = curves.iter().map(|c| c.2.len()).max().unwrap_or(0);
    let layers = curves
        .iter()
        .map(|(label, color, values)| {
            let points: Vec<[f64; 2]> = (values.iter().enumerate())
                .map(|(k, &v)| [start + k as f64 * period, v])
                .collect();
            let name = label.replace(' ', "_");
            let geometry = PlotGeometry::Lines(vec![points]);
            PlotLayer::new(&name, *color, 1.5, geometry, vec![label.to_string()])
        })
        .collect();
    Plot2D {
        title: title.into(),
        notes: String::new(),
        x: PlotAxis {
            title: "time [s]".into(),
            range: [start, start + len.saturating_sub(1).max(1) as f64 * period],
        },
        y: PlotAxis {
            title: format!("{title} [{unit}]"),
            range: padded(curves.iter().flat_map(|c| c.2.iter().copied())),
        },
        aspect: Some(0.3),
        layers,
    }
}

/// The one-sided amplitude spectra of residuals, each divided by its RMS (so that signals of
/// any unit share the plot), in decibels, against frequency: a white residual is flat.
pub fn residual_spectra(period: f64, residuals: &[(&str, Vec<f64>)]) -> Plot2D {
    let palette = [
        [31, 119, 180],
        BEFORE,
        AFTER,
        RESIDUAL,
        [148, 103, 189],
        [140, 86, 75],
    ];
    let mut layers = Vec::new();
    let mut all = Vec::new();
    for (index, (name, residual)) in residuals.iter().enumerate() {
        let points = spectrum_db(residual, period);
        all.extend(points.iter().map(|p| p[1]));
        let color = palette[index % palette.len()];
        let geometry = PlotGeometry::Lines(vec![points]);
        let layer = name.replace(['.', ' '], "_");
        layers.push(PlotLayer::new(
            &layer,
            color,
            1.0,
            geometry,
            vec![name.to_string()],
        ));
    }
    Plot2D {
        title: "residual spectra".into(),
        notes: String::new(),
        x: PlotAxis {
            title: "frequency [Hz]".into(),
            range: [0.0, 0.5 / period],
        },
        y: PlotAxis {
            title: "amplitude / RMS [dB]".into(),
            range: padded(all.into_iter()),
        },
        aspect: Some(0.35),
        layers,
    }
}

/// The residual's amplitude spectrum (the twin's own, Hann-windowed) relative to its RMS, dB.
fn spectrum_db(residual: &[f64], period: f64) -> Vec<[f64; 2]> {
    let n = residual.len().max(1) as f64;
    let mean = residual.iter().sum::<f64>() / n;
    let rms = (residual.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / n).sqrt();
    let spectrum = Spectrum::of(residual, period);
    (spectrum.amplitudes.iter().enumerate().skip(1))
        .map(|(k, a)| {
            let relative = a / rms.max(f64::MIN_POSITIVE);
            [
                k as f64 * spectrum.bin_width,
                20.0 * relative.max(1e-12).log10(),
            ]
        })
        .collect()
}

/// The cost after each accepted step, log10, against the step's number.
pub fn cost_plot(costs: &[f64]) -> Plot2D {
    let points: Vec<[f64; 2]> = (costs.iter().enumerate())
        .map(|(k, &c)| [k as f64, c.max(f64::MIN_POSITIVE).log10()])
        .collect();
    Plot2D {
        title: "cost per iteration".into(),
        notes: String::new(),
        x: PlotAxis {
            title: "accepted step".into(),
            range: [0.0, costs.len().saturating_sub(1).max(1) as f64],
        },
        y: PlotAxis {
            title: "log10 cost".into(),
            range: padded(points.iter().map(|p| p[1])),
        },
        aspect: Some(0.3),
        layers: vec![
            PlotLayer::new(
                "cost",
                AFTER,
                2.0,
                PlotGeometry::Lines(vec![points.clone()]),
                vec![],
            ),
            PlotLayer::new("steps", AFTER, 6.0, PlotGeometry::Points(points), vec![]),
        ],
    }
}

/// Each parameter's estimate and 95 % interval relative to its start (1 = unchanged), one row
/// per parameter, labelled with its key.
pub fn interval_plot(parameters: &[(String, f64, [f64; 2], f64)]) -> Plot2D {
    let mut bars = Vec::new();
    let mut points = Vec::new();
    let mut labels = Vec::new();
    for (row, (key, estimate, [lo, hi], start)) in parameters.iter().enumerate() {
        let unit = if *start != 0.0 { *start } else { 1.0 };
        let y = -(row as f64);
        bars.push(vec![[lo / unit, y], [hi / unit, y]]);
        points.push([estimate / unit, y]);
        labels.push(key.clone());
    }
    let xs = points
        .iter()
        .map(|p| p[0])
        .chain(bars.iter().flatten().map(|p| p[0]));
    let mut x = padded(xs.chain([1.0]));
    if x[1] - x[0] < 1e-6 {
        x = [x[0] - 0.01, x[1] + 0.01];
    }
    Plot2D {
        title: "parameters".into(),
        notes: String::new(),
        x: PlotAxis {
            title: "estimate / start (bar: 95 % interval)".into(),
            range: x,
        },
        y: PlotAxis {
            title: "parameter".into(),
            range: [-(parameters.len() as f64), 1.0],
        },
        aspect: Some(0.3),
        layers: vec![
            PlotLayer::new("intervals", BEFORE, 3.0, PlotGeometry::Lines(bars), vec![]),
            PlotLayer::new(
                "estimates",
                AFTER,
                8.0,
                PlotGeometry::Points(points),
                labels,
            ),
        ],
    }
}
