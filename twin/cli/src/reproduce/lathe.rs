//! `twin reproduce lathe`: Sudhakara & Landers, "Output Feedback Force Control for a Parallel
//! Turning Operation" (ACC 2003). The phase-plane claims (Figs 4–9, Sudhakara eqs (15), (21)–(23)) are
//! checked on the reduced model of Sudhakara eq (17); the rigid-body twin (scenario `lathe-turning`) is then
//! started inside and outside the failing region and must end where the reduced model, started at
//! the twin's own forces when both tools meet the part, says it ends.
//!
//! Files: `phase-<gains>/` holds each gain set's CSV files and `phase_plane.rrd`; `<run>.rrd` each
//! twin run.

use super::error::ReproduceError;
use super::report::{Claim, Report, Verdict};
use crate::analysis::lathe::{analyze, Gains, PhasePlane, PhasePlaneRequest};
use framework::Registry;
use models::lathe::{EquilibriumKind, Lathe, TOOLS};
use std::f64::consts::TAU;
use std::path::Path;
use twin::summary;
use twin::Twin;
use twin::{LoadedScenario, Scenario, ScenarioError};

/// Twin and reduced model must agree on the settled forces within this share of F_r.
pub const AGREEMENT: f64 = 0.01;
/// Approach travel time: each tool's air gap is its approach feed times N_s times this, so its
/// feed has settled (6 τ) when it meets the part, s.
pub const APPROACH_TIME: f64 = 0.3;
/// How long the reduced model runs to find where a start ends, s.
const MODEL_HORIZON: f64 = 30.0;

/// A twin run of the comparison.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TwinStart {
    pub label: &'static str,
    /// Gains by design time constants or given.
    pub gains: Gains,
    pub initial_forces: [f64; TOOLS],
    pub duration: f64,
}

/// What a twin run and the reduced model say about one start.
#[derive(Debug, Clone, PartialEq)]
pub struct Comparison {
    pub start: TwinStart,
    /// The twin's forces when both tools first cut, N.
    pub twin_initial: [f64; TOOLS],
    pub twin_settled: [f64; TOOLS],
    /// Sudhakara eq (17) from `twin_initial`, N.
    pub model_settled: [f64; TOOLS],
    /// max_i |twin − model| / F_ri.
    pub difference: f64,
    /// Both end at the reference forces, or both elsewhere.
    pub same_end: bool,
    pub run: serde_json::Value,
}

/// The air gaps that give each tool `APPROACH_TIME` of travel at its approach feed, m.
pub fn approach_gaps(lathe: &Lathe, initial_forces: [f64; TOOLS]) -> [f64; TOOLS] {
    let revolutions_per_second = lathe.params().spindle_speed / TAU;
    [0, 1].map(|i| {
        let feed =
            lathe.params().tools[i].feed_for_force(lathe.cutting_speeds()[i], initial_forces[i]);
        feed * revolutions_per_second * APPROACH_TIME
    })
}

/// `lathe-turning` set up to run from `start`.
pub fn scenario(
    lathe: &Lathe,
    start: &TwinStart,
    registry: &Registry,
) -> Result<LoadedScenario, ScenarioError> {
    let gains = match start.gains {
        Gains::Design { time_constants } => ("controller.params.time_constants", time_constants),
        Gains::Given(power_gains) => ("controller.params.power_gains", power_gains),
    };
    Scenario::builtin("lathe-turning")?
        .set("controller.params.initial_forces", start.initial_forces)?
        .set(
            "process.approach_gaps",
            approach_gaps(lathe, start.initial_forces),
        )?
        .duration(start.duration)
        .set(gains.0, gains.1)?
        .build(registry)
}

