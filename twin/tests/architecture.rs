//! The library's shape, read from its source: no two modules import each other, directly or
//! around a circle (in the engine and in the applications on it), the library does not depend
//! on the applications' crates, and every source file opens with a `//!` line saying what it is.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Every `.rs` file under `dir`.
fn sources(dir: &Path) -> Vec<PathBuf> {
    let mut files = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            files.extend(sources(&path));
        } else if path.extension().is_some_and(|e| e == "rs") {
            files.push(path);
        }
    }
    files
}

/// The module a file is, as a path of names from the crate root (`run::evaluate`).
fn module_of(root: &Path, file: &Path) -> Vec<String> {
    let relative = file.strip_prefix(root).unwrap().with_extension("");
    let mut parts: Vec<String> = relative
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    if matches!(
        parts.last().map(String::as_str),
        Some("mod" | "lib" | "main")
    ) {
        parts.pop();
    }
    parts
}

/// The modules a file's code (not its comments) refers to through `crate::a::b` and `super::a`
/// paths, as paths from the crate root.
fn references(module: &[String], text: &str) -> BTreeSet<Vec<String>> {
    let code: String = text
        .lines()
        .filter(|line| !line.trim_start().starts_with("//"))
        .collect::<Vec<_>>()
        .join("\n");
    let text = code.as_str();
    let mut found = BTreeSet::new();
    // The lower-case names of a path (`run::summary` of `run::summary::RunSummary`).
    let words = |mut rest: &str| -> Vec<String> {
        let mut path = Vec::new();
        loop {
            let name: String = rest
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect();
            if !name.starts_with(|c: char| c.is_ascii_lowercase()) {
                return path;
            }
            rest = &rest[name.len()..];
            path.push(name);
            match rest.strip_prefix("::") {
                Some(after) => rest = after,
                None => return path,
            }
        }
    };
    let parent = &module[..module.len().saturating_sub(1)];
    for (prefix, base) in [("crate::", &[][..]), ("super::", parent)] {
        for (at, _) in text.match_indices(prefix) {
            for item in items(&text[at + prefix.len()..]) {
                let mut path = base.to_vec();
                path.extend(words(item));
                found.insert(path);
            }
        }
    }
    found
}

/// The paths a `use` names after its prefix: `a::b` alone, or each item of `{a::b, c, D}`
/// (braces nested within an item kept with it).
fn items(rest: &str) -> Vec<&str> {
    let Some(inner) = rest.strip_prefix('{') else {
        return vec![rest];
    };
    let (mut depth, mut start, mut found) = (0, 0, Vec::new());
    for (i, c) in inner.char_indices() {
        match c {
            '{' => depth += 1,
            '}' if depth == 0 => {
                found.push(inner[start..i].trim_start());
                return found;
            }
            '}' => depth -= 1,
            ',' if depth == 0 => {
                found.push(inner[start..i].trim_start());
                start = i + 1;
            }
            _ => {}
        }
    }
    found
}

/// The module-to-module graph: an edge from each module to every other module (at any depth
/// shared with it) it refers to, ignoring references into itself or its own submodules.
fn graph(root: &Path) -> BTreeMap<Vec<String>, BTreeSet<Vec<String>>> {
    let mut edges: BTreeMap<Vec<String>, BTreeSet<Vec<String>>> = BTreeMap::new();
    for file in sources(root) {
        let module = module_of(root, &file);
        let text = std::fs::read_to_string(&file).unwrap();
        for target in references(&module, &text) {
            // Compare at the first level where the two paths part.
            let common = module
                .iter()
                .zip(&target)
                .take_while(|(a, b)| a == b)
                .count();
            if common == target.len() || common == module.len() {
                continue; // itself, an ancestor (declaring it), or its own submodule
            }
            edges
                .entry(module[..=common].to_vec())
                .or_default()
                .insert(target[..=common].to_vec());
        }
    }
    edges
}

/// A circle in the graph, if any, as the modules around it.
fn circle(edges: &BTreeMap<Vec<String>, BTreeSet<Vec<String>>>) -> Option<Vec<String>> {
    fn visit(
        node: &Vec<String>,
        edges: &BTreeMap<Vec<String>, BTreeSet<Vec<String>>>,
        path: &mut Vec<Vec<String>>,
        done: &mut BTreeSet<Vec<String>>,
    ) -> Option<Vec<String>> {
        if let Some(start) = path.iter().position(|n| n == node) {
            return Some(path[start..].iter().map(|m| m.join("::")).collect());
        }
        if !done.insert(node.clone()) {
            return None;
        }
        path.push(node.clone());
        for next in edges.get(node).into_iter().flatten() {
            if let Some(found) = visit(next, edges, path, done) {
                return Some(found);
            }
        }
        path.pop();
        None
    }
    let mut done = BTreeSet::new();
    edges
        .keys()
        .find_map(|node| visit(node, edges, &mut Vec::new(), &mut done))
}

