//! The `twin` command line: list, run and benchmark the machines' twins. The commands live in
//! the `twin_cli` library; this only parses, dispatches and turns a failure into its exit code.

use clap::Parser;
use std::process::ExitCode;
use twin_cli::command_line::{dispatch, Cli};
use twin_cli::failure::EXIT_USAGE;
use twin_cli::usage::usage_error;

fn main() -> ExitCode {
    quiet_broken_pipe();
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(error) => return usage_error(&error),
    };
    dispatch(cli).unwrap_or_else(|failure| {
        eprintln!("error: {}", failure.message);
        if failure.code == EXIT_USAGE {
            // A usage error: the arguments are at fault, and the command's help says what they
            // take.
            eprintln!("hint: twin {} --help", command_named());
        }
        ExitCode::from(failure.code)
    })
}

/// The command the arguments name (`shadow`), or `<command>`.
fn command_named() -> String {
    std::env::args_os()
        .nth(1)
        .map(|a| a.to_string_lossy().into_owned())
        .filter(|a| !a.starts_with('-'))
        .unwrap_or_else(|| "<command>".into())
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
