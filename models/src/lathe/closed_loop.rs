//! The parallel lathe under the paper's power feedback, Sudhakara eqs (16)–(23), and its
//! phase-plane analysis: RK4 trajectories forward and in reverse time, equilibria and their
//! linearised stability, nullclines, saturation lines, phase portraits and the region-of-attraction
//! boundary by the reverse-trajectory method. Results are plain data for plotting or recording.
//!
//! The commanded feeds follow Sudhakara eqs (19)–(20): f_ci = sat(f_ni − h_i (P − P_max)) with
//! 0 ≤ f_ci ≤ f_max, and the forces follow Sudhakara eq (3), τ_i Ḟ_i = K̄_i f_ci^α_i − F_i. The
//! paper prints Sudhakara eqs (16)–(17) without the exponent α_i; Sudhakara eqs (8) and (25) keep
//! it, and so does this model.

use super::process::{require_positive, Lathe, LatheError, TOOLS};

/// The paper's RK4 step and controller sample period, s.
pub const PAPER_STEP: f64 = 0.004;

/// Longest integration accepted, in steps, so a bad request cannot exhaust memory.
const MAX_STEPS: f64 = 1e7;

/// Samples of spindle power scanned for equilibria; every equilibrium has 0 ≤ P ≤ P_cap.
const EQUILIBRIUM_SCAN_SAMPLES: usize = 20_000;

/// Relative size (of P_cap, or of f_max) below which a power residual counts as a root and a
/// commanded feed counts as sitting on a limit of Sudhakara eq (20).
const ROUNDING_TOLERANCE: f64 = 1e-12;

/// Which way in time an RK4 step integrates the power loop.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TimeDirection {
    /// Integrates Ḟ = f(F), as the machine runs.
    Forward,
    /// Integrates Ḟ = −f(F): the paper's reverse trajectory (sign of Sudhakara eq (16) changed).
    Reverse,
}

/// An axis-aligned window of the force plane, N.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ForceBox {
    /// Lower corner: the smallest F_1 and F_2, N.
    pub min: [f64; TOOLS],
    /// Upper corner: the largest F_1 and F_2, N.
    pub max: [f64; TOOLS],
}

impl ForceBox {
    /// Whether `forces` (F_1, F_2, N) lie in the window, edges included.
    pub fn contains(&self, forces: [f64; TOOLS]) -> bool {
        (0..TOOLS).all(|i| forces[i] >= self.min[i] && forces[i] <= self.max[i])
    }

    fn validate(&self) -> Result<(), LatheError> {
        for i in 0..TOOLS {
            require_positive(
                format!("force box width for tool {}", i + 1),
                self.max[i] - self.min[i],
            )?;
        }
        Ok(())
    }
}

/// One eigenvalue of a real 2×2 matrix, 1/s.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Eigenvalue {
    /// Real part, 1/s: negative decays, positive grows.
    pub re: f64,
    /// Imaginary part, 1/s; non-zero for a conjugate pair, whose trajectories turn.
    pub im: f64,
}

/// Eigenvalues of a real 2×2 matrix in closed form, the one with the smaller real part (or the
/// negative imaginary part of a conjugate pair) first.
pub fn eigenvalues(matrix: [[f64; 2]; 2]) -> [Eigenvalue; 2] {
    let half_trace = 0.5 * (matrix[0][0] + matrix[1][1]);
    let determinant = matrix[0][0] * matrix[1][1] - matrix[0][1] * matrix[1][0];
    let discriminant = half_trace * half_trace - determinant;
    if discriminant >= 0.0 {
        let root = discriminant.sqrt();
        [half_trace - root, half_trace + root].map(|re| Eigenvalue { re, im: 0.0 })
    } else {
        let root = (-discriminant).sqrt();
        [-root, root].map(|im| Eigenvalue { re: half_trace, im })
    }
}

/// Which branch of Sudhakara eq (20) a tool's commanded feed is on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FeedRegime {
    /// The law asks for a feed ≤ 0: the tool dwells at zero feed and stops cutting.
    ZeroFeed,
    /// The linear law of Sudhakara eq (19) is active.
    Regulating,
    /// Clipped at f_max.
    MaxFeed,
}

/// Linearised character of an equilibrium (Theorem 2, Lemma 2.1).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EquilibriumKind {
    /// Two negative real eigenvalues: nearby trajectories approach without turning.
    StableNode,
    /// A conjugate pair with negative real part: nearby trajectories spiral in.
    StableFocus,
    /// Real eigenvalues of opposite signs: its stable manifold can bound a region of attraction.
    Saddle,
    /// Two positive real eigenvalues: nearby trajectories leave without turning.
    UnstableNode,
    /// A conjugate pair with positive real part: nearby trajectories spiral out.
    UnstableFocus,
    /// An eigenvalue on the imaginary axis: the linearisation decides nothing.
    NonHyperbolic,
    /// A commanded feed sits exactly on a limit of Sudhakara eq (20), where the vector field has a
    /// kink (and, with α < 1, an unbounded slope on the zero-feed side): no linearisation applies.
    NonSmooth,
}

