//! The controllers of the twin, one file each, and the control-design math behind them
//! ([`design`]).
//!
//! Each controller has a parameters struct, a *design* function that turns the parameters and the
//! plant into gains, and the *law* (a [`framework::Controller`]) that applies them. What a
//! controller is, what it sees and how it is chosen by name is the vocabulary of the `framework`
//! crate; this crate is the collection, gathered by [`builtin`].

#![warn(missing_docs)]

mod check;
pub mod design;

pub mod arm;
pub mod feed_axis;
pub mod filters;
pub mod generic;
pub mod lathe;
pub mod milling;
pub mod passive;
pub mod platform;
pub mod whitworth;

use framework::Registry;

/// Every controller shipped with the twin, in the order `twin list` shows them.
pub fn builtin() -> Registry {
    Registry::with([
        passive::entry(),
        generic::joint_pid::entry(),
        generic::replay::entry(),
        generic::computed_torque::entry(),
        generic::lqr::entry(),
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
    ])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::whitworth::crank_pi::CrankPiParams;
    use framework::{parse_params, ControllerError, ANY_MACHINE};

    fn table(text: &str) -> toml::Table {
        text.parse().unwrap()
    }

    #[test]
    fn build_checks_the_name_and_the_machine() {
        let registry = builtin();
        let err = registry
            .build("p-pi", "whitworth", &toml::Table::new())
            .err()
            .unwrap();
        assert_eq!(
            err,
            ControllerError::WrongMachine {
                controller: "p-pi".into(),
                machine: "whitworth".into(),
                written_for: "feed_axis".into(),
            }
        );
        assert_eq!(
            err.to_string(),
            "controller `p-pi` is written for machine `feed_axis`, not `whitworth`"
        );
        // The machine is checked before the parameters are read.
        let err = registry
            .build("p-pi", "whitworth", &table("mass_estimate = -1.0"))
            .err()
            .unwrap();
        assert!(matches!(err, ControllerError::WrongMachine { .. }), "{err}");
        let err = registry
            .build("no-such", "whitworth", &toml::Table::new())
            .err()
            .unwrap();
        assert!(
            matches!(
                &err,
                ControllerError::Unknown { name, known }
                    if name == "no-such" && known.contains("crank-pi")
            ),
            "{err}"
        );
        for machine in ["whitworth", "arm", "feed_axis"] {
            assert!(registry
                .build("passive", machine, &toml::Table::new())
                .is_ok());
        }
        assert!(registry
            .build("p-pi", "feed_axis", &toml::Table::new())
            .is_ok());
    }

    #[test]
    fn every_builtin_entry_builds_with_its_defaults_on_its_machine() {
        let registry = builtin();
        for entry in registry.entries() {
            assert_eq!(registry.entry(entry.name).map(|e| e.name), Some(entry.name));
            let machine = if entry.machine == ANY_MACHINE {
                "whitworth"
            } else {
                entry.machine
            };
            let built = registry.build(entry.name, machine, &toml::Table::new());
            assert!(built.is_ok(), "{}: {:?}", entry.name, built.err());
        }
        assert!(registry.entry("no-such").is_none());
    }

    #[test]
    fn serde_errors_carry_the_key_path() {
        let err = parse_params::<CrankPiParams>("crank-pi", &table("natural_frequency = \"fast\""))
            .unwrap_err();
        let ControllerError::BadParameter {
            key, value, reason, ..
        } = &err
        else {
            panic!("{err:?}");
        };
        assert_eq!((key.as_str(), value), ("natural_frequency", &None));
        assert!(reason.starts_with("invalid type: string"), "{reason}");
        assert!(
            err.to_string()
                .starts_with("controller `crank-pi`: params.natural_frequency: invalid type"),
            "{err}"
        );
        let err = parse_params::<CrankPiParams>("crank-pi", &table("gain = 1.0")).unwrap_err();
        assert!(
            matches!(
                &err,
                ControllerError::BadParameter { key, reason, .. }
                    if key == "gain" && reason.starts_with("unknown field `gain`")
            ),
            "{err:?}"
        );
    }

    #[test]
    fn non_finite_numbers_are_named_with_their_value() {
        let err = parse_params::<CrankPiParams>("crank-pi", &table("inertia = nan")).unwrap_err();
        assert_eq!(
            err,
            ControllerError::BadParameter {
                controller: "crank-pi".into(),
                key: "inertia".into(),
                value: Some("NaN".into()),
                reason: "must be a finite number".into(),
            }
        );
        assert_eq!(
            err.to_string(),
            "controller `crank-pi`: params.inertia = NaN: must be a finite number"
        );
    }
}