/// Runs the twin from `start` (recording to `recording` when given) and the reduced model from
/// the twin's forces at engagement.
pub fn compare(
    plane: &PhasePlane,
    start: &TwinStart,
    registry: &Registry,
    recording: Option<&Path>,
) -> Result<Comparison, ReproduceError> {
    let loaded = scenario(&plane.lathe, start, registry).map_err(twin::TwinError::from)?;
    let result = Twin::new(loaded)?.run(recording)?;
    let metric = |name: String| result.metric(&name).unwrap_or(f64::NAN);
    let twin_initial = [1, 2].map(|i| metric(format!("initial_force/tool_{i}")));
    let twin_settled = [1, 2].map(|i| metric(format!("settled_force/tool_{i}")));
    let model_settled = plane
        .final_forces(twin_initial, MODEL_HORIZON)
        .map_err(|e| ReproduceError::Output {
            path: "reduced model".into(),
            reason: e.to_string(),
        })?;
    let reference = plane.lathe.reference_forces();
    let difference = (0..TOOLS)
        .map(|i| (twin_settled[i] - model_settled[i]).abs() / reference[i])
        .fold(0.0, f64::max);
    let at_reference = |forces: [f64; TOOLS]| {
        (0..TOOLS).all(|i| (forces[i] - reference[i]).abs() <= AGREEMENT * reference[i])
    };
    let mut run = summary::to_json(&result);
    if let Some(path) = recording {
        run["recording"] = serde_json::json!(path.display().to_string());
    }
    run["label"] = serde_json::json!(start.label);
    Ok(Comparison {
        start: *start,
        twin_initial,
        twin_settled,
        model_settled,
        difference,
        same_end: at_reference(twin_settled) == at_reference(model_settled),
        run,
    })
}

fn verdict(ok: bool) -> Verdict {
    if ok {
        Verdict::Reproduced
    } else {
        Verdict::NotReproduced
    }
}

fn pair(forces: [f64; TOOLS]) -> String {
    format!("({:.1}, {:.1}) N", forces[0], forces[1])
}

fn phase_plane(gains: Gains, out_dir: &Path, name: &str) -> Result<PhasePlane, ReproduceError> {
    let as_output = |e: crate::analysis::error::AnalysisError| ReproduceError::Output {
        path: out_dir.join(name).display().to_string(),
        reason: e.to_string(),
    };
    let plane = analyze(&PhasePlaneRequest {
        gains,
        ..Default::default()
    })
    .map_err(as_output)?;
    plane.write(&out_dir.join(name)).map_err(as_output)?;
    Ok(plane)
}

/// The runs go through the phase-plane analysis, which builds its scenarios on the exact engine
/// (`--engine rapier` is refused before this).
pub(super) fn run(
    out_dir: &Path,
    registry: &Registry,
    _engine: Option<twin::Engine>,
) -> Result<Report, ReproduceError> {
    let fast = phase_plane(
        Gains::Design {
            time_constants: [0.5, 0.49],
        },
        out_dir,
        "phase-m0.5",
    )?;
    let slow = phase_plane(
        Gains::Design {
            time_constants: [1.5, 1.49],
        },
        out_dir,
        "phase-m1.5",
    )?;
    let eq23_gains = [
        slow.power_gains[0].max(slow.global_stability.lower_bounds[0]),
        slow.power_gains[1].max(slow.global_stability.lower_bounds[1]),
    ];
    let eq23 = phase_plane(Gains::Given(eq23_gains), out_dir, "phase-eq23")?;

    let mut claims = vec![
        theorem1_claim(&fast, &slow),
        fast_equilibrium_claim(&fast),
        fast_portrait_claim(&fast),
        slow_equilibria_claim(&slow),
        slow_region_claim(&slow),
        slope_claim(&slow),
        eq23_claim(&slow, &eq23),
    ];

    let low = [1000.0, 500.0];
    let starts = [
        (&fast, "twin-m0.5-low", fast.request.gains, low, 3.0),
        (&slow, "twin-m1.5-low", slow.request.gains, low, 6.0),
        (
            &slow,
            "twin-m1.5-high",
            slow.request.gains,
            [2000.0, 1000.0],
            9.0,
        ),
        (&eq23, "twin-eq23-low", eq23.request.gains, low, 4.0),
    ];
    let mut runs = Vec::new();
    for (plane, label, gains, initial_forces, duration) in starts {
        let start = TwinStart {
            label,
            gains,
            initial_forces,
            duration,
        };
        let recording = out_dir.join(format!("{label}.rrd"));
        let comparison = compare(plane, &start, registry, Some(&recording))?;
        claims.push(twin_claim(plane, &comparison));
        runs.push(comparison.run);
    }
    Ok(Report {
        paper: "Sudhakara & Landers 2003, output feedback force control, parallel turning".into(),
        claims,
        runs,
    })
}