/// Every crate of the workspace, as its source folder relative to the workspace root.
const CRATES: [&str; 9] = [
    "models/src",
    "twin/framework/src",
    "controllers/src",
    "twin/src",
    "twin/cli/src",
    "twin/fmu/src",
    "twin/python/src",
    "tests",
    "workspace-hack/src",
];

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("the twin crate sits in the workspace")
        .to_path_buf()
}

#[test]
fn no_module_imports_another_that_imports_it_back() {
    for crate_dir in CRATES {
        let root = workspace().join(crate_dir);
        let edges = graph(&root);
        if let Some(found) = circle(&edges) {
            panic!("{crate_dir}: import circle {}", found.join(" → "));
        }
    }
    // The check reads something: the engine alone has dozens of modules that import others.
    assert!(graph(&workspace().join("twin/src")).len() > 20);
}

/// A file under a folder reaches what its siblings define through their modules
/// (`super::spec::Scenario`), never through the folder's `mod.rs` re-exports (`super::Scenario`):
/// a `mod.rs` declares its files, so a reference back into it would hide the edge between the
/// two siblings from the circle check above. A folder's tests may read the folder as a whole.
/// Held in the engine (whose `mod.rs` files only declare), the command line and the
/// controllers; the models' folders still share what their `mod.rs` defines.
#[test]
fn no_file_reaches_its_siblings_through_the_folders_mod_rs() {
    let mut checked = 0;
    for crate_dir in ["twin/src", "twin/cli/src", "controllers/src", "models/src"] {
        checked += references_back_into_mod_rs(&workspace().join(crate_dir));
    }
    assert!(checked > 100, "{checked} references");
}

/// The command line's commands, each a module `command_line.rs` dispatches to.
const COMMANDS: [&str; 14] = [
    "analyze",
    "bench",
    "calibrate",
    "compare",
    "fmu",
    "frf",
    "linearize",
    "list",
    "reproduce",
    "run",
    "salvage",
    "serve",
    "shadow",
    "sweep",
];

#[test]
fn the_command_lines_commands_are_peers_over_a_shared_floor() {
    let root = workspace().join("twin/cli/src");
    let door = std::fs::read_to_string(root.join("command_line.rs")).unwrap();
    let dispatched: BTreeSet<&str> = (door.lines())
        .filter_map(|line| line.strip_prefix("use crate::")?.strip_suffix(';'))
        .filter(|name| name.chars().all(|c| c.is_ascii_lowercase() || c == '_'))
        .filter(|&name| name != "reference")
        .collect();
    assert_eq!(
        dispatched,
        COMMANDS.into_iter().collect(),
        "command_line.rs dispatches to these modules: name each command in COMMANDS"
    );
    let mut checked = 0;
    for file in sources(&root) {
        let module = module_of(&root, &file);
        let Some(command) = module.first().filter(|m| COMMANDS.contains(&m.as_str())) else {
            continue;
        };
        let text = std::fs::read_to_string(&file).unwrap();
        let code = text.split("#[cfg(test)]").next().unwrap_or_default();
        for target in references(&module, code) {
            let other = target.first().filter(|t| *t != command);
            assert!(
                !other.is_some_and(|t| COMMANDS.contains(&t.as_str())),
                "{}: the command `{command}` uses the command `{}`: move what both use below \
                 the commands",
                file.display(),
                target.join("::")
            );
            checked += 1;
        }
    }
    assert!(checked > 50, "{checked} references");
}

/// Checks the rule above under `root`; how many references it read.
fn references_back_into_mod_rs(root: &Path) -> usize {
    let mut checked = 0;
    for file in sources(root) {
        let stem = file.file_stem().map(|s| s.to_string_lossy().into_owned());
        if stem
            .as_deref()
            .is_none_or(|s| s == "tests" || s.ends_with("_tests"))
        {
            continue;
        }
        let module = module_of(root, &file);
        let text = std::fs::read_to_string(&file).unwrap();
        let code = text.split("#[cfg(test)]").next().unwrap_or_default();
        for target in references(&module, code) {
            let folder = root.join(target.join("/"));
            let ancestor =
                !target.is_empty() && target.len() < module.len() && module.starts_with(&target);
            assert!(
                !(ancestor && folder.join("mod.rs").is_file()),
                "{}: refers to `{}` through its mod.rs: name the file that defines it",
                file.display(),
                target.join("::")
            );
            checked += 1;
        }
    }
    checked
}

