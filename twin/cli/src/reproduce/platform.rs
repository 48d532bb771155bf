//! `twin reproduce platform`: Kalinski et al. 2013, §4 — the two-wheeled mobile platform under
//! optimal control at the kinetic-energy index (`energy-optimal`, Kaliński eqs (19)–(21)) and under two PID
//! loops (`pid`, its grid-searched defaults), on the Fig. 7 path (`platform-path`) and the Fig. 10
//! path (`platform-path-s`), and on the Fig. 10 path again on a slippery floor (μ = 0.05).
//!
//! Recordings: `<scenario>-<controller>.rrd` and `<scenario>-<controller>-slippery.rrd` in the
//! output folder. Verdicts:
//! - Fig. 8, Δβ small and vanishing: *reproduced* when energy-optimal's final |Δβ| < 0.5° and its
//!   largest < 2° on the Fig. 7 path, *partly* when only the final one is;
//! - Fig. 10, energy-optimal far more precise than PID: RMS path error of H, *reproduced* when
//!   energy-optimal/PID < 0.5 on both paths, *partly* when < 1 on both;
//! - Fig. 11, direct and incremental final positions close: *reproduced* when they are within
//!   5 mm for energy-optimal on the Fig. 10 path, *partly* within 2 cm;
//! - slip a serious problem for the PID: *reproduced* when the PID's peak wheel slip is over twice
//!   energy-optimal's on both floors, *partly* when it is larger on both.

use super::error::ReproduceError;
use super::report::{Claim, Report, Verdict};
use framework::Registry;
use std::path::Path;
use twin::summary;
use twin::{RunSummary, Twin, TwinError};

const PATHS: [&str; 2] = ["platform-path", "platform-path-s"];
const CONTROLLERS: [&str; 2] = ["energy-optimal", "pid"];
/// The slippery floor's μ.
const SLIPPERY: f64 = 0.05;

struct Run {
    scenario: &'static str,
    controller: &'static str,
    slippery: bool,
    summary: RunSummary,
}

impl Run {
    fn metric(&self, name: &str) -> f64 {
        self.summary.metric(name).unwrap_or(f64::NAN)
    }

    /// |incremental − direct| final position of H, m.
    fn odometry_drift(&self) -> f64 {
        (self.metric("controller_final/odometry.x_h") - self.metric("final_x_h"))
            .hypot(self.metric("controller_final/odometry.y_h") - self.metric("final_y_h"))
    }
}

pub fn run(
    out_dir: &Path,
    registry: &Registry,
    engine: Option<twin::Engine>,
) -> Result<Report, ReproduceError> {
    let mut runs = Vec::new();
    let mut records = Vec::new();
    let cases = PATHS
        .iter()
        .flat_map(|p| CONTROLLERS.map(|c| (*p, c, false)))
        .chain(CONTROLLERS.map(|c| ("platform-path-s", c, true)));
    for (scenario_name, controller, slippery) in cases {
        let loaded = super::scenarios::builtin(scenario_name, engine)
            .map(|s| s.controller(controller))
            .and_then(|s| match slippery {
                true => s.set("process.friction", SLIPPERY),
                false => Ok(s),
            })
            .and_then(|b| b.build(registry))
            .map_err(TwinError::from)?;
        let suffix = if slippery { "-slippery" } else { "" };
        let file = format!("{scenario_name}-{controller}{suffix}.rrd");
        let result = Twin::new(loaded)?.run(Some(&out_dir.join(&file)))?;
        let mut record = summary::to_json(&result);
        record["slippery"] = slippery.into();
        record["recording"] = file.into();
        records.push(record);
        runs.push(Run {
            scenario: scenario_name,
            controller,
            slippery,
            summary: result,
        });
    }
    let claims = vec![
        heading_vanishes(find(&runs, "platform-path", "energy-optimal", false)),
        path_precision(&runs),
        final_positions(
            find(&runs, "platform-path-s", "energy-optimal", false),
            find(&runs, "platform-path-s", "pid", false),
        ),
        slip(&runs),
    ];
    Ok(Report {
        paper: "Kalinski et al. 2013 §4: two-wheeled platform, optimal control at the energy index vs two PIDs".into(),
        claims,
        runs: records,
    })
}

fn find<'a>(runs: &'a [Run], scenario_name: &str, controller: &str, slippery: bool) -> &'a Run {
    runs.iter()
        .find(|r| {
            r.scenario == scenario_name && r.controller == controller && r.slippery == slippery
        })
        .expect("every case ran")
}

