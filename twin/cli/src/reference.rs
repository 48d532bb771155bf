//! The command-line reference as Markdown, read from clap's definition of the commands, so that
//! the page cannot drift from `--help`.

use clap::{Arg, ArgAction, Command};
use std::fmt::Write as _;

/// `command` and every command under it, depth first in the order they are defined: for each a
/// `## <bin name>` section with its description, usage, arguments and subcommands.
pub fn markdown(command: &mut Command) -> String {
    // Building fills in what the sections read: bin names, value counts, the help flags.
    command.build();
    let mut text = String::new();
    section(command, &mut text);
    // One newline at the end, as editors and pre-commit hooks leave a file.
    text.truncate(text.trim_end().len());
    text.push('\n');
    text
}

/// One command's section, then its subcommands'.
fn section(command: &Command, text: &mut String) {
    let name = command.get_bin_name().unwrap_or(command.get_name());
    let about = command.get_long_about().or(command.get_about());
    let usage = command.clone().render_usage().to_string();
    let _ = writeln!(text, "## {name}\n");
    if let Some(about) = about {
        let _ = writeln!(text, "{}\n", sentence(&about.to_string()));
    }
    let _ = writeln!(text, "```text\n{}\n```\n", usage.trim_end());
    // In the order `--help` shows them: a flag a command rewrites (`mut_arg`) keeps its place.
    let (positionals, mut options): (Vec<&Arg>, Vec<&Arg>) = command
        .get_arguments()
        .filter(|arg| !arg.is_hide_set() && !is_help(arg))
        .partition(|arg| arg.is_positional());
    options.sort_by_key(|arg| arg.get_display_order());
    for (title, args) in [("Arguments", positionals), ("Options", options)] {
        if !args.is_empty() {
            let _ = writeln!(text, "{title}:\n");
            for arg in args {
                let _ = writeln!(text, "{}", argument(command, arg));
            }
            text.push('\n');
        }
    }
    let subcommands: Vec<&Command> = listed(command).collect();
    if !subcommands.is_empty() {
        let _ = writeln!(text, "Commands:\n");
        for sub in &subcommands {
            let _ = writeln!(text, "{}", subcommand(name, sub));
        }
        text.push('\n');
    }
    if let Some(after) = command.get_after_long_help().or(command.get_after_help()) {
        let _ = writeln!(text, "{}\n", sentence(&after.to_string()));
    }
    for sub in subcommands {
        section(sub, text);
    }
}

/// The subcommands the reference lists: all but hidden ones and clap's own `help`.
fn listed(command: &Command) -> impl Iterator<Item = &Command> {
    command
        .get_subcommands()
        .filter(|sub| !sub.is_hide_set() && sub.get_name() != "help")
}

/// Clap's `-h`/`--help`, which every command has and the reference leaves out.
fn is_help(arg: &Arg) -> bool {
    matches!(
        arg.get_action(),
        ArgAction::Help | ArgAction::HelpShort | ArgAction::HelpLong
    )
}

/// A list item for one argument: its name and values, then its help, what it conflicts with,
/// its possible values and its default, as sentences.
fn argument(command: &Command, arg: &Arg) -> String {
    let mut item = match arg.get_short().filter(|_| arg.get_long().is_some()) {
        Some(short) => format!("- `-{short}, {arg}`"),
        None => format!("- `{arg}`"),
    };
    if arg.is_required_set() {
        item.push_str(" (required)");
    }
    // `--rpm FROM TO` appends too, but is given once; only one-value options are repeated.
    let one_value = arg.get_num_args().is_none_or(|n| n.max_values() <= 1);
    if !arg.is_positional() && one_value && matches!(arg.get_action(), ArgAction::Append) {
        item.push_str(" (repeatable)");
    }
    let mut sentences = Vec::new();
    if let Some(help) = arg.get_long_help().or(arg.get_help()) {
        // Later paragraphs are indented to stay inside the list item.
        sentences.push(sentence(&help.to_string()).replace("\n\n", "\n\n  "));
    }
    let conflicts: Vec<String> = command
        .get_arg_conflicts_with(arg)
        .iter()
        .map(|other| format!("`{}`", flag(other)))
        .collect();
    if !conflicts.is_empty() {
        sentences.push(format!("Not with {}.", conflicts.join(", ")));
    }
    if arg.get_action().takes_values() {
        let values = possible_values(arg);
        if !values.is_empty() {
            sentences.push(format!("Values: {values}."));
        }
        let defaults: Vec<String> = arg
            .get_default_values()
            .iter()
            .map(|value| value.to_string_lossy().into_owned())
            .collect();
        if !defaults.is_empty() {
            sentences.push(format!("Default: `{}`.", defaults.join(" ")));
        }
    }
    if !sentences.is_empty() {
        let _ = write!(item, ": {}", sentences.join(" "));
    }
    item
}

/// How an argument is named in prose: `--long`, else as its usage shows it.
fn flag(arg: &Arg) -> String {
    arg.get_long()
        .map_or_else(|| arg.to_string(), |long| format!("--{long}"))
}

/// An argument's possible values (a value enum's), each with its help when it has one.
fn possible_values(arg: &Arg) -> String {
    arg.get_possible_values()
        .iter()
        .filter(|value| !value.is_hide_set())
        .map(|value| match value.get_help() {
            Some(help) => format!("`{}` ({})", value.get_name(), escape(&help.to_string())),
            None => format!("`{}`", value.get_name()),
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// A list item for a subcommand, linking to its section (mdBook's heading ids).
fn subcommand(parent: &str, sub: &Command) -> String {
    let name = format!("{parent} {}", sub.get_name());
    let anchor = name.replace(' ', "-");
    let about = sub.get_about().map(|a| sentence(&a.to_string()));
    format!("- [`{name}`](#{anchor}): {}", about.unwrap_or_default())
}

/// Help text as Markdown ending in a full stop (clap drops a doc comment's last one).
fn sentence(text: &str) -> String {
    let text = escape(text.trim_end());
    if text.ends_with(['.', '!', '?', ':']) {
        text
    } else {
        text + "."
    }
}

/// Help text as Markdown: `<` and `&` outside code spans are escaped, so that `<scenario>` is
/// shown, not taken for an HTML tag.
fn escape(text: &str) -> String {
    let mut escaped = String::with_capacity(text.len());
    let mut in_code = false;
    for c in text.chars() {
        match c {
            '`' => {
                in_code = !in_code;
                escaped.push(c);
            }
            '<' if !in_code => escaped.push_str("&lt;"),
            '&' if !in_code => escaped.push_str("&amp;"),
            _ => escaped.push(c),
        }
    }
    escaped
}