fn theorem1_claim(fast: &PhasePlane, slow: &PhasePlane) -> Claim {
    // Theorem 1 holds when K C+ C = K to this relative residual (round-off, not a design error).
    const RESIDUAL_TOLERANCE: f64 = 1e-6;
    let residual = |plane: &PhasePlane| {
        plane
            .design
            .map_or(f64::NAN, |design| design.consistency_residual)
    };
    let holds = [fast, slow]
        .iter()
        .all(|plane| residual(plane) <= RESIDUAL_TOLERANCE);
    Claim {
        claim: "H of eq (15) meets Theorem 1 (K C+ C = K)".into(),
        paper: "stated for the design; poles exactly at -1/m_i".into(),
        twin: format!(
            "{}: relative residual {:.2} (m = 0.5) and {:.2} (m = 1.5); H = K C+ of eq (14) \
             is used (eq (15) as printed flips h_1)",
            if holds { "holds" } else { "fails" },
            residual(fast),
            residual(slow)
        ),
        verdict: verdict(holds),
    }
}

fn fast_equilibrium_claim(fast: &PhasePlane) -> Claim {
    let only = fast.equilibria.first();
    let ok = fast.equilibria.len() == 1 && only.is_some_and(|e| e.is_asymptotically_stable());
    Claim {
        claim: "m = 0.5/0.49 s: one equilibrium (Fig 6)".into(),
        paper: "(17a) = 0 and (17b) = 0 meet once, at the reference forces".into(),
        twin: match only {
            Some(e) => format!(
                "{} equilibrium: {} {}, eigenvalues {:.2}, {:.2} 1/s",
                fast.equilibria.len(),
                kind(e.kind),
                pair(e.forces),
                e.eigenvalues[0].re,
                e.eigenvalues[1].re
            ),
            None => "none".into(),
        },
        verdict: verdict(ok),
    }
}

fn fast_portrait_claim(fast: &PhasePlane) -> Claim {
    let region = fast.region();
    // The grid's forces run from max/n to max on each axis.
    let request = &fast.request;
    let largest = request.max_forces[0].max(request.max_forces[1]);
    let smallest =
        request.max_forces[0].min(request.max_forces[1]) / request.points_per_axis.max(1) as f64;
    Claim {
        claim: "m = 0.5/0.49 s: every positive start converges (Fig 4)".into(),
        paper: "globally stable phase plot".into(),
        twin: format!(
            "{} of {} grid starts ({smallest:.0} to {largest:.0} N) reach the reference forces",
            region.starts - region.failing_starts,
            region.starts
        ),
        verdict: verdict(region.failing_starts == 0),
    }
}

fn kind(kind: EquilibriumKind) -> &'static str {
    match kind {
        EquilibriumKind::StableNode => "stable node",
        EquilibriumKind::StableFocus => "stable focus",
        EquilibriumKind::Saddle => "saddle",
        EquilibriumKind::UnstableNode => "unstable node",
        EquilibriumKind::UnstableFocus => "unstable focus",
        EquilibriumKind::NonHyperbolic => "non-hyperbolic point",
        EquilibriumKind::NonSmooth => "non-smooth rest point",
    }
}

fn slow_equilibria_claim(slow: &PhasePlane) -> Claim {
    let saddle = slow
        .equilibria
        .iter()
        .find(|e| e.kind == EquilibriumKind::Saddle);
    let others: Vec<String> = slow
        .equilibria
        .iter()
        .filter(|e| e.kind != EquilibriumKind::Saddle)
        .map(|e| format!("{} {}", kind(e.kind), pair(e.forces)))
        .collect();
    let twin = match saddle {
        Some(s) => format!(
            "{} equilibria: saddle {} at {:.2} kW, eigenvalues {:.3}, {:.3} 1/s; {}",
            slow.equilibria.len(),
            pair(s.forces),
            s.spindle_power / 1e3,
            s.eigenvalues[0].re,
            s.eigenvalues[1].re,
            others.join("; ")
        ),
        None => format!("{} equilibria, no saddle", slow.equilibria.len()),
    };
    Claim {
        claim: "m = 1.5/1.49 s: a second, unstable equilibrium (Fig 7)".into(),
        paper: "two equilibria; the other one is unstable".into(),
        twin: format!(
            "{twin} (the third, with tool 2 at zero feed on the F2 = 0 axis, is not in the paper)"
        ),
        verdict: if saddle.is_none() {
            Verdict::NotReproduced
        } else if slow.equilibria.len() == 2 {
            Verdict::Reproduced
        } else {
            Verdict::Partly
        },
    }
}

