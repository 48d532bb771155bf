//! The lathe phase plane as files: CSV tables (SI: N, W, m/rev, s, 1/s) and a 2D `.rrd` plot,
//! plus a text summary. The summary also gives H in the paper's mm/kW (1 mm/kW = 10⁻⁶ m/(rev·W)).

use super::phase_plane::{PhasePlane, RECORD_EVERY};
use crate::analysis::error::AnalysisError;
use crate::analysis::files::{create_dir, write_text};
use models::lathe::{EquilibriumKind, FeedLimit, FeedRegime, PAPER_STEP};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use twin::recordings::{write_plot, Plot2D, PlotAxis, PlotGeometry, PlotLayer};

const GREEN: [u8; 3] = [44, 160, 44];
const RED: [u8; 3] = [214, 39, 40];
const BLUE: [u8; 3] = [31, 119, 180];
const CYAN: [u8; 3] = [23, 190, 207];
const ORANGE: [u8; 3] = [255, 127, 14];
const PURPLE: [u8; 3] = [148, 103, 189];
const YELLOW: [u8; 3] = [240, 200, 30];
/// Trajectory points within this distance of where the trajectory ends are not written, N.
const AT_REST: f64 = 0.5;

impl PhasePlane {
    /// Writes `phase_portrait.csv`, `equilibria.csv`, `region_boundary.csv`,
    /// `saturation_lines.csv`, `nullclines.csv` and `phase_plane.rrd` into `out_dir`.
    pub fn write(&self, out_dir: &Path) -> Result<Vec<PathBuf>, AnalysisError> {
        write(self, out_dir)
    }

    /// A few lines for people: H, Sudhakara eq (23), equilibria, the failing region.
    pub fn summary(&self) -> String {
        summary(self)
    }
}

fn write(plane: &PhasePlane, out_dir: &Path) -> Result<Vec<PathBuf>, AnalysisError> {
    create_dir(out_dir)?;
    let files = [
        ("phase_portrait.csv", portrait_csv(plane)),
        ("equilibria.csv", equilibria_csv(plane)),
        ("region_boundary.csv", boundary_csv(plane)),
        ("saturation_lines.csv", saturation_csv(plane)),
        ("nullclines.csv", nullclines_csv(plane)),
    ];
    let mut written = Vec::new();
    for (name, text) in files {
        let path = out_dir.join(name);
        write_text(&path, &text)?;
        written.push(path);
    }
    let path = out_dir.join("phase_plane.rrd");
    write_plot(&path, &plot(plane))?;
    written.push(path);
    Ok(written)
}

fn portrait_csv(plane: &PhasePlane) -> String {
    let mut csv = String::from(
        "trajectory,initial_force_1_n,initial_force_2_n,converged,time_s,force_1_n,force_2_n\n",
    );
    let steps = (plane.request.duration / PAPER_STEP).round() as usize;
    for (k, trajectory) in plane.portrait.trajectories.iter().enumerate() {
        let [a, b] = trajectory.initial_forces;
        for (j, point) in kept(&trajectory.points) {
            let time = (j * RECORD_EVERY).min(steps) as f64 * PAPER_STEP;
            let _ = writeln!(
                csv,
                "{k},{a},{b},{},{time},{},{}",
                trajectory.converged, point[0], point[1]
            );
        }
    }
    csv
}

/// A trajectory's points while it still moves, and its last point: the points (with their index)
/// up to the last one farther than [`AT_REST`] from where it ends.
fn kept(points: &[[f64; 2]]) -> impl Iterator<Item = (usize, &[f64; 2])> {
    let end = points.last().copied().unwrap_or([0.0; 2]);
    let moving = points
        .iter()
        .rposition(|p| (p[0] - end[0]).hypot(p[1] - end[1]) > AT_REST)
        .map_or(0, |last| last + 1);
    let last = points.len().saturating_sub(1);
    points
        .iter()
        .enumerate()
        .filter(move |(j, _)| *j <= moving || *j == last)
}