/// A rest point of Sudhakara eq (17): an intersection of the zero sets of (17a) and (17b).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Equilibrium {
    /// F_1, F_2, N.
    pub forces: [f64; TOOLS],
    /// Sudhakara eq (4) there, W.
    pub spindle_power: f64,
    /// Sudhakara eq (20) there, m/rev.
    pub commanded_feeds: [f64; TOOLS],
    /// Which branch of the feed saturation each tool's commanded feed is on.
    pub feed_regimes: [FeedRegime; TOOLS],
    /// ∂Ḟ/∂F, analytic (see [`PowerLoop::jacobian`]), 1/s.
    pub jacobian: [[f64; 2]; 2],
    /// Eigenvalues of the Jacobian, ordered as [`eigenvalues`] returns them, 1/s.
    pub eigenvalues: [Eigenvalue; 2],
    /// The verdict of the linearisation, or [`EquilibriumKind::NonSmooth`] on a feed limit.
    pub kind: EquilibriumKind,
}

impl Equilibrium {
    /// Locally asymptotically stable by Theorem 2 (a stable node or focus).
    pub fn is_asymptotically_stable(&self) -> bool {
        matches!(
            self.kind,
            EquilibriumKind::StableNode | EquilibriumKind::StableFocus
        )
    }

    /// Unit eigenvector of a saddle's negative eigenvalue: the tangent of its stable manifold,
    /// which the reverse-trajectory method follows to trace the boundary of R_a.
    pub fn stable_direction(&self) -> Option<[f64; TOOLS]> {
        if self.kind != EquilibriumKind::Saddle {
            return None;
        }
        let lambda = self.eigenvalues[0].re;
        let j = self.jacobian;
        let from_first_row = [j[0][1], lambda - j[0][0]];
        let from_second_row = [lambda - j[1][1], j[1][0]];
        let norm = |v: [f64; 2]| v[0].hypot(v[1]);
        let v = if norm(from_first_row) >= norm(from_second_row) {
            from_first_row
        } else {
            from_second_row
        };
        let length = norm(v);
        (length > 0.0).then(|| [v[0] / length, v[1] / length])
    }
}

/// Which end of Sudhakara eq (20) a saturation line marks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FeedLimit {
    /// Sudhakara eq (21): the law yields zero feed.
    Zero,
    /// The law yields f_max.
    Max,
}

/// A saturation boundary: the line V_1 F_1 + V_2 F_2 = `spindle_power` on which tool `tool`'s
/// commanded feed reaches `limit`. Its slope is −V_1/V_2 for every tool and gain,
/// Sudhakara eq (22).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SaturationLine {
    /// 1 or 2, as numbered in the paper.
    pub tool: usize,
    /// Whether the commanded feed reaches zero or f_max on this line.
    pub limit: FeedLimit,
    /// W.
    pub spindle_power: f64,
}

impl SaturationLine {
    /// The part of the line inside `window`, as its two end points (None when it misses).
    pub fn segment(
        &self,
        cutting_speeds: [f64; TOOLS],
        window: &ForceBox,
    ) -> Option<[[f64; TOOLS]; 2]> {
        let [v1, v2] = cutting_speeds;
        let p = self.spindle_power;
        let candidates = [
            [window.min[0], (p - v1 * window.min[0]) / v2],
            [window.max[0], (p - v1 * window.max[0]) / v2],
            [(p - v2 * window.min[1]) / v1, window.min[1]],
            [(p - v2 * window.max[1]) / v1, window.max[1]],
        ];
        let inside: Vec<[f64; TOOLS]> = candidates
            .into_iter()
            .filter(|point| point.iter().all(|x| x.is_finite()) && window.contains(*point))
            .collect();
        let first = *inside.first()?;
        let distance = |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).hypot(a[1] - b[1]);
        let last = inside
            .iter()
            .copied()
            .max_by(|a, b| distance(first, *a).total_cmp(&distance(first, *b)))?;
        Some([first, last])
    }
}

/// Zero sets of Sudhakara eqs (17a) and (17b) inside a window, each as polylines (a curve leaving
/// and re-entering the window gives several).
#[derive(Debug, Clone, PartialEq)]
pub struct Nullclines {
    /// Ḟ_1 = 0.
    pub tool1_at_rest: Vec<Vec<[f64; TOOLS]>>,
    /// Ḟ_2 = 0.
    pub tool2_at_rest: Vec<Vec<[f64; TOOLS]>>,
}

