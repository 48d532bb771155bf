//! How a data file is read: its columns renamed (`--rename old=new`), its CSV separator, and
//! whether the columns the plant does not know are refused.

use super::error::DataError;

/// How a data file is read: its columns renamed, the CSV separator, and whether the columns the
/// plant does not know are refused.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ReadOptions {
    /// Column renames, old → new (names without their units), applied before anything else
    /// looks at the columns (`--rename old=new`, [`parse_renames`]).
    pub renames: Vec<(String, String)>,
    /// The CSV separator; `None`: the one the header holds most of (`,` when it holds none).
    pub delimiter: Option<Delimiter>,
    /// Refuse the columns the plant does not know instead of leaving them out with a note.
    pub strict: bool,
}

/// The separator of a CSV file's cells (`--delimiter`). With `;` or tab, a number may have a
/// decimal comma (`0,25`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Delimiter {
    /// `,`
    Comma,
    /// `;`
    Semicolon,
    /// A tab.
    Tab,
}

impl std::str::FromStr for Delimiter {
    type Err = String;

    /// `,`, `;` or `tab` (also `comma`, `semicolon` and a tab character).
    fn from_str(text: &str) -> Result<Self, String> {
        match text {
            "," | "comma" => Ok(Delimiter::Comma),
            ";" | "semicolon" => Ok(Delimiter::Semicolon),
            "tab" | "\t" => Ok(Delimiter::Tab),
            other => Err(format!(
                "`{other}` is not a separator; give `,`, `;` or `tab`"
            )),
        }
    }
}

impl Delimiter {
    /// The character that separates cells.
    pub fn separator(self) -> char {
        match self {
            Delimiter::Comma => ',',
            Delimiter::Semicolon => ';',
            Delimiter::Tab => '\t',
        }
    }

    /// How a message and `--delimiter` name it: `,`, `;` or `tab`.
    pub fn name(self) -> &'static str {
        match self {
            Delimiter::Comma => ",",
            Delimiter::Semicolon => ";",
            Delimiter::Tab => "tab",
        }
    }
}

/// Parses `--rename old=new` arguments: each renames the column `old` (its name without the
/// unit) to `new`.
pub fn parse_renames(args: &[String]) -> Result<Vec<(String, String)>, DataError> {
    args.iter()
        .map(|given| {
            let error = |reason: &str| DataError::Rename {
                given: given.clone(),
                reason: reason.to_owned(),
            };
            let (old, new) = given
                .split_once('=')
                .ok_or_else(|| error("give old=new, e.g. --rename pos=ram_position"))?;
            let (old, new) = (old.trim(), new.trim());
            if old.is_empty() || new.is_empty() {
                return Err(error("both names are needed: old=new"));
            }
            if new.contains(['[', ']', ',', ';', '\t', '"', '\n', '\r']) {
                return Err(error(
                    "the new name may not hold brackets, separators, quotes or line breaks",
                ));
            }
            Ok((old.to_owned(), new.to_owned()))
        })
        .collect()
}
