//! The documentation as a checked product: every paper equation cited in the code in one spelling,
//! `<Author> eq (N)`, and each machine's chapter of the guide holding the index from its paper's
//! equations to the files and items that implement them.
//!
//! `TWIN_BLESS=1 cargo test -p twin-tests --test docs` rewrites the generated indexes.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The papers' first authors, as citations name them.
const AUTHORS: [&str; 5] = ["Perrusquía", "Ilyukhin", "Kaliński", "Sudhakara", "Rubio"];

/// Each machine's chapter and the paper whose equations it indexes; a Kaliński citation belongs to
/// the milling chapter when its file is about milling, to the platform's otherwise.
const CHAPTERS: [(&str, &str); 6] = [
    ("whitworth.md", "Perrusquía"),
    ("arm.md", "Ilyukhin"),
    ("platform.md", "Kaliński"),
    ("feed-axis.md", "Rubio"),
    ("lathe.md", "Sudhakara"),
    ("milling.md", "Kaliński"),
];

/// Where the generated part of a chapter starts.
const MARKER: &str = "<!-- generated: equation index; do not edit below -->";

/// The folders whose sources carry citations.
const SOURCE_DIRS: [&str; 4] = ["models", "controllers", "twin", "tests"];

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("the tests crate sits in the workspace")
        .to_path_buf()
}

/// Every `.rs` and `.toml` file under `dir`, sorted, leaving out build output.
fn sources(dir: &Path, files: &mut Vec<PathBuf>) {
    let mut entries: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    entries.sort();
    for path in entries {
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        if path.is_dir() && !matches!(name.as_str(), "target" | "book" | ".git") {
            sources(&path, files);
        } else if name.ends_with(".rs") || (name.ends_with(".toml") && name != "Cargo.toml") {
            files.push(path);
        }
    }
}

fn all_sources() -> Vec<PathBuf> {
    let mut files = Vec::new();
    for dir in SOURCE_DIRS {
        sources(&workspace().join(dir), &mut files);
    }
    files
}

/// The comment part of a line (after `//` in Rust, `#` in TOML) outside a string literal.
fn comment(line: &str, toml: bool) -> Option<&str> {
    let marker = if toml { "#" } else { "//" };
    let at = line.find(marker)?;
    line[..at]
        .matches('"')
        .count()
        .is_multiple_of(2)
        .then(|| &line[at..])
}

/// The citations in a comment that do not have the one spelling: each `eq`/`eqs` word (any case)
/// followed by a number, a bracketed number or `K(`, unless written `<Author> eq (N` or
/// `<Author> eqs (N`.
fn misspelt(text: &str) -> Vec<String> {
    let lower = text.to_lowercase();
    let mut found = Vec::new();
    for (at, _) in lower.match_indices("eq") {
        let before = &text[..at];
        if before
            .chars()
            .last()
            .is_some_and(|c| c.is_alphanumeric() || c == '_')
        {
            continue;
        }
        let word_end = at + if lower[at..].starts_with("eqs") { 3 } else { 2 };
        let after = &text[word_end..];
        let rest = after.trim_start_matches(['.', ' ']);
        // An appendix's equation (`B.4`) counts as a number too.
        let appendix = rest.len() > 2
            && rest.starts_with(|c: char| c.is_ascii_uppercase())
            && rest[1..].starts_with('.');
        let cited = appendix
            || rest.starts_with(|c: char| c.is_ascii_digit())
            || rest.starts_with("K(")
            || (rest.starts_with('(') && rest[1..].starts_with(|c: char| c.is_ascii_digit()));
        if !cited {
            continue;
        }
        let word = &text[at..word_end];
        // One equation is `eq`, a range of them `eqs`.
        let range = after
            .find(')')
            .is_some_and(|close| after[close + 1..].starts_with("–("));
        let spelt = (word == "eqs" || (word == "eq" && !range))
            && after.starts_with(" (")
            && AUTHORS.iter().any(|a| before.ends_with(&format!("{a} ")));
        if !spelt {
            found.push(text[at..].chars().take(24).collect());
        }
    }
    found
}