/// A grid of initial forces simulated forward (the phase plots, Figs 4–5).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PortraitSpec {
    /// Initial forces are max · k / n for k = 1..=n on each axis (positive forces only: the
    /// machine's operating space), N.
    pub max_forces: [f64; TOOLS],
    /// n.
    pub points_per_axis: usize,
    /// Simulated time per trajectory, s.
    pub duration: f64,
    /// RK4 step, s.
    pub step: f64,
    /// Keep every k-th state of each trajectory (the last one is always kept).
    pub record_every: usize,
    /// A trajectory converged if it ends within this distance of the reference forces on each
    /// axis, N.
    pub tolerance: f64,
}

/// One simulated run of the power loop from a grid point of a [`PortraitSpec`].
#[derive(Debug, Clone, PartialEq)]
pub struct Trajectory {
    /// F_1, F_2 at the start, N.
    pub initial_forces: [f64; TOOLS],
    /// States spaced `record_every · step` apart in time, starting with the initial forces.
    pub points: Vec<[f64; TOOLS]>,
    /// F_1, F_2 at the end of the simulated time, N.
    pub final_forces: [f64; TOOLS],
    /// Ended at the desired equilibrium (the reference forces of Sudhakara eq (5)).
    pub converged: bool,
}

/// The forward runs from every grid point of a [`PortraitSpec`].
#[derive(Debug, Clone, PartialEq)]
pub struct PhasePortrait {
    /// One per grid point, tool 1's initial force varying slowest.
    pub trajectories: Vec<Trajectory>,
}

impl PhasePortrait {
    /// The initial forces whose trajectories do not reach the reference forces: the complement
    /// of R_a within the grid.
    pub fn non_converging_initial_forces(&self) -> Vec<[f64; TOOLS]> {
        self.trajectories
            .iter()
            .filter(|t| !t.converged)
            .map(|t| t.initial_forces)
            .collect()
    }
}

/// How to trace the stable manifold of a saddle backwards in time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReverseTrajectorySpec {
    /// Distance from the saddle along its stable direction where each branch starts, N.
    pub offset: f64,
    /// Longest reverse time per branch, s.
    pub duration: f64,
    /// RK4 step, s.
    pub step: f64,
    /// A branch stops when it leaves this window.
    pub window: ForceBox,
}

/// The lathe under the output-feedback law of Sudhakara eq (9) with feed saturation,
/// Sudhakara eq (20).
#[derive(Debug, Clone, PartialEq)]
pub struct PowerLoop {
    lathe: Lathe,
    power_gains: [f64; TOOLS],
}

impl PowerLoop {
    /// `power_gains` is H = (h_1, h_2) of Sudhakara eq (9): commanded-feed change per watt of
    /// spindle-power error, m/(rev·W) (the paper's mm/kW is 10⁻⁶ of this).
    pub fn new(lathe: Lathe, power_gains: [f64; TOOLS]) -> Result<Self, LatheError> {
        for (i, gain) in power_gains.iter().enumerate() {
            if !gain.is_finite() {
                return Err(LatheError::NotFinite {
                    name: format!("power gain h_{}", i + 1),
                    value: *gain,
                });
            }
        }
        Ok(Self { lathe, power_gains })
    }

    /// The lathe the loop is closed around.
    pub fn lathe(&self) -> &Lathe {
        &self.lathe
    }

    /// H, m/(rev·W).
    pub fn power_gains(&self) -> [f64; TOOLS] {
        self.power_gains
    }

    /// Sudhakara eq (19) before saturation: f_ni − h_i (P − P_max), m/rev.
    pub fn unsaturated_feeds(&self, forces: [f64; TOOLS]) -> [f64; TOOLS] {
        self.feeds_at_power(self.lathe.spindle_power(forces))
    }

    /// Sudhakara eq (20): the commanded feeds the servos receive, m/rev.
    pub fn commanded_feeds(&self, forces: [f64; TOOLS]) -> [f64; TOOLS] {
        self.saturate(self.unsaturated_feeds(forces))
    }

    /// Sudhakara eq (17) with Sudhakara eq (20): Ḟ_i = (K̄_i f_ci^α_i − F_i) / τ_i, N/s.
    pub fn force_rates(&self, forces: [f64; TOOLS]) -> [f64; TOOLS] {
        self.lathe.force_rates(forces, self.commanded_feeds(forces))
    }

    /// ∂Ḟ_i/∂F_j in closed form: (−δ_ij − α_i K̄_i f_ci^(α_i−1) h_i V_j) / τ_i while tool i
    /// regulates, −δ_ij / τ_i while its feed is clipped. Exactly on a clipping boundary the
    /// clipped side is used (with α < 1 the other side's slope is unbounded at zero feed).
    pub fn jacobian(&self, forces: [f64; TOOLS]) -> [[f64; 2]; 2] {
        let feeds = self.unsaturated_feeds(forces);
        let speeds = self.lathe.cutting_speeds();
        let gains = self.lathe.static_gains();
        let taus = self.lathe.feed_time_constants();
        let max_feed = self.lathe.params().max_feed;
        let mut jacobian = [[0.0; 2]; 2];
        for i in 0..TOOLS {
            let alpha = self.lathe.params().tools[i].feed_exponent;
            let feed_slope = if feeds[i] > 0.0 && feeds[i] < max_feed {
                alpha * gains[i] * feeds[i].powf(alpha - 1.0)
            } else {
                0.0
            };
            for j in 0..TOOLS {
                let own = if i == j { -1.0 } else { 0.0 };
                jacobian[i][j] = (own - feed_slope * self.power_gains[i] * speeds[j]) / taus[i];
            }
        }
        jacobian
    }

