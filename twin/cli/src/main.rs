//! The `twin` command line: list, run and benchmark the machines' twins. The commands live in
//! the `twin_cli` library; this only parses, dispatches and turns a failure into its exit code.

use clap::Parser;
use std::process::ExitCode;
use twin_cli::command_line::{dispatch, Cli};
use twin_cli::usage::usage_error;

fn main() -> ExitCode {
    quiet_broken_pipe();
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(error) => return usage_error(&error),
    };
    dispatch(cli).unwrap_or_else(|failure| {
        eprintln!("error: {}", failure.message);
        ExitCode::from(failure.code)
    })
}

/// A reader that stops early (`twin compare … | head`) ends `twin` quietly, as it ends any Unix
/// tool: SIGPIPE back to its default action, which Rust's runtime sets aside.
fn quiet_broken_pipe() {
    #[cfg(unix)]
    // SAFETY: setting a signal's disposition to SIG_DFL before any thread starts.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}
