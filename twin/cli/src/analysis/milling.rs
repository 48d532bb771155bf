//! `twin analyze milling [scenario]`: the stability lobe diagram of a milling scenario's tool and
//! cut by semi-discretization ([`models::milling::stability`]), checked against the twin's own
//! time-domain runs of the same scenario.
//!
//! **Inputs** come from the scenario (built-in name or file, `--set` applied): the tool's two
//! modes from the mechanism — modal mass of x = every link the `tool_x` joint carries, of y =
//! every link `tool_y` carries, stiffness from their `<spring>`s, damping from their
//! `<dynamics>` — so a tool given directly by modal values is `[plant.link.tool_tip] mass` and
//! `[plant.joint.tool_x] stiffness, damping` on the shipped URDF; flutes, k_d, μ and the immersion
//! from `[process.cut]`.
//!
//! **The check**: on a grid of speeds × depths the scenario is run under `spindle-constant` from
//! the speed, and each run is called chattering when the tool's once-per-tooth samples (a
//! stable cut repeats every tooth: its Poincaré samples converge) still move at the end of the
//! run (see `chatters`). Points within 5 % of the lobes' depth are left out of the agreement.

use super::error::AnalysisError;
use super::files::{create_dir, write_text};
use crate::frequency_response::file::read_csv;
use crate::frequency_response::fit::{fit_mode, ModalFit};
use framework::Registry;
use models::milling::stability::{
    limiting_depth, lobe_diagram, CutGeometry, LobePoint, SemiDiscretization, ToolModes,
};
use models::milling::MillingCutParams;
use rayon::prelude::*;
use std::f64::consts::TAU;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use twin::engine::Mechanism;
use twin::recordings::{write_plot, Plot2D, PlotAxis, PlotGeometry, PlotLayer};
use twin::{Findings, Observer, ObserverError, SignalLayout, StepView, Twin};
use twin::{LoadedScenario, ScenarioBuilder};

const RPM: f64 = 60.0 / TAU;
/// Points this close to the boundary (relative depth) are not judged.
const BOUNDARY_MARGIN: f64 = 0.05;

/// What `twin analyze milling` is asked.
#[derive(Debug, Clone)]
pub struct LobeRequest {
    /// The scenario with `--set` applied; the check's runs start from it.
    pub scenario: ScenarioBuilder,
    /// Speed range of the diagram, rad/s, and its number of speeds.
    pub speeds: [f64; 2],
    pub speed_count: usize,
    /// Largest depth searched, m.
    pub max_depth: f64,
    /// Time-domain check grid (speeds × depths) and run length, s.
    pub check: [usize; 2],
    pub check_duration: f64,
    /// Measured (or simulated) frequency responses of the tool in x and y (`frf.csv` files):
    /// the tool's modes are fitted to them instead of read from the scenario's mechanism.
    pub frf: Option<[PathBuf; 2]>,
}

/// One time-domain run of the check.
#[derive(Debug, Clone, Copy)]
pub struct CheckPoint {
    pub speed: f64,
    pub depth: f64,
    /// The lobes' limiting depth at this speed, m (∞ when stable to the maximum depth).
    pub limit: f64,
    /// RMS once-per-tooth steps early and late in the run, m.
    pub spread: [f64; 2],
    pub chatter: bool,
}

impl CheckPoint {
    fn predicted_chatter(&self) -> bool {
        self.depth >= self.limit
    }
    fn judged(&self) -> bool {
        (self.depth - self.limit).abs() > BOUNDARY_MARGIN * self.limit
    }
}

pub struct LobeAnalysis {
    pub tool: ToolModes,
    pub cut: CutGeometry,
    pub lobes: Vec<LobePoint>,
    pub checks: Vec<CheckPoint>,
    /// Speed and depth of the scenario itself (its operating point), rad/s and m.
    pub operating_point: [f64; 2],
    /// With FRFs: the modes fitted to them (x, y) and the lobes of the scenario's own tool.
    pub from_frf: Option<([ModalFit; 2], Vec<LobePoint>)>,
}

