//! `twin list`: the built-in scenarios, the papers `twin reproduce` knows and the registered
//! controllers.

use crate::papers::PAPERS;
use framework::Registry;
use twin::BUILTIN_SCENARIOS;

/// Prints the three lists, one name and its one-line description a row.
pub fn run(registry: &Registry) {
    println!("scenarios:");
    for (name, text) in BUILTIN_SCENARIOS {
        println!("  {name:<28} {}", description(text));
    }
    println!("papers (twin reproduce):");
    for paper in PAPERS {
        println!("  {:<28} {}", paper.name, paper.summary);
    }
    println!("controllers:");
    for entry in registry.entries() {
        println!("  {:<28} [{}] {}", entry.name, entry.machine, entry.summary);
    }
}

/// A scenario's `description` (empty when the TOML has none).
fn description(text: &str) -> String {
    text.parse::<toml::Table>()
        .ok()
        .and_then(|t| {
            t.get("description")
                .and_then(|d| d.as_str())
                .map(String::from)
        })
        .unwrap_or_default()
}
