//! How `twin` reports a command line that clap rejects: help and version on stdout, anything
//! else as one line on stderr with a hint.

use crate::failure::EXIT_USAGE;
use clap::error::ErrorKind;
use std::process::ExitCode;

/// Help and version go to stdout (exit 0); `twin` alone lists the commands (exit 2); a usage
/// error is one line naming what is wrong (the missing `<SCENARIO>`, the `--h2` that `--h1`
/// needs, the argument that is not UTF-8) and a hint (exit 2).
pub fn usage_error(error: &clap::Error) -> ExitCode {
    match error.kind() {
        ErrorKind::DisplayHelp | ErrorKind::DisplayVersion => {
            print!("{error}");
            return ExitCode::SUCCESS;
        }
        ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand => {
            eprint!("{error}");
            return ExitCode::from(EXIT_USAGE);
        }
        _ => {}
    }
    let message = match (error.kind(), non_utf8_argument()) {
        (ErrorKind::InvalidUtf8, Some(argument)) => {
            format!("error: {argument} is not UTF-8 text; give it in UTF-8")
        }
        _ => first_paragraph(&error.render().to_string()),
    };
    eprintln!("{message}");
    eprintln!("hint: twin --help, or twin <command> --help");
    ExitCode::from(EXIT_USAGE)
}

/// Clap's message up to its usage line, on one line: "the following required arguments were not
/// provided:" keeps the arguments clap lists below it.
fn first_paragraph(rendered: &str) -> String {
    let lines: Vec<&str> = rendered
        .lines()
        .take_while(|line| !line.trim().is_empty() && !line.starts_with("Usage:"))
        .map(str::trim)
        .collect();
    match lines.join(" ").trim() {
        "" => "error: usage error".to_string(),
        line => line.to_string(),
    }
}

/// The first command-line argument that is not UTF-8, by position (and the option it follows),
/// shown with its bad bytes replaced.
fn non_utf8_argument() -> Option<String> {
    let arguments: Vec<std::ffi::OsString> = std::env::args_os().collect();
    let index = arguments.iter().position(|a| a.to_str().is_none())?;
    let shown = arguments[index].to_string_lossy().into_owned();
    let after = arguments[..index]
        .last()
        .and_then(|a| a.to_str())
        .filter(|a| a.starts_with('-'))
        .map(|option| format!(" (the value of {option})"))
        .unwrap_or_default();
    Some(format!("argument {index} `{shown}`{after}"))
}