#[test]
fn every_citation_in_the_code_has_the_one_spelling() {
    let mut wrong = Vec::new();
    for file in all_sources() {
        let toml = file.extension().is_some_and(|e| e == "toml");
        let text = std::fs::read_to_string(&file).unwrap();
        for (number, line) in text.lines().enumerate() {
            for citation in comment(line, toml).map(misspelt).unwrap_or_default() {
                let shown = file
                    .strip_prefix(workspace())
                    .unwrap()
                    .display()
                    .to_string();
                wrong.push(format!("{shown}:{}: `{citation}`", number + 1));
            }
        }
    }
    // The guide and the documents at the top, as prose: lines joined (a citation may wrap), code
    // spans left out (they show spellings as examples).
    for file in markdown_files() {
        let text = std::fs::read_to_string(&file).unwrap_or_default();
        let prose: String = text
            .split('`')
            .step_by(2)
            .collect::<Vec<_>>()
            .join(" ")
            .split_whitespace()
            .collect::<Vec<_>>()
            .join(" ");
        for citation in misspelt(&prose) {
            let shown = file
                .strip_prefix(workspace())
                .unwrap()
                .display()
                .to_string();
            wrong.push(format!("{shown}: `{citation}`"));
        }
    }
    assert!(
        wrong.is_empty(),
        "write citations as `<Author> eq (N)` (authors: {}):\n{}",
        AUTHORS.join(", "),
        wrong.join("\n")
    );
}

#[test]
fn the_spelling_check_rejects_the_other_forms() {
    for bad in [
        "eq 12",
        "Eq (12)",
        "eqs 2–4",
        "eq12",
        "Eq. 3",
        "the paper's eq (4)",
        "eqs K(11)",
    ] {
        assert_eq!(misspelt(bad).len(), 1, "{bad}");
    }
    for good in [
        "Perrusquía eq (12)",
        "Sudhakara eqs (12)–(14)",
        "PartialEq",
        "eq sign",
        "seq 3",
    ] {
        assert!(misspelt(good).is_empty(), "{good}");
    }
}

/// The equation numbers a citation names: `(12)`, `(12)–(14)` (expanded), `(8), (11) and (12)`.
fn numbers(after: &str) -> Vec<String> {
    let mut found = Vec::new();
    let mut rest = after;
    let mut previous: Option<u32> = None;
    while let Some(open) = rest.strip_prefix('(') {
        let label: String = open
            .chars()
            .take_while(|c| c.is_alphanumeric() || *c == '.')
            .collect();
        if !open[label.len()..].starts_with(')') || label.is_empty() {
            break;
        }
        rest = &open[label.len() + 1..];
        let value: Option<u32> = label.parse().ok();
        match (previous, value) {
            (Some(from), Some(to)) if to > from + 1 && to - from <= 30 => {
                found.extend((from + 1..=to).map(|n| n.to_string()))
            }
            _ => found.push(label.clone()),
        }
        previous = None;
        for separator in ["–", ", ", " and ", ","] {
            if let Some(next) = rest.strip_prefix(separator) {
                previous = (separator == "–").then_some(value).flatten();
                rest = next;
                break;
            }
        }
        if !rest.starts_with('(') {
            break;
        }
    }
    found
}

/// The item a comment line documents or sits in: the next item after a `///` comment, the
/// enclosing function for a `//` comment, the module for `//!`.
fn item_of(lines: &[&str], index: usize) -> String {
    let trimmed = lines[index].trim_start();
    if trimmed.starts_with("//!") || trimmed.starts_with('#') {
        return "module".into();
    }
    let documented = trimmed.starts_with("///");
    let candidates: Box<dyn Iterator<Item = &&str>> = if documented {
        Box::new(lines[index + 1..].iter())
    } else {
        Box::new(lines[..index].iter().rev())
    };
    for line in candidates {
        let line = line.trim_start();
        if line.starts_with("//") || line.starts_with("#[") {
            continue;
        }
        // A `//` comment sits in a function: fields of a struct literal above it are not items.
        if let Some(item) = item_name(line).filter(|i| documented || i.contains(' ')) {
            return item;
        }
        if documented {
            break;
        }
    }
    "module".into()
}

