//! Stability lobes of milling with a flexible tool, by the semi-discretization method of
//! Insperger & Stépán.
//!
//! # Model
//!
//! The tool tip deflects by `u = (x, y)` (m): x along the feed, y normal to it, in the machine's
//! plane seen along the tool axis. Each direction is one uncoupled mode,
//! `m_d·ü_d + c_d·u̇_d + k_d·u_d = F_d`. Flute `j` of `N` is at `φ_j(t) = Ω·t + 2πj/N`, measured
//! clockwise from +y, with the radial unit vector `n(φ) = (sin φ, cos φ)` and the edge-velocity
//! direction `t̂(φ) = (cos φ, −sin φ)`. It cuts while `φ_j mod 2π` lies in
//! `[entry_angle, exit_angle]`, with chip `h_j = f_z·sin φ_j + (u(t) − u(t − τ))·n(φ_j)`,
//! `τ = 2π/(N·Ω)`, and pushes the tool with `F = −F_t·t̂ − F_r·n`, `F_t = k_c·a_p·h_j`,
//! `F_r = μ·F_t`. The feed term is a periodic forcing that does not change stability, so what is
//! studied is the regenerative part,
//!
//! `M·ü + C·u̇ + K·u = a_p·k_c·H(t)·(u(t) − u(t − τ))`,
//! `H(t) = Σ_j g_j · (−(t̂(φ_j) + μ·n(φ_j))·n(φ_j)ᵀ)`,
//!
//! a linear delay-differential equation whose coefficients repeat every tooth period `τ`, equal
//! to the delay. The cut is stable iff every Floquet multiplier (eigenvalue of the map of the
//! state over one period) has modulus below 1.
//!
//! # Method
//!
//! The state `z = (u, u̇/ω_r)` (velocity scaled by the lower natural frequency `ω_r`, a similarity
//! that keeps the exponentials well balanced and leaves the multipliers unchanged) obeys
//! `ż = A(t)·z + B(t)·u(t − τ)`. The period is cut into `m` intervals of `Δt = τ/m`:
//!
//! * on interval `i`, `H` is replaced by its **average over the interval**, computed in closed
//!   form (the milling example of Insperger & Stépán 2004 also averages the cutting coefficients
//!   over each interval rather than sampling them; unlike a midpoint sample, the average weighs a
//!   flute that enters or leaves the cut part way through the interval correctly);
//! * the delayed displacement is replaced by the straight line through the two stored samples
//!   that bracket `t − τ`: `u(t − τ) ≈ (1 − s/Δt)·u_{i−m} + (s/Δt)·u_{i−m+1}`, `s = t − t_i`.
//!   The 2004 paper weighs the same two samples with constant weights (those interpolating the
//!   interval's midpoint, ½ and ½ here since `τ = m·Δt`); weights linear in time are the
//!   first-order semi-discretization (Insperger, Stépán & Turi 2008), which keeps the 2004
//!   paper's discrete map and its dimension but converges faster in `m`.
//!
//! Solving the resulting ordinary equation over the interval gives
//! `z_{i+1} = P_i·z_i + R_old,i·u_{i−m} + R_new,i·u_{i−m+1}`, a linear map of the
//! `4 + 2m`-dimensional vector `(z_i, u_{i−1}, …, u_{i−m})`; the product of the `m` maps is the
//! approximate monodromy matrix, and its spectral radius decides stability.
//!
//! # References
//!
//! * T. Insperger, G. Stépán, "Semi-discretization method for delayed systems", Int. J. Numer.
//!   Meth. Engng 55 (2002) 503–518.
//! * T. Insperger, G. Stépán, "Updated semi-discretization method for periodic
//!   delay-differential equations with discrete delay", Int. J. Numer. Meth. Engng 61 (2004)
//!   117–141.
//! * T. Insperger, G. Stépán, J. Turi, "On the higher-order semi-discretizations for periodic
//!   delayed systems", J. Sound Vib. 313 (2008) 334–341.
//! * Y. Altintas, E. Budak, "Analytical prediction of stability lobes in milling", CIRP Annals
//!   44 (1995) 357–362 (the zero-order approximation the tests compare against).

use nalgebra::{Complex, DMatrix, Matrix2, Matrix4, Matrix4x2, SMatrix, Schur};
use std::f64::consts::{PI, TAU};
use thiserror::Error;

/// Depths tried, evenly spaced up to the maximum, before [`limiting_depth`] bisects: fine enough
/// not to step over the thin lobes of partial immersion.
const SCAN_POINTS: usize = 40;
/// Relative width of the stable/unstable bracket at which [`limiting_depth`] stops.
const DEPTH_TOLERANCE: f64 = 1e-4;
/// Bisection steps cap: the bracket only shrinks relative to its top if the boundary is above 0.
const MAX_BISECTIONS: usize = 64;
/// Largest number of intervals: the monodromy matrix has `4 + 2m` rows.
const MAX_INTERVALS: usize = 1000;
/// Largest number of flutes accepted (face mills with many inserts stay well below).
const MAX_FLUTES: usize = 1000;
/// Taylor degree of the matrix exponential; with the argument scaled to norm ≤ ½ the truncation
/// error is below 1e-16.
const TAYLOR_DEGREE: usize = 14;

type Matrix8 = SMatrix<f64, 8, 8>;

/// The tool's two uncoupled modes, `[x, y]` (x along the feed).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ToolModes {
    /// Modal masses, kg.
    pub mass: [f64; 2],
    /// Modal stiffnesses, N/m.
    pub stiffness: [f64; 2],
    /// Modal viscous damping, N·s/m.
    pub damping: [f64; 2],
}

