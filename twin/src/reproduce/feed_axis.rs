//! `twin reproduce feed-axis`: Rubio, Ibeas & Luo, "P-PI and super twisting sliding mode control
//! schemes comparison for high-precision CNC machining" — the linear-motor feed axis of their §V
//! tracking a 1 µm sine at 3 rad/s, with and without the micro-milling cut, under P-PI (§III),
//! super-twisting SMC (§IV) and super-twisting SMC with a disturbance observer (their Fig. 3).
//!
//! Six runs of the scenario `feed-axis-micromilling`: each controller (its default parameters:
//! the paper's where it gives them) with the cut and in air (`process.cutting=false`); each
//! recording is `feed-axis-micromilling-<controller>-<cut|air>.rrd` in the output folder.
//!
//! The report holds Table I beside the twin's figures — the position error's max and σ in µm, the
//! velocity error's in µm/s (the twin computes in m and m/s; µm only here) — then the paper's
//! three claims. Verdicts:
//! - a Table I row is *reproduced* when the twin's position-error max and σ are both within 25 %
//!   of the paper's, *partly* when one is, else *not reproduced*;
//! - "STSMC's max position error is about 3× smaller than P-PI's": *reproduced* when P-PI/STSMC
//!   lies in [2, 4.5] with and without the cut, *partly* when STSMC is smaller in both but not by
//!   about 3×;
//! - "the cut affects STSMC less than P-PI": the cut's relative increase of the position-error σ
//!   and max, *reproduced* when STSMC's is the smaller in both, *partly* in one;
//! - "the observer damps the cut's effect further": the position-error σ under the cut and the
//!   cut's increase of it, *reproduced* when STSMC-DOB's are the smaller in both, *partly* in one.

use super::{Claim, Report, ReproduceError, Verdict};
use crate::run::{RunSummary, Twin, TwinError};
use crate::scenario::{self, Overrides};
use crate::summary;
use controllers::Registry;
use std::path::Path;

const SCENARIO: &str = "feed-axis-micromilling";
const CONTROLLERS: [&str; 3] = ["p-pi", "stsmc", "stsmc-dob"];
/// Metres to micrometres, for the report only.
const MICRO: f64 = 1e6;

/// Table I's four columns: position error max and σ (µm), velocity error max and σ (µm/s).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Errors {
    position_max: f64,
    position_sigma: f64,
    velocity_max: f64,
    velocity_sigma: f64,
}

impl Errors {
    fn of(summary: &RunSummary) -> Self {
        let metric = |name: &str| summary.metric(name).unwrap_or(f64::NAN) * MICRO;
        Self {
            position_max: metric("position_error_max"),
            position_sigma: metric("position_error_sigma"),
            velocity_max: metric("velocity_error_max"),
            velocity_sigma: metric("velocity_error_sigma"),
        }
    }

    fn describe(&self) -> String {
        format!(
            "x: max {} σ {} µm; v: max {} σ {} µm/s",
            figure(self.position_max),
            figure(self.position_sigma),
            figure(self.velocity_max),
            figure(self.velocity_sigma)
        )
    }
}

/// Four significant digits, in fixed notation.
fn figure(value: f64) -> String {
    if value == 0.0 || !value.is_finite() {
        return value.to_string();
    }
    let decimals = (3 - value.abs().log10().floor() as i32).max(0) as usize;
    format!("{value:.decimals$}")
}

/// The paper's Table I, µm and µm/s: (controller, with the cut, errors).
const TABLE_I: [(&str, bool, Errors); 4] = [
    (
        "p-pi",
        false,
        Errors {
            position_max: 0.1826,
            position_sigma: 0.0178,
            velocity_max: 1.9014,
            velocity_sigma: 0.2096,
        },
    ),
    (
        "p-pi",
        true,
        Errors {
            position_max: 0.1895,
            position_sigma: 0.0307,
            velocity_max: 1.6910,
            velocity_sigma: 0.2339,
        },
    ),
    (
        "stsmc",
        false,
        Errors {
            position_max: 0.059,
            position_sigma: 0.0186,
            velocity_max: 3.0,
            velocity_sigma: 0.0790,
        },
    ),
    (
        "stsmc",
        true,
        Errors {
            position_max: 0.0604,
            position_sigma: 0.0189,
            velocity_max: 3.0,
            velocity_sigma: 0.0855,
        },
    ),
];

/// One run of the comparison.
struct Run {
    controller: &'static str,
    cutting: bool,
    errors: Errors,
}

fn condition(cutting: bool) -> &'static str {
    if cutting {
        "cut"
    } else {
        "air"
    }
}

pub fn run(out_dir: &Path, registry: &Registry) -> Result<Report, ReproduceError> {
    let mut runs = Vec::new();
    let mut records = Vec::new();
    for controller in CONTROLLERS {
        for cutting in [false, true] {
            let overrides = Overrides {
                controller: Some(controller.into()),
                set: vec![format!("process.cutting={cutting}")],
                ..Default::default()
            };
            let loaded = scenario::load(SCENARIO, &overrides).map_err(TwinError::from)?;
            let file = format!("{SCENARIO}-{controller}-{}.rrd", condition(cutting));
            let result = Twin::new(loaded, registry)?.run(Some(&out_dir.join(&file)))?;
            let mut record = summary::to_json(&result);
            record["cutting"] = cutting.into();
            record["recording"] = file.into();
            records.push(record);
            runs.push(Run {
                controller,
                cutting,
                errors: Errors::of(&result),
            });
        }
    }
    let errors = |controller: &str, cutting: bool| {
        runs.iter()
            .find(|r| r.controller == controller && r.cutting == cutting)
            .map(|r| r.errors)
            .expect("every controller ran with and without the cut")
    };
    let mut claims: Vec<Claim> = TABLE_I
        .iter()
        .map(|(controller, cutting, paper)| {
            table_row(controller, *cutting, paper, &errors(controller, *cutting))
        })
        .collect();
    claims.push(three_times_smaller(&errors));
    claims.push(less_affected(&errors));
    claims.push(observer_damps(&errors));
    Ok(Report {
        paper: "Rubio, Ibeas & Luo: P-PI vs super-twisting SMC on a linear-motor feed axis (Table I)"
            .into(),
        claims,
        runs: records,
    })
}

