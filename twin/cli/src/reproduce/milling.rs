//! `twin reproduce milling`: Kaliński & Galewski 2013, §3 — chatter of a slender ball-end mill
//! at constant spindle speed and its reduction by spindle-speed programmes (Figs 2–3).
//!
//! Runs the five milling scenarios (recordings `<scenario>.rrd` in the output folder); every
//! figure is over 0.4–2.4 s of the tool tip's displacement normal to the feed. Verdicts:
//! - Fig. 2a, strong chatter at 808 Hz at constant 15,000 rpm: *reproduced* when the spectrum's
//!   peak lies off the tooth-passing harmonics and within 5 % of 808 Hz, *partly* when it lies
//!   off the harmonics elsewhere;
//! - Fig. 2b, Z04 and Z05 lower the spectrum's maximum by up to 68 %: each *reproduced* at a
//!   reduction ≥ 50 %, *partly* at any reduction;
//! - Fig. 3a, the RMS displacement is reduced too: *reproduced* when both programmes lower it;
//! - §3, the optimal-linear programme reduces both: *reproduced* at ≥ 50 % on the peak and a
//!   lower RMS, *partly* at any reduction of either;
//! - the constant 16,500 rpm reference: *reproduced* when both programmes' peaks lie below it as
//!   well (varying the speed does more than moving to the programme's top speed).

use super::error::ReproduceError;
use super::report::{Claim, Report, Verdict};
use framework::Registry;
use std::path::Path;
use twin::summary;
use twin::{RunSummary, Twin, TwinError};

const SCENARIOS: [&str; 5] = [
    "milling-constant-15000",
    "milling-constant-16500",
    "milling-z04",
    "milling-z05",
    "milling-optimal-linear",
];
/// The paper's chatter frequency at 15,000 rpm, Hz.
const PAPER_CHATTER: f64 = 808.0;
/// Tooth-passing frequency at 15,000 rpm with two flutes, Hz.
const TOOTH_PASSING: f64 = 500.0;

pub fn run(
    out_dir: &Path,
    registry: &Registry,
    engine: Option<twin::Engine>,
) -> Result<Report, ReproduceError> {
    let mut records = Vec::new();
    let mut run = |name: &str| -> Result<RunSummary, ReproduceError> {
        let loaded = super::scenarios::builtin(name, engine)
            .and_then(|b| b.build(registry))
            .map_err(TwinError::from)?;
        let file = format!("{name}.rrd");
        let result = Twin::new(loaded)?.run(Some(&out_dir.join(&file)))?;
        let mut record = summary::to_json(&result);
        record["recording"] = file.into();
        records.push(record);
        Ok(result)
    };
    let [constant, constant_high, z04, z05, optimal] = [
        &run(SCENARIOS[0])?,
        &run(SCENARIOS[1])?,
        &run(SCENARIOS[2])?,
        &run(SCENARIOS[3])?,
        &run(SCENARIOS[4])?,
    ];
    let claims = vec![
        chatter_at_15000(constant),
        peak_reduction("Z04", z04, constant),
        peak_reduction("Z05", z05, constant),
        rms_reduction(z04, z05, constant),
        optimal_linear(optimal, constant),
        reference_16500(constant_high, [z04, z05], constant),
    ];
    Ok(Report {
        paper: "Kaliński & Galewski 2013 §3: chatter of a slender ball-end mill reduced by spindle-speed variation".into(),
        claims,
        runs: records,
    })
}

fn metric(run: &RunSummary, name: &str) -> f64 {
    run.metric(name).unwrap_or(f64::NAN)
}

/// Relative reduction of `name` from `base` to `run`, %.
fn reduction(run: &RunSummary, base: &RunSummary, name: &str) -> f64 {
    100.0 * (1.0 - metric(run, name) / metric(base, name))
}

/// A reduction shown as the signed change it is: 56 → "−56 %", −2 → "+2 %".
fn change(reduction: f64) -> String {
    let change = -reduction;
    let sign = if change < 0.0 { "−" } else { "+" };
    format!("{sign}{:.0} %", change.abs())
}