fn regime(regime: FeedRegime) -> &'static str {
    match regime {
        FeedRegime::ZeroFeed => "zero_feed",
        FeedRegime::Regulating => "regulating",
        FeedRegime::MaxFeed => "max_feed",
    }
}

fn kind(kind: EquilibriumKind) -> &'static str {
    match kind {
        EquilibriumKind::StableNode => "stable_node",
        EquilibriumKind::StableFocus => "stable_focus",
        EquilibriumKind::Saddle => "saddle",
        EquilibriumKind::UnstableNode => "unstable_node",
        EquilibriumKind::UnstableFocus => "unstable_focus",
        EquilibriumKind::NonHyperbolic => "non_hyperbolic",
        EquilibriumKind::NonSmooth => "non_smooth",
    }
}

fn limit(limit: FeedLimit) -> &'static str {
    match limit {
        FeedLimit::Zero => "zero_feed",
        FeedLimit::Max => "max_feed",
    }
}

fn equilibria_csv(plane: &PhasePlane) -> String {
    let mut csv = String::from(
        "force_1_n,force_2_n,spindle_power_w,commanded_feed_1_m,commanded_feed_2_m,\
         feed_regime_1,feed_regime_2,eigenvalue_1_re,eigenvalue_1_im,eigenvalue_2_re,\
         eigenvalue_2_im,kind\n",
    );
    for e in &plane.equilibria {
        let [l1, l2] = e.eigenvalues;
        let _ = writeln!(
            csv,
            "{},{},{},{},{},{},{},{},{},{},{},{}",
            e.forces[0],
            e.forces[1],
            e.spindle_power,
            e.commanded_feeds[0],
            e.commanded_feeds[1],
            regime(e.feed_regimes[0]),
            regime(e.feed_regimes[1]),
            l1.re,
            l1.im,
            l2.re,
            l2.im,
            kind(e.kind)
        );
    }
    csv
}

fn boundary_csv(plane: &PhasePlane) -> String {
    let mut csv = String::from("boundary,point,force_1_n,force_2_n,spindle_power_w\n");
    for (b, boundary) in plane.boundaries.iter().enumerate() {
        for (p, forces) in boundary.iter().enumerate() {
            let power = plane.lathe.spindle_power(*forces);
            let _ = writeln!(csv, "{b},{p},{},{},{power}", forces[0], forces[1]);
        }
    }
    csv
}

fn saturation_csv(plane: &PhasePlane) -> String {
    let mut csv = String::from("tool,limit,spindle_power_w,end,force_1_n,force_2_n\n");
    for (line, segment) in &plane.saturation_lines {
        let head = format!("{},{},{}", line.tool, limit(line.limit), line.spindle_power);
        match segment {
            Some(ends) => {
                for (e, end) in ends.iter().enumerate() {
                    let _ = writeln!(csv, "{head},{},{},{}", e + 1, end[0], end[1]);
                }
            }
            // Outside the window: the line is listed, without ends.
            None => {
                let _ = writeln!(csv, "{head},,,");
            }
        }
    }
    csv
}

fn nullclines_csv(plane: &PhasePlane) -> String {
    let mut csv = String::from("tool_at_rest,segment,force_1_n,force_2_n\n");
    let sets = [
        &plane.nullclines.tool1_at_rest,
        &plane.nullclines.tool2_at_rest,
    ];
    for (tool, segments) in sets.into_iter().enumerate() {
        for (s, segment) in segments.iter().enumerate() {
            for point in segment {
                let _ = writeln!(csv, "{},{s},{},{}", tool + 1, point[0], point[1]);
            }
        }
    }
    csv
}

fn lines(name: &str, color: [u8; 3], size: f32, lines: Vec<Vec<[f64; 2]>>) -> PlotLayer {
    PlotLayer {
        name: name.into(),
        color,
        size,
        geometry: PlotGeometry::Lines(lines),
        labels: Vec::new(),
    }
}