fn heading_vanishes(run: &Run) -> Claim {
    let max = run.metric("heading_error_max").to_degrees();
    let rms = run.metric("heading_error_rms").to_degrees();
    let last = run.metric("heading_error_final").abs().to_degrees();
    let verdict = if last < 0.5 && max < 2.0 {
        Verdict::Reproduced
    } else if last < 0.5 {
        Verdict::Partly
    } else {
        Verdict::NotReproduced
    };
    Claim {
        claim: "Fig. 8: Δβ small, → 0 at the end (energy-optimal, Fig. 7 path)".into(),
        paper: "very small errors of β, approaching zero by the end".into(),
        twin: format!("|Δβ| max {max:.3}°, RMS {rms:.3}°, final {last:.3}°"),
        verdict,
    }
}

fn path_precision(runs: &[Run]) -> Claim {
    let rms =
        |path: &str, controller: &str| find(runs, path, controller, false).metric("path_error_rms");
    let ratios = PATHS.map(|path| rms(path, "energy-optimal") / rms(path, "pid"));
    let verdict = if ratios.iter().all(|r| *r < 0.5) {
        Verdict::Reproduced
    } else if ratios.iter().all(|r| *r < 1.0) {
        Verdict::Partly
    } else {
        Verdict::NotReproduced
    };
    let describe = |i: usize, figure: &str| {
        format!(
            "{figure}: {:.3} vs {:.3} mm (×{:.2})",
            rms(PATHS[i], "energy-optimal") * 1e3,
            rms(PATHS[i], "pid") * 1e3,
            ratios[i]
        )
    };
    Claim {
        claim: "Fig. 10: energy-optimal path of H far more precise than PID's".into(),
        paper: "PID visibly off the path; optimal control very close to it".into(),
        twin: format!(
            "RMS path error, energy-optimal vs PID: {}; {}",
            describe(0, "Fig. 7"),
            describe(1, "Fig. 10")
        ),
        verdict,
    }
}

fn final_positions(optimal: &Run, pid: &Run) -> Claim {
    let (eo, p) = (optimal.odometry_drift(), pid.odometry_drift());
    let verdict = if eo < 5e-3 {
        Verdict::Reproduced
    } else if eo < 2e-2 {
        Verdict::Partly
    } else {
        Verdict::NotReproduced
    };
    Claim {
        claim: "Fig. 11: direct and incremental final positions of H close (Fig. 10 path)".into(),
        paper: "very good coincidence of direct and encoder (incremental) measurement".into(),
        twin: format!(
            "|odometry − true|: energy-optimal {:.2} mm, PID {:.2} mm; final error of H {:.2} / {:.2} mm",
            eo * 1e3,
            p * 1e3,
            optimal.metric("final_position_error") * 1e3,
            pid.metric("final_position_error") * 1e3
        ),
        verdict,
    }
}

fn slip(runs: &[Run]) -> Claim {
    let peak = |controller: &str, slippery: bool| {
        find(runs, "platform-path-s", controller, slippery).metric("wheel_slip_max")
    };
    let drift = |controller: &str| find(runs, "platform-path-s", controller, true).odometry_drift();
    let friction = |slippery: bool| {
        find(runs, "platform-path-s", "pid", slippery).metric("wheel_friction/left_wheel")
    };
    let ratios =
        [false, true].map(|slippery| peak("pid", slippery) / peak("energy-optimal", slippery));
    let verdict = if ratios.iter().all(|r| *r > 2.0) {
        Verdict::Reproduced
    } else if ratios.iter().all(|r| *r > 1.0) {
        Verdict::Partly
    } else {
        Verdict::NotReproduced
    };
    Claim {
        claim: "slip a serious problem for the PID (Fig. 10 path)".into(),
        paper: "PID inaccurate, slippage a serious problem".into(),
        twin: format!(
            "peak slip PID/energy-optimal: μ = {} {:.2e}/{:.2e}, μ = {} {:.2e}/{:.2e}; odometry drift at μ = {}: {:.1} / {:.1} mm",
            friction(false),
            peak("pid", false),
            peak("energy-optimal", false),
            friction(true),
            peak("pid", true),
            peak("energy-optimal", true),
            friction(true),
            drift("pid") * 1e3,
            drift("energy-optimal") * 1e3
        ),
        verdict,
    }
}
