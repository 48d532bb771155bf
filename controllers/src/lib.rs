//! Controllers of the twin and the control-design math behind them.
//!
//! A controller acts on a machine only through joint efforts (torques on revolute joints, forces on
//! prismatic joints). It sees a [`Measurement`]: named sensor, task-space, process and reference
//! signals, laid out by the [`PlantInterface`] it is bound to at [`Controller::reset`].

pub mod controller;
pub mod design;
pub mod event;
pub mod registry;
pub mod signal;

pub use controller::{
    Actuator, Controller, ControllerError, EffortKind, Measurement, PlantInterface,
};
pub use event::{Event, EventKind, EventLevel};
pub use registry::{parse_params, Registry};
pub use signal::{SignalSpec, Unit};

pub mod arm_servo;
pub mod crank_pi;
pub mod energy_optimal;
pub mod filters;
pub mod lathe_force;
pub mod output_feedback_design;
pub mod p_pi;
pub mod passive;
pub mod path_speed_adaptive;
pub mod path_speed_constant;
pub mod platform_guidance;
pub mod platform_model;
pub mod platform_pid;
pub mod spindle_constant;
pub mod spindle_optimal_linear;
pub mod spindle_programme;
pub mod spindle_speed;
pub mod stsmc;
pub mod stsmc_dob;
pub mod whitworth;

/// Every controller shipped with the twin, in the order `twin list` shows them.
fn builtin_entries() -> Vec<registry::Entry> {
    vec![
        passive::entry(),
        crank_pi::entry(),
        whitworth::osmc::entry(),
        whitworth::ffc::entry(),
        whitworth::lqt::entry(),
        whitworth::smc2::entry(),
        path_speed_adaptive::entry(),
        path_speed_constant::entry(),
        energy_optimal::entry(),
        platform_pid::entry(),
        p_pi::entry(),
        stsmc::entry(),
        stsmc_dob::entry(),
        lathe_force::entry(),
        spindle_constant::entry(),
        spindle_programme::entry(),
        spindle_optimal_linear::entry(),
    ]
}
