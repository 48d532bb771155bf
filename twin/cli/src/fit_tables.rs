//! The tables `twin compare` and `twin calibrate` print: per signal its fit %, RMS and largest
//! error and whiteness (before and after a fit), per segment its worst signal, and the data's
//! own rate.

use twin::calibration::{SegmentFit, SignalFit, SignalVerdict};
use twin::data::DataRate;

/// Segments listed in full up to this many; beyond, the worst of them.
const SEGMENTS_LISTED: usize = 12;

/// Per segment, its times and its worst-fitting signal (the worst segments, where there are
/// many); every segment's figures are in comparison.json.
pub fn segment_table(segments: &[SegmentFit]) -> String {
    if segments.len() < 2 {
        return String::new();
    }
    let worst = |s: &SegmentFit| -> Option<SignalFit> {
        (s.signals.iter())
            .min_by(|a, b| a.fit_percent.total_cmp(&b.fit_percent))
            .cloned()
    };
    let score = |s: &SegmentFit| worst(s).map_or(f64::INFINITY, |f| f.fit_percent);
    let mut listed: Vec<&SegmentFit> = segments.iter().collect();
    let mut out = format!(
        "  per segment, the signal that fits worst ({} segments):\n",
        segments.len()
    );
    if listed.len() > SEGMENTS_LISTED {
        listed.sort_by(|a, b| score(a).total_cmp(&score(b)));
        listed.truncate(SEGMENTS_LISTED);
        listed.sort_by(|a, b| a.start_time.total_cmp(&b.start_time));
        out = format!(
            "  the {SEGMENTS_LISTED} segments of {} that fit worst, and their worst signal:\n",
            segments.len()
        );
    }
    for segment in listed {
        if let Some(fit) = worst(segment) {
            out += &format!(
                "    {:>16}  {:<28} {:>9.3} %\n",
                format!("{:.3}–{:.3} s", segment.start_time, segment.end_time),
                fit.signal,
                fit.fit_percent
            );
        }
    }
    out
}

/// The figures per signal as a table: fit %, RMS and largest error, whiteness; with `before`,
/// the fit % before beside it.
pub fn table(source: &str, signals: &[SignalFit], before: Option<&[SignalFit]>) -> String {
    table_judged(source, signals, before, &[])
}

/// [`table`], the whiteness column as a calibration's verdict reads it: a residual that is its
/// signal's quantisation, or at the data's precision, counts as white.
pub fn table_judged(
    source: &str,
    signals: &[SignalFit],
    before: Option<&[SignalFit]>,
    judged: &[SignalVerdict],
) -> String {
    let mut out = format!("{source}\n");
    let head = match before {
        Some(_) => "fit before %  fit after %",
        None => "fit %",
    };
    out += &format!(
        "  {:<28} {head:>12} {:>12} {:>12}  {:<8} unit\n",
        "signal", "rms error", "max error", "white"
    );
    for (k, fit) in signals.iter().enumerate() {
        let fits = match before {
            Some(before) => format!("{:>12.3}  {:>11.3}", before[k].fit_percent, fit.fit_percent),
            None => format!("{:>12.3}", fit.fit_percent),
        };
        out += &format!(
            "  {:<28} {fits} {:>12.4e} {:>12.4e}  {:<8} {}\n",
            fit.signal,
            fit.rms_error,
            fit.max_error,
            white_word(fit, judged.iter().find(|j| j.signal == fit.signal)),
            fit.unit
        );
    }
    out
}

/// The whiteness column: `yes`, `no`, or why a residual that is not white still counts.
fn white_word(fit: &SignalFit, judged: Option<&SignalVerdict>) -> &'static str {
    match (fit.whiteness.white, judged) {
        (true, _) => "yes",
        (false, Some(j)) if j.white && j.quantum.is_some() => "quantised",
        (false, Some(j)) if j.white => "exact",
        (false, _) => "no",
    }
}

/// The data's own sampling, and whether it was resampled onto the control period.
pub fn rate_line(rate: &DataRate, period: f64) -> String {
    let resampled = match rate.resampled {
        true => format!("resampled onto the control period, {period} s"),
        false => "on the control period already".to_string(),
    };
    format!(
        "data sampled every {:.6} s on average ({:.6}–{:.6} s): {resampled}",
        rate.mean_period, rate.min_period, rate.max_period
    )
}