/// The names a crate root (`lib.rs` or `main.rs`) defines itself, rather than declares or
/// re-exports: functions, types, constants and statics.
fn defined_at_root(text: &str) -> Vec<String> {
    let mut names = Vec::new();
    for line in text.lines() {
        let mut rest = line.trim_start();
        for visibility in ["pub(crate) ", "pub "] {
            rest = rest.strip_prefix(visibility).unwrap_or(rest);
        }
        for kind in [
            "fn ", "struct ", "enum ", "trait ", "const ", "static ", "type ",
        ] {
            if let Some(after) = rest.strip_prefix(kind) {
                let name: String = after
                    .chars()
                    .take_while(|c| c.is_alphanumeric() || *c == '_')
                    .collect();
                if !name.is_empty() && name != "main" {
                    names.push(name);
                }
            }
        }
    }
    names
}

/// A crate root and its modules import each other when a module uses what the root defines: the
/// root declares the module, the module reaches back into the root. Roots only declare modules
/// and re-export.
#[test]
fn no_module_uses_what_its_crate_root_defines() {
    for crate_dir in CRATES {
        let root = workspace().join(crate_dir);
        for root_file in ["lib.rs", "main.rs"] {
            let Ok(text) = std::fs::read_to_string(root.join(root_file)) else {
                continue;
            };
            for name in defined_at_root(&text) {
                for file in sources(&root) {
                    if file.parent() == Some(root.as_path())
                        && matches!(
                            file.file_name().and_then(|n| n.to_str()),
                            Some("lib.rs" | "main.rs")
                        )
                    {
                        continue;
                    }
                    let code = std::fs::read_to_string(&file).unwrap();
                    let uses = code
                        .lines()
                        .filter(|l| !l.trim_start().starts_with("//"))
                        .any(|l| {
                            l.contains(&format!("crate::{name}"))
                                || (l.contains("use crate::{") && l.contains(&name))
                        });
                    assert!(
                        !uses,
                        "{}: uses `{name}`, defined in {crate_dir}/{root_file}: move it into a module of its own",
                        file.display()
                    );
                }
            }
        }
    }
}

/// A folder's `mod.rs` only declares its files and re-exports: what the library shows
/// (`twin::data`, `twin::calibration`, `twin::shadowing`) is named like its folder, and no file
/// reaches back into its parent for what the parent defines.
#[test]
fn every_mod_rs_only_declares_and_re_exports() {
    let mut checked = 0;
    for crate_dir in ["twin/src", "twin/cli/src", "controllers/src", "models/src"] {
        checked += mod_rs_definitions(&workspace().join(crate_dir), crate_dir);
    }
    // The check reads something: the engine's run/, machines/, data/, calibration/ and
    // shadowing/, the command line's serve/, shadow/ and study/ at least.
    assert!(checked >= 8, "{checked} mod.rs files");
    let root = workspace().join("twin/src");
    for folder in ["data", "calibration", "shadowing"] {
        let lib = std::fs::read_to_string(root.join("lib.rs")).unwrap();
        assert!(
            lib.contains(&format!("\npub mod {folder};")),
            "twin::{folder} is not its folder src/{folder}/"
        );
    }
}

/// Checks that no mod.rs under `root` (the crate folder `name`) defines anything; how many it
/// read.
fn mod_rs_definitions(root: &Path, name: &str) -> usize {
    let mut checked = 0;
    for file in sources(root) {
        let folder = file.parent().and_then(|f| f.strip_prefix(root).ok());
        let Some(folder) = folder.map(|f| f.to_string_lossy().into_owned()) else {
            continue;
        };
        if file.file_name().is_none_or(|n| n != "mod.rs") {
            continue;
        }
        let text = std::fs::read_to_string(&file).unwrap();
        let code = text.lines().take_while(|l| !l.contains("#[cfg(test)]"));
        let mut names = defined_at_root(&code.clone().collect::<Vec<_>>().join("\n"));
        names.extend(code.filter(|l| l.starts_with("impl")).map(str::to_owned));
        assert!(
            names.is_empty(),
            "{name}/{folder}/mod.rs defines {}: move it into a file of the folder and re-export it",
            names.join(", ")
        );
        checked += 1;
    }
    checked
}

