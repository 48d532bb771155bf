//! The simulator an FMU steps: the scenario's plant alone, or its closed loop with the
//! scenario's controller.

use framework::Registry;
use twin::{LoadedScenario, Simulator, TwinError};

/// The FMU's simulator: the plant alone, or with `controlled` the closed loop with the
/// scenario's controller built from `registry`.
pub(crate) fn simulator(
    loaded: LoadedScenario,
    controlled: bool,
    registry: &Registry,
) -> Result<Simulator, TwinError> {
    if controlled {
        Simulator::with_controller(loaded, registry)
    } else {
        Simulator::new(loaded)
    }
}
