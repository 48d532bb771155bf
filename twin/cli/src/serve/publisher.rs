//! The observer of a served run: starts the server on the run's names, publishes the measured
//! signals (and the scenario's controller's commands, when it is inside) and the status at each
//! control update, stamped with its simulated time mapped to the wall clock, and paces the run
//! (wall clock or lockstep).

use super::address_space::Commanding;
use super::pacing::Pacing;
use super::sampling::SourceClock;
use super::server::{OpcUaServer, Published};
use super::shared::Shared;
use opcua::types::{DataValue, DateTime, Variant};
use std::sync::Arc;
use twin::{Findings, Observer, ObserverError, RunSummary, SignalLayout, StepView, StopFlag};

/// How the run keeps time with the world.
#[derive(Debug)]
pub enum Pace {
    /// Simulated time at `rate` × the wall clock.
    WallClock(Pacing),
    /// One control period per period the client grants with `Advance`.
    Lockstep,
}

/// Publishes a run to its OPC UA server.
pub struct Publisher {
    server: OpcUaServer,
    machine: String,
    shared: Arc<Shared>,
    pace: Pace,
    stop: StopFlag,
    commanding: Commanding,
    published: Option<Published>,
    /// The scenario's control period, s.
    control_period: f64,
    /// The source timestamps of the published values.
    clock: SourceClock,
    /// The simulated time of the last control update published, s.
    last_update: f64,
    /// Control updates reached so far.
    updates: u64,
    /// The text of the run's last event, published as `status.last_event`.
    last_event: String,
}

impl Publisher {
    /// A publisher serving `machine` on `server`, its actuators commanded as `commanding` says,
    /// every `control_period` s of simulated time.
    pub fn new(
        server: OpcUaServer,
        machine: &str,
        shared: Arc<Shared>,
        pace: Pace,
        control_period: f64,
        stop: StopFlag,
        commanding: Commanding,
    ) -> Self {
        Self {
            server,
            machine: machine.to_string(),
            shared,
            pace,
            stop,
            commanding,
            published: None,
            control_period,
            clock: SourceClock::default(),
            last_update: 0.0,
            updates: 0,
            last_event: String::new(),
        }
    }

    /// The deadline misses so far (none in lockstep).
    pub fn deadline_misses(&self) -> u64 {
        match &self.pace {
            Pace::WallClock(pacing) => pacing.misses,
            Pace::Lockstep => 0,
        }
    }

    /// Publishes how the run ended, stamped one control period after its last control update,
    /// and hands back the server, to be stopped.
    pub fn ended(mut self, summary: &RunSummary) -> OpcUaServer {
        let state = match (&summary.failure, &summary.interrupted) {
            (Some(_), _) => "diverged",
            (None, Some(_)) => "interrupted",
            (None, None) => "finished",
        };
        let stamp = self.clock.stamp(self.last_update + self.control_period);
        if let Some(published) = &self.published {
            let id = &published.nodes.status[3];
            let value = stamped(Variant::from(state), stamp);
            // The run is over either way; a client that misses the last state sees the run end.
            let _ = published
                .manager
                .set_value(&published.subscriptions, id, None, value);
        }
        self.server
    }

    fn publish(&mut self, view: &StepView) -> Result<(), ObserverError> {
        if let Some(event) = view.events.last() {
            self.last_event.clone_from(&event.text);
        }
        let stamp = self.clock.stamp(view.time);
        self.last_update = view.time;
        let Some(published) = &self.published else {
            return Ok(());
        };
        let status = [
            Variant::Double(view.time),
            Variant::UInt64(view.step as u64),
            Variant::UInt64(self.updates),
            Variant::from("running"),
            Variant::UInt64(self.deadline_misses()),
            Variant::from(self.last_event.as_str()),
        ];
        let nodes = &published.nodes;
        let signals = (nodes.signals.iter()).zip(view.measured.iter().map(|v| Variant::Double(*v)));
        // Empty when the client commands: its own writes are what the efforts read.
        let efforts =
            (nodes.efforts.iter()).zip(view.commanded.iter().map(|v| Variant::Double(*v)));
        let values = signals
            .chain(efforts)
            .chain(nodes.status.iter().zip(status))
            .map(|(id, value)| (id, None, stamped(value, stamp)));
        published
            .manager
            .set_values(&published.subscriptions, values)
            .map_err(|status| format!("cannot publish the run's values: {status}").into())
    }
}

/// `value` with source timestamp `source`, received by the server now.
fn stamped(value: Variant, source: DateTime) -> DataValue {
    DataValue {
        source_timestamp: Some(source),
        ..DataValue::new_now(value)
    }
}

/// Deadline misses logged as events, at most; later ones are only counted.
const LOGGED_MISSES: u64 = 20;

/// Asks for miss number `misses` to be logged (the first [`LOGGED_MISSES`], then one line saying
/// the rest are only counted).
fn log_miss(shared: &Shared, misses: u64, time: f64, late: f64) {
    if misses <= LOGGED_MISSES {
        shared.note(format!(
            "deadline miss: the control update at t = {time:.6} s came {:.3} ms late",
            late * 1e3
        ));
    } else if misses == LOGGED_MISSES + 1 {
        shared.note(format!(
            "deadline misses: more than {LOGGED_MISSES}; the rest are counted, not logged"
        ));
    }
}

impl Observer for Publisher {
    fn start(&mut self, layout: &SignalLayout) -> Result<(), ObserverError> {
        self.published = Some((self.server).start(
            &self.machine,
            layout,
            &self.shared,
            self.commanding,
            self.control_period,
        )?);
        Ok(())
    }

    fn observe(&mut self, view: &StepView) -> Result<(), ObserverError> {
        if view.control_update {
            if let Pace::WallClock(pacing) = &mut self.pace {
                if let Some(late) = pacing.wait_until(view.time) {
                    log_miss(&self.shared, pacing.misses, view.time, late);
                }
            }
            self.publish(view)?;
            self.shared.reached(self.updates);
            if matches!(self.pace, Pace::Lockstep) && !view.last {
                self.shared.take_grant(&self.stop);
            }
            self.updates += 1;
        }
        if view.last {
            self.shared.end();
        }
        Ok(())
    }

    fn finish(&mut self) -> Result<Findings, ObserverError> {
        self.shared.end();
        let mut metrics = Vec::new();
        if let Pace::WallClock(pacing) = &self.pace {
            metrics.push(("serve.deadline_misses".into(), pacing.misses as f64));
            metrics.push(("serve.worst_lateness_s".into(), pacing.worst_lateness));
        }
        Ok(Findings {
            metrics,
            warnings: Vec::new(),
        })
    }
}
