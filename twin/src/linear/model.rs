//! The linear model and how it is made: the central differences of the reduced equations of
//! motion about an operating point ([`differentiate`]), and the model they give (its
//! zero-order-hold discretisation, poles and frequency response).

use crate::physics::{MechanismState, ReducedDynamics, ReducedError};
use nalgebra::{Complex, DMatrix};
use thiserror::Error;

use super::expm::zero_order_hold;

/// Why the Jacobians make no model.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ModelError {
    /// The loop closures do not converge at the operating point or at a state perturbed from it.
    #[error("at the operating point: {0}")]
    State(#[from] ReducedError),
    /// A matrix came out with a NaN or infinite entry.
    #[error("the linear model is not finite ({what}): the operating point is not one to linearise about")]
    NotFinite {
        /// Which matrices: "A", "B", "C" or "Ad, Bd".
        what: &'static str,
    },
}

/// A state, input or output: its name in the machine's words and its SI unit.
#[derive(Debug, Clone, PartialEq)]
pub struct Channel {
    /// `joint.position` or `joint.velocity` for a state, the actuated joint for an input, the
    /// measured signal for an output.
    pub name: String,
    /// SI unit label, e.g. "rad/s" or "N·m".
    pub unit: &'static str,
}

/// Where the model was linearised.
#[derive(Debug, Clone, PartialEq)]
pub struct OperatingPoint {
    /// s, on the physics step.
    pub time: f64,
    /// x₀ (SI).
    pub state: Vec<f64>,
    /// u₀: the efforts applied at the joints, held (N·m or N).
    pub efforts: Vec<f64>,
    /// y₀ (SI).
    pub outputs: Vec<f64>,
}

/// The linear model. Matrices are row-major lists of rows.
#[derive(Debug, Clone, PartialEq)]
pub struct LinearModel {
    /// Name of the scenario linearised.
    pub scenario: String,
    /// x: the independent joints' coordinates, then their rates.
    pub states: Vec<Channel>,
    /// u: the efforts at the actuated joints.
    pub inputs: Vec<Channel>,
    /// y: the measured signals that are functions of the state.
    pub outputs: Vec<Channel>,
    /// Measured signals not among the outputs, and why (they depend on the machine's history or
    /// its drives' states, not on the mechanism's state).
    pub outputs_left_out: Vec<(String, String)>,
    /// A = ∂ẋ/∂x, states × states.
    pub a: Vec<Vec<f64>>,
    /// B = ∂ẋ/∂u, states × inputs.
    pub b: Vec<Vec<f64>>,
    /// C = ∂y/∂x, outputs × states.
    pub c: Vec<Vec<f64>>,
    /// D = ∂y/∂u, outputs × inputs: all zeros.
    pub d: Vec<Vec<f64>>,
    /// The scenario's control period, s: the zero-order hold's.
    pub control_period: f64,
    /// Ad = e^(A·T): the state matrix discretised by zero-order hold at the control period T.
    pub ad: Vec<Vec<f64>>,
    /// Bd = ∫₀ᵀ e^(A·τ) dτ · B: the input matrix discretised by zero-order hold.
    pub bd: Vec<Vec<f64>>,
    /// Eigenvalues of A, [real, imaginary] (1/s), ordered by real part, then imaginary.
    pub poles: Vec<[f64; 2]>,
    /// (t, x₀, u₀, y₀) the model was linearised about.
    pub operating_point: OperatingPoint,
    /// The central-difference steps taken, per state (SI).
    pub state_steps: Vec<f64>,
    /// The central-difference steps taken, per input (N·m or N).
    pub input_steps: Vec<f64>,
}

/// What [`differentiate`] works on: the reduced plant, the inputs' joints and the outputs.
pub(crate) struct Plant<'a> {
    pub dynamics: &'a mut ReducedDynamics,
    /// Tree joint of each input, and the number of tree joints.
    pub input_joints: &'a [usize],
    pub joints: usize,
    /// The outputs at a mechanism state, into the vector (cleared first).
    pub outputs: &'a mut dyn FnMut(&MechanismState, &mut Vec<f64>),
}

/// The continuous-time Jacobians and the steps behind them.
pub(crate) struct Jacobians {
    pub a: DMatrix<f64>,
    pub b: DMatrix<f64>,
    pub c: DMatrix<f64>,
    pub y0: Vec<f64>,
    pub state_steps: Vec<f64>,
    pub input_steps: Vec<f64>,
}

/// The central-difference step for a value: ∛ε·max(|v|, 1), as represented at v.
fn step_at(value: f64) -> f64 {
    let h = f64::EPSILON.cbrt() * value.abs().max(1.0);
    (value + h) - value
}

