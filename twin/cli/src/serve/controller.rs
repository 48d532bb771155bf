//! The controller of a served run: the efforts are the commands the OPC UA client wrote last,
//! or (`--with-controller`) the scenario's controller's, its setpoint the client's.

use super::shared::Shared;
use framework::{
    Controller, ControllerError, Event, EventKind, Measurement, PlantInterface, SignalSpec,
};
use std::sync::Arc;

/// Copies the client's latest commands (`effort.<joint>`) into the efforts at each update.
pub struct ClientCommands {
    shared: Arc<Shared>,
}

impl ClientCommands {
    /// The controller reading `shared`'s commands.
    pub fn new(shared: Arc<Shared>) -> Self {
        Self { shared }
    }
}

impl Controller for ClientCommands {
    fn name(&self) -> &str {
        "opcua-client"
    }

    fn reset(&mut self, plant: &PlantInterface) -> Result<(), ControllerError> {
        self.shared.bind(plant.actuators.len());
        Ok(())
    }

    fn update(&mut self, _measurement: &Measurement, _period: f64, efforts: &mut [f64]) {
        self.shared.copy_commands(efforts);
    }

    /// The serving's own notes (deadline misses), raised as the run's warning events.
    fn drain_events(&mut self, events: &mut Vec<Event>) {
        let notes = self.shared.take_notes().into_iter();
        events.extend(notes.map(|text| Event::warning(EventKind::Note, text)));
    }
}

/// The scenario's own controller in a served run (`--with-controller`): every call goes to it,
/// and the serving's notes join its events.
pub struct ScenarioController {
    inner: Box<dyn Controller>,
    shared: Arc<Shared>,
}

impl ScenarioController {
    /// `inner`, with `shared`'s notes raised as its events.
    pub fn new(inner: Box<dyn Controller>, shared: Arc<Shared>) -> Self {
        Self { inner, shared }
    }
}

impl Controller for ScenarioController {
    fn name(&self) -> &str {
        self.inner.name()
    }

    fn reset(&mut self, plant: &PlantInterface) -> Result<(), ControllerError> {
        self.inner.reset(plant)
    }

    fn update(&mut self, measurement: &Measurement, period: f64, efforts: &mut [f64]) {
        self.inner.update(measurement, period, efforts);
    }

    fn internals(&self) -> Vec<SignalSpec> {
        self.inner.internals()
    }

    fn internal_values(&self, values: &mut [f64]) {
        self.inner.internal_values(values);
    }

    fn drain_events(&mut self, events: &mut Vec<Event>) {
        self.inner.drain_events(events);
        let notes = self.shared.take_notes().into_iter();
        events.extend(notes.map(|text| Event::warning(EventKind::Note, text)));
    }
}
