//! Whitworth quick-return shaper controllers: the crank-speed PI and the task-space controllers.
//!
//! Task-space control of the Whitworth quick-return shaper after Perrusquía, Flores-Campos & Yu,
//! "Optimal sliding mode control for cutting tasks of quick-return mechanisms", ISA Transactions
//! 122 (2022) 88–95: the ram is controlled in the task space through crank torque during the
//! cutting stroke, the crank returned open loop through the singular points.
//!
//! - [`slider`]: the ram's dynamics (Perrusquía eqs (7)–(10)) for the twin's linkage and the
//!   Jacobian compensator (Perrusquía eq (33));
//! - [`switching`]: the stroke switching criterion (Fig. 4) and the open-loop return;
//! - [`task`]: the reference (Algorithm 1 or the scenario's) and the controller frame shared by
//! - [`osmc`] (the paper's controller), [`ffc`], [`lqt`] and [`smc2`] (its baselines, §6.1);
//! - [`crank_pi`]: the crank-speed PI the paper starts from (its §1), in joint space.

pub mod crank_pi;
pub mod ffc;
pub mod lqt;
pub mod osmc;
pub mod slider;
pub mod smc2;
pub mod switching;
pub mod task;

#[cfg(test)]
mod task_tests;
#[cfg(test)]
mod test_plant;