/// Peak amplitude (µm) and frequency (Hz), for display.
fn peak(run: &RunSummary) -> String {
    format!(
        "{:.1} µm at {:.0} Hz",
        metric(run, "spectrum_peak") * 1e6,
        metric(run, "chatter_frequency")
    )
}

fn chatter_at_15000(run: &RunSummary) -> Claim {
    let frequency = metric(run, "chatter_frequency");
    let harmonic = (frequency / TOOTH_PASSING).round() * TOOTH_PASSING;
    let off_harmonics = (frequency - harmonic).abs() > 0.02 * TOOTH_PASSING;
    let error = 100.0 * (frequency / PAPER_CHATTER - 1.0);
    let verdict = match (off_harmonics, error.abs() <= 5.0) {
        (true, true) => Verdict::Reproduced,
        (true, false) => Verdict::Partly,
        _ => Verdict::NotReproduced,
    };
    Claim {
        claim: "Fig. 2a: strong chatter at constant 15,000 rpm".into(),
        paper: "chatter at 808 Hz".into(),
        twin: format!(
            "peak {} ({}{:.1} % vs 808 Hz), RMS {:.1} µm",
            peak(run),
            if error < 0.0 { "−" } else { "+" },
            error.abs(),
            metric(run, "displacement_rms") * 1e6
        ),
        verdict,
    }
}

fn peak_reduction(programme: &str, run: &RunSummary, constant: &RunSummary) -> Claim {
    let cut = reduction(run, constant, "spectrum_peak");
    let verdict = if cut >= 50.0 {
        Verdict::Reproduced
    } else if cut > 0.0 {
        Verdict::Partly
    } else {
        Verdict::NotReproduced
    };
    Claim {
        claim: format!("Fig. 2b: {programme} lowers the spectrum's maximum"),
        paper: "up to −68 % vs 15,000 rpm".into(),
        twin: format!("{} → {}", change(cut), peak(run)),
        verdict,
    }
}

fn rms_reduction(z04: &RunSummary, z05: &RunSummary, constant: &RunSummary) -> Claim {
    let cuts = [z04, z05].map(|run| reduction(run, constant, "displacement_rms"));
    Claim {
        claim: "Fig. 3a: the programmes lower the RMS displacement".into(),
        paper: "RMS reduced".into(),
        twin: format!("Z04 {}, Z05 {}", change(cuts[0]), change(cuts[1])),
        verdict: if cuts.iter().all(|&c| c > 0.0) {
            Verdict::Reproduced
        } else {
            Verdict::NotReproduced
        },
    }
}

fn optimal_linear(run: &RunSummary, constant: &RunSummary) -> Claim {
    let peak_cut = reduction(run, constant, "spectrum_peak");
    let rms_cut = reduction(run, constant, "displacement_rms");
    let verdict = if peak_cut >= 50.0 && rms_cut > 0.0 {
        Verdict::Reproduced
    } else if peak_cut > 0.0 || rms_cut > 0.0 {
        Verdict::Partly
    } else {
        Verdict::NotReproduced
    };
    Claim {
        claim: "§3: the optimal-linear programme reduces chatter".into(),
        paper: "RMS and chatter amplitude reduced".into(),
        twin: format!(
            "peak {}, RMS {}; speed {:.0}–{:.0} rpm",
            change(peak_cut),
            change(rms_cut),
            metric(run, "spindle_speed_min"),
            metric(run, "spindle_speed_max")
        ),
        verdict,
    }
}

fn reference_16500(
    high: &RunSummary,
    programmes: [&RunSummary; 2],
    constant: &RunSummary,
) -> Claim {
    let below = programmes
        .iter()
        .all(|run| metric(run, "spectrum_peak") < metric(high, "spectrum_peak"));
    Claim {
        claim: "constant 16,500 rpm (reference run)".into(),
        paper: "reference data beside the programmes".into(),
        twin: format!(
            "peak {} ({} vs 15,000 rpm); programmes {}",
            peak(high),
            change(reduction(high, constant, "spectrum_peak")),
            if below {
                "below it"
            } else {
                "not both below it"
            }
        ),
        verdict: if below {
            Verdict::Reproduced
        } else {
            Verdict::Partly
        },
    }
}
