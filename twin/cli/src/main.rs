//! The `twin` command line: list, run and benchmark the machines' twins. The commands live in
//! the `twin_cli` library; this only parses, dispatches and turns a failure into its exit code.

use clap::Parser;
use std::process::ExitCode;
use twin_cli::command_line::{dispatch, Cli};
use twin_cli::usage::usage_error;

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(error) => return usage_error(&error),
    };
    dispatch(cli).unwrap_or_else(|failure| {
        eprintln!("error: {}", failure.message);
        ExitCode::from(failure.code)
    })
}