/// The cutter and its engagement.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CutGeometry {
    /// Number of equally spaced flutes N.
    pub flutes: usize,
    /// Average dynamic specific cutting pressure k_c, N/m² (tangential force per chip area).
    pub cutting_pressure: f64,
    /// Radial to tangential force ratio μ.
    pub force_ratio: f64,
    /// Flute angle where the cut starts, rad, clockwise from +y (0 for slotting and up-milling).
    pub entry_angle: f64,
    /// Flute angle where the cut ends, rad (π for slotting and down-milling).
    pub exit_angle: f64,
}

/// Resolution of the semi-discretization.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SemiDiscretization {
    /// Intervals m per tooth period.
    pub intervals: usize,
}

impl Default for SemiDiscretization {
    /// 40 intervals: near the lobes the multipliers are within ~1.5e-3 of their converged values
    /// and the limiting depths within ~0.3 % (the error falls as 1/m²).
    fn default() -> Self {
        Self { intervals: 40 }
    }
}

/// The critical (largest-modulus) Floquet multiplier.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Multiplier {
    /// Its modulus, the spectral radius: the cut is stable iff it is below 1.
    pub modulus: f64,
    /// The vibration frequency it implies, Hz: `±arg(μ)/(2πτ) + k/τ` with the sign and the
    /// integer `k` that put it nearest the tool's lower undamped natural frequency (the
    /// vibration's other harmonics `f + k/τ` are present in the same Floquet mode).
    pub frequency_hz: f64,
}

/// Where a cut turns unstable as the depth grows.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Boundary {
    /// Limiting axial depth of cut, m (the first unstable depth, within relative 1e-4).
    pub depth: f64,
    /// Chatter frequency just above it, Hz.
    pub chatter_frequency_hz: f64,
}

/// One spindle speed of a lobe diagram.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LobePoint {
    /// Spindle speed Ω, rad/s.
    pub spindle_speed: f64,
    /// The stability boundary, `None` if the cut is stable up to the maximum depth.
    pub boundary: Option<Boundary>,
}

/// Why a stability computation cannot run; each case names the input to change.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum StabilityError {
    /// A modal mass or stiffness, the cutting pressure, the spindle speed or the maximum depth is
    /// zero, negative or not finite.
    #[error("milling stability: {field} = {value} must be finite and > 0 (SI units)")]
    NotPositive {
        /// The input, e.g. `tool.mass[0] (x)`.
        field: &'static str,
        /// The rejected value, in the input's SI unit.
        value: f64,
    },
    /// A modal damping, the force ratio or the axial depth is negative or not finite.
    #[error("milling stability: {field} = {value} must be finite and ≥ 0 (SI units)")]
    Negative {
        /// The input, e.g. `tool.damping[1] (y)`.
        field: &'static str,
        /// The rejected value, in the input's SI unit.
        value: f64,
    },
    /// The number of flutes is 0 or above the largest accepted; holds the count.
    #[error("milling stability: cut.flutes = {0}; use between 1 and {MAX_FLUTES} flutes")]
    Flutes(usize),
    /// The engagement is not an arc within [0, π] with entry before exit.
    #[error(
        "milling stability: cut.entry_angle = {entry} rad and cut.exit_angle = {exit} rad must \
         satisfy 0 ≤ entry_angle < exit_angle ≤ π (the chip f_z·sin φ is positive only there; \
         slotting is [0, π])"
    )]
    Engagement {
        /// Entry angle of the cut, rad.
        entry: f64,
        /// Exit angle of the cut, rad.
        exit: f64,
    },
    /// The intervals per tooth period are fewer than 2 or above the largest accepted; holds the
    /// count.
    #[error(
        "milling stability: sd.intervals = {0}; use between 2 and {MAX_INTERVALS} (40 is \
         usually enough)"
    )]
    Intervals(usize),
    /// A spindle speed of a lobe diagram is zero, negative or not finite.
    #[error("milling stability: speeds[{index}] = {value} rad/s must be finite and > 0")]
    Speed {
        /// Its position in the list of speeds.
        index: usize,
        /// The rejected speed, rad/s.
        value: f64,
    },
    /// The period map at this speed and depth is not finite, or its eigenvalues did not converge.
    #[error(
        "milling stability: the period map at {spindle_speed} rad/s and depth {axial_depth} m is \
         not finite or its eigenvalues did not converge; lower the depth or check the inputs' \
         units (SI)"
    )]
    Numerical {
        /// Spindle speed Ω where it failed, rad/s.
        spindle_speed: f64,
        /// Axial depth of cut where it failed, m.
        axial_depth: f64,
    },
}

/// The critical Floquet multiplier of the cut at `spindle_speed` (rad/s) and `axial_depth` (m):
/// the spectral radius of the first-order semi-discrete monodromy matrix (the product of the
/// per-interval maps, Insperger & Stépán 2004), and the chatter frequency it implies. At zero
/// depth it is the free vibration's decay over one tooth period, `max_d exp(−c_d·τ/(2m_d))`
/// for underdamped modes.
pub fn spectral_radius(
    tool: &ToolModes,
    cut: &CutGeometry,
    spindle_speed: f64,
    axial_depth: f64,
    sd: &SemiDiscretization,
) -> Result<Multiplier, StabilityError> {
    let problem = Problem::new(tool, cut, sd)?;
    require_positive("spindle_speed", spindle_speed)?;
    require_non_negative("axial_depth", axial_depth)?;
    problem.multiplier(spindle_speed, axial_depth)
}

/// The smallest depth in `(0, max_depth]` (m) at which the cut at `spindle_speed` (rad/s) is
/// unstable (spectral radius ≥ 1), or `None` if it is stable up to `max_depth`: 40 evenly
/// spaced depths are tried upwards, then the first stable/unstable bracket is bisected to
/// relative width 1e-4.
pub fn limiting_depth(
    tool: &ToolModes,
    cut: &CutGeometry,
    spindle_speed: f64,
    max_depth: f64,
    sd: &SemiDiscretization,
) -> Result<Option<Boundary>, StabilityError> {
    let problem = Problem::new(tool, cut, sd)?;
    require_positive("spindle_speed", spindle_speed)?;
    require_positive("max_depth", max_depth)?;
    problem.boundary(spindle_speed, max_depth)
}