    /// One classical RK4 step of Sudhakara eq (17), forward or in reverse time, N.
    pub fn rk4_step(
        &self,
        forces: [f64; TOOLS],
        step: f64,
        direction: TimeDirection,
    ) -> [f64; TOOLS] {
        let h = match direction {
            TimeDirection::Forward => step,
            TimeDirection::Reverse => -step,
        };
        let along = |x: [f64; 2], k: [f64; 2], s: f64| [x[0] + s * k[0], x[1] + s * k[1]];
        let k1 = self.force_rates(forces);
        let k2 = self.force_rates(along(forces, k1, 0.5 * h));
        let k3 = self.force_rates(along(forces, k2, 0.5 * h));
        let k4 = self.force_rates(along(forces, k3, h));
        [0, 1].map(|i| forces[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]))
    }

    /// The forces every `step` seconds over `duration` (the initial forces first), by RK4.
    pub fn trajectory(
        &self,
        initial_forces: [f64; TOOLS],
        direction: TimeDirection,
        duration: f64,
        step: f64,
    ) -> Result<Vec<[f64; TOOLS]>, LatheError> {
        let steps = step_count(duration, step)?;
        let mut points = Vec::with_capacity(steps + 1);
        let mut forces = initial_forces;
        points.push(forces);
        for _ in 0..steps {
            forces = self.rk4_step(forces, step, direction);
            points.push(forces);
        }
        Ok(points)
    }

    /// The rest point the loop is designed for: the reference forces of Sudhakara eq (5) (the
    /// origin of the perturbed system, Sudhakara eq (16)).
    pub fn desired_equilibrium(&self) -> Equilibrium {
        self.equilibrium_at(self.lathe.reference_forces())
    }

    /// Describes the rest point at `forces` (the caller vouches that it is one, e.g. the origin
    /// under the Lyapunov gains of Sudhakara eq (26)): feeds, Jacobian, eigenvalues and their
    /// verdict.
    pub fn equilibrium_at(&self, forces: [f64; TOOLS]) -> Equilibrium {
        let spindle_power = self.lathe.spindle_power(forces);
        let unsaturated = self.feeds_at_power(spindle_power);
        let max_feed = self.lathe.params().max_feed;
        let on_limit = unsaturated.iter().any(|feed| {
            feed.abs() <= ROUNDING_TOLERANCE * max_feed
                || (feed - max_feed).abs() <= ROUNDING_TOLERANCE * max_feed
        });
        let feed_regimes = unsaturated.map(|feed| {
            if feed <= 0.0 {
                FeedRegime::ZeroFeed
            } else if feed >= max_feed {
                FeedRegime::MaxFeed
            } else {
                FeedRegime::Regulating
            }
        });
        let jacobian = self.jacobian(forces);
        let eigenvalues = eigenvalues(jacobian);
        Equilibrium {
            forces,
            spindle_power,
            commanded_feeds: self.saturate(unsaturated),
            feed_regimes,
            jacobian,
            eigenvalues,
            kind: if on_limit {
                EquilibriumKind::NonSmooth
            } else {
                classify(eigenvalues)
            },
        }
    }

    /// Every rest point of Sudhakara eq (17), including those where a feed is clipped.
    ///
    /// At rest F_i = K̄_i sat(f_ci(P))^α_i, and f_ci depends on the forces only through the
    /// spindle power P. So the intersections of the zero sets of (17a) and (17b) are the roots of
    /// the scalar function P ↦ Σ V_i F_i(P) − P, all within 0 ≤ P ≤ Σ V_i K̄_i f_max^α_i. They are
    /// bracketed on a fine scan and bisected; a root where the curve only touches zero without
    /// crossing can be missed.
    pub fn equilibria(&self) -> Vec<Equilibrium> {
        let max_feed = self.lathe.params().max_feed;
        let ceiling = self
            .lathe
            .spindle_power(self.lathe.cutting_forces([max_feed; TOOLS]));
        let residual = |power: f64| self.lathe.spindle_power(self.forces_at_power(power)) - power;
        let is_root = |value: f64| value.abs() <= ROUNDING_TOLERANCE * ceiling;
        let mut powers = Vec::new();
        let mut previous = (0.0, residual(0.0));
        if is_root(previous.1) {
            powers.push(0.0);
        }
        for k in 1..=EQUILIBRIUM_SCAN_SAMPLES {
            let power = ceiling * k as f64 / EQUILIBRIUM_SCAN_SAMPLES as f64;
            let value = residual(power);
            if is_root(value) {
                powers.push(power);
            } else if !is_root(previous.1) && (value > 0.0) != (previous.1 > 0.0) {
                powers.push(bisect(&residual, previous.0, power));
            }
            previous = (power, value);
        }
        powers
            .into_iter()
            .map(|power| self.equilibrium_at(self.forces_at_power(power)))
            .collect()
    }

    /// Zero sets of (17a) and (17b) within `window`, `samples` points each. Each is a curve
    /// parametrised by the spindle power P: Ḟ_1 = 0 is F_1 = K̄_1 sat(f_c1(P))^α_1 with
    /// F_2 = (P − V_1 F_1)/V_2, and likewise for tool 2.
    pub fn nullclines(&self, window: &ForceBox, samples: usize) -> Result<Nullclines, LatheError> {
        window.validate()?;
        require_positive("nullcline samples", samples as f64)?;
        let [v1, v2] = self.lathe.cutting_speeds();
        let lowest = self.lathe.spindle_power(window.min);
        let highest = self.lathe.spindle_power(window.max);
        let powers = (0..=samples).map(|k| lowest + (highest - lowest) * k as f64 / samples as f64);
        let tool1 = powers.clone().map(|p| {
            let f1 = self.forces_at_power(p)[0];
            [f1, (p - v1 * f1) / v2]
        });
        let tool2 = powers.map(|p| {
            let f2 = self.forces_at_power(p)[1];
            [(p - v2 * f2) / v1, f2]
        });
        Ok(Nullclines {
            tool1_at_rest: segments_within(tool1, window),
            tool2_at_rest: segments_within(tool2, window),
        })
    }

    /// The lines where each tool's commanded feed reaches zero (Sudhakara eq (21)) or f_max, for
    /// tools with a non-zero gain. A zero-feed line at P = P_max + f_ni/h_i lies in the positive
    /// quadrant exactly when h_i < −f_ni/P_max: the situation Sudhakara eq (23) rules out.
    pub fn saturation_lines(&self) -> Vec<SaturationLine> {
        let nominal = self.lathe.nominal_feeds();
        let max_power = self.lathe.params().max_spindle_power;
        let max_feed = self.lathe.params().max_feed;
        let mut lines = Vec::new();
        for (i, (&h, &nominal_feed)) in self.power_gains.iter().zip(&nominal).enumerate() {
            if h == 0.0 {
                continue;
            }
            for (limit, feed) in [(FeedLimit::Zero, 0.0), (FeedLimit::Max, max_feed)] {
                lines.push(SaturationLine {
                    tool: i + 1,
                    limit,
                    spindle_power: max_power + (nominal_feed - feed) / h,
                });
            }
        }
        lines
    }

    /// Simulates every grid point of `spec` forward (the phase plots, Figs 4–5).
    pub fn phase_portrait(&self, spec: &PortraitSpec) -> Result<PhasePortrait, LatheError> {
        require_positive("portrait points per axis", spec.points_per_axis as f64)?;
        require_positive("portrait record interval", spec.record_every as f64)?;
        require_positive("portrait tolerance", spec.tolerance)?;
        for i in 0..TOOLS {
            require_positive(
                format!("portrait max force of tool {}", i + 1),
                spec.max_forces[i],
            )?;
        }
        let steps = step_count(spec.duration, spec.step)?;
        let n = spec.points_per_axis;
        // The whole portrait is bounded, not only one trajectory (n² can wrap or exhaust memory).
        let total = (n as f64).powi(2) * steps as f64;
        if total > MAX_STEPS {
            return Err(LatheError::TooManySteps {
                steps: total,
                limit: MAX_STEPS,
            });
        }
        let reference = self.lathe.reference_forces();
        let mut trajectories = Vec::with_capacity(n * n);
        for a in 1..=n {
            for b in 1..=n {
                let initial_forces = [
                    spec.max_forces[0] * a as f64 / n as f64,
                    spec.max_forces[1] * b as f64 / n as f64,
                ];
                let mut forces = initial_forces;
                let mut points = vec![forces];
                for k in 1..=steps {
                    forces = self.rk4_step(forces, spec.step, TimeDirection::Forward);
                    if k % spec.record_every == 0 || k == steps {
                        points.push(forces);
                    }
                }
                let converged =
                    (0..TOOLS).all(|i| (forces[i] - reference[i]).abs() <= spec.tolerance);
                trajectories.push(Trajectory {
                    initial_forces,
                    points,
                    final_forces: forces,
                    converged,
                });
            }
        }
        Ok(PhasePortrait { trajectories })
    }

    /// The reverse-trajectory method (Lemma 3.1, ref. \[11]): the two branches of a saddle's
    /// stable manifold, traced backwards in time from either side of it. Together with the
    /// saddle they bound the region of attraction R_a of the desired equilibrium.
    pub fn reverse_trajectories(
        &self,
        saddle: &Equilibrium,
        spec: &ReverseTrajectorySpec,
    ) -> Result<[Vec<[f64; TOOLS]>; 2], LatheError> {
        require_positive("reverse-trajectory offset", spec.offset)?;
        spec.window.validate()?;
        let steps = step_count(spec.duration, spec.step)?;
        let direction = saddle.stable_direction().ok_or(LatheError::NotASaddle {
            forces: saddle.forces,
        })?;
        Ok([1.0, -1.0].map(|side| {
            let mut forces = [0, 1].map(|i| saddle.forces[i] + side * spec.offset * direction[i]);
            let mut branch = vec![forces];
            for _ in 0..steps {
                forces = self.rk4_step(forces, spec.step, TimeDirection::Reverse);
                if !spec.window.contains(forces) {
                    break;
                }
                branch.push(forces);
            }
            branch
        }))
    }

    fn feeds_at_power(&self, spindle_power: f64) -> [f64; TOOLS] {
        let error = spindle_power - self.lathe.params().max_spindle_power;
        let nominal = self.lathe.nominal_feeds();
        [0, 1].map(|i| nominal[i] - self.power_gains[i] * error)
    }

    fn saturate(&self, feeds: [f64; TOOLS]) -> [f64; TOOLS] {
        let max_feed = self.lathe.params().max_feed;
        feeds.map(|feed| feed.clamp(0.0, max_feed))
    }

    /// The forces each tool settles to while the spindle power is held at `spindle_power`.
    fn forces_at_power(&self, spindle_power: f64) -> [f64; TOOLS] {
        self.lathe
            .cutting_forces(self.saturate(self.feeds_at_power(spindle_power)))
    }
}

