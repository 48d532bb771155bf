//! Controllers of the twin and the control-design math behind them.
//!
//! A controller acts on a machine only through joint efforts (torques on revolute joints, forces on
//! prismatic joints). It sees a [`Measurement`]: named sensor, task-space, process and reference
//! signals, laid out by the [`PlantInterface`] it is bound to at [`Controller::reset`].

mod check;
pub mod controller;
pub mod design;
pub mod event;
pub mod registry;
pub mod signal;

pub use controller::{
    parameter_message, Actuator, Controller, ControllerError, EffortKind, Measurement,
    PlantInterface,
};
pub use event::{Event, EventKind, EventLevel};
pub use registry::{parse_params, Registry};
pub use signal::{SignalSpec, Unit};

pub mod arm;
pub mod feed_axis;
pub mod filters;
pub mod lathe;
pub mod milling;
pub mod passive;
pub mod platform;
pub mod whitworth;

/// Every controller shipped with the twin, in the order `twin list` shows them.
fn builtin_entries() -> Vec<registry::Entry> {
    vec![
        passive::entry(),
        whitworth::crank_pi::entry(),
        whitworth::osmc::entry(),
        whitworth::ffc::entry(),
        whitworth::lqt::entry(),
        whitworth::smc2::entry(),
        arm::path_speed_adaptive::entry(),
        arm::path_speed_constant::entry(),
        platform::energy_optimal::entry(),
        platform::pid::entry(),
        feed_axis::p_pi::entry(),
        feed_axis::stsmc::entry(),
        feed_axis::stsmc_dob::entry(),
        lathe::output_feedback_force::entry(),
        milling::spindle_constant::entry(),
        milling::spindle_programme::entry(),
        milling::spindle_optimal_linear::entry(),
    ]
}
