//! A linear model as JSON for scripts (`linear.json`) and as a table for people.

use super::model::{Channel, LinearModel};
use serde_json::{json, Value};
use std::fmt::Write;

/// Where `linear.json` gives the frequency response, rad/s: two points a decade over 0.1–10⁵.
pub const FREQUENCIES: [f64; 13] = [
    0.1, 0.316, 1.0, 3.16, 10.0, 31.6, 100.0, 316.0, 1e3, 3.16e3, 1e4, 3.16e4, 1e5,
];

fn channels(list: &[Channel]) -> Value {
    list.iter()
        .map(|c| json!({ "name": c.name, "unit": c.unit }))
        .collect()
}

impl LinearModel {
    /// `linear.json`: names with units, the matrices (row-major), the poles, the operating
    /// point, the difference steps and the frequency response at 0.1–10⁵ rad/s, two points a
    /// decade.
    pub fn to_json(&self) -> Value {
        let response: Vec<Value> = FREQUENCIES
            .iter()
            .filter_map(|&omega| {
                let g = self.frequency_response(omega)?;
                let part = |k: usize| -> Vec<Vec<f64>> {
                    g.iter()
                        .map(|row| row.iter().map(|z| z[k]).collect())
                        .collect()
                };
                Some(json!({ "omega": omega, "real": part(0), "imag": part(1) }))
            })
            .collect();
        let left_out: Vec<Value> = self
            .outputs_left_out
            .iter()
            .map(|(name, reason)| json!({ "name": name, "reason": reason }))
            .collect();
        let point = &self.operating_point;
        json!({
            "scenario": self.scenario,
            "states": channels(&self.states),
            "inputs": channels(&self.inputs),
            "outputs": channels(&self.outputs),
            "outputs_left_out": left_out,
            "A": self.a, "B": self.b, "C": self.c, "D": self.d,
            "control_period": self.control_period,
            "Ad": self.ad, "Bd": self.bd,
            "poles": self.poles.iter().map(|p| json!({ "re": p[0], "im": p[1] })).collect::<Vec<_>>(),
            "operating_point": {
                "time": point.time,
                "state": point.state,
                "efforts": point.efforts,
                "outputs": point.outputs,
            },
            "finite_difference_steps": { "states": self.state_steps, "inputs": self.input_steps },
            "frequency_response": response,
        })
    }

    /// The states, inputs and outputs at the operating point and the poles, as `twin linearize`
    /// prints them.
    pub fn to_table(&self) -> String {
        let mut out = String::new();
        let point = &self.operating_point;
        let _ = writeln!(
            out,
            "{} linearised at t = {} s (zero-order hold at {} s)",
            self.scenario, point.time, self.control_period
        );
        let mut section = |title: &str, list: &[Channel], values: &[f64]| {
            let _ = writeln!(out, "{title:<34} {:>14}", "value");
            for (channel, value) in list.iter().zip(values) {
                let name = format!("{} [{}]", channel.name, channel.unit);
                let _ = writeln!(out, "  {name:<32} {value:>14.6e}");
            }
        };
        section("states", &self.states, &point.state);
        section("inputs (efforts held)", &self.inputs, &point.efforts);
        section("outputs", &self.outputs, &point.outputs);
        for (name, reason) in &self.outputs_left_out {
            let _ = writeln!(out, "  (left out: {name}: {reason})");
        }
        let _ = writeln!(
            out,
            "{:<34} {:>14} {:>14} {:>12} {:>10}",
            "poles", "real (1/s)", "imag (rad/s)", "|s| (rad/s)", "damping"
        );
        for [re, im] in &self.poles {
            let magnitude = re.hypot(*im);
            let damping = if magnitude > 0.0 {
                -re / magnitude
            } else {
                f64::NAN
            };
            let _ = writeln!(
                out,
                "  {:<32} {re:>14.6e} {im:>14.6e} {magnitude:>12.4e} {damping:>10.4}",
                ""
            );
        }
        out
    }
}