fn classify(eigenvalues: [Eigenvalue; 2]) -> EquilibriumKind {
    let [a, b] = eigenvalues;
    if a.re == 0.0 || b.re == 0.0 {
        EquilibriumKind::NonHyperbolic
    } else if a.im != 0.0 {
        if a.re < 0.0 {
            EquilibriumKind::StableFocus
        } else {
            EquilibriumKind::UnstableFocus
        }
    } else if a.re < 0.0 && b.re < 0.0 {
        EquilibriumKind::StableNode
    } else if a.re > 0.0 && b.re > 0.0 {
        EquilibriumKind::UnstableNode
    } else {
        EquilibriumKind::Saddle
    }
}

fn step_count(duration: f64, step: f64) -> Result<usize, LatheError> {
    require_positive("integration step", step)?;
    require_positive("integration duration", duration)?;
    let steps = (duration / step).round();
    if steps > MAX_STEPS {
        return Err(LatheError::TooManySteps {
            steps,
            limit: MAX_STEPS,
        });
    }
    Ok((steps as usize).max(1))
}

/// A root of `f` between `low` and `high`, where `f` changes sign.
fn bisect(f: &impl Fn(f64) -> f64, mut low: f64, mut high: f64) -> f64 {
    let low_positive = f(low) > 0.0;
    for _ in 0..200 {
        let mid = 0.5 * (low + high);
        if mid <= low || mid >= high {
            break;
        }
        let value = f(mid);
        if value == 0.0 {
            return mid;
        }
        if (value > 0.0) == low_positive {
            low = mid;
        } else {
            high = mid;
        }
    }
    0.5 * (low + high)
}

