//! Changing one value of a deck before it is read: `peridyn run --set 'KEY PATH=VALUE'` and the
//! variants of `peridyn study`.
//!
//! An override names a key by its path in the deck's own spelling, keys joined by `.` (or
//! ` → `, as error messages write paths), e.g. `Solver.Verlet.Safety Factor=0.5` or
//! `Discretization.TensorProduct3DMeshGenerator.Number Points X=40`; a leading `Peridigm` is
//! optional. It is applied to the parsed tree, before the deck is checked, so the changed deck
//! is validated exactly like a written one, relative file names still resolve against the
//! deck's folder, and YAML and XML decks take the same overrides.
//!
//! Every list on the path must exist in the deck. The last key may be missing from its list:
//! it is then added (a default made explicit, such as a `Safety Factor` the deck leaves at
//! 1.0), and the deck reader decides whether it is a valid key there.

use std::path::Path;

use super::error::{DeckError, KeyPath};
use super::reader::suggest;
use super::tree::{infer_plain_scalar, Entry, Node, NodeKind, Scalar, ScalarKind};

/// One changed value: the key path and the new value as it would be written in a YAML deck
/// (without quotes).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Override {
    /// The keys from the top level down, in the deck's spelling.
    pub path: Vec<String>,
    /// The new value (typed like an unquoted YAML scalar; a key whose deck value is a string
    /// stays a string).
    pub value: String,
}

impl Override {
    /// Parses `KEY PATH=VALUE` (the first `=` separates them).
    pub fn parse(text: &str) -> Result<Override, String> {
        let (path, value) = text.split_once('=').ok_or_else(|| {
            format!("\"{text}\": expected KEY PATH=VALUE, e.g. \"Solver.Verlet.Safety Factor=0.5\"")
        })?;
        Ok(Override {
            path: split_key_path(path)?,
            value: value.trim().to_string(),
        })
    }

    /// The key path as error messages write it (`Solver → Verlet → Safety Factor`).
    pub fn key_path(&self) -> KeyPath {
        KeyPath(self.path.clone())
    }
}

/// Splits `A.B.C` (or `A → B → C`) into its keys, trimmed; an optional leading `Peridigm` (the
/// YAML root key) is dropped.
pub fn split_key_path(text: &str) -> Result<Vec<String>, String> {
    let keys: Vec<String> = text
        .split(['.', '→'])
        .map(|k| k.trim().to_string())
        .collect();
    if keys.iter().any(String::is_empty) {
        return Err(format!(
            "\"{}\": a key path is keys joined by \".\", none of them empty, e.g. \"Blocks.My Block.Horizon\"",
            text.trim()
        ));
    }
    let keys = match keys.split_first() {
        Some((first, rest)) if first == "Peridigm" && !rest.is_empty() => rest.to_vec(),
        _ => keys,
    };
    Ok(keys)
}

/// Applies `overrides` in order to the top-level `entries` of a parsed deck.
pub(crate) fn apply(
    entries: &mut Vec<Entry>,
    root_line: usize,
    overrides: &[Override],
    file: &Path,
) -> Result<(), DeckError> {
    for o in overrides {
        apply_one(entries, root_line, o, file)?;
    }
    Ok(())
}

fn apply_one(
    entries: &mut Vec<Entry>,
    root_line: usize,
    o: &Override,
    file: &Path,
) -> Result<(), DeckError> {
    let error = |line: usize, depth: usize, message: String| DeckError::Invalid {
        file: file.to_path_buf(),
        line: Some(line),
        key_path: KeyPath(o.path[..depth].to_vec()),
        message: format!("key path \"{}\": {message}", o.path.join(".")),
    };
    let mut list = entries;
    let mut line = root_line;
    let (leaf, parents) = o
        .path
        .split_last()
        .expect("split_key_path gives at least one key");
    for (depth, key) in parents.iter().enumerate() {
        let Some(index) = list.iter().position(|e| &e.key == key) else {
            let hint = match suggest(key, list.iter().map(|e| e.key.as_str())) {
                Some(s) => format!("did you mean \"{s}\"?"),
                None => format!("the list has {}", names(list)),
            };
            return Err(error(
                line,
                depth,
                format!("no key \"{key}\" in this list of the deck; {hint}"),
            ));
        };
        let entry = &mut list[index];
        line = entry.line;
        match &mut entry.value.kind {
            NodeKind::List(children) => list = children,
            NodeKind::Scalar(_) => {
                return Err(error(
                    line,
                    depth + 1,
                    format!(
                        "\"{key}\" is a value, not a list, so it has no key \"{}\"",
                        o.path[depth + 1]
                    ),
                ))
            }
        }
    }
    let depth = o.path.len();
    match list.iter_mut().find(|e| &e.key == leaf) {
        Some(entry) => match &mut entry.value.kind {
            NodeKind::Scalar(scalar) => {
                *scalar = retyped(scalar, &o.value);
                Ok(())
            }
            NodeKind::List(_) => Err(error(
                entry.line,
                depth,
                format!(
                    "\"{leaf}\" is a list; give the path of one of its keys ({})",
                    names_of(entry)
                ),
            )),
        },
        None => {
            list.push(Entry {
                key: leaf.clone(),
                line,
                value: Node {
                    line,
                    kind: NodeKind::Scalar(infer_plain_scalar(&o.value)),
                },
            });
            Ok(())
        }
    }
}