/// The phase plane in N on both axes (equal scales), the window the portrait's.
fn plot(plane: &PhasePlane) -> Plot2D {
    let (min, max) = (plane.window.min, plane.window.max);
    let mut layers = Vec::new();
    for (converged, name, color) in [(true, "converged", GREEN), (false, "failing", RED)] {
        let chosen = || {
            plane
                .portrait
                .trajectories
                .iter()
                .filter(move |t| t.converged == converged)
        };
        layers.push(lines(
            &format!("trajectories/{name}"),
            color,
            1.0,
            chosen()
                .map(|t| kept(&t.points).map(|(_, p)| *p).collect())
                .collect(),
        ));
        layers.push(PlotLayer {
            name: format!("starts/{name}"),
            color,
            size: 4.0,
            geometry: PlotGeometry::Points(chosen().map(|t| t.initial_forces).collect()),
            labels: Vec::new(),
        });
    }
    layers.extend(curve_layers(plane));
    layers.extend(equilibrium_layers(plane));
    let axis = |i: usize| PlotAxis {
        title: format!("cutting force F{} [N]", i + 1),
        range: [min[i], max[i]],
    };
    Plot2D {
        title: "lathe phase plane".into(),
        notes: summary(plane),
        x: axis(0),
        y: axis(1),
        aspect: Some((max[1] - min[1]) / (max[0] - min[0])),
        layers,
    }
}

/// Nullclines, saturation lines and the boundary of R_a, each labelled on the plot.
fn curve_layers(plane: &PhasePlane) -> Vec<PlotLayer> {
    let mut layers = Vec::new();
    for (tool, segments, color) in [
        (1, &plane.nullclines.tool1_at_rest, BLUE),
        (2, &plane.nullclines.tool2_at_rest, CYAN),
    ] {
        layers.push(PlotLayer {
            labels: vec![format!("Ḟ{tool} = 0 nullcline")],
            ..lines(
                &format!("nullclines/tool_{tool}_at_rest"),
                color,
                2.0,
                segments.clone(),
            )
        });
    }
    for (line, segment) in &plane.saturation_lines {
        if let Some([a, b]) = segment {
            layers.push(PlotLayer {
                labels: vec![format!(
                    "tool {} {} (eq 21, P = {:.2} kW)",
                    line.tool,
                    limit(line.limit).replace('_', " "),
                    line.spindle_power / 1e3
                )],
                ..lines(
                    &format!("saturation/tool_{}_{}", line.tool, limit(line.limit)),
                    if line.tool == 1 { ORANGE } else { PURPLE },
                    2.0,
                    vec![vec![*a, *b]],
                )
            });
        }
    }
    if !plane.boundaries.is_empty() {
        layers.push(PlotLayer {
            labels: vec!["boundary of R_a".into(); plane.boundaries.len()],
            ..lines("boundary", YELLOW, 3.0, plane.boundaries.clone())
        });
    }
    layers
}

fn equilibrium_layers(plane: &PhasePlane) -> Vec<PlotLayer> {
    let mut layers = Vec::new();
    for (stable, name, color) in [(true, "stable", GREEN), (false, "unstable", RED)] {
        let chosen: Vec<_> = plane
            .equilibria
            .iter()
            .filter(|e| e.is_asymptotically_stable() == stable)
            .collect();
        layers.push(PlotLayer {
            name: format!("equilibria/{name}"),
            color,
            size: 10.0,
            geometry: PlotGeometry::Points(chosen.iter().map(|e| e.forces).collect()),
            labels: chosen
                .iter()
                .map(|e| {
                    format!(
                        "{} ({:.1}, {:.1}) N",
                        kind(e.kind).replace('_', " "),
                        e.forces[0],
                        e.forces[1]
                    )
                })
                .collect(),
        });
    }
    layers
}

/// m/(rev·W) → mm/kW, for the paper's reader.
fn mm_per_kw(gain: f64) -> f64 {
    gain * 1e6
}