/// Splits a sampled curve into the runs of consecutive points inside `window`.
fn segments_within(
    points: impl Iterator<Item = [f64; TOOLS]>,
    window: &ForceBox,
) -> Vec<Vec<[f64; TOOLS]>> {
    let mut segments: Vec<Vec<[f64; TOOLS]>> = Vec::new();
    let mut current = Vec::new();
    for point in points {
        if window.contains(point) {
            current.push(point);
        } else if !current.is_empty() {
            segments.push(std::mem::take(&mut current));
        }
    }
    if !current.is_empty() {
        segments.push(current);
    }
    segments
}

#[cfg(test)]
mod tests {
    use super::super::LatheParams;
    use super::*;

    fn table1() -> Lathe {
        Lathe::new(LatheParams::default()).unwrap()
    }

    /// α = 1 makes Sudhakara eq (17) linear while no feed clips: Ḟ = M (F − F_r) with
    /// M = A − B H C, whose exponential has Sylvester's closed form for distinct eigenvalues.
    #[test]
    fn rk4_matches_the_closed_form_of_the_unsaturated_linear_loop() {
        let mut params = LatheParams::default();
        for tool in &mut params.tools {
            tool.feed_exponent = 1.0;
            tool.cutting_coefficient = super::super::cutting_coefficient_from_paper_units(
                1.17,
                tool.feed_exponent,
                tool.depth_exponent,
                tool.speed_exponent,
            );
        }
        let lathe = Lathe::new(params).unwrap();
        let gains = [-1.3e-8, -5.5e-8];
        let power_loop = PowerLoop::new(lathe.clone(), gains).unwrap();
        let reference = lathe.reference_forces();
        let start = [reference[0] * 0.9, reference[1] * 1.1];
        let m = power_loop.jacobian(start);
        let [l1, l2] = eigenvalues(m).map(|e| {
            assert_eq!(e.im, 0.0);
            e.re
        });
        let exact = |t: f64| {
            let (e1, e2) = ((l1 * t).exp(), (l2 * t).exp());
            let identity_part = (l1 * e2 - l2 * e1) / (l1 - l2);
            let matrix_part = (e1 - e2) / (l1 - l2);
            let d = [start[0] - reference[0], start[1] - reference[1]];
            [0, 1].map(|i| {
                reference[i]
                    + identity_part * d[i]
                    + matrix_part * (m[i][0] * d[0] + m[i][1] * d[1])
            })
        };
        let worst_error = |step: f64| {
            let points = power_loop
                .trajectory(start, TimeDirection::Forward, 1.0, step)
                .unwrap();
            points
                .iter()
                .enumerate()
                .map(|(k, p)| {
                    let e = exact(k as f64 * step);
                    (p[0] - e[0]).abs().max((p[1] - e[1]).abs())
                })
                .fold(0.0, f64::max)
        };
        let coarse = worst_error(PAPER_STEP);
        let fine = worst_error(0.5 * PAPER_STEP);
        assert!(coarse < 1e-4, "RK4 error {coarse} N at h = 4 ms");
        // Fourth order: halving the step divides the error by ~16.
        let ratio = coarse / fine;
        assert!((12.0..20.0).contains(&ratio), "error ratio {ratio}");
        // No clipping happened along the way, so the closed form applied throughout.
        for p in power_loop
            .trajectory(start, TimeDirection::Forward, 1.0, PAPER_STEP)
            .unwrap()
        {
            assert!(power_loop
                .unsaturated_feeds(p)
                .iter()
                .all(|f| *f > 0.0 && *f < 1.5e-3));
        }
    }