#[test]
fn the_circle_finder_finds_a_circle() {
    let mut edges = BTreeMap::new();
    let name = |n: &str| vec![n.to_string()];
    edges.insert(name("a"), BTreeSet::from([name("b")]));
    edges.insert(name("b"), BTreeSet::from([name("c")]));
    edges.insert(name("c"), BTreeSet::from([name("a")]));
    assert_eq!(
        circle(&edges),
        Some(vec!["a".into(), "b".into(), "c".into()])
    );
    edges.insert(name("c"), BTreeSet::new());
    assert_eq!(circle(&edges), None);
    let module = ["analysis".to_string(), "lathe".to_string()];
    let found = references(
        &module,
        "use super::lathe_output::write;\n/// [`crate::scenario`]\ncrate::run::Twin",
    );
    let path = |names: &[&str]| names.iter().map(|n| n.to_string()).collect::<Vec<_>>();
    assert!(
        found.contains(&path(&["analysis", "lathe_output", "write"])),
        "{found:?}"
    );
    assert!(found.contains(&path(&["run"])));
    assert!(!found.iter().any(|p| p[0] == "scenario"), "{found:?}");
}

/// The `[dependencies]` table of the library's manifest, as written (dev-dependencies apart).
fn library_dependencies() -> String {
    let manifest =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("Cargo.toml")).unwrap();
    let table = manifest.split("[dependencies]").nth(1).unwrap();
    table.split("\n[").next().unwrap().to_string()
}

#[test]
fn the_library_leaves_the_command_line_crates_to_the_applications() {
    let dependencies = library_dependencies();
    // tokio and async-opcua are `twin serve`'s and `twin shadow`'s network; workspace-hack pins
    // features for the entry points, and is only a dev-dependency of the engine.
    let denied = "clap indicatif signal-hook rayon tokio async-opcua workspace-hack";
    for crate_name in denied.split(' ') {
        assert!(
            !dependencies.contains(&format!("\n{crate_name}")),
            "the library depends on {crate_name}"
        );
    }
}

/// The engine below the controllers' collection (as Drake's analysis depends on the framework
/// alone): `twin` takes a registry of controllers and builds none itself; the collection is a
/// dev-dependency, for its tests and examples. Shared math the two need (first-order filters)
/// lives in `models`.
#[test]
fn the_engine_imports_nothing_from_the_controller_collection() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dependencies = library_dependencies();
    assert!(
        !dependencies.contains("\ncontrollers"),
        "twin's [dependencies] list the controller collection"
    );
    for file in sources(&root.join("src")) {
        let text = std::fs::read_to_string(&file).unwrap();
        let code = text
            .lines()
            .filter(|l| !l.trim_start().starts_with("//"))
            .take_while(|l| !l.contains("#[cfg(test)]"));
        for line in code {
            assert!(
                !line.contains("use controllers::"),
                "{}: imports the controller collection: {line}",
                file.display()
            );
        }
    }
}

/// The folders of Rust files beside the crates' sources: integration tests and examples.
const TESTS_AND_EXAMPLES: [&str; 4] = [
    "twin/tests",
    "twin/cli/tests",
    "twin/examples",
    "twin/fmu/examples",
];

#[test]
fn every_source_file_opens_with_its_doc() {
    let root = workspace();
    let mut files = Vec::new();
    for folder in CRATES.iter().chain(&TESTS_AND_EXAMPLES) {
        files.extend(sources(&root.join(folder)));
    }
    files.retain(|file| {
        let relative = file.strip_prefix(&root).unwrap();
        !relative.components().any(|c| c.as_os_str() == "target")
    });
    let undocumented: Vec<String> = files
        .iter()
        .filter(|file| {
            let text = std::fs::read_to_string(file).unwrap();
            !text.lines().next().is_some_and(|l| l.starts_with("//!"))
        })
        .map(|file| file.strip_prefix(&root).unwrap().display().to_string())
        .collect();
    assert!(
        undocumented.is_empty(),
        "these files do not open with a `//!` line saying what they are: {}",
        undocumented.join(", ")
    );
    // The check reads something: the workspace has hundreds of source files.
    assert!(files.len() > 200, "{} files", files.len());
}