/// The tool's modes and the cut from the scenario.
fn inputs(
    mechanism: &Mechanism,
    process: &toml::Table,
) -> Result<(ToolModes, CutGeometry, f64), AnalysisError> {
    let bad = |reason: String| AnalysisError::Argument {
        flag: "scenario",
        reason,
    };
    let mode = |name: &str| -> Result<(f64, f64, f64), AnalysisError> {
        let j = mechanism
            .joint_index(name)
            .ok_or_else(|| bad(format!("the URDF has no joint `{name}` (the tool's mode)")))?;
        let joint = &mechanism.joints[j];
        let spring = joint
            .spring
            .ok_or_else(|| bad(format!("joint `{name}` has no <spring>")))?;
        let mass = mechanism.carried_mass(joint.child);
        Ok((mass, spring.stiffness, joint.damping))
    };
    let (x, y) = (mode("tool_x")?, mode("tool_y")?);
    let cut_table = process
        .get("cut")
        .cloned()
        .unwrap_or(toml::Value::Table(toml::Table::new()));
    let cut: MillingCutParams = cut_table
        .try_into()
        .map_err(|e| bad(format!("process.cut: {e}")))?;
    cut.validate()
        .map_err(|e| bad(format!("process.cut.{e}")))?;
    let tool = ToolModes {
        mass: [x.0, y.0],
        stiffness: [x.1, y.1],
        damping: [x.2, y.2],
    };
    let geometry = CutGeometry {
        flutes: cut.flutes,
        cutting_pressure: cut.cutting_pressure,
        force_ratio: cut.force_ratio,
        entry_angle: cut.entry_angle,
        exit_angle: cut.exit_angle,
    };
    Ok((tool, geometry, cut.axial_depth))
}

/// The lobes, then the time-domain check.
pub fn analyze(request: &LobeRequest, registry: &Registry) -> Result<LobeAnalysis, AnalysisError> {
    let loaded = request.scenario.clone().build(registry).map_err(argument)?;
    let (model_tool, cut, depth) = scenario_inputs(&loaded)?;
    let sd = SemiDiscretization::default();
    let [low, high] = request.speeds;
    let speeds = spaced(low, high, request.speed_count);
    let diagram = |tool: &ToolModes| {
        lobe_diagram(tool, &cut, &speeds, request.max_depth, &sd).map_err(argument)
    };
    let (tool, from_frf) = match &request.frf {
        Some(files) => {
            let fits = [
                fitted_mode(&files[0], "--frf-x")?,
                fitted_mode(&files[1], "--frf-y")?,
            ];
            let tool = ToolModes {
                mass: fits.map(|f| f.mass),
                stiffness: fits.map(|f| f.stiffness),
                damping: fits.map(|f| f.damping),
            };
            (tool, Some((fits, diagram(&model_tool)?)))
        }
        None => (model_tool, None),
    };
    let lobes = diagram(&tool)?;
    // The runs are of the scenario's own tool; with FRFs they judge the lobes of its measured
    // response, as a tap test's lobes are judged by test cuts.
    let checks = check(request, registry, (&tool, &cut, &sd))?;
    let speed = loaded
        .scenario
        .initial
        .get("spindle")
        .map_or(0.0, |state| state.velocity);
    Ok(LobeAnalysis {
        tool,
        cut,
        lobes,
        checks,
        operating_point: [speed, depth],
        from_frf,
    })
}

/// The mode fitted to an FRF file (a receptance, m/N, as `twin frf` writes it).
fn fitted_mode(path: &Path, flag: &'static str) -> Result<ModalFit, AnalysisError> {
    let lines = read_csv(path).map_err(|reason| AnalysisError::Argument { flag, reason })?;
    fit_mode(&lines).map_err(|reason| AnalysisError::Argument {
        flag,
        reason: format!("{}: {reason}", path.display()),
    })
}

fn argument(e: impl std::fmt::Display) -> AnalysisError {
    AnalysisError::Argument {
        flag: "scenario",
        reason: e.to_string(),
    }
}

/// `count` values from `low` to `high`, ends included.
fn spaced(low: f64, high: f64, count: usize) -> Vec<f64> {
    (0..count)
        .map(|k| low + (high - low) * k as f64 / (count.max(2) - 1) as f64)
        .collect()
}