fn slow_region_claim(slow: &PhasePlane) -> Claim {
    let region = slow.region();
    let boundary = match (region.boundary_ends, region.boundary_power_range) {
        (Some([a, b]), Some([low, high])) => format!(
            "; the reverse-trajectory boundary runs from {} to {}, {:.2} to {:.2} kW",
            pair(a),
            pair(b),
            low / 1e3,
            high / 1e3
        ),
        _ => String::new(),
    };
    Claim {
        claim: "m = 1.5/1.49 s: low initial forces diverge (Figs 5, 8)".into(),
        paper: "a region of low initial forces fails; boundary by reverse trajectories".into(),
        twin: format!(
            "{} of {} grid starts fail (tool 2 ends at zero feed), up to F1 = {:.0} N, \
             F2 = {:.0} N, P = {:.2} kW{boundary}",
            region.failing_starts,
            region.starts,
            region.failing_max_forces[0],
            region.failing_max_forces[1],
            region.failing_max_power / 1e3
        ),
        verdict: verdict(region.failing_starts > 0 && region.boundary_ends.is_some()),
    }
}

fn slope_claim(slow: &PhasePlane) -> Claim {
    let [v1, v2] = slow.lathe.cutting_speeds();
    let boundary: Vec<[f64; TOOLS]> = slow.boundaries.iter().flatten().copied().collect();
    let slope = match (boundary.first(), boundary.last()) {
        (Some(a), Some(b)) if b[0] != a[0] => (b[1] - a[1]) / (b[0] - a[0]),
        _ => f64::NAN,
    };
    let saturation = -v1 / v2;
    Claim {
        claim: "boundary parallel to the saturation line (eq 22, Fig 9)".into(),
        paper: format!("both slope -V1/V2 = {saturation:.3}"),
        twin: format!("boundary end-to-end slope {slope:.3}"),
        verdict: verdict((slope - saturation).abs() <= 0.05 * saturation.abs()),
    }
}

fn eq23_claim(slow: &PhasePlane, eq23: &PhasePlane) -> Claim {
    let region = eq23.region();
    let [h1, h2] = eq23.power_gains;
    let ok = region.failing_starts == 0 && eq23.equilibria.len() == 1;
    Claim {
        claim: "gains meeting eq (23) remove the failing region".into(),
        paper: "h_i >= f_ni/P_max (printed sign) gives global stability".into(),
        twin: format!(
            "with h_i >= -f_ni/P_max (sign from its derivation): h = ({:.6}, {:.6}) mm/kW \
             (was {:.6} for tool 2): {} equilibrium, {} of {} starts converge",
            h1 * 1e6,
            h2 * 1e6,
            slow.power_gains[1] * 1e6,
            eq23.equilibria.len(),
            region.starts - region.failing_starts,
            region.starts
        ),
        verdict: verdict(ok),
    }
}

fn twin_claim(plane: &PhasePlane, comparison: &Comparison) -> Claim {
    let reference = plane.lathe.reference_forces();
    let converged = (0..TOOLS)
        .all(|i| (comparison.model_settled[i] - reference[i]).abs() <= AGREEMENT * reference[i]);
    let gains = match comparison.start.gains {
        Gains::Design {
            time_constants: [m1, m2],
        } => format!("m = {m1}/{m2} s"),
        Gains::Given(_) => "eq (23) gains".into(),
    };
    Claim {
        claim: format!(
            "rigid-body twin, {gains}, from {}",
            pair(comparison.start.initial_forces)
        ),
        paper: if converged {
            "reaches the reference forces".into()
        } else {
            "tool 2 goes to zero feed; P_max not reached".into()
        },
        twin: format!(
            "meets the part at {}, settles at {}; reduced model from there: {}; difference \
             {:.3} % of F_r",
            pair(comparison.twin_initial),
            pair(comparison.twin_settled),
            pair(comparison.model_settled),
            100.0 * comparison.difference
        ),
        verdict: verdict(comparison.same_end && comparison.difference <= AGREEMENT),
    }
}
