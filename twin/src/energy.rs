//! Mechanical energy of a mechanism: a check on the integrator, conserved by a passive, undamped
//! linkage.

use crate::mechanism::Mechanism;
use crate::physics::MechanismState;

/// Kinetic plus gravitational potential energy, J.
pub fn mechanical_energy(mechanism: &Mechanism, state: &MechanismState, gravity: [f64; 2]) -> f64 {
    mechanism
        .links
        .iter()
        .enumerate()
        .filter_map(|(i, link)| link.inertial.map(|inertial| (i, inertial)))
        .map(|(i, inertial)| {
            let pose = state.link_poses[i];
            let [cx, cy] = inertial.centre_of_mass;
            let offset = pose.rotate(cx, cy);
            let omega = state.link_angular_velocities[i];
            let [vx, vy] = state.link_velocities[i];
            // Velocity of the centre of mass: v_origin + ω × r.
            let (ux, uy) = (vx - omega * offset[1], vy + omega * offset[0]);
            let kinetic =
                0.5 * inertial.mass * (ux * ux + uy * uy) + 0.5 * inertial.izz * omega * omega;
            let com = [pose.x + offset[0], pose.y + offset[1]];
            let potential = -inertial.mass * (gravity[0] * com[0] + gravity[1] * com[1]);
            kinetic + potential
        })
        .sum()
}
