//! `docs/src/cli.md` below its marker line is the command-line reference generated from clap's
//! definitions (`twin_cli::command_line::reference_markdown`); `TWIN_BLESS=1` rewrites it.

use std::path::PathBuf;
use twin_cli::command_line::reference_markdown;

const MARKER: &str = "<!-- generated: twin cli-reference; do not edit below -->";

fn page() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../docs/src/cli.md")
}

#[test]
fn the_cli_page_is_the_reference_generated_from_the_definitions() {
    let path = page();
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let end = text
        .find(MARKER)
        .unwrap_or_else(|| panic!("{}: no line `{MARKER}`", path.display()))
        + MARKER.len();
    // Everything up to and including the marker's line is written by hand.
    let head = match text[end..].find('\n') {
        Some(newline) => &text[..end + newline + 1],
        None => &text[..end],
    };
    let generated = reference_markdown();
    if std::env::var("TWIN_BLESS").is_ok_and(|v| v == "1") {
        let separator = if head.ends_with('\n') { "" } else { "\n" };
        std::fs::write(&path, format!("{head}{separator}{generated}")).unwrap();
        return;
    }
    let written = &text[head.len()..];
    assert!(
        written == generated,
        "{} is stale below its marker: run `TWIN_BLESS=1 cargo test -p twin-cli --test reference`",
        path.display()
    );
}

#[test]
fn the_reference_covers_every_command_and_the_sweep_merge_subcommand() {
    let generated = reference_markdown();
    for command in [
        "list",
        "run",
        "bench",
        "reproduce",
        "analyze",
        "frf",
        "salvage",
        "linearize",
        "sweep",
        "sweep merge",
        "fmu",
    ] {
        assert!(
            generated.contains(&format!("\n## twin {command}\n")),
            "no section for twin {command}"
        );
    }
    assert!(generated.contains("--record <RECORD>"), "{generated}");
    assert!(!generated.contains("--help"), "the help flags are left out");
}