/// The new scalar: a string stays a string (an expression such as `"0.0"` must not become a
/// number), anything else is typed from the text as YAML types an unquoted value.
fn retyped(old: &Scalar, text: &str) -> Scalar {
    match old.kind {
        ScalarKind::String => Scalar {
            text: text.to_string(),
            kind: ScalarKind::String,
        },
        _ => infer_plain_scalar(text),
    }
}

fn names(list: &[Entry]) -> String {
    if list.is_empty() {
        return "no keys".to_string();
    }
    list.iter()
        .map(|e| format!("\"{}\"", e.key))
        .collect::<Vec<_>>()
        .join(", ")
}

fn names_of(entry: &Entry) -> String {
    match &entry.value.kind {
        NodeKind::List(children) => names(children),
        NodeKind::Scalar(_) => String::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::deck::{parse_str_with, DeckFormat};

    const DECK: &str = "Peridigm:
  Discretization:
    Type: \"PdQuickGrid\"
    NeighborhoodType: \"Spherical\"
    TensorProduct3DMeshGenerator:
      X Origin: 0.0
      Y Origin: 0.0
      Z Origin: 0.0
      X Length: 1.0
      Y Length: 0.2
      Z Length: 0.2
      Number Points X: 10
      Number Points Y: 2
      Number Points Z: 2
  Materials:
    Steel:
      Material Model: \"Elastic\"
      Density: 7800.0
      Bulk Modulus: 160.0e9
      Shear Modulus: 79.0e9
  Blocks:
    Bar:
      Block Names: \"block_1\"
      Material: \"Steel\"
      Horizon: 0.301
  Solver:
    Final Time: 1.0e-5
    Verlet:
      Safety Factor: 0.8
";

    fn load(sets: &[&str]) -> Result<crate::io::deck::Deck, DeckError> {
        let overrides: Vec<Override> = sets.iter().map(|s| Override::parse(s).unwrap()).collect();
        parse_str_with(DECK, DeckFormat::Yaml, Path::new("bar.yaml"), &overrides)
    }

    #[test]
    fn key_paths_split_on_dots_and_arrows() {
        let o = Override::parse("Peridigm.Blocks.Bar.Horizon = 0.5").unwrap();
        assert_eq!(o.path, ["Blocks", "Bar", "Horizon"]);
        assert_eq!(o.value, "0.5");
        let arrows = Override::parse("Blocks → Bar → Horizon=0.5").unwrap();
        assert_eq!(arrows, o);
        assert!(Override::parse("Blocks..Horizon=1").is_err());
        assert!(Override::parse("Blocks.Bar.Horizon").is_err());
    }

    #[test]
    fn an_override_changes_the_value_the_deck_reads() {
        let deck = load(&[
            "Discretization.TensorProduct3DMeshGenerator.Number Points X=20",
            "Blocks.Bar.Horizon=0.151",
        ])
        .unwrap();
        match &deck.discretization.source {
            crate::io::deck::PointSource::PdQuickGrid { generator, .. } => {
                assert!(format!("{generator:?}").contains("20"), "{generator:?}")
            }
            other => panic!("{other:?}"),
        }
        assert_eq!(format!("{:?}", deck.blocks[0].horizon), "Constant(0.151)");
        // Without overrides the deck is the one written.
        assert_eq!(
            format!("{:?}", load(&[]).unwrap().blocks[0].horizon),
            "Constant(0.301)"
        );
    }

    #[test]
    fn a_missing_last_key_is_added_and_checked_by_the_deck_reader() {
        assert!(load(&["Solver.Initial Time=0.0"]).is_ok());
        let typo = load(&["Solver.Verlet.Safety Facter=0.5"])
            .unwrap_err()
            .to_string();
        assert!(
            typo.contains("Safety Facter")
                && typo.contains("did you mean \"Safety Factor\"")
                && typo.contains("bar.yaml:28"),
            "{typo}"
        );
    }

    #[test]
    fn an_unknown_list_names_the_path_and_the_line_of_its_parent() {
        let message = load(&["Blocks.Rod.Horizon=0.2"]).unwrap_err().to_string();
        assert!(
            message.contains("bar.yaml:21:")
                && message.contains("Blocks.Rod.Horizon")
                && message.contains("no key \"Rod\"")
                && message.contains("\"Bar\""),
            "{message}"
        );
        let list = load(&["Blocks.Bar=1"]).unwrap_err().to_string();
        assert!(
            list.contains("is a list") && list.contains("Horizon"),
            "{list}"
        );
    }
}