/// The modes and cut of a loaded scenario (its URDF with `[plant]` values applied).
fn scenario_inputs(
    loaded: &LoadedScenario,
) -> Result<(ToolModes, CutGeometry, f64), AnalysisError> {
    let mut mechanism =
        twin::engine::load_urdf(&loaded.urdf_text, &loaded.urdf_source).map_err(argument)?;
    loaded
        .scenario
        .plant
        .apply(&mut mechanism)
        .map_err(argument)?;
    inputs(&mechanism, &loaded.scenario.process)
}

/// Runs the check grid: depths up to 1.6 times the deepest limit at the check speeds.
fn check(
    request: &LobeRequest,
    registry: &Registry,
    (tool, cut, sd): (&ToolModes, &CutGeometry, &SemiDiscretization),
) -> Result<Vec<CheckPoint>, AnalysisError> {
    let [speed_count, depth_count] = request.check;
    if speed_count == 0 || depth_count == 0 {
        return Ok(Vec::new());
    }
    let speeds = spaced(request.speeds[0], request.speeds[1], speed_count);
    let limits: Vec<f64> = speeds
        .iter()
        .map(|&speed| {
            limiting_depth(tool, cut, speed, request.max_depth, sd)
                .map(|b| b.map_or(f64::INFINITY, |b| b.depth))
        })
        .collect::<Result<_, _>>()
        .map_err(argument)?;
    let deepest = limits
        .iter()
        .map(|l| l.min(request.max_depth))
        .fold(0.0, f64::max);
    let points: Vec<(f64, f64, f64)> = speeds
        .iter()
        .zip(&limits)
        .flat_map(|(&speed, &limit)| {
            (1..=depth_count)
                .map(move |k| (speed, 1.6 * deepest * k as f64 / depth_count as f64, limit))
        })
        .collect();
    points
        .par_iter()
        .map(|&(speed, depth, limit)| {
            let spread = time_domain(request, registry, speed, depth)?;
            Ok(CheckPoint {
                speed,
                depth,
                limit,
                spread,
                chatter: chatters(spread),
            })
        })
        .collect()
}

/// A run chatters when its once-per-tooth samples still move at the end: the late RMS step is
/// over 1 µm (a stable cut's settles to nm; the spindle loop's speed ripple leaves ~10 nm) and
/// either is not decaying (over half the early one) or is over 10 µm (a limit cycle, whose steps
/// wander, from the start transient's ~15 µm).
fn chatters([early, late]: [f64; 2]) -> bool {
    late > 1e-6 && (late > 0.5 * early || late > 1e-5)
}

/// One run at constant `speed` (rad/s) and `depth` (m): the RMS once-per-tooth steps over
/// 20–40 % and 80–100 % of the run, m.
fn time_domain(
    request: &LobeRequest,
    registry: &Registry,
    speed: f64,
    depth: f64,
) -> Result<[f64; 2], AnalysisError> {
    let loaded = request
        .scenario
        .clone()
        .controller("spindle-constant")
        .set("controller.params.speed", speed)
        .and_then(|s| s.set("initial.spindle.velocity", speed))
        .and_then(|s| s.set("process.cut.axial_depth", depth))
        .and_then(|s| s.set("metrics", toml::Value::Array(Vec::new())))
        .map(|s| s.duration(request.check_duration))
        .and_then(|b| b.build(registry))
        .map_err(argument)?;
    let pitch = TAU / scenario_inputs(&loaded)?.1.flutes as f64;
    let mut sampler = ToothSampler::new(pitch);
    let twin = Twin::new(loaded).map_err(argument)?;
    twin.run_with(None, &mut [&mut sampler]).map_err(argument)?;
    Ok(sampler.spread(request.check_duration))
}

/// The tool's deflection each time the spindle passes a whole tooth pitch.
struct ToothSampler {
    pitch: f64,
    signals: [usize; 3],
    last: Option<(f64, [f64; 3])>,
    samples: Vec<(f64, [f64; 2])>,
}

impl ToothSampler {
    fn new(pitch: f64) -> Self {
        Self {
            pitch,
            signals: [0; 3],
            last: None,
            samples: Vec::new(),
        }
    }

