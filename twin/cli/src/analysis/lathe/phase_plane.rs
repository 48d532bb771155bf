//! The phase-plane analysis itself: its request, the equilibria, portrait and region of
//! attraction it finds, and the gains it is made for.

use crate::analysis::error::AnalysisError;
use controllers::lathe::output_feedback_design::{
    self, Consistency, DesignSpec, GlobalStabilityCheck, OutputFeedbackDesign,
};
use models::lathe::{
    Equilibrium, EquilibriumKind, ForceBox, Lathe, LatheParams, Nullclines, PhasePortrait,
    PortraitSpec, PowerLoop, ReverseTrajectorySpec, SaturationLine, PAPER_STEP, TOOLS,
};

/// Where the power gains H come from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Gains {
    /// Sudhakara eqs (12)–(14) for the design time constants m_1, m_2 (s), Theorem 1 reported.
    Design { time_constants: [f64; TOOLS] },
    /// H given, m/(rev·W).
    Given([f64; TOOLS]),
}

/// What to analyse.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PhasePlaneRequest {
    pub lathe: LatheParams,
    pub gains: Gains,
    /// The window and grid: initial forces up to these, N.
    pub max_forces: [f64; TOOLS],
    /// Grid points per axis of the portrait.
    pub points_per_axis: usize,
    /// Simulated time per trajectory, s.
    pub duration: f64,
}

impl Default for PhasePlaneRequest {
    /// Table 1 with m = 0.5 / 0.49 s, forces up to 5 kN on a 12 × 12 grid, 20 s each (the
    /// slowest closed-loop pole of the paper's designs is −0.84 1/s).
    fn default() -> Self {
        Self {
            lathe: LatheParams::default(),
            gains: Gains::Design {
                time_constants: [0.5, 0.49],
            },
            max_forces: [5000.0, 5000.0],
            points_per_axis: 12,
            duration: 20.0,
        }
    }
}

/// A trajectory ends "converged" within this distance of the reference forces on each axis, N.
const CONVERGED_WITHIN: f64 = 1.0;
/// The reverse-trajectory branches start this far from the saddle, N.
const BOUNDARY_OFFSET: f64 = 1.0;
/// Keep every this many RK4 steps of each portrait trajectory.
pub(super) const RECORD_EVERY: usize = 5;

/// The analysis' results, plain data.
#[derive(Debug, Clone, PartialEq)]
pub struct PhasePlane {
    pub request: PhasePlaneRequest,
    pub lathe: Lathe,
    /// H, m/(rev·W).
    pub power_gains: [f64; TOOLS],
    /// The design behind H, when it was designed.
    pub design: Option<OutputFeedbackDesign>,
    pub global_stability: GlobalStabilityCheck,
    pub window: ForceBox,
    pub equilibria: Vec<Equilibrium>,
    pub portrait: PhasePortrait,
    /// Per saddle: its stable manifold's two branches joined through it, the boundary of R_a.
    pub boundaries: Vec<Vec<[f64; TOOLS]>>,
    /// Each saturation line of Sudhakara eq (20) with its segment in the window, if it crosses it.
    pub saturation_lines: Vec<(SaturationLine, Option<[[f64; TOOLS]; 2]>)>,
    pub nullclines: Nullclines,
}

/// How far the set of initial forces that fail reaches.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RegionExtent {
    /// Grid starts that do not reach the reference forces, of all.
    pub failing_starts: usize,
    pub starts: usize,
    /// Largest F_1 and F_2 among the failing starts, N (0 when none fail).
    pub failing_max_forces: [f64; TOOLS],
    /// Highest spindle power among the failing starts, W (0 when none fail).
    pub failing_max_power: f64,
    /// The boundary's two ends (where it leaves the window), N.
    pub boundary_ends: Option<[[f64; TOOLS]; 2]>,
    /// Lowest and highest spindle power along the boundary, W.
    pub boundary_power_range: Option<[f64; 2]>,
}

