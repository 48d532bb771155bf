//! Parallel-lathe output-feedback power control (Sudhakara & Landers 2003) and its design.

pub mod output_feedback_design;
pub mod output_feedback_force;