fn table_row(controller: &str, cutting: bool, paper: &Errors, twin: &Errors) -> Claim {
    let close = |twin: f64, paper: f64| (twin - paper).abs() <= 0.25 * paper;
    let matches = usize::from(close(twin.position_max, paper.position_max))
        + usize::from(close(twin.position_sigma, paper.position_sigma));
    Claim {
        claim: format!("Table I: {controller}, {}", condition_words(cutting)),
        paper: paper.describe(),
        twin: twin.describe(),
        verdict: count_verdict(matches, 2),
    }
}

fn condition_words(cutting: bool) -> &'static str {
    if cutting {
        "with the cut"
    } else {
        "in air"
    }
}

/// Reproduced when all `of` checks hold, partly when some do.
fn count_verdict(holding: usize, of: usize) -> Verdict {
    match holding {
        0 => Verdict::NotReproduced,
        n if n == of => Verdict::Reproduced,
        _ => Verdict::Partly,
    }
}

/// Claim: STSMC's max position error is about 3× smaller than P-PI's (Table I: 3.1× in air and
/// with the cut).
fn three_times_smaller(errors: &impl Fn(&str, bool) -> Errors) -> Claim {
    let ratio = |cutting: bool| {
        errors("p-pi", cutting).position_max / errors("stsmc", cutting).position_max
    };
    let (air, cut) = (ratio(false), ratio(true));
    let about_three = |r: f64| (2.0..=4.5).contains(&r);
    let verdict = if about_three(air) && about_three(cut) {
        Verdict::Reproduced
    } else if air > 1.0 && cut > 1.0 {
        Verdict::Partly
    } else {
        Verdict::NotReproduced
    };
    Claim {
        claim: "STSMC's max position error ≈ 3× smaller than P-PI's".into(),
        paper: "P-PI/STSMC 0.1826/0.059 = 3.1× in air, 0.1895/0.0604 = 3.1× with the cut".into(),
        twin: format!(
            "P-PI/STSMC {}/{} = {:.1}× in air, {}/{} = {:.1}× with the cut (µm)",
            figure(errors("p-pi", false).position_max),
            figure(errors("stsmc", false).position_max),
            air,
            figure(errors("p-pi", true).position_max),
            figure(errors("stsmc", true).position_max),
            cut
        ),
        verdict,
    }
}

/// The cut's relative change of the position error's σ and max for `controller`.
fn cut_effect(errors: &impl Fn(&str, bool) -> Errors, controller: &str) -> (f64, f64) {
    let (air, cut) = (errors(controller, false), errors(controller, true));
    (
        cut.position_sigma / air.position_sigma - 1.0,
        cut.position_max / air.position_max - 1.0,
    )
}

fn percent(change: f64) -> String {
    format!("{:+.1} %", 100.0 * change)
}

/// Claim: the cut disturbs STSMC less than P-PI.
fn less_affected(errors: &impl Fn(&str, bool) -> Errors) -> Claim {
    let (p_pi, stsmc) = (cut_effect(errors, "p-pi"), cut_effect(errors, "stsmc"));
    let holding = usize::from(stsmc.0 < p_pi.0) + usize::from(stsmc.1 < p_pi.1);
    Claim {
        claim: "the cut disturbs STSMC less than P-PI (position error σ, max)".into(),
        paper: "cut: P-PI σ +72.5 %, max +3.8 %; STSMC σ +1.6 %, max +2.4 %".into(),
        twin: format!(
            "cut: P-PI σ {}, max {}; STSMC σ {}, max {}",
            percent(p_pi.0),
            percent(p_pi.1),
            percent(stsmc.0),
            percent(stsmc.1)
        ),
        verdict: count_verdict(holding, 2),
    }
}

/// Claim: the disturbance observer damps the cut's effect further (the paper's Fig. 8; Table I
/// has no row for it).
fn observer_damps(errors: &impl Fn(&str, bool) -> Errors) -> Claim {
    let (stsmc, dob) = (errors("stsmc", true), errors("stsmc-dob", true));
    let nano = |value_um: f64| figure(value_um * 1e3);
    let (stsmc_effect, dob_effect) = (
        cut_effect(errors, "stsmc").0,
        cut_effect(errors, "stsmc-dob").0,
    );
    let holding = usize::from(dob.position_sigma < stsmc.position_sigma)
        + usize::from(dob_effect < stsmc_effect);
    Claim {
        claim: "the disturbance observer damps the cut's effect further".into(),
        paper: "Fig. 8 (STSMC with observer, under the cut); no figures".into(),
        twin: format!(
            "with the cut: σ {} nm (DOB) vs {} nm (STSMC), max {} vs {} nm; \
             the cut changes σ by {} (DOB) vs {} (STSMC)",
            nano(dob.position_sigma),
            nano(stsmc.position_sigma),
            nano(dob.position_max),
            nano(stsmc.position_max),
            percent(dob_effect),
            percent(stsmc_effect)
        ),
        verdict: count_verdict(holding, 2),
    }
}
