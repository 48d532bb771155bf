//! The shadow's own OPC UA server: its estimates, residuals, alarms and parameters published as
//! it goes, for an HMI. Nothing is ever written to the machine.

use crate::failure::Failure;
use crate::machine_link::{PublishedValue, PublishedVariable, ShadowServer, VariableKind};
use std::time::Duration;
use twin::shadowing::{Shadow, ShadowStep};

/// How long the shadow's server stays up after the end, so that a client's last read answers.
const LINGER: Duration = Duration::from_millis(300);

/// The shadow's own server, if asked for.
pub struct Publisher {
    server: Option<ShadowServer>,
    anomalies: usize,
}

/// The published variables: per watched signal its estimate, residual and normalised residual,
/// then the alarm, the anomaly count and the last anomaly's line, then per tracked parameter its
/// estimate and standard deviation.
fn variables(shadow: &Shadow) -> Vec<PublishedVariable> {
    let variable =
        |folder: &str, name: String, unit: &str, description: String| PublishedVariable {
            folder: folder.into(),
            name,
            unit: unit.into(),
            description,
            kind: VariableKind::Double,
        };
    let mut all = Vec::new();
    let units = shadow.columns().signals.clone();
    for name in shadow.watched() {
        let unit = units.iter().find(|(s, _)| s == name).map_or("", |(_, u)| u);
        let say = |what: &str| format!("{name}: {what}, SI");
        all.push(variable(
            "Estimates",
            name.clone(),
            unit,
            say("the twin's estimate"),
        ));
        all.push(variable(
            "Residuals",
            name.clone(),
            unit,
            say("measured less predicted"),
        ));
        all.push(variable(
            "Residuals",
            format!("{name}.normalised"),
            "1",
            say("residual over its predicted standard deviation"),
        ));
    }
    let mut alarm = variable("Alarms", "alarm".into(), "", "an anomaly is open".into());
    alarm.kind = VariableKind::Boolean;
    all.push(alarm);
    all.push(variable(
        "Alarms",
        "anomalies".into(),
        "1",
        "anomalies so far".into(),
    ));
    let mut last = variable(
        "Alarms",
        "last_anomaly".into(),
        "",
        "the last anomaly".into(),
    );
    last.kind = VariableKind::Text;
    all.push(last);
    for key in shadow.parameters() {
        let say = |what: &str| format!("{key}: {what}, SI");
        all.push(variable("Parameters", key.clone(), "", say("estimate")));
        all.push(variable("Parameters", format!("{key}.sigma"), "", say("σ")));
    }
    all
}

impl Publisher {
    /// Starts the server at `endpoint`, if given.
    pub fn start(endpoint: Option<&str>, shadow: &Shadow) -> Result<Self, Failure> {
        let server = endpoint
            .map(|url| {
                let namespace = format!("urn:twin:shadow:{}", shadow.scenario_name());
                ShadowServer::start(url, &namespace, "shadow", &variables(shadow))
            })
            .transpose()?;
        Ok(Self {
            server,
            anomalies: 0,
        })
    }

    /// Publishes one processed step.
    pub fn publish(&mut self, shadow: &Shadow, step: &ShadowStep) -> Result<(), Failure> {
        let Some(server) = &self.server else {
            return Ok(());
        };
        let w = shadow.watched().len();
        let mut values = Vec::with_capacity(3 * w + 3);
        for (s, estimate) in step.estimate.iter().enumerate() {
            values.push((3 * s, PublishedValue::Double(*estimate)));
        }
        let residuals = step.innovation.residual.iter();
        let variances = step.innovation.variance.iter();
        for ((s, residual), variance) in
            step.innovation.signals.iter().zip(residuals).zip(variances)
        {
            values.push((3 * s + 1, PublishedValue::Double(*residual)));
            values.push((
                3 * s + 2,
                PublishedValue::Double(residual / variance.sqrt()),
            ));
        }
        values.push((3 * w, PublishedValue::Boolean(step.detector.alarm)));
        if let Some(change) = &step.change {
            self.anomalies +=
                usize::from(matches!(change, twin::shadowing::AnomalyChange::Opened(_)));
            let line = twin::shadowing::describe(change).1;
            values.push((3 * w + 1, PublishedValue::Double(self.anomalies as f64)));
            values.push((3 * w + 2, PublishedValue::Text(line)));
        }
        for (j, (estimate, sigma)) in step.parameters.iter().enumerate() {
            values.push((3 * w + 3 + 2 * j, PublishedValue::Double(*estimate)));
            values.push((3 * w + 4 + 2 * j, PublishedValue::Double(*sigma)));
        }
        let source = shadow.origin().unwrap_or(0.0) + step.time;
        server.set(&values, source)?;
        Ok(())
    }

    /// Stops the server.
    pub fn stop(&mut self) {
        if let Some(server) = self.server.take() {
            server.stop(LINGER);
        }
    }
}
