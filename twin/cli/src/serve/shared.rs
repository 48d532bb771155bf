//! What the OPC UA server and the run share: the commands (or the setpoint offset) the client
//! wrote, and the lockstep gate through which `Advance` lets the run go on.

use std::sync::{Condvar, Mutex, MutexGuard, PoisonError};
use std::time::Duration;
use twin::{SetpointSource, StopFlag};

/// How long the run waits for a grant before it looks at the stop flag again.
const STOP_POLL: Duration = Duration::from_millis(50);

/// The commands and the lockstep gate, behind one lock each.
#[derive(Debug, Default)]
pub struct Shared {
    commands: Mutex<Vec<f64>>,
    /// The offset on the scenario's reference triple (`--with-controller`).
    setpoint: Mutex<[f64; 3]>,
    /// What the run should log at its next control update (deadline misses).
    notes: Mutex<Vec<String>>,
    gate: Mutex<Gate>,
    changed: Condvar,
}

/// The lockstep bookkeeping: periods granted but not yet run, the control update reached, and
/// whether the run is over.
#[derive(Debug, Default)]
struct Gate {
    granted: u64,
    period: u64,
    ended: bool,
}

/// Why `Advance` gave up.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AdvanceRefusal {
    /// The run is over.
    Ended,
}

impl Shared {
    /// Commands for `actuators` actuators, all zero (when the controller binds to the plant).
    pub fn bind(&self, actuators: usize) {
        *self.commands() = vec![0.0; actuators];
    }

    fn commands(&self) -> MutexGuard<'_, Vec<f64>> {
        self.commands.lock().unwrap_or_else(PoisonError::into_inner)
    }

    fn gate(&self) -> MutexGuard<'_, Gate> {
        self.gate.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// Sets actuator `index`'s command (ignored beyond the actuators).
    pub fn set_command(&self, index: usize, value: f64) {
        if let Some(command) = self.commands().get_mut(index) {
            *command = value;
        }
    }

    /// Actuator `index`'s latest command (0 beyond the actuators).
    pub fn command(&self, index: usize) -> f64 {
        self.commands().get(index).copied().unwrap_or(0.0)
    }

    fn setpoint(&self) -> MutexGuard<'_, [f64; 3]> {
        self.setpoint.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// Sets component `index` of the reference offset (ignored beyond the three).
    pub fn set_setpoint(&self, index: usize, value: f64) {
        if let Some(component) = self.setpoint().get_mut(index) {
            *component = value;
        }
    }

    /// Component `index` of the reference offset (0 beyond the three).
    pub fn setpoint_component(&self, index: usize) -> f64 {
        self.setpoint().get(index).copied().unwrap_or(0.0)
    }

    /// Copies the latest commands into `efforts`.
    pub fn copy_commands(&self, efforts: &mut [f64]) {
        for (effort, command) in efforts.iter_mut().zip(self.commands().iter()) {
            *effort = *command;
        }
    }

    /// Asks for `text` to be logged as a warning event at the next control update.
    pub fn note(&self, text: String) {
        self.notes
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .push(text);
    }

    /// The notes asked for since the last call.
    pub fn take_notes(&self) -> Vec<String> {
        std::mem::take(&mut *self.notes.lock().unwrap_or_else(PoisonError::into_inner))
    }

    /// Lets the run go on `periods` control periods and waits (at most `timeout`) until it has
    /// reached the control update after them or ended; the control update reached.
    pub fn advance(&self, periods: u64, timeout: Duration) -> Result<u64, AdvanceRefusal> {
        let mut gate = self.gate();
        if gate.ended {
            return Err(AdvanceRefusal::Ended);
        }
        let target = gate.period.saturating_add(periods);
        gate.granted = gate.granted.saturating_add(periods);
        self.changed.notify_all();
        let (gate, _) = self
            .changed
            .wait_timeout_while(gate, timeout, |gate| gate.period < target && !gate.ended)
            .unwrap_or_else(PoisonError::into_inner);
        Ok(gate.period)
    }

    /// The run has reached control update `period`.
    pub fn reached(&self, period: u64) {
        self.gate().period = period;
        self.changed.notify_all();
    }

    /// Waits until a period is granted (and takes it) or a stop is asked for.
    pub fn take_grant(&self, stop: &StopFlag) {
        let mut gate = self.gate();
        while gate.granted == 0 && !gate.ended {
            if stop.load(std::sync::atomic::Ordering::Relaxed) != 0 {
                return;
            }
            gate = self
                .changed
                .wait_timeout(gate, STOP_POLL)
                .unwrap_or_else(PoisonError::into_inner)
                .0;
        }
        gate.granted = gate.granted.saturating_sub(1);
    }

    /// The run is over: every waiting `Advance` returns, later ones are refused.
    pub fn end(&self) {
        self.gate().ended = true;
        self.changed.notify_all();
    }
}

impl SetpointSource for Shared {
    fn offset(&self) -> [f64; 3] {
        *self.setpoint()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;

    #[test]
    fn advance_returns_once_the_run_reaches_its_target() {
        let shared = Arc::new(Shared::default());
        let run = {
            let shared = shared.clone();
            std::thread::spawn(move || {
                let stop = StopFlag::default();
                for period in 1..=3 {
                    shared.take_grant(&stop);
                    shared.reached(period);
                }
            })
        };
        assert_eq!(shared.advance(3, Duration::from_secs(10)), Ok(3));
        run.join().unwrap();
        shared.end();
        assert_eq!(
            shared.advance(1, Duration::from_secs(1)),
            Err(AdvanceRefusal::Ended)
        );
    }
}
