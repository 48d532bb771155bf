//! The machine map: which OPC UA node of the running machine carries which of the twin's
//! columns, and in which unit. A TOML file:
//!
//! ```toml
//! # optional: the machine's server; the command line's --opcua wins
//! endpoint = "opc.tcp://127.0.0.1:4841"
//! [nodes]
//! "effort.crank"   = { node = "ns=2;s=Crank.Torque", unit = "N·m" }
//! "crank.position" = { node = "nsu=urn:machine;s=Crank.Position", unit = "deg" }
//! ```
//!
//! The nodes keep the file's order (the workspace's `toml` has no `preserve_order`, so the
//! entries are sorted back by where they stand in the file). Binding the columns and units to
//! the twin is the caller's.

use super::error::LinkError;
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::Path;
use toml::Spanned;

/// A machine map, as read from its file.
#[derive(Debug, Clone, PartialEq)]
pub struct MachineMap {
    /// The machine's server (`opc.tcp://HOST:PORT`), if the file names it.
    pub endpoint: Option<String>,
    /// The mapped nodes, in the file's order.
    pub nodes: Vec<MappedNode>,
}

/// One of the twin's columns and the machine's node that carries it.
#[derive(Debug, Clone, PartialEq)]
pub struct MappedNode {
    /// The twin's column name (`effort.crank`, `crank.position`).
    pub column: String,
    /// The node id as the file gives it (`ns=2;s=Crank.Torque`, `nsu=urn:machine;i=7`).
    pub node: String,
    /// The unit the machine publishes the value in, as the file gives it.
    pub unit: String,
}

/// The namespace part of a node id.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
pub enum Namespace {
    /// `ns=<index>` (or none: index 0).
    Index(u16),
    /// `nsu=<uri>`, resolved through the server's NamespaceArray.
    Uri(String),
}

/// The identifier part of a node id.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
pub enum Identifier {
    /// `s=<string>`.
    String(String),
    /// `i=<u32>`.
    Numeric(u32),
}

/// A node id as parsed from the map, before its namespace is resolved on a server.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
pub struct NodeAddress {
    /// Its namespace.
    pub namespace: Namespace,
    /// Its identifier.
    pub identifier: Identifier,
}

/// Parses `ns=<u16>;s=<string>`, `ns=<u16>;i=<u32>`, `nsu=<uri>;s=…`, `nsu=<uri>;i=…`, or the
/// identifier alone (namespace 0); the error says what is wrong, for a message.
pub fn parse_node_id(text: &str) -> Result<NodeAddress, String> {
    let (namespace, identifier) = if let Some(rest) = text.strip_prefix("nsu=") {
        let (uri, identifier) = rest
            .split_once(';')
            .ok_or("a namespace URI must be followed by `;s=…` or `;i=…`")?;
        if uri.is_empty() {
            return Err("the namespace URI after nsu= is empty".into());
        }
        (Namespace::Uri(uri.to_string()), identifier)
    } else if let Some(rest) = text.strip_prefix("ns=") {
        let (index, identifier) = rest
            .split_once(';')
            .ok_or("a namespace index must be followed by `;s=…` or `;i=…`")?;
        let index = index
            .parse::<u16>()
            .map_err(|_| format!("namespace index `{index}` is not a number from 0 to 65535"))?;
        (Namespace::Index(index), identifier)
    } else {
        (Namespace::Index(0), text)
    };
    let identifier = if let Some(name) = identifier.strip_prefix("s=") {
        if name.is_empty() {
            return Err("the string identifier after s= is empty".into());
        }
        Identifier::String(name.to_string())
    } else if let Some(number) = identifier.strip_prefix("i=") {
        Identifier::Numeric(
            number
                .parse::<u32>()
                .map_err(|_| format!("`i={number}` is not a number from 0 to 4294967295"))?,
        )
    } else {
        return Err(
            "the identifier must be s=<string> or i=<number> (after ns=<index>; or nsu=<uri>;)"
                .into(),
        );
    };
    Ok(NodeAddress {
        namespace,
        identifier,
    })
}

/// The file as written (the entries' fields optional, to name a missing one).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MapFile {
    endpoint: Option<String>,
    #[serde(default)]
    nodes: BTreeMap<String, Spanned<NodeEntry>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct NodeEntry {
    node: Option<String>,
    unit: Option<String>,
}