/// Runs the analysis.
pub fn analyze(request: &PhasePlaneRequest) -> Result<PhasePlane, AnalysisError> {
    let lathe = Lathe::new(request.lathe)?;
    let (power_gains, design) = match request.gains {
        Gains::Given(gains) => (gains, None),
        Gains::Design { time_constants } => {
            let design = output_feedback_design::design(
                &lathe,
                &DesignSpec {
                    time_constants,
                    consistency: Consistency::Report,
                },
            )?;
            (design.power_gains, Some(design))
        }
    };
    let power_loop = PowerLoop::new(lathe.clone(), power_gains)?;
    let window = ForceBox {
        min: [0.0, 0.0],
        max: request.max_forces,
    };
    let portrait = power_loop.phase_portrait(&PortraitSpec {
        max_forces: request.max_forces,
        points_per_axis: request.points_per_axis,
        duration: request.duration,
        step: PAPER_STEP,
        record_every: RECORD_EVERY,
        tolerance: CONVERGED_WITHIN,
    })?;
    let equilibria = power_loop.equilibria();
    let mut boundaries = Vec::new();
    for saddle in equilibria
        .iter()
        .filter(|e| e.kind == EquilibriumKind::Saddle)
    {
        let [upper, lower] = power_loop.reverse_trajectories(
            saddle,
            &ReverseTrajectorySpec {
                offset: BOUNDARY_OFFSET,
                duration: request.duration,
                step: PAPER_STEP,
                window,
            },
        )?;
        let mut boundary: Vec<[f64; TOOLS]> = lower.into_iter().rev().collect();
        boundary.push(saddle.forces);
        boundary.extend(upper);
        boundaries.push(boundary);
    }
    let speeds = lathe.cutting_speeds();
    let saturation_lines = power_loop
        .saturation_lines()
        .into_iter()
        .map(|line| (line, line.segment(speeds, &window)))
        .collect();
    let nullclines = power_loop.nullclines(&window, 2000)?;
    Ok(PhasePlane {
        request: *request,
        global_stability: output_feedback_design::global_stability(&lathe, power_gains),
        lathe,
        power_gains,
        design,
        window,
        equilibria,
        portrait,
        boundaries,
        saturation_lines,
        nullclines,
    })
}

impl PhasePlane {
    /// The failing grid starts and the boundary's reach.
    pub fn region(&self) -> RegionExtent {
        let failing = self.portrait.non_converging_initial_forces();
        let failing_max_forces = failing
            .iter()
            .fold([0.0_f64; TOOLS], |m, f| [m[0].max(f[0]), m[1].max(f[1])]);
        let failing_max_power = failing
            .iter()
            .map(|f| self.lathe.spindle_power(*f))
            .fold(0.0, f64::max);
        let boundary: Vec<[f64; TOOLS]> = self.boundaries.iter().flatten().copied().collect();
        let powers = boundary.iter().map(|f| self.lathe.spindle_power(*f));
        let boundary_power_range = (!boundary.is_empty()).then(|| {
            powers.fold([f64::INFINITY, f64::NEG_INFINITY], |r, p| {
                [r[0].min(p), r[1].max(p)]
            })
        });
        let boundary_ends = match (boundary.first(), boundary.last()) {
            (Some(first), Some(last)) => Some([*first, *last]),
            _ => None,
        };
        RegionExtent {
            failing_starts: failing.len(),
            starts: self.portrait.trajectories.len(),
            failing_max_forces,
            failing_max_power,
            boundary_ends,
            boundary_power_range,
        }
    }

    /// The reduced model's rest point from `initial_forces`: where Sudhakara eq (17) ends after `duration`.
    pub fn final_forces(
        &self,
        initial_forces: [f64; TOOLS],
        duration: f64,
    ) -> Result<[f64; TOOLS], AnalysisError> {
        let power_loop = PowerLoop::new(self.lathe.clone(), self.power_gains)?;
        let points = power_loop.trajectory(
            initial_forces,
            models::lathe::TimeDirection::Forward,
            duration,
            PAPER_STEP,
        )?;
        Ok(*points.last().unwrap_or(&initial_forces))
    }
}