/// The stability lobe diagram: [`limiting_depth`] at each of `speeds` (rad/s).
pub fn lobe_diagram(
    tool: &ToolModes,
    cut: &CutGeometry,
    speeds: &[f64],
    max_depth: f64,
    sd: &SemiDiscretization,
) -> Result<Vec<LobePoint>, StabilityError> {
    let problem = Problem::new(tool, cut, sd)?;
    require_positive("max_depth", max_depth)?;
    if let Some((index, &value)) = speeds
        .iter()
        .enumerate()
        .find(|(_, &v)| !(v > 0.0 && v.is_finite()))
    {
        return Err(StabilityError::Speed { index, value });
    }
    speeds
        .iter()
        .map(|&spindle_speed| {
            Ok(LobePoint {
                spindle_speed,
                boundary: problem.boundary(spindle_speed, max_depth)?,
            })
        })
        .collect()
}

fn require_positive(field: &'static str, value: f64) -> Result<(), StabilityError> {
    if value > 0.0 && value.is_finite() {
        Ok(())
    } else {
        Err(StabilityError::NotPositive { field, value })
    }
}

fn require_non_negative(field: &'static str, value: f64) -> Result<(), StabilityError> {
    if value >= 0.0 && value.is_finite() {
        Ok(())
    } else {
        Err(StabilityError::Negative { field, value })
    }
}

/// Validated inputs and what does not depend on speed or depth.
struct Problem {
    inverse_mass: [f64; 2],
    stiffness: [f64; 2],
    damping: [f64; 2],
    /// Velocity scale of the state, rad/s: the lower natural frequency.
    velocity_scale: f64,
    flutes: usize,
    cutting_pressure: f64,
    /// `H` averaged over each interval of a tooth period, `None` where no flute cuts.
    directional: Vec<Option<Matrix2<f64>>>,
}

/// One interval's map `z_{i+1} = p·z_i + older·u_{i−m} + newer·u_{i−m+1}`.
struct IntervalMap {
    p: Matrix4<f64>,
    older: Matrix4x2<f64>,
    newer: Matrix4x2<f64>,
}

impl Problem {
    /// Checks every input (each error names the field to change) and averages `H`.
    fn new(
        tool: &ToolModes,
        cut: &CutGeometry,
        sd: &SemiDiscretization,
    ) -> Result<Self, StabilityError> {
        for (field, value) in [
            ("tool.mass[0] (x)", tool.mass[0]),
            ("tool.mass[1] (y)", tool.mass[1]),
            ("tool.stiffness[0] (x)", tool.stiffness[0]),
            ("tool.stiffness[1] (y)", tool.stiffness[1]),
            ("cut.cutting_pressure", cut.cutting_pressure),
        ] {
            require_positive(field, value)?;
        }
        for (field, value) in [
            ("tool.damping[0] (x)", tool.damping[0]),
            ("tool.damping[1] (y)", tool.damping[1]),
            ("cut.force_ratio", cut.force_ratio),
        ] {
            require_non_negative(field, value)?;
        }
        if !(1..=MAX_FLUTES).contains(&cut.flutes) {
            return Err(StabilityError::Flutes(cut.flutes));
        }
        let (entry, exit) = (cut.entry_angle, cut.exit_angle);
        if !(0.0 <= entry && entry < exit && exit <= PI) {
            return Err(StabilityError::Engagement { entry, exit });
        }
        if !(2..=MAX_INTERVALS).contains(&sd.intervals) {
            return Err(StabilityError::Intervals(sd.intervals));
        }
        let inverse_mass = tool.mass.map(|m| 1.0 / m);
        let velocity_scale =
            (tool.stiffness[0] * inverse_mass[0]).min(tool.stiffness[1] * inverse_mass[1]);
        Ok(Self {
            inverse_mass,
            stiffness: tool.stiffness,
            damping: tool.damping,
            velocity_scale: velocity_scale.sqrt(),
            flutes: cut.flutes,
            cutting_pressure: cut.cutting_pressure,
            directional: averaged_directional(cut, sd.intervals),
        })
    }

    /// `A_i` and `B_i` of `ż = A_i·z + B_i·u(t − τ)` on an interval whose averaged directional
    /// matrix is `h` (the semi-discrete system of Insperger & Stépán 2002, with the periodic
    /// coefficients frozen on the interval).
    fn system(&self, h: &Matrix2<f64>, depth: f64) -> (Matrix4<f64>, Matrix4x2<f64>) {
        let w = self.velocity_scale;
        let mut a = Matrix4::zeros();
        let mut b = Matrix4x2::zeros();
        for d in 0..2 {
            a[(d, 2 + d)] = w;
            a[(2 + d, d)] = -self.stiffness[d] * self.inverse_mass[d] / w;
            a[(2 + d, 2 + d)] = -self.damping[d] * self.inverse_mass[d];
            for e in 0..2 {
                let regenerative = depth * self.cutting_pressure * self.inverse_mass[d] * h[(d, e)];
                a[(2 + d, e)] += regenerative / w;
                b[(2 + d, e)] = -regenerative / w;
            }
        }
        (a, b)
    }