impl MachineMap {
    /// Reads and checks the map at `path`; every refusal is one line naming the file, the key
    /// and what to change.
    pub fn read(path: impl AsRef<Path>) -> Result<MachineMap, LinkError> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|e| LinkError::Map {
            path: path.to_path_buf(),
            reason: format!("cannot read the machine map: {e}"),
        })?;
        Self::parse(&text, path)
    }

    /// Parses the text of the map at `path` (named in the messages).
    pub fn parse(text: &str, path: &Path) -> Result<MachineMap, LinkError> {
        let refuse = |reason: String| LinkError::Map {
            path: path.to_path_buf(),
            reason,
        };
        let file: MapFile = toml::from_str(text).map_err(|e| {
            let line = e
                .span()
                .map(|span| format!("line {}: ", line_of(text, span.start)))
                .unwrap_or_default();
            let message = e.message().trim().replace('\n', " ");
            refuse(format!("{line}{message}"))
        })?;
        if file.nodes.is_empty() {
            return Err(refuse(
                "[nodes] is empty or missing; add one line per column, e.g. \
                 \"crank.position\" = { node = \"ns=2;s=Crank.Position\", unit = \"deg\" }"
                    .into(),
            ));
        }
        let mut entries: Vec<_> = file.nodes.into_iter().collect();
        entries.sort_by_key(|(_, entry)| entry.span().start);
        let mut nodes = Vec::with_capacity(entries.len());
        let mut seen: Vec<(NodeAddress, String)> = Vec::new();
        for (column, entry) in entries {
            let line = line_of(text, entry.span().start);
            let entry = entry.into_inner();
            let missing = |key: &str, example: &str| {
                refuse(format!(
                    "line {line}: nodes.\"{column}\" has no `{key}`; add {key} = \"{example}\""
                ))
            };
            let node = entry.node.ok_or_else(|| missing("node", "ns=2;s=…"))?;
            let unit = entry.unit.ok_or_else(|| missing("unit", "N·m"))?;
            let address = parse_node_id(&node).map_err(|reason| {
                refuse(format!(
                    "line {line}: nodes.\"{column}\": node \"{node}\": {reason}"
                ))
            })?;
            if let Some((_, other)) = seen.iter().find(|(a, _)| *a == address) {
                return Err(refuse(format!(
                    "line {line}: nodes.\"{column}\": node \"{node}\" is mapped already to \
                     nodes.\"{other}\"; map each node once"
                )));
            }
            seen.push((address, column.clone()));
            nodes.push(MappedNode { column, node, unit });
        }
        Ok(MachineMap {
            endpoint: file.endpoint,
            nodes,
        })
    }
}

