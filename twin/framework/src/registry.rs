//! Controllers chosen by name at run time: the registry of names, machines and constructors.

use crate::{Controller, ControllerError};

/// Builds a controller from the scenario's `[controller.params]` table.
pub type Constructor = fn(&toml::Table) -> Result<Box<dyn Controller>, ControllerError>;

/// One registered controller.
#[derive(Clone)]
pub struct Entry {
    /// The name a scenario's `[controller] name` selects, e.g. `crank-pi`.
    pub name: &'static str,
    /// The machine it is written for ([`ANY_MACHINE`] for any): [`Registry::build`] refuses it
    /// for another.
    pub machine: &'static str,
    /// One line on what the controller does, for listings.
    pub summary: &'static str,
    /// Builds the controller from its parameter table.
    pub build: Constructor,
}

/// Name → constructor. The `controllers` crate's `builtin()` holds the project's controllers; a
/// downstream crate adds its own with [`Registry::register`].
#[derive(Clone, Default)]
pub struct Registry {
    entries: Vec<Entry>,
}

/// [`Entry::machine`] of a controller written for any machine.
pub const ANY_MACHINE: &str = "*";

impl Registry {
    /// A registry holding `entries`, in their order (a later entry replaces an earlier one of the
    /// same name).
    pub fn with(entries: impl IntoIterator<Item = Entry>) -> Self {
        let mut registry = Self::default();
        for entry in entries {
            registry.register(entry);
        }
        registry
    }

    /// Adds (or replaces, by name) a controller.
    pub fn register(&mut self, entry: Entry) {
        self.entries.retain(|e| e.name != entry.name);
        self.entries.push(entry);
    }

    /// The registered controllers, in registration order.
    pub fn entries(&self) -> &[Entry] {
        &self.entries
    }

    /// The controller called `name`, if registered.
    pub fn entry(&self, name: &str) -> Option<&Entry> {
        self.entries.iter().find(|e| e.name == name)
    }

    /// Builds the controller called `name` for the machine called `machine` from its parameter
    /// table. Fails, before any parameter is read, when no controller has that name or it is
    /// written for another machine.
    pub fn build(
        &self,
        name: &str,
        machine: &str,
        params: &toml::Table,
    ) -> Result<Box<dyn Controller>, ControllerError> {
        let entry = self.entry(name).ok_or_else(|| ControllerError::Unknown {
            name: name.to_string(),
            known: self
                .entries
                .iter()
                .map(|e| e.name)
                .collect::<Vec<_>>()
                .join(", "),
        })?;
        if entry.machine != ANY_MACHINE && entry.machine != machine {
            return Err(ControllerError::WrongMachine {
                controller: name.to_string(),
                machine: machine.to_string(),
                written_for: entry.machine.to_string(),
            });
        }
        (entry.build)(params)
    }
}