/// The text summary: the loop and its design, the equilibria, the region of attraction.
fn summary(plane: &PhasePlane) -> String {
    let mut out = String::new();
    loop_summary(&mut out, plane);
    equilibria_summary(&mut out, plane);
    region_summary(&mut out, plane);
    out
}

/// The power loop's parameters and gains H, how H was designed, and the global-stability
/// condition (Sudhakara eq (23)).
fn loop_summary(out: &mut String, plane: &PhasePlane) {
    let params = plane.lathe.params();
    let [h1, h2] = plane.power_gains;
    let _ = writeln!(
        out,
        "lathe power loop: P_max = {} W, N_s = {:.2} rad/s, f_max = {} m/rev",
        params.max_spindle_power, params.spindle_speed, params.max_feed
    );
    let _ = write!(
        out,
        "H = ({h1:.6e}, {h2:.6e}) m/(rev·W) = ({:.6}, {:.6}) mm/kW",
        mm_per_kw(h1),
        mm_per_kw(h2)
    );
    match &plane.design {
        Some(design) => {
            let [m1, m2] = design.spec.time_constants;
            let [a, b] = design.output_feedback_poles;
            let _ = writeln!(
                out,
                ", designed for m = {m1} / {m2} s (eqs 12-14); Theorem 1 residual {:.3}, \
                 linearised poles {:.3}, {:.3} 1/s",
                design.consistency_residual, a.re, b.re
            );
        }
        None => out.push_str(", given\n"),
    }
    let check = &plane.global_stability;
    let _ = writeln!(
        out,
        "eq (23), h_i >= -f_ni/P_max = ({:.6}, {:.6}) mm/kW: {}",
        mm_per_kw(check.lower_bounds[0]),
        mm_per_kw(check.lower_bounds[1]),
        if check.satisfied { "met" } else { "NOT met" }
    );
}

/// Each equilibrium: kind, forces, power, feed regimes and eigenvalues.
fn equilibria_summary(out: &mut String, plane: &PhasePlane) {
    let _ = writeln!(out, "equilibria:");
    for e in &plane.equilibria {
        let [l1, l2] = e.eigenvalues;
        let _ = writeln!(
            out,
            "  {} at ({:.1}, {:.1}) N, P = {:.1} W, feeds {} / {}, eigenvalues {:.3}{:+.3}i, \
             {:.3}{:+.3}i 1/s",
            kind(e.kind).replace('_', " "),
            e.forces[0],
            e.forces[1],
            e.spindle_power,
            regime(e.feed_regimes[0]),
            regime(e.feed_regimes[1]),
            l1.re,
            l1.im,
            l2.re,
            l2.im
        );
    }
}

/// The failing starts of the grid, the boundary of R_a and the saturation lines.
fn region_summary(out: &mut String, plane: &PhasePlane) {
    let region = plane.region();
    let _ = write!(
        out,
        "grid: {} of {} starts up to ({}, {}) N fail",
        region.failing_starts, region.starts, plane.window.max[0], plane.window.max[1]
    );
    if region.failing_starts > 0 {
        let [f1, f2] = region.failing_max_forces;
        let _ = write!(
            out,
            "; they reach F1 <= {f1:.1} N, F2 <= {f2:.1} N, P <= {:.1} W",
            region.failing_max_power
        );
    }
    out.push('\n');
    if let (Some([a, b]), Some([low, high])) = (region.boundary_ends, region.boundary_power_range) {
        let _ = writeln!(
            out,
            "boundary of R_a (reverse trajectories): from ({:.1}, {:.1}) N to ({:.1}, {:.1}) N, \
             P {low:.1} to {high:.1} W",
            a[0], a[1], b[0], b[1]
        );
    }
    for (line, segment) in &plane.saturation_lines {
        let _ = writeln!(
            out,
            "saturation line: tool {} at {} where P = {:.1} W{}",
            line.tool,
            limit(line.limit).replace('_', " "),
            line.spindle_power,
            if segment.is_some() {
                " (crosses the window)"
            } else {
                ""
            }
        );
    }
}