    /// The transpose of the monodromy matrix over one tooth period: the product of the `m`
    /// interval maps on `(z_i, u_{i−1}, …, u_{i−m})` (the transition matrix of Insperger & Stépán
    /// 2004). Each map only replaces the 4 state rows and shifts the history down by one sample,
    /// so the product is updated in place of a dense multiplication; working on the transpose
    /// makes those rows contiguous columns.
    fn monodromy_transposed(&self, speed: f64, depth: f64) -> DMatrix<f64> {
        let m = self.directional.len();
        let n = 4 + 2 * m;
        let dt = TAU / (self.flutes as f64 * speed) / m as f64;
        let free = interval_map(
            &self.system(&Matrix2::zeros(), 0.0).0,
            &Matrix4x2::zeros(),
            dt,
        );
        let (newer_column, older_column) = (4 + 2 * (m - 2), 4 + 2 * (m - 1));
        let mut current = DMatrix::<f64>::identity(n, n);
        let mut next = DMatrix::<f64>::zeros(n, n);
        for h in &self.directional {
            match h.filter(|_| depth > 0.0) {
                None => next.fixed_columns_mut::<4>(0).gemm(
                    1.0,
                    &current.fixed_columns::<4>(0),
                    &free.p.transpose(),
                    0.0,
                ),
                Some(h) => {
                    let (a, b) = self.system(&h, depth);
                    let map = interval_map(&a, &b, dt);
                    let mut top = next.fixed_columns_mut::<4>(0);
                    top.gemm(1.0, &current.fixed_columns::<4>(0), &map.p.transpose(), 0.0);
                    let newer = current.fixed_columns::<2>(newer_column);
                    top.gemm(1.0, &newer, &map.newer.transpose(), 1.0);
                    let older = current.fixed_columns::<2>(older_column);
                    top.gemm(1.0, &older, &map.older.transpose(), 1.0);
                }
            }
            next.fixed_columns_mut::<2>(4)
                .copy_from(&current.fixed_columns::<2>(0));
            next.columns_mut(6, n - 6)
                .copy_from(&current.columns(4, n - 6));
            std::mem::swap(&mut current, &mut next);
        }
        current
    }

    /// The critical multiplier at `speed` and `depth` (stability criterion of Insperger & Stépán
    /// 2004: the map is asymptotically stable iff the spectral radius is below 1).
    fn multiplier(&self, speed: f64, depth: f64) -> Result<Multiplier, StabilityError> {
        let tau = TAU / (self.flutes as f64 * speed);
        let critical = critical_eigenvalue(self.monodromy_transposed(speed, depth)).ok_or(
            StabilityError::Numerical {
                spindle_speed: speed,
                axial_depth: depth,
            },
        )?;
        let natural_hz = self.velocity_scale / TAU;
        Ok(Multiplier {
            modulus: critical.norm(),
            frequency_hz: vibration_frequency(critical, tau, natural_hz),
        })
    }

    /// Upward scan then bisection of the first stable/unstable bracket.
    fn boundary(&self, speed: f64, max_depth: f64) -> Result<Option<Boundary>, StabilityError> {
        let mut stable = 0.0;
        for k in 1..=SCAN_POINTS {
            let depth = max_depth * k as f64 / SCAN_POINTS as f64;
            let at = self.multiplier(speed, depth)?;
            if at.modulus >= 1.0 {
                return self.bisect(speed, stable, depth, at).map(Some);
            }
            stable = depth;
        }
        Ok(None)
    }

    fn bisect(
        &self,
        speed: f64,
        mut stable: f64,
        mut unstable: f64,
        mut at_unstable: Multiplier,
    ) -> Result<Boundary, StabilityError> {
        for _ in 0..MAX_BISECTIONS {
            if unstable - stable <= DEPTH_TOLERANCE * unstable {
                break;
            }
            let depth = 0.5 * (stable + unstable);
            let at = self.multiplier(speed, depth)?;
            if at.modulus >= 1.0 {
                (unstable, at_unstable) = (depth, at);
            } else {
                stable = depth;
            }
        }
        Ok(Boundary {
            depth: unstable,
            chatter_frequency_hz: at_unstable.frequency_hz,
        })
    }
}

/// `H` averaged over each of the `m` intervals of a tooth period, flute 0 at φ = 0 at t = 0 (the
/// multipliers do not depend on that phase); `None` for intervals where no flute cuts. The
/// 2004 paper's milling example uses such interval averages of the cutting coefficients.
fn averaged_directional(cut: &CutGeometry, intervals: usize) -> Vec<Option<Matrix2<f64>>> {
    let step = TAU / (cut.flutes * intervals) as f64;
    (0..intervals)
        .map(|i| {
            let mut sum = Matrix2::zeros();
            let mut cutting = false;
            // The intervals tile the turn, so none straddles 2π.
            for j in 0..cut.flutes {
                let start = (i + j * intervals) as f64 * step;
                let from = start.max(cut.entry_angle);
                let to = (start + step).min(cut.exit_angle);
                if to > from {
                    sum += directional_integral(from, to, cut.force_ratio);
                    cutting = true;
                }
            }
            cutting.then(|| sum / step)
        })
        .collect()
}

/// `∫ −(t̂(φ) + μ·n(φ))·n(φ)ᵀ dφ` over `[from, to]`, in closed form.
fn directional_integral(from: f64, to: f64, mu: f64) -> Matrix2<f64> {
    let length = to - from;
    let sin_2 = 0.5 * ((2.0 * from).cos() - (2.0 * to).cos());
    let cos_2 = 0.5 * ((2.0 * to).sin() - (2.0 * from).sin());
    let (sc, ss, cc) = (0.5 * sin_2, 0.5 * (length - cos_2), 0.5 * (length + cos_2));
    -Matrix2::new(sc + mu * ss, cc + mu * sc, -ss + mu * sc, -sc + mu * cc)
}

