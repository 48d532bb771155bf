//! The twin's equations of motion against Rapier's own mass matrix, and the integrator against
//! closed forms.

use super::*;
use crate::urdf;

fn whitworth() -> Mechanism {
    let text = include_str!("../../../urdf/whitworth.urdf");
    urdf::load_str(text, "whitworth.urdf").expect("loads")
}

#[test]
fn mass_matrix_matches_rapiers_own() {
    let mechanism = whitworth();
    let mut physics = Physics::new(
        &mechanism,
        SolverSettings {
            dt: 1e-3,
            gravity: [0.0, -9.81],
            substeps: 1,
        },
    );
    let n = physics.q.len();
    for configuration in 0..5 {
        let q: Vec<f64> = (0..n)
            .map(|g| 0.7 * ((configuration * n + g) as f64).sin())
            .collect();
        physics.rapier.pose(&mechanism, &q, &mut physics.kin);
        let ours: Vec<f64> = (0..n)
            .map(|g| {
                let mut column = vec![0.0; n];
                physics
                    .dynamics
                    .inverse_mass_column(&physics.model, &physics.kin, g, &mut column);
                column[g]
            })
            .collect();
        let rapiers = physics.rapier.rapier_inverse_mass_diagonal(n);
        for g in 0..n {
            assert!(
                (ours[g] - rapiers[g]).abs() <= 1e-12 * rapiers[g].abs(),
                "coordinate {g}: twin {} vs Rapier {}",
                ours[g],
                rapiers[g]
            );
        }
    }
}