    /// RMS step between successive samples whose time lies in each window.
    fn spread(&self, duration: f64) -> [f64; 2] {
        [(0.2, 0.4), (0.8, 1.0)].map(|(from, to)| {
            let steps: Vec<f64> = self
                .samples
                .windows(2)
                .filter(|w| w[1].0 >= from * duration && w[1].0 <= to * duration)
                .map(|w| (w[1].1[0] - w[0].1[0]).hypot(w[1].1[1] - w[0].1[1]))
                .collect();
            (steps.iter().map(|s| s * s).sum::<f64>() / steps.len().max(1) as f64).sqrt()
        })
    }
}

impl Observer for ToothSampler {
    fn start(&mut self, layout: &SignalLayout) -> Result<(), ObserverError> {
        for (slot, name) in
            self.signals
                .iter_mut()
                .zip(["spindle.position", "tool_x.position", "tool_y.position"])
        {
            *slot = layout
                .signal(name)
                .ok_or_else(|| format!("no signal {name}"))?;
        }
        Ok(())
    }

    fn observe(&mut self, view: &StepView) -> Result<(), ObserverError> {
        let now = self.signals.map(|i| view.signals[i]);
        if let Some((time, before)) = self.last {
            let crossing = (now[0] / self.pitch).floor();
            if crossing > (before[0] / self.pitch).floor() {
                // Linear between the two steps, at the pitch crossed.
                let w = (crossing * self.pitch - before[0]) / (now[0] - before[0]);
                let at = |k: usize| before[k] + w * (now[k] - before[k]);
                self.samples
                    .push((time + w * (view.time - time), [at(1), at(2)]));
            }
        }
        self.last = Some((view.time, now));
        Ok(())
    }

    fn finish(&mut self) -> Result<Findings, ObserverError> {
        Ok(Findings::default())
    }
}

impl LobeAnalysis {
    /// Judged points and how many agree with the lobes.
    pub fn agreement(&self) -> (usize, usize) {
        let judged: Vec<&CheckPoint> = self.checks.iter().filter(|c| c.judged()).collect();
        let agree = judged
            .iter()
            .filter(|c| c.chatter == c.predicted_chatter())
            .count();
        (agree, judged.len())
    }

    /// The terminal summary: tool, lobes' minimum, operating point and the check's points.
    pub fn summary(&self) -> String {
        let t = &self.tool;
        let mut out = String::new();
        let f = |d: usize| (t.stiffness[d] / t.mass[d]).sqrt() / TAU;
        let zeta = |d: usize| t.damping[d] / (2.0 * (t.stiffness[d] * t.mass[d]).sqrt());
        let _ = writeln!(
            out,
            "tool modes: x {:.1} Hz ζ {:.4}, y {:.1} Hz ζ {:.4}; {} flutes, k_d {:.3e} N/m², μ {}",
            f(0),
            zeta(0),
            f(1),
            zeta(1),
            self.cut.flutes,
            self.cut.cutting_pressure,
            self.cut.force_ratio
        );
        if let Some(lowest) = self
            .lobes
            .iter()
            .filter_map(|p| p.boundary.map(|b| (p.spindle_speed, b)))
            .min_by(|a, b| a.1.depth.total_cmp(&b.1.depth))
        {
            let _ = writeln!(
                out,
                "lowest limiting depth {:.3} mm at {:.0} rpm (chatter {:.0} Hz)",
                lowest.1.depth * 1e3,
                lowest.0 * RPM,
                lowest.1.chatter_frequency_hz
            );
        }
        self.frf_summary(&mut out);
        let [speed, depth] = self.operating_point;
        let _ = writeln!(
            out,
            "scenario's operating point: {:.0} rpm, {:.3} mm",
            speed * RPM,
            depth * 1e3
        );
        if self.checks.is_empty() {
            return out;
        }
        let _ = writeln!(out, "check (time-domain runs vs lobes):\n  speed rpm  depth mm  limit mm  runs     lobes    step early/late nm");
        for c in &self.checks {
            let word = |chatter: bool| if chatter { "chatter" } else { "stable" };
            let _ = writeln!(
                out,
                "  {:>9.0}  {:>8.4}  {:>8.4}  {:<7}  {:<7}  {:>8.1} / {:<8.1}{}",
                c.speed * RPM,
                c.depth * 1e3,
                c.limit * 1e3,
                word(c.chatter),
                word(c.predicted_chatter()),
                c.spread[0] * 1e9,
                c.spread[1] * 1e9,
                if !c.judged() {
                    "  (within 5 % of the boundary: not judged)"
                } else if c.chatter != c.predicted_chatter() {
                    "  DISAGREES"
                } else {
                    ""
                }
            );
        }
        let (agree, judged) = self.agreement();
        let _ = writeln!(
            out,
            "agreement: {agree} of {judged} judged points ({:.1} %)",
            100.0 * agree as f64 / judged.max(1) as f64
        );
        out
    }