/// The 1-based line of byte `offset` in `text`.
fn line_of(text: &str, offset: usize) -> usize {
    text.as_bytes()[..offset.min(text.len())]
        .iter()
        .filter(|b| **b == b'\n')
        .count()
        + 1
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<MachineMap, String> {
        MachineMap::parse(text, Path::new("map.toml")).map_err(|e| e.to_string())
    }

    fn refusal(text: &str) -> String {
        let message = parse(text).expect_err("refused");
        assert!(!message.contains('\n'), "one line: {message}");
        assert!(message.starts_with("map.toml: "), "{message}");
        message
    }

    #[test]
    fn a_map_keeps_the_file_order_and_its_endpoint() {
        let map = parse(
            r#"
endpoint = "opc.tcp://127.0.0.1:4841"
[nodes]
"zeta"           = { node = "ns=2;s=Z", unit = "m" }
"effort.crank"   = { node = "ns=2;s=Crank.Torque", unit = "N·m" }
"crank.position" = { node = "nsu=urn:machine;s=Crank.Position", unit = "deg" }
"alpha"          = { node = "i=2258", unit = "1" }
"#,
        )
        .unwrap();
        assert_eq!(map.endpoint.as_deref(), Some("opc.tcp://127.0.0.1:4841"));
        let columns: Vec<_> = map.nodes.iter().map(|n| n.column.as_str()).collect();
        assert_eq!(columns, ["zeta", "effort.crank", "crank.position", "alpha"]);
        assert_eq!(map.nodes[1].node, "ns=2;s=Crank.Torque");
        assert_eq!(map.nodes[1].unit, "N·m");
        let no_endpoint = parse("[nodes]\na = { node = \"ns=1;i=5\", unit = \"m\" }").unwrap();
        assert_eq!(no_endpoint.endpoint, None);
    }

    #[test]
    fn node_ids_parse_in_every_accepted_form() {
        let id = |ns, s: &str| NodeAddress {
            namespace: ns,
            identifier: Identifier::String(s.into()),
        };
        assert_eq!(
            parse_node_id("ns=2;s=Crank.Torque"),
            Ok(id(Namespace::Index(2), "Crank.Torque"))
        );
        assert_eq!(
            parse_node_id("nsu=urn:machine;s=a;b"),
            Ok(id(Namespace::Uri("urn:machine".into()), "a;b"))
        );
        assert_eq!(
            parse_node_id("ns=3;i=7").map(|a| a.identifier),
            Ok(Identifier::Numeric(7))
        );
        assert_eq!(
            parse_node_id("nsu=http://x/;i=9").map(|a| a.namespace),
            Ok(Namespace::Uri("http://x/".into()))
        );
        assert_eq!(
            parse_node_id("s=Plain"),
            Ok(id(Namespace::Index(0), "Plain"))
        );
        for bad in [
            "ns=70000;s=X",
            "ns=x;s=X",
            "ns=2",
            "ns=2;g=0000",
            "nsu=;s=X",
            "nsu=urn:x",
            "ns=2;i=-1",
            "ns=2;s=",
            "Crank",
            "",
        ] {
            assert!(parse_node_id(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn an_unreadable_file_is_refused_naming_it() {
        let message = MachineMap::read(Path::new("/nonexistent/map.toml"))
            .unwrap_err()
            .to_string();
        assert!(
            message.starts_with("/nonexistent/map.toml: cannot read the machine map"),
            "{message}"
        );
    }

    #[test]
    fn bad_toml_is_refused_with_its_line() {
        let message = refusal("[nodes]\n\"a\" = { node = \"ns=1;s=A\", unit = \"m\" }\nb = = 3\n");
        assert!(message.starts_with("map.toml: line 3: "), "{message}");
    }

    #[test]
    fn unknown_keys_are_refused_naming_them() {
        let message =
            refusal("endpont = \"opc.tcp://h:1\"\n[nodes]\na = { node = \"i=1\", unit = \"m\" }");
        assert!(
            message.contains("line 1: unknown field `endpont`"),
            "{message}"
        );
        let message = refusal("[nodes]\na = { node = \"i=1\", unit = \"m\", scale = 2 }");
        assert!(
            message.contains("line 2: unknown field `scale`"),
            "{message}"
        );
    }

    #[test]
    fn an_entry_without_node_or_unit_is_refused() {
        let message = refusal("[nodes]\n\"crank.position\" = { unit = \"deg\" }");
        assert_eq!(
            message,
            "map.toml: line 2: nodes.\"crank.position\" has no `node`; add node = \"ns=2;s=…\""
        );
        let message = refusal("[nodes]\n\"effort.crank\" = { node = \"ns=2;s=T\" }");
        assert_eq!(
            message,
            "map.toml: line 2: nodes.\"effort.crank\" has no `unit`; add unit = \"N·m\""
        );
    }

    #[test]
    fn an_empty_or_missing_nodes_table_is_refused() {
        for text in ["[nodes]\n", "endpoint = \"opc.tcp://127.0.0.1:4841\"\n"] {
            let message = refusal(text);
            assert!(
                message.starts_with("map.toml: [nodes] is empty or missing; add one line"),
                "{message}"
            );
        }
    }

    #[test]
    fn a_node_id_that_does_not_parse_is_refused() {
        let message = refusal("[nodes]\na = { node = \"ns=2;s=A\", unit = \"m\" }\nb = { node = \"ns=two;s=B\", unit = \"m\" }");
        assert_eq!(
            message,
            "map.toml: line 3: nodes.\"b\": node \"ns=two;s=B\": namespace index `two` is not a \
             number from 0 to 65535"
        );
    }

    #[test]
    fn the_same_node_twice_is_refused() {
        let message = refusal(
            "[nodes]\na = { node = \"ns=0;i=5\", unit = \"m\" }\nb = { node = \"i=5\", unit = \"m\" }",
        );
        assert_eq!(
            message,
            "map.toml: line 3: nodes.\"b\": node \"i=5\" is mapped already to nodes.\"a\"; map \
             each node once"
        );
    }
}
