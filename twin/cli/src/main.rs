//! The `twin` command line: list, run and benchmark the machines' twins. The commands live in
//! the `twin_cli` library; this only parses, dispatches and turns a failure into its exit code.

use clap::Parser;
use std::process::ExitCode;
use twin_cli::command_line::{dispatch, Cli};
use twin_cli::failure::EXIT_USAGE;
use twin_cli::usage::usage_error;

fn main() -> ExitCode {
    quiet_broken_pipe();
    keep_freed_memory();
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

/// glibc's allocator gives freed memory back to the kernel eagerly: it trims a thread's arena
/// once 128 KiB lie free at its top, and maps blocks over its (adaptive) mmap threshold one by
/// one. A recording's threads allocate and free batch-sized blocks all run long, so each batch
/// faulted its pages in afresh: a recorded 50 s Whitworth took 15,000 page faults and 10 % more
/// processor time than with up to 32 MiB kept (3,700 faults). Fixed thresholds (glibc's
/// `M_TRIM_THRESHOLD`, `M_MMAP_THRESHOLD`) keep them; other platforms keep their allocator's ways.
fn keep_freed_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: mallopt only changes the allocator's thresholds; called before any thread starts.
    unsafe {
        libc::mallopt(libc::M_TRIM_THRESHOLD, 32 << 20);
        libc::mallopt(libc::M_MMAP_THRESHOLD, 32 << 20);
    }
}