    #[test]
    fn reverse_integration_retraces_the_forward_trajectory() {
        let power_loop = PowerLoop::new(table1(), [-1.3e-8, -5.5e-8]).unwrap();
        let forward = power_loop
            .trajectory([1500.0, 900.0], TimeDirection::Forward, 0.2, PAPER_STEP)
            .unwrap();
        let end = *forward.last().unwrap();
        let back = power_loop
            .trajectory(end, TimeDirection::Reverse, 0.2, PAPER_STEP)
            .unwrap();
        let home = back.last().unwrap();
        assert!(
            (home[0] - 1500.0).abs() < 1e-2 && (home[1] - 900.0).abs() < 1e-2,
            "{home:?}"
        );
    }

    #[test]
    fn open_loop_has_only_the_reference_equilibrium() {
        let lathe = table1();
        let power_loop = PowerLoop::new(lathe.clone(), [0.0, 0.0]).unwrap();
        let equilibria = power_loop.equilibria();
        assert_eq!(equilibria.len(), 1, "{equilibria:?}");
        let only = equilibria[0];
        let reference = lathe.reference_forces();
        assert!((only.forces[0] - reference[0]).abs() < 1e-6);
        assert!((only.forces[1] - reference[1]).abs() < 1e-6);
        // Without feedback the Jacobian is diag(−1/τ_i), Sudhakara eq (7a).
        assert_eq!(only.kind, EquilibriumKind::StableNode);
        assert!((only.eigenvalues[0].re + 1.0 / 0.049).abs() < 1e-9);
        assert!((only.eigenvalues[1].re + 1.0 / 0.05).abs() < 1e-9);
        assert!(power_loop.saturation_lines().is_empty());
    }

    #[test]
    fn jacobian_matches_finite_differences_where_the_feeds_regulate() {
        let power_loop = PowerLoop::new(table1(), [1.3e-8, -7.3e-8]).unwrap();
        let at = [2200.0, 1500.0];
        let analytic = power_loop.jacobian(at);
        let h = 1e-3;
        for j in 0..TOOLS {
            let (mut up, mut down) = (at, at);
            up[j] += h;
            down[j] -= h;
            let (ru, rd) = (power_loop.force_rates(up), power_loop.force_rates(down));
            for i in 0..TOOLS {
                let numeric = (ru[i] - rd[i]) / (2.0 * h);
                assert!(
                    (analytic[i][j] - numeric).abs() < 1e-6 * analytic[i][j].abs().max(1.0),
                    "J[{i}][{j}] {} vs {numeric}",
                    analytic[i][j]
                );
            }
        }
    }

