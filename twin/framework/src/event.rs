//! Events: what happened during a run, for a person (`text`) and for a program (`kind`).

/// How serious an event is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum EventLevel {
    /// Worth knowing, nothing wrong: a mode switch, a design report, the run's end.
    Info,
    /// Something to look at that does not end the run: a saturation, a fault, a collision.
    Warning,
    /// The run failed: it diverged, or a collision stopped it.
    Error,
}

/// What an event is, for a program to match (never the text).
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub enum EventKind {
    /// A controller entered another mode or phase; `mode` is its identifier in snake case
    /// (`cutting_stroke`, `power_loop`, `correction_engaged`, …), listed on each controller.
    ModeSwitch {
        /// The mode entered, in snake case.
        mode: String,
    },
    /// A command reached a limit (an effort clipped to its actuator limit, a feed bound); the
    /// subject is the actuator's joint or the limited quantity.
    SaturationStart {
        /// The saturated actuator's joint, or the limited quantity.
        subject: String,
    },
    /// A command that was at its limit is back within it.
    SaturationEnd {
        /// The actuator's joint, or the quantity, as in the matching start.
        subject: String,
    },
    /// What a controller designed at reset (gains, poles) or a condition its design does not meet.
    Design,
    /// The run diverged: a signal left its bounds (the summary's `failure`).
    Divergence,
    /// The run was stopped on request (a signal).
    Interruption,
    /// An injected fault (the scenario's `[[faults]]` entry `name`) began.
    FaultOnset {
        /// The fault's `name` in the scenario.
        name: String,
    },
    /// An injected fault ended.
    FaultCleared {
        /// The fault's `name` in the scenario.
        name: String,
    },
    /// Two links or bodies that may not touch started to (a crash: not an adjacent pair, not in
    /// the scenario's `[[allowed_contacts]]`); the text says how deep and where.
    Collision {
        /// The first link or body (links before bodies).
        a: String,
        /// The link or body it hits.
        b: String,
    },
    /// Anything else worth a line in the log.
    Note,
}

/// One event: its level, its kind and the sentence a person reads.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Event {
    /// How serious it is.
    pub level: EventLevel,
    /// What happened, for a program to match.
    pub kind: EventKind,
    /// One sentence for the log, for a person.
    pub text: String,
}

impl Event {
    /// An event of `kind` at information level.
    pub fn info(kind: EventKind, text: impl Into<String>) -> Self {
        Self {
            level: EventLevel::Info,
            kind,
            text: text.into(),
        }
    }

    /// An event of `kind` at warning level.
    pub fn warning(kind: EventKind, text: impl Into<String>) -> Self {
        Self {
            level: EventLevel::Warning,
            kind,
            text: text.into(),
        }
    }

    /// An event of `kind` at error level.
    pub fn error(kind: EventKind, text: impl Into<String>) -> Self {
        Self {
            level: EventLevel::Error,
            kind,
            text: text.into(),
        }
    }

    /// A mode switch into `mode`, at information level.
    pub fn mode(mode: &str, text: impl Into<String>) -> Self {
        Self::info(
            EventKind::ModeSwitch {
                mode: mode.to_string(),
            },
            text,
        )
    }

    /// The mode entered, if this is a mode switch.
    pub fn mode_entered(&self) -> Option<&str> {
        match &self.kind {
            EventKind::ModeSwitch { mode } => Some(mode),
            _ => None,
        }
    }
}