/// `fn name`, `struct Name`, … or a field `name` from an item's first line.
fn item_name(line: &str) -> Option<String> {
    let mut rest = line;
    for prefix in ["pub(crate) ", "pub(super) ", "pub "] {
        rest = rest.strip_prefix(prefix).unwrap_or(rest);
    }
    for kind in [
        "fn ", "struct ", "enum ", "trait ", "const ", "type ", "impl ", "mod ",
    ] {
        if let Some(after) = rest.strip_prefix(kind) {
            let name: String = after
                .chars()
                .take_while(|c| c.is_alphanumeric() || matches!(c, '_' | '<' | '>' | ' '))
                .collect();
            return Some(format!("{}{}", kind, name.trim()));
        }
    }
    let field: String = rest
        .chars()
        .take_while(|c| c.is_alphanumeric() || *c == '_')
        .collect();
    let after = &rest[field.len()..];
    (!field.is_empty() && after.starts_with(':') && !after.starts_with("::")).then_some(field)
}

/// The equation index of each chapter: equation → the places citing it, each `file` — item.
fn indexes() -> BTreeMap<&'static str, BTreeMap<(u32, String), Vec<String>>> {
    let mut index: BTreeMap<&str, BTreeMap<(u32, String), Vec<String>>> = BTreeMap::new();
    for file in all_sources() {
        let shown = file
            .strip_prefix(workspace())
            .unwrap()
            .display()
            .to_string();
        let toml = shown.ends_with(".toml");
        let text = std::fs::read_to_string(&file).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        for (number, line) in lines.iter().enumerate() {
            let Some(comment) = comment(line, toml) else {
                continue;
            };
            for (chapter, author) in CHAPTERS {
                let milling = shown.contains("milling") && !shown.contains("micromilling");
                if author == "Kaliński" && (chapter == "milling.md") != milling {
                    continue;
                }
                for word in [" eq ", " eqs "] {
                    let cite = format!("{author}{word}");
                    for (at, _) in comment.match_indices(&cite) {
                        for equation in numbers(&comment[at + cite.len()..]) {
                            let key: u32 = equation
                                .trim_end_matches(char::is_alphabetic)
                                .parse()
                                .unwrap_or(0);
                            let place = format!("`{shown}` — {}", item_of(&lines, number));
                            let places = index.entry(chapter).or_default();
                            let entry = places.entry((key, equation)).or_default();
                            if !entry.contains(&place) {
                                entry.push(place);
                            }
                        }
                    }
                }
            }
        }
    }
    index
}

/// A chapter's generated index as Markdown.
fn render(author: &str, places: &BTreeMap<(u32, String), Vec<String>>) -> String {
    let mut text = format!(
        "\nWhere each of {author}'s equations is implemented or discussed (search the code for \
         `{author} eq (N)`).\n\n| equation | where |\n| --- | --- |\n"
    );
    for ((_, equation), where_) in places {
        text.push_str(&format!(
            "| {author} eq ({equation}) | {} |\n",
            where_.join("<br>")
        ));
    }
    text
}

#[test]
fn each_machine_chapter_holds_its_equation_index() {
    let bless = std::env::var_os("TWIN_BLESS").is_some();
    let indexes = indexes();
    for (chapter, author) in CHAPTERS {
        let path = workspace().join("docs/src/machines").join(chapter);
        let text =
            std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let at = text
            .find(MARKER)
            .unwrap_or_else(|| panic!("{}: no line `{MARKER}`", path.display()));
        let head = &text[..at + MARKER.len()];
        let places = indexes.get(chapter).cloned().unwrap_or_default();
        assert!(
            places.len() >= 3,
            "{chapter}: only {} equations",
            places.len()
        );
        let generated = render(author, &places);
        if bless {
            std::fs::write(&path, format!("{head}\n{generated}")).unwrap();
        } else {
            assert_eq!(
                &text[at + MARKER.len()..],
                format!("\n{generated}"),
                "{}: the equation index is stale; TWIN_BLESS=1 cargo test -p twin-tests --test docs",
                path.display()
            );
        }
    }
}

#[test]
fn citations_are_read_with_their_ranges() {
    assert_eq!(numbers("(12)–(14) and"), ["12", "13", "14"]);
    assert_eq!(numbers("(8), (11) and (12) imply"), ["8", "11", "12"]);
    assert_eq!(numbers("(7a) prints"), ["7a"]);
    assert_eq!(numbers("(15), (21)–(23)) are"), ["15", "21", "22", "23"]);
}

/// The Markdown files a reader walks: the guide's chapters and the documents at the top.
fn markdown_files() -> Vec<PathBuf> {
    fn walk(dir: &Path, files: &mut Vec<PathBuf>) {
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                walk(&path, files);
            } else if path.extension().is_some_and(|e| e == "md") {
                files.push(path);
            }
        }
    }
    let mut files = Vec::new();
    walk(&workspace().join("docs/src"), &mut files);
    for top in [
        "README.md",
        "ARCHITECTURE.md",
        "CONTRIBUTING.md",
        "CHANGELOG.md",
    ] {
        files.push(workspace().join(top));
    }
    files.sort();
    files
}

