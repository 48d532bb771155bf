//! Control-design math for the twin's controllers: Riccati/LQR, pole placement and the optimal
//! sliding hyperplane of the Whitworth OSMC paper (Perrusquía et al. 2022, §5).

pub mod care;
pub mod lqr;
pub mod pole_placement;
pub mod sliding_surface;

pub use care::{solve_care, solve_care_with, CareError, CareOptions, CareSolution};
pub use lqr::{lqr, Lqr};
pub use pole_placement::{
    ackermann, characteristic_polynomial, place_poles, second_order_polynomial, Pole,
    PolePlacementError,
};
pub use sliding_surface::{
    optimal_hyperplane, slider_hyperplane, slider_state_space, SliderWeights, SlidingHyperplane,
    SlidingSurfaceError,
};
