//! Parallel turning after Sudhakara & Landers (ACC 2003): the open-loop process ([`process`]) and
//! the power-feedback loop with its phase-plane analysis ([`closed_loop`]).

pub mod closed_loop;
pub mod process;

pub use closed_loop::{
    eigenvalues, Eigenvalue, Equilibrium, EquilibriumKind, FeedLimit, FeedRegime, ForceBox,
    Nullclines, PhasePortrait, PortraitSpec, PowerLoop, ReverseTrajectorySpec, SaturationLine,
    TimeDirection, Trajectory, PAPER_STEP,
};
pub use process::{
    cutting_coefficient_from_paper_units, reference_forces, spindle_power, Lathe, LatheError,
    LatheParams, ToolParams, TOOLS,
};