/// A, B and C of `plant` at (x₀, u₀) by central differences (see the module's notes).
pub(crate) fn differentiate(
    plant: &mut Plant,
    x0: &[f64],
    u0: &[f64],
) -> Result<Jacobians, ReducedError> {
    let (n, m) = (x0.len(), u0.len());
    let (input_joints, joints) = (plant.input_joints, plant.joints);
    let efforts = |u: &[f64]| {
        let mut joint_efforts = vec![0.0; joints];
        for (&j, &value) in input_joints.iter().zip(u) {
            joint_efforts[j] = value;
        }
        joint_efforts
    };
    let u0_joints = efforts(u0);
    let mut state = MechanismState::default();
    let mut y0 = Vec::new();
    plant.dynamics.read_state(x0, &mut state)?;
    (plant.outputs)(&state, &mut y0);
    let p = y0.len();
    let (mut a, mut c) = (DMatrix::zeros(n, n), DMatrix::zeros(p, n));
    let (mut plus, mut minus) = (vec![0.0; n], vec![0.0; n]);
    let (mut y_plus, mut y_minus) = (Vec::new(), Vec::new());
    let mut state_steps = Vec::with_capacity(n);
    for j in 0..n {
        let h = step_at(x0[j]);
        state_steps.push(h);
        for (sign, rates, outputs) in [
            (1.0, &mut plus, &mut y_plus),
            (-1.0, &mut minus, &mut y_minus),
        ] {
            let mut x = x0.to_vec();
            x[j] += sign * h;
            plant.dynamics.rates(&x, &u0_joints, rates)?;
            plant.dynamics.read_state(&x, &mut state)?;
            (plant.outputs)(&state, outputs);
        }
        for i in 0..n {
            a[(i, j)] = (plus[i] - minus[i]) / (2.0 * h);
        }
        for i in 0..p {
            c[(i, j)] = (y_plus[i] - y_minus[i]) / (2.0 * h);
        }
    }
    let mut b = DMatrix::zeros(n, m);
    let mut input_steps = Vec::with_capacity(m);
    for k in 0..m {
        let h = step_at(u0[k]);
        input_steps.push(h);
        for (sign, rates) in [(1.0, &mut plus), (-1.0, &mut minus)] {
            let mut u = u0.to_vec();
            u[k] += sign * h;
            plant.dynamics.rates(x0, &efforts(&u), rates)?;
        }
        for i in 0..n {
            b[(i, k)] = (plus[i] - minus[i]) / (2.0 * h);
        }
    }
    Ok(Jacobians {
        a,
        b,
        c,
        y0,
        state_steps,
        input_steps,
    })
}

/// What [`LinearModel::assemble`] puts together besides the Jacobians.
pub(crate) struct Description {
    pub scenario: String,
    pub states: Vec<Channel>,
    pub inputs: Vec<Channel>,
    pub outputs: Vec<Channel>,
    pub outputs_left_out: Vec<(String, String)>,
    pub control_period: f64,
    pub time: f64,
    pub x0: Vec<f64>,
    pub u0: Vec<f64>,
}

impl LinearModel {
    /// The model from its Jacobians: the zero-order hold at the control period and the poles.
    pub(crate) fn assemble(
        description: Description,
        jacobians: Jacobians,
    ) -> Result<Self, ModelError> {
        let Jacobians { a, b, c, .. } = &jacobians;
        let finite = |m: &DMatrix<f64>| m.iter().all(|v| v.is_finite());
        for (what, matrix) in [("A", a), ("B", b), ("C", c)] {
            if !finite(matrix) {
                return Err(ModelError::NotFinite { what });
            }
        }
        let (ad, bd) = zero_order_hold(a, b, description.control_period)
            .ok_or(ModelError::NotFinite { what: "Ad, Bd" })?;
        let mut poles: Vec<[f64; 2]> = a
            .clone()
            .complex_eigenvalues()
            .iter()
            .map(|z| [z.re, z.im])
            .collect();
        poles.sort_by(|p, q| p[0].total_cmp(&q[0]).then(p[1].total_cmp(&q[1])));
        let rows = |m: &DMatrix<f64>| -> Vec<Vec<f64>> {
            m.row_iter().map(|r| r.iter().copied().collect()).collect()
        };
        Ok(Self {
            scenario: description.scenario,
            outputs_left_out: description.outputs_left_out,
            a: rows(a),
            b: rows(b),
            c: rows(c),
            d: vec![vec![0.0; description.inputs.len()]; description.outputs.len()],
            control_period: description.control_period,
            ad: rows(&ad),
            bd: rows(&bd),
            poles,
            operating_point: OperatingPoint {
                time: description.time,
                state: description.x0,
                efforts: description.u0,
                outputs: jacobians.y0,
            },
            states: description.states,
            inputs: description.inputs,
            outputs: description.outputs,
            state_steps: jacobians.state_steps,
            input_steps: jacobians.input_steps,
        })
    }

    /// G(jω) = C·(jω·I − A)⁻¹·B + D at `omega` (rad/s), per output and input as [re, im];
    /// `None` where jω is a pole.
    pub fn frequency_response(&self, omega: f64) -> Option<Vec<Vec<[f64; 2]>>> {
        let matrix = |rows: &[Vec<f64>], columns: usize| {
            DMatrix::from_fn(rows.len(), columns, |r, c| Complex::new(rows[r][c], 0.0))
        };
        let (n, m) = (self.states.len(), self.inputs.len());
        let a = matrix(&self.a, n);
        let shifted = DMatrix::from_fn(n, n, |r, c| {
            let diagonal = if r == c {
                Complex::new(0.0, omega)
            } else {
                Complex::new(0.0, 0.0)
            };
            diagonal - a[(r, c)]
        });
        let solved = shifted.lu().solve(&matrix(&self.b, m))?;
        let response = matrix(&self.c, n) * solved + matrix(&self.d, m);
        Some(
            response
                .row_iter()
                .map(|row| row.iter().map(|z| [z.re, z.im]).collect())
                .collect(),
        )
    }
}
