//! A scenario's plant linearised at an operating point: ẋ = A·x + B·u, y = C·x + D·u about
//! (x₀, u₀), its zero-order-hold discretisation at the control period, its poles and frequency
//! response — what a control engineer designs a controller on before trying it on the twin.
//!
//! States are a minimal set: the independent joint coordinates and their rates
//! ([`crate::physics::ReducedDynamics`]); inputs the efforts at the actuated joints; outputs the
//! machine's measured signals without the sensors' quantisation and noise.
//!
//! **Derivatives.** The exact engine has no analytic derivatives of its equations (they are
//! assembled from Rapier's Jacobians), so A, B and C are central differences,
//! (f(x + h·eⱼ) − f(x − h·eⱼ)) / 2h, with a step per coordinate hⱼ = ∛ε·max(|xⱼ|, 1) (in SI:
//! 6.1·10⁻⁶ m or rad, m/s or rad/s, N or N·m at the scale of one unit), the step that balances
//! the O(h²) truncation against the O(ε/h) round-off; the step actually taken is the
//! representable (x + h) − x. f is affine in the efforts, so B is exact to round-off. D is zero:
//! the outputs kept are functions of the state alone.
//!
//! This file only declares the modules and re-exports what the library shows.

mod expm;
mod model;
mod report;
#[cfg(test)]
mod tests;

pub(crate) use model::{differentiate, Description, Plant};
pub use model::{Channel, LinearModel, ModelError, OperatingPoint};