    #[test]
    fn lyapunov_gains_make_the_origin_a_non_smooth_rest_point() {
        let lathe = table1();
        let max_power = lathe.params().max_spindle_power;
        let reference = lathe.reference_forces();
        let gains = lathe.nominal_feeds().map(|feed| -feed / max_power);
        let power_loop = PowerLoop::new(lathe, gains).unwrap();
        // Sudhakara eq (26): f_ci = f_ni P / P_max, so zero force commands zero feed.
        let origin = power_loop.equilibrium_at([0.0, 0.0]);
        assert_eq!(origin.kind, EquilibriumKind::NonSmooth);
        assert!(!origin.is_asymptotically_stable());
        let equilibria = power_loop.equilibria();
        assert_eq!(equilibria.len(), 2, "{equilibria:?}");
        assert!(equilibria[0].spindle_power.abs() < 1e-6);
        assert_eq!(equilibria[0].kind, EquilibriumKind::NonSmooth);
        assert!(equilibria[1].is_asymptotically_stable());
        // With α < 1, K̄ f_c^α outgrows F near zero: a 1 N start still reaches the references.
        let end = *power_loop
            .trajectory([1.0, 1.0], TimeDirection::Forward, 20.0, PAPER_STEP)
            .unwrap()
            .last()
            .unwrap();
        assert!((end[0] - reference[0]).abs() < 1.0 && (end[1] - reference[1]).abs() < 1.0);
    }

    /// H of the m = 1.5 / 1.49 s design (Sudhakara eq (14)); three rest points, each on both zero
    /// sets.
    #[test]
    fn equilibria_lie_on_both_nullclines() {
        let power_loop = PowerLoop::new(table1(), [-1.305_207_6e-8, -7.265_477_4e-8]).unwrap();
        let window = ForceBox {
            min: [0.0, 0.0],
            max: [5000.0, 5000.0],
        };
        let nullclines = power_loop.nullclines(&window, 2000).unwrap();
        for (tool, curves) in [&nullclines.tool1_at_rest, &nullclines.tool2_at_rest]
            .into_iter()
            .enumerate()
        {
            assert!(!curves.is_empty());
            for point in curves.iter().flatten() {
                assert!(window.contains(*point));
                assert!(
                    power_loop.force_rates(*point)[tool].abs() < 1e-6,
                    "{point:?}"
                );
            }
        }
        let equilibria = power_loop.equilibria();
        assert_eq!(equilibria.len(), 3, "{equilibria:?}");
        for equilibrium in &equilibria {
            let rates = power_loop.force_rates(equilibrium.forces);
            assert!(rates[0].abs() < 1e-6 && rates[1].abs() < 1e-6, "{rates:?}");
        }
        assert!(matches!(
            power_loop.nullclines(&window, 0),
            Err(LatheError::NonPositive { .. })
        ));
    }

    #[test]
    fn eigenvalues_of_a_rotation_are_a_conjugate_pair() {
        let [a, b] = eigenvalues([[-1.0, -2.0], [2.0, -1.0]]);
        assert_eq!((a.re, a.im, b.re, b.im), (-1.0, -2.0, -1.0, 2.0));
        assert_eq!(classify([a, b]), EquilibriumKind::StableFocus);
    }

    #[test]
    fn saturation_lines_follow_eq_21_and_slope_eq_22() {
        let lathe = table1();
        let gains = [-1.3e-8, -7.3e-8];
        let power_loop = PowerLoop::new(lathe.clone(), gains).unwrap();
        let window = ForceBox {
            min: [0.0, 0.0],
            max: [5000.0, 5000.0],
        };
        let zero2 = power_loop
            .saturation_lines()
            .into_iter()
            .find(|l| l.tool == 2 && l.limit == FeedLimit::Zero)
            .unwrap();
        let [a, b] = zero2.segment(lathe.cutting_speeds(), &window).unwrap();
        for end in [a, b] {
            assert!(power_loop.unsaturated_feeds(end)[1].abs() < 1e-12);
        }
        let [v1, v2] = lathe.cutting_speeds();
        assert!(((b[1] - a[1]) / (b[0] - a[0]) + v1 / v2).abs() < 1e-9);
    }

    #[test]
    fn bad_analysis_requests_are_errors_not_panics() {
        let power_loop = PowerLoop::new(table1(), [0.0, 0.0]).unwrap();
        assert!(matches!(
            power_loop.trajectory([1.0, 1.0], TimeDirection::Forward, 1.0, 0.0),
            Err(LatheError::NonPositive { .. })
        ));
        assert!(matches!(
            power_loop.trajectory([1.0, 1.0], TimeDirection::Forward, 1e9, 1e-9),
            Err(LatheError::TooManySteps { .. })
        ));
        assert!(matches!(
            PowerLoop::new(table1(), [f64::NAN, 0.0]),
            Err(LatheError::NotFinite { .. })
        ));
        let stable = power_loop.desired_equilibrium();
        let spec = ReverseTrajectorySpec {
            offset: 1.0,
            duration: 1.0,
            step: PAPER_STEP,
            window: ForceBox {
                min: [0.0, 0.0],
                max: [1.0, 1.0],
            },
        };
        assert!(matches!(
            power_loop.reverse_trajectories(&stable, &spec),
            Err(LatheError::NotASaddle { .. })
        ));
    }
}