/// The exact solution over one interval of `ż = A·z + B·((1 − s/Δt)·u_old + (s/Δt)·u_new)`:
/// `P = e^{AΔt}`, `R_new = ∫₀^Δt e^{A(Δt−s)}·B·s/Δt ds`, `R_old = ∫₀^Δt e^{A(Δt−s)}·B ds − R_new`
/// (the first-order counterpart of the 2002 paper's `P_i`, `R_i`), all read off one exponential
/// of the block matrix `[[AΔt, BΔt, 0], [0, 0, I], [0, 0, 0]]` (Van Loan), which needs no
/// inverse of `A`.
fn interval_map(a: &Matrix4<f64>, b: &Matrix4x2<f64>, dt: f64) -> IntervalMap {
    let mut block = Matrix8::zeros();
    block.fixed_view_mut::<4, 4>(0, 0).copy_from(&(a * dt));
    block.fixed_view_mut::<4, 2>(0, 4).copy_from(&(b * dt));
    block[(4, 6)] = 1.0;
    block[(5, 7)] = 1.0;
    let e = exponential(&block);
    let whole = e.fixed_view::<4, 2>(0, 4).into_owned();
    let newer = e.fixed_view::<4, 2>(0, 6).into_owned();
    IntervalMap {
        p: e.fixed_view::<4, 4>(0, 0).into_owned(),
        older: whole - newer,
        newer,
    }
}

/// `e^X` by scaling and squaring with a Taylor polynomial; never panics (a non-finite argument
/// gives a non-finite result, caught by [`critical_eigenvalue`]).
fn exponential(x: &Matrix8) -> Matrix8 {
    let norm = x
        .column_iter()
        .map(|c| c.iter().map(|v| v.abs()).sum::<f64>())
        .fold(0.0, f64::max);
    // Halvings until the norm is ≤ ½; at most ~1030 for any finite norm.
    let mut squarings = 0;
    let mut scaled_norm = norm;
    while scaled_norm > 0.5 && squarings < 1100 {
        scaled_norm *= 0.5;
        squarings += 1;
    }
    let scaled = x * 0.5_f64.powi(squarings);
    let mut e = Matrix8::identity();
    for k in (1..=TAYLOR_DEGREE).rev() {
        e = Matrix8::identity() + scaled * e / k as f64;
    }
    for _ in 0..squarings {
        e = e * e;
    }
    e
}

/// The largest-modulus eigenvalue of a (transposed) monodromy matrix, `None` if it is not finite
/// or the QR iteration does not converge.
fn critical_eigenvalue(transposed: DMatrix<f64>) -> Option<Complex<f64>> {
    if !transposed.iter().all(|v| v.is_finite()) {
        return None;
    }
    // A zero column of the monodromy matrix (a history sample no cutting interval reads) only
    // adds an eigenvalue 0: dropping it with its row keeps the others and shrinks the problem.
    let keep: Vec<usize> = (0..transposed.nrows())
        .filter(|&r| transposed.row(r).iter().any(|&v| v != 0.0))
        .collect();
    let reduced = transposed.select_rows(&keep).select_columns(&keep);
    let size = reduced.nrows();
    let schur = Schur::try_new(reduced, f64::EPSILON, 100 * size.max(1))?;
    schur
        .complex_eigenvalues()
        .iter()
        .copied()
        .max_by(|a, b| a.norm().total_cmp(&b.norm()))
}