/// mdBook's id of a heading: lower case, letters, digits, `_` and `-` kept, spaces as `-`.
fn heading_id(heading: &str) -> String {
    heading
        .trim()
        .to_lowercase()
        .chars()
        .filter_map(|c| match c {
            ' ' => Some('-'),
            c if c.is_alphanumeric() || c == '_' || c == '-' => Some(c),
            _ => None,
        })
        .collect()
}

/// The ids of a Markdown file's headings (outside code blocks).
fn heading_ids(text: &str) -> Vec<String> {
    let mut ids = Vec::new();
    let mut fenced = false;
    for line in text.lines() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
        } else if !fenced && line.starts_with('#') {
            let id = heading_id(line.trim_start_matches('#'));
            let seen = ids.iter().filter(|i: &&String| i.as_str() == id).count();
            ids.push(if seen == 0 {
                id.clone()
            } else {
                format!("{id}-{seen}")
            });
        }
    }
    ids
}

/// The targets of a Markdown file's inline links and images (`](target)`), outside code.
fn link_targets(text: &str) -> Vec<String> {
    let mut targets = Vec::new();
    let mut fenced = false;
    for line in text.lines() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
            continue;
        }
        if fenced {
            continue;
        }
        // Inline code spans may hold `](` in examples: leave them out.
        let prose: String = line.split('`').step_by(2).collect::<Vec<_>>().join(" ");
        for (at, _) in prose.match_indices("](") {
            let rest = &prose[at + 2..];
            if let Some(end) = rest.find(')') {
                targets.push(
                    rest[..end]
                        .split_whitespace()
                        .next()
                        .unwrap_or("")
                        .to_string(),
                );
            }
        }
    }
    targets
}

#[test]
fn every_link_in_the_guide_and_the_top_documents_resolves() {
    let mut broken = Vec::new();
    for file in markdown_files() {
        let text =
            std::fs::read_to_string(&file).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
        for target in link_targets(&text) {
            if target.contains("://") || target.starts_with("mailto:") || target.is_empty() {
                continue;
            }
            let (path, anchor) = target.split_once('#').unwrap_or((&target, ""));
            let resolved = if path.is_empty() {
                file.clone()
            } else {
                file.parent().unwrap().join(path)
            };
            let shown = file
                .strip_prefix(workspace())
                .unwrap()
                .display()
                .to_string();
            if !resolved.exists() {
                broken.push(format!("{shown}: `{target}`: no such file"));
            } else if !anchor.is_empty() && resolved.extension().is_some_and(|e| e == "md") {
                let ids = heading_ids(&std::fs::read_to_string(&resolved).unwrap());
                if !ids.iter().any(|id| id == anchor) {
                    broken.push(format!("{shown}: `{target}`: no heading with that id"));
                }
            }
        }
    }
    assert!(broken.is_empty(), "broken links:\n{}", broken.join("\n"));
}

#[test]
fn the_link_check_reads_links_and_heading_ids() {
    assert_eq!(heading_id(" The exact engine "), "the-exact-engine");
    assert_eq!(heading_id("Tests (`scripts/test`)"), "tests-scriptstest");
    assert_eq!(heading_ids("# A\n```\n# not\n```\n# A"), ["a", "a-1"]);
    assert_eq!(
        link_targets("see [x](a.md#b) and `[y](no.md)` ![p](i.png \"t\")"),
        ["a.md#b", "i.png"]
    );
}

#[test]
fn every_chapter_of_the_guide_is_in_its_table_of_contents() {
    let src = workspace().join("docs/src");
    let summary = std::fs::read_to_string(src.join("SUMMARY.md")).unwrap();
    let listed = link_targets(&summary);
    let missing: Vec<String> = markdown_files()
        .iter()
        .filter_map(|file| file.strip_prefix(&src).ok())
        .map(|chapter| chapter.display().to_string())
        .filter(|chapter| chapter != "SUMMARY.md" && !listed.contains(chapter))
        .collect();
    assert!(
        missing.is_empty(),
        "docs/src/SUMMARY.md lists no link to {missing:?}"
    );
}
