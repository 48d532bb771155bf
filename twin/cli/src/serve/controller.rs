//! The controller of a served run: the efforts are the commands the OPC UA client wrote last.

use super::shared::Shared;
use framework::{Controller, ControllerError, Event, EventKind, Measurement, PlantInterface};
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
