//! How a run or a study hears SIGINT and SIGTERM, so that it can finish its files first.

use crate::failure::Failure;
use twin::StopFlag;

/// SIGINT and SIGTERM ask the run to stop (it finishes its files); a second one ends the
/// process at once. SIGXFSZ is caught too, so that a file-size limit fails a write with its
/// error instead of killing the process.
pub fn stop_on_signals() -> Result<StopFlag, Failure> {
    use signal_hook::consts::{SIGINT, SIGTERM, SIGXFSZ};
    use signal_hook::flag;
    let stop = StopFlag::default();
    let requested = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let install = || -> std::io::Result<()> {
        for signal in [SIGINT, SIGTERM] {
            flag::register_conditional_shutdown(signal, 128 + signal, requested.clone())?;
            flag::register(signal, requested.clone())?;
            flag::register_usize(signal, stop.clone(), signal as usize)?;
        }
        flag::register(SIGXFSZ, std::sync::Arc::new(Default::default()))?;
        Ok(())
    };
    install().map_err(|e| format!("cannot install the signal handlers: {e}"))?;
    Ok(stop)
}