/// The frequency (Hz) of the vibration a multiplier `μ` stands for: over one period `τ` a
/// vibration `e^{iωt}` turns by `ωτ`, known only modulo 2π and up to its conjugate, so
/// `f = ±arg(μ)/(2πτ) + k/τ`; the sign and `k` are those nearest `natural_hz`, where chatter
/// vibrates. Where two of these aliases are about equally near (`f ≈ k/(2τ)` close to the
/// natural frequency) the pick may switch between them from one speed to the next.
fn vibration_frequency(mu: Complex<f64>, tau: f64, natural_hz: f64) -> f64 {
    let base = mu.arg().abs() / (TAU * tau);
    let nearest = |f: f64| f + ((natural_hz - f) * tau).round() / tau;
    let (up, down) = (nearest(base), nearest(-base));
    if (up - natural_hz).abs() <= (down - natural_hz).abs() {
        up
    } else {
        down
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector2;

    /// A tool from modal mass, stiffness and damping ratio per direction.
    fn tool(mass: [f64; 2], stiffness: [f64; 2], zeta: [f64; 2]) -> ToolModes {
        let damping = [0, 1].map(|d| 2.0 * zeta[d] * (stiffness[d] * mass[d]).sqrt());
        ToolModes {
            mass,
            stiffness,
            damping,
        }
    }

    /// The brief's symmetric test tool: 0.1 kg, 2.4 MN/m, ζ = 0.02 (780 Hz).
    fn symmetric_tool() -> ToolModes {
        tool([0.1; 2], [2.4e6; 2], [0.02; 2])
    }

    fn slotting() -> CutGeometry {
        CutGeometry {
            flutes: 2,
            cutting_pressure: 7e8,
            force_ratio: 0.3,
            entry_angle: 0.0,
            exit_angle: PI,
        }
    }

    fn rad_per_s(rpm: f64) -> f64 {
        rpm * TAU / 60.0
    }

    fn sd(intervals: usize) -> SemiDiscretization {
        SemiDiscretization { intervals }
    }

    #[test]
    fn zero_depth_gives_free_decay_over_a_period() {
        let tool = tool([0.1, 0.15], [2.4e6, 3.0e6], [0.02, 0.01]);
        let down_milling = CutGeometry {
            entry_angle: 2.0,
            ..slotting()
        };
        for cut in [slotting(), down_milling] {
            for rpm in [3_000.0, 12_345.0, 30_000.0] {
                let speed = rad_per_s(rpm);
                let tau = TAU / (cut.flutes as f64 * speed);
                let expected = (0..2)
                    .map(|d| (-tool.damping[d] / (2.0 * tool.mass[d]) * tau).exp())
                    .fold(0.0, f64::max);
                let rho = spectral_radius(&tool, &cut, speed, 0.0, &sd(40)).unwrap();
                assert!(
                    (rho.modulus / expected - 1.0).abs() < 1e-9,
                    "{rpm} rpm: ρ = {}, expected {expected}",
                    rho.modulus
                );
            }
        }
    }

    #[test]
    fn forty_intervals_are_converged_near_a_lobe() {
        let (tool, cut) = (symmetric_tool(), slotting());
        // The bottom of a lobe and both of its flanks.
        for rpm in [13_000.0, 15_000.0, 20_000.0] {
            let speed = rad_per_s(rpm);
            let rho = |depth, intervals| {
                spectral_radius(&tool, &cut, speed, depth, &sd(intervals))
                    .unwrap()
                    .modulus
            };
            let boundary = limiting_depth(&tool, &cut, speed, 3e-3, &sd(40))
                .unwrap()
                .unwrap()
                .depth;
            for factor in [0.95, 1.0, 1.05] {
                let depth = factor * boundary;
                let (coarse, fine) = (rho(depth, 40), rho(depth, 80));
                assert!(
                    (coarse - fine).abs() < 1e-3,
                    "{rpm} rpm, {depth} m: ρ = {coarse} (m = 40) vs {fine} (m = 80)"
                );
            }
            // With m = 80 the boundary is still within ±0.5 % of the one found with m = 40.
            assert!(rho(0.995 * boundary, 80) < 1.0 && rho(1.005 * boundary, 80) >= 1.0);
        }
    }

    /// One cutting flute's `−(t̂ + μ·n)·nᵀ`, straight from the unit vectors.
    fn flute_matrix(phi: f64, mu: f64) -> Matrix2<f64> {
        let n = Vector2::new(phi.sin(), phi.cos());
        let t = Vector2::new(phi.cos(), -phi.sin());
        -(t + n * mu) * n.transpose()
    }

    /// `H(t)`, summing the flutes in the cut.
    fn directional_at(cut: &CutGeometry, speed: f64, time: f64) -> Matrix2<f64> {
        let pitch = TAU / cut.flutes as f64;
        (0..cut.flutes)
            .map(|j| (speed * time + pitch * j as f64).rem_euclid(TAU))
            .filter(|phi| (cut.entry_angle..=cut.exit_angle).contains(phi))
            .map(|phi| flute_matrix(phi, cut.force_ratio))
            .sum()
    }

    /// The zero-order approximation (Altintas & Budak 1995) for a tool with the same mode in x
    /// and y: `H` is replaced by its mean `H̄`, and chatter at ω needs
    /// `a·k_c·(1 − e^{−iωτ})·Λ = 1` with `Λ = g(iω)·λ` for an eigenvalue `λ` of `H̄`. A real
    /// positive depth needs `Re Λ > 0` and gives `a = 1/(2·k_c·Re Λ)`, `ωτ = π + 2·arg Λ + 2πn`.
    struct ZeroOrder {
        tool: ToolModes,
        cutting_pressure: f64,
        flutes: usize,
        eigenvalues: [Complex<f64>; 2],
        /// `(ω, Λ)` on a fine grid of chatter frequencies, per eigenvalue.
        samples: [Vec<(f64, Complex<f64>)>; 2],
    }

    /// Lobe numbers tried by the zero-order approximation.
    const ZOA_LOBES: usize = 8;

    impl ZeroOrder {
        fn new(tool: &ToolModes, cut: &CutGeometry) -> Self {
            // Mean of H over a turn, by the midpoint rule.
            let points = 20_000;
            let width = (cut.exit_angle - cut.entry_angle) / points as f64;
            let integral: Matrix2<f64> = (0..points)
                .map(|i| flute_matrix(cut.entry_angle + (i as f64 + 0.5) * width, cut.force_ratio))
                .sum::<Matrix2<f64>>()
                * width;
            let mean = integral * (cut.flutes as f64 / TAU);
            let half_trace = Complex::new(0.5 * mean.trace(), 0.0);
            let root = (half_trace * half_trace - mean.determinant()).sqrt();
            let mut zoa = Self {
                tool: *tool,
                cutting_pressure: cut.cutting_pressure,
                flutes: cut.flutes,
                eigenvalues: [half_trace + root, half_trace - root],
                samples: [Vec::new(), Vec::new()],
            };
            // From half to 3× the natural frequency, 160 points across the resonance peak.
            let natural = (tool.stiffness[0] / tool.mass[0]).sqrt();
            for branch in 0..2 {
                zoa.samples[branch] = (0..=points)
                    .map(|i| natural * (0.5 + 2.5 * i as f64 / points as f64))
                    .map(|w| (w, zoa.lambda(branch, w)))
                    .collect();
            }
            zoa
        }

        fn lambda(&self, branch: usize, omega: f64) -> Complex<f64> {
            let (m, k, c) = (
                self.tool.mass[0],
                self.tool.stiffness[0],
                self.tool.damping[0],
            );
            self.eigenvalues[branch] / Complex::new(k - m * omega * omega, c * omega)
        }

        fn depth(&self, lambda: Complex<f64>) -> f64 {
            1.0 / (2.0 * self.cutting_pressure * lambda.re)
        }

        /// The lowest depth of all lobes.
        fn minimum_depth(&self) -> f64 {
            let best = self
                .samples
                .iter()
                .flatten()
                .map(|s| s.1.re)
                .fold(0.0, f64::max);
            self.depth(Complex::new(best, 0.0))
        }

        /// Limiting depth at `speed`: the lowest lobe over both eigenvalues and all lobe numbers.
        fn limiting_depth(&self, speed: f64) -> Option<f64> {
            let tau = TAU / (self.flutes as f64 * speed);
            let mut lowest: Option<f64> = None;
            for (branch, lobe) in (0..2).flat_map(|b| (0..ZOA_LOBES).map(move |n| (b, n))) {
                // Phase mismatch, decreasing in ω where the depth is positive.
                let mismatch = |w: f64, l: Complex<f64>| {
                    (l.re > 0.0).then(|| PI + 2.0 * l.arg() + TAU * lobe as f64 - w * tau)
                };
                for pair in self.samples[branch].windows(2) {
                    let (f0, f1) = (
                        mismatch(pair[0].0, pair[0].1),
                        mismatch(pair[1].0, pair[1].1),
                    );
                    let (Some(f0), Some(f1)) = (f0, f1) else {
                        continue;
                    };
                    if f0.signum() == f1.signum() {
                        continue;
                    }
                    let (mut lo, mut hi) = (pair[0].0, pair[1].0);
                    for _ in 0..60 {
                        let mid = 0.5 * (lo + hi);
                        let f = mismatch(mid, self.lambda(branch, mid));
                        if f.is_some_and(|f| f.signum() == f0.signum()) {
                            lo = mid;
                        } else {
                            hi = mid;
                        }
                    }
                    let depth = self.depth(self.lambda(branch, lo));
                    lowest = Some(lowest.map_or(depth, |d| d.min(depth)));
                }
            }
            lowest
        }
    }

    #[test]
    fn agrees_with_zero_order_approximation_in_slotting() {
        let (tool, cut) = (symmetric_tool(), slotting());
        let zoa = ZeroOrder::new(&tool, &cut);
        let zoa_min = zoa.minimum_depth();
        let rho = |speed, depth| {
            spectral_radius(&tool, &cut, speed, depth, &sd(40))
                .unwrap()
                .modulus
        };
        let speeds: Vec<f64> = (0..=50)
            .map(|i| rad_per_s(10_000.0 + 200.0 * i as f64))
            .collect();

        // Minimum limiting depth within 5 %: reached at the lobe bottom near 15,000 rpm, and
        // nowhere in the band is the cut unstable 5 % below the zero-order minimum.
        let bottom = [14_000.0, 15_000.0, 16_000.0].map(rad_per_s);
        let sd_min = lobe_diagram(&tool, &cut, &bottom, 10.0 * zoa_min, &sd(40))
            .unwrap()
            .iter()
            .filter_map(|p| p.boundary.map(|b| b.depth))
            .fold(f64::INFINITY, f64::min);
        assert!(
            (sd_min / zoa_min - 1.0).abs() < 0.05,
            "minimum limiting depth: {sd_min} m (semi-discretization) vs {zoa_min} m (ZOA)"
        );
        for &speed in &speeds {
            assert!(rho(speed, 0.95 * zoa_min) < 1.0, "{speed} rad/s");
        }

        // Away from the cusps, where the lobes are shallow enough for the small speed shift
        // between the two models not to dominate (the zero-order limit below 3× its minimum),
        // the boundary lies within ±10 % of the zero-order one: stable 10 % below, unstable 10 %
        // above.
        let mut compared = 0;
        for &speed in &speeds {
            let Some(depth) = zoa.limiting_depth(speed).filter(|&d| d < 3.0 * zoa_min) else {
                continue;
            };
            let (below, above) = (rho(speed, 0.9 * depth), rho(speed, 1.1 * depth));
            assert!(
                below < 1.0 && above >= 1.0,
                "{} rpm, ZOA limit {depth} m: ρ = {below} at −10 %, {above} at +10 %",
                speed * 60.0 / TAU
            );
            compared += 1;
        }
        assert!(compared >= 35, "only {compared} speeds compared");
    }

    /// Samples of the simulated vibration per tooth period.
    const STEPS_PER_PERIOD: usize = 400;

    /// Norm of the state once per tooth period, integrating the linear delay equation with RK4
    /// (step τ/400; delayed values at half steps by cubic Hermite interpolation of the stored
    /// displacements and velocities), from rest at `u = (1, 1) µm` with zero history.
    fn simulated_norms(
        tool: &ToolModes,
        cut: &CutGeometry,
        speed: f64,
        depth: f64,
        periods: usize,
    ) -> Vec<f64> {
        let h = TAU / (cut.flutes as f64 * speed) / STEPS_PER_PERIOD as f64;
        let rhs = |time: f64, s: [f64; 4], delayed: [f64; 4]| {
            let du = Vector2::new(s[0] - delayed[0], s[1] - delayed[1]);
            let force = directional_at(cut, speed, time) * du * (depth * cut.cutting_pressure);
            let acc = |d: usize| {
                (force[d] - tool.damping[d] * s[2 + d] - tool.stiffness[d] * s[d]) / tool.mass[d]
            };
            [s[2], s[3], acc(0), acc(1)]
        };
        let axpy = |s: [f64; 4], k: [f64; 4], a: f64| [0, 1, 2, 3].map(|i| s[i] + a * k[i]);
        let mut history = vec![[1e-6, 1e-6, 0.0, 0.0]];
        for step in 0..periods * STEPS_PER_PERIOD {
            let delayed = |k: usize| {
                k.checked_sub(STEPS_PER_PERIOD)
                    .map_or([0.0; 4], |k| history[k])
            };
            let (d0, d1) = (delayed(step), delayed(step + 1));
            let mid = [
                0.5 * (d0[0] + d1[0]) + h * (d0[2] - d1[2]) / 8.0,
                0.5 * (d0[1] + d1[1]) + h * (d0[3] - d1[3]) / 8.0,
                0.0, // the delayed velocity is not used
                0.0,
            ];
            let (t, s) = (step as f64 * h, history[step]);
            let k1 = rhs(t, s, d0);
            let k2 = rhs(t + 0.5 * h, axpy(s, k1, 0.5 * h), mid);
            let k3 = rhs(t + 0.5 * h, axpy(s, k2, 0.5 * h), mid);
            let k4 = rhs(t + h, axpy(s, k3, h), d1);
            let next =
                [0, 1, 2, 3].map(|i| s[i] + h / 6.0 * (k1[i] + 2.0 * (k2[i] + k3[i]) + k4[i]));
            history.push(next);
        }
        let omega = (tool.stiffness[0] / tool.mass[0]).sqrt();
        history
            .iter()
            .step_by(STEPS_PER_PERIOD)
            .map(|s| (s[0].hypot(s[1])).hypot(s[2].hypot(s[3]) / omega))
            .collect()
    }

    /// Growth per period of simulated norms: the largest norm over the last 20 periods against
    /// the largest over the 20 periods half the run earlier (the window spans the beat of a
    /// complex multiplier pair).
    fn growth_per_period(norms: &[f64]) -> f64 {
        let window = 20;
        let lag = norms.len() / 2;
        let peak = |end: usize| norms[end - window..end].iter().copied().fold(0.0, f64::max);
        (peak(norms.len()) / peak(norms.len() - lag)).powf(1.0 / lag as f64)
    }

    #[test]
    fn simulation_decays_below_and_grows_above_the_boundary() {
        let tool = symmetric_tool();
        let half_down = CutGeometry {
            entry_angle: 0.5 * PI,
            ..slotting()
        };
        // A lobe bottom, a steep flank where the zero-order approximation is 11 % lower, a
        // flank of the next lobe, and half-immersion down-milling (flutes entering mid-interval).
        for (cut, rpm) in [
            (slotting(), 15_000.0),
            (slotting(), 11_400.0),
            (slotting(), 20_000.0),
            (half_down, 17_000.0),
        ] {
            let speed = rad_per_s(rpm);
            let boundary = limiting_depth(&tool, &cut, speed, 5e-3, &sd(40))
                .unwrap()
                .unwrap();
            for (factor, grows) in [(0.8, false), (1.2, true)] {
                let depth = factor * boundary.depth;
                let rho = spectral_radius(&tool, &cut, speed, depth, &sd(40)).unwrap();
                let norms = simulated_norms(&tool, &cut, speed, depth, 400);
                let growth = growth_per_period(&norms);
                assert_eq!(growth > 1.0, grows, "{rpm} rpm, {depth} m: growth {growth}");
                assert!(
                    (growth - rho.modulus).abs() < 0.01,
                    "{rpm} rpm, {depth} m: simulated growth {growth} per period, ρ = {}",
                    rho.modulus
                );
            }
        }
    }

    /// An edit of one input field.
    type Change<T> = fn(&mut T);

    #[test]
    fn bad_inputs_are_errors_naming_the_field() {
        let (tool, cut, speed) = (symmetric_tool(), slotting(), rad_per_s(15_000.0));
        let names = |result: Result<Multiplier, StabilityError>, field: &str| {
            let error = result.expect_err(field).to_string();
            assert!(error.contains(field), "{error} should name {field}");
        };
        let tool_changes: [(Change<ToolModes>, &str); 6] = [
            (|t| t.mass[0] = 0.0, "tool.mass[0]"),
            (|t| t.mass[1] = f64::NAN, "tool.mass[1]"),
            (|t| t.stiffness[0] = -1.0, "tool.stiffness[0]"),
            (|t| t.stiffness[1] = f64::INFINITY, "tool.stiffness[1]"),
            (|t| t.damping[0] = -1.0, "tool.damping[0]"),
            (|t| t.damping[1] = f64::NAN, "tool.damping[1]"),
        ];
        for (change, field) in tool_changes {
            let mut tool = tool;
            change(&mut tool);
            names(spectral_radius(&tool, &cut, speed, 1e-4, &sd(40)), field);
        }
        let cut_changes: [(Change<CutGeometry>, &str); 8] = [
            (|c| c.flutes = 0, "cut.flutes"),
            (|c| c.flutes = 5000, "cut.flutes"),
            (|c| c.cutting_pressure = 0.0, "cut.cutting_pressure"),
            (|c| c.force_ratio = -0.1, "cut.force_ratio"),
            (|c| c.entry_angle = PI, "cut.entry_angle"),
            (|c| c.entry_angle = -0.1, "cut.entry_angle"),
            (|c| c.exit_angle = 4.0, "cut.exit_angle"),
            (|c| c.exit_angle = f64::NAN, "cut.exit_angle"),
        ];
        for (change, field) in cut_changes {
            let mut cut = cut;
            change(&mut cut);
            names(spectral_radius(&tool, &cut, speed, 1e-4, &sd(40)), field);
        }
        let arguments = [
            (0.0, 1e-4, 40, "spindle_speed"),
            (f64::NAN, 1e-4, 40, "spindle_speed"),
            (speed, -1e-4, 40, "axial_depth"),
            (speed, f64::INFINITY, 40, "axial_depth"),
            (speed, 1e-4, 1, "sd.intervals"),
            (speed, 1e-4, 100_000, "sd.intervals"),
            // Finite but absurd: the period map overflows.
            (speed, 1e300, 40, "lower the depth"),
        ];
        for (speed, depth, intervals, field) in arguments {
            names(
                spectral_radius(&tool, &cut, speed, depth, &sd(intervals)),
                field,
            );
        }
        assert_eq!(
            spectral_radius(&tool, &cut, speed, 1e-4, &sd(1)),
            Err(StabilityError::Intervals(1))
        );
        let limit = |speed, max_depth| limiting_depth(&tool, &cut, speed, max_depth, &sd(40));
        assert!(limit(speed, 0.0).is_err_and(|e| e.to_string().contains("max_depth")));
        assert!(limit(-speed, 1e-3).is_err_and(|e| e.to_string().contains("spindle_speed")));
        assert!(matches!(
            lobe_diagram(&tool, &cut, &[speed, f64::NAN], 1e-3, &sd(40)),
            Err(StabilityError::Speed { index: 1, .. })
        ));
        assert!(lobe_diagram(&tool, &cut, &[speed], f64::NAN, &sd(40))
            .is_err_and(|e| e.to_string().contains("max_depth")));
    }
}