    /// With FRFs: the fitted modes and how far their lobes are from the scenario tool's.
    fn frf_summary(&self, out: &mut String) {
        if let Some((fits, _)) = &self.from_frf {
            for (axis, fit) in ["x", "y"].iter().zip(fits) {
                let _ = writeln!(
                    out,
                    "{axis} mode fitted to its FRF ({} lines, {:.1}–{:.1} Hz): mass {:.6} kg, \
                     stiffness {:.6e} N/m, damping {:.4} N·s/m",
                    fit.lines, fit.band[0], fit.band[1], fit.mass, fit.stiffness, fit.damping
                );
            }
            let (worst, speed) = self.frf_deviation().unwrap_or((f64::NAN, f64::NAN));
            let _ = writeln!(
                out,
                "lobes from the FRFs against the scenario's tool: largest difference in limiting \
                 depth {:.2} % (at {speed:.0} rpm)",
                100.0 * worst
            );
        }
    }

    /// With FRFs: the largest relative difference between their lobes' limiting depth and the
    /// scenario tool's over the diagram, and the speed (rpm) where it is; a speed where only one
    /// of the two is stable to the maximum depth counts as infinite.
    pub fn frf_deviation(&self) -> Option<(f64, f64)> {
        let (_, model) = self.from_frf.as_ref()?;
        self.lobes
            .iter()
            .zip(model)
            .map(|(p, m)| {
                let deviation = match (p.boundary, m.boundary) {
                    (Some(a), Some(b)) => (a.depth / b.depth - 1.0).abs(),
                    (None, None) => 0.0,
                    _ => f64::INFINITY,
                };
                (deviation, p.spindle_speed * RPM)
            })
            .max_by(|a, b| a.0.total_cmp(&b.0))
    }

    /// Writes `lobes.csv` and `lobes.rrd` into `dir`, `check.csv` when time-domain runs were
    /// made, and with FRFs `frf-vs-model.csv` (both lobes per speed).
    pub fn write(&self, dir: &Path) -> Result<Vec<PathBuf>, AnalysisError> {
        create_dir(dir)?;
        let mut texts = vec![("lobes.csv", self.lobes_csv())];
        if !self.checks.is_empty() {
            texts.push(("check.csv", self.check_csv()));
        }
        if let Some(text) = self.frf_csv() {
            texts.push(("frf-vs-model.csv", text));
        }
        let mut written = Vec::new();
        for (name, text) in texts {
            let path = dir.join(name);
            write_text(&path, &text)?;
            written.push(path);
        }
        let plot = dir.join("lobes.rrd");
        write_plot(&plot, &self.plot())?;
        written.push(plot);
        Ok(written)
    }

    fn lobes_csv(&self) -> String {
        let mut lobes = String::from("spindle_speed_rpm,limiting_depth_m,chatter_frequency_hz\n");
        for p in &self.lobes {
            let (depth, frequency) = p.boundary.map_or((f64::INFINITY, f64::NAN), |b| {
                (b.depth, b.chatter_frequency_hz)
            });
            let _ = writeln!(lobes, "{},{depth},{frequency}", p.spindle_speed * RPM);
        }
        lobes
    }

    fn check_csv(&self) -> String {
        let mut check = String::from(
            "spindle_speed_rpm,axial_depth_m,limiting_depth_m,run_chatter,lobes_chatter,judged,step_early_m,step_late_m\n",
        );
        for c in &self.checks {
            let _ = writeln!(
                check,
                "{},{},{},{},{},{},{},{}",
                c.speed * RPM,
                c.depth,
                c.limit,
                c.chatter,
                c.predicted_chatter(),
                c.judged(),
                c.spread[0],
                c.spread[1]
            );
        }
        check
    }

    /// With FRFs: their lobes and the scenario tool's per speed.
    fn frf_csv(&self) -> Option<String> {
        let (_, model) = self.from_frf.as_ref()?;
        let depth = |p: &LobePoint| p.boundary.map_or(f64::INFINITY, |b| b.depth);
        let mut text = String::from(
            "spindle_speed_rpm,frf_limiting_depth_m,model_limiting_depth_m,relative_difference\n",
        );
        for (p, m) in self.lobes.iter().zip(model) {
            let (a, b) = (depth(p), depth(m));
            let _ = writeln!(text, "{},{a},{b},{}", p.spindle_speed * RPM, a / b - 1.0);
        }
        Some(text)
    }
}

impl LobeAnalysis {
    /// The diagram: x the spindle speed in rpm, y the axial depth of cut in mm.
    fn plot(&self) -> Plot2D {
        let rpm = |speed: f64| speed * RPM;
        let mm = |depth: f64| depth * 1e3;
        let [x0, x1] = [
            self.lobes.first().map_or(0.0, |p| rpm(p.spindle_speed)),
            self.lobes.last().map_or(1.0, |p| rpm(p.spindle_speed)),
        ];
        let points = |chatter: bool| -> Vec<[f64; 2]> {
            self.checks
                .iter()
                .filter(|c| c.chatter == chatter)
                .map(|c| [rpm(c.speed), mm(c.depth)])
                .collect()
        };
        let [speed, depth] = self.operating_point;
        let mut layers = vec![
            PlotLayer::new(
                "lobes",
                [40, 90, 200],
                2.0,
                PlotGeometry::Lines(lobe_curves(&self.lobes)),
                vec!["stability limit".into()],
            ),
            PlotLayer::new(
                "runs/stable",
                [40, 170, 70],
                5.0,
                PlotGeometry::Points(points(false)),
                Vec::new(),
            ),
            PlotLayer::new(
                "runs/chatter",
                [220, 50, 40],
                5.0,
                PlotGeometry::Points(points(true)),
                Vec::new(),
            ),
            PlotLayer::new(
                "operating_point",
                [240, 170, 20],
                9.0,
                PlotGeometry::Points(vec![[rpm(speed), mm(depth)]]),
                vec![format!(
                    "scenario: {:.0} rpm, {:.3} mm",
                    rpm(speed),
                    mm(depth)
                )],
            ),
        ];
        if let Some((_, model)) = &self.from_frf {
            layers.push(PlotLayer::new(
                "model_lobes",
                [150, 150, 150],
                1.5,
                PlotGeometry::Lines(lobe_curves(model)),
                vec!["scenario's tool".into()],
            ));
        }
        Plot2D {
            title: "twin analyze milling: stability lobes".into(),
            notes: format!(
                "Stability lobes (semi-discretization): limiting axial depth against spindle speed.\n\
                 Above the curve the cut chatters. Dots: the twin's time-domain runs, green stable, red chatter.\n\
                 Star: the scenario's operating point.\n\n{}",
                self.summary()
            ),
            x: PlotAxis {
                title: "spindle speed [rpm]".into(),
                range: [x0, x1],
            },
            y: PlotAxis {
                title: "axial depth of cut [mm]".into(),
                range: [0.0, 1.05 * mm(self.depth_top())],
            },
            aspect: None,
            layers,
        }
    }

    /// The largest depth drawn (a check run, the lobes or the operating point), m.
    fn depth_top(&self) -> f64 {
        self.checks
            .iter()
            .map(|c| c.depth)
            .chain(
                self.lobes
                    .iter()
                    .filter_map(|p| p.boundary.map(|b| b.depth)),
            )
            .chain([self.operating_point[1]])
            .fold(0.0, f64::max)
            .max(1e-6)
    }
}

/// Lobes as polylines of (rpm, mm), broken where a speed is stable to the maximum depth.
fn lobe_curves(lobes: &[LobePoint]) -> Vec<Vec<[f64; 2]>> {
    {
        let mut curves = vec![Vec::new()];
        for p in lobes {
            match p.boundary {
                Some(b) => curves
                    .last_mut()
                    .map_or((), |c| c.push([p.spindle_speed * RPM, b.depth * 1e3])),
                None => curves.push(Vec::new()),
            }
        }
        curves.retain(|c| c.len() > 1);
        curves
    }
}
