//! The `Study` section: the grid of variations and the measured quantities of `peridyn study`.
//! `peridyn run` and `peridyn check` read it (so a malformed section is reported alike) and
//! ignore it.
//!
//! ```yaml
//! Study:
//!   Vary:
//!     "Discretization.TensorProduct3DMeshGenerator.Number Points X": "20, 40, 80"
//!     "Solver.Verlet.Safety Factor": "0.5, 0.9"
//!   Measure:
//!     Tip displacement: "global:Far_End_DisplacementX"
//!     Kinetic energy: "global:Global_Kinetic_Energy=0.125"
//!   Jobs: 2
//!   Threads: 1
//! ```
//!
//! * `Vary` — one entry per variation: the key path (keys joined by `.`, in the deck's own
//!   spelling) and its values separated by commas (commas inside parentheses belong to the
//!   value, so expressions such as `max(x,0)` stay whole). The study runs the product of the
//!   variations. Keys that must change together (the three `Number Points` of a grid refined
//!   in every direction, a mesh file and its node-set files) form one variation: their key
//!   paths joined by ` & `, each value the matching parts joined by `&`
//!   (`"…Number Points X & …Number Points Y": "20 & 4, 40 & 8"`).
//! * `Measure` — one entry per measured quantity: a column label and a measure (see
//!   `peridyn study --help`: `global:NAME`, `mean:FIELD@NODE SET`, `modulus:AREA`, each with an
//!   optional `=EXACT` analytic value).
//! * `Jobs` — runs at once (default: cores / threads per run); `Threads` — worker threads of
//!   each run (default 1).
//!
//! Command-line `--measure` options add to the section's measures, `--vary` options to its
//! variations (replacing the section's variation of the same key path).

use super::error::DeckError;
use super::overrides::split_key_path;
use super::reader::{Ctx, Field};
use super::tree::NodeKind;

/// The `Study` section.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Study {
    /// `Vary`, file order.
    pub variations: Vec<Variation>,
    /// `Measure`, file order: (column label, measure text).
    pub measures: Vec<(String, String)>,
    /// `Jobs` (≥ 1); default: cores / threads per run.
    pub jobs: Option<usize>,
    /// `Threads` (≥ 1): worker threads per run; default 1.
    pub threads: Option<usize>,
}

/// One variation: a key path (with the key paths linked to it) and the values it takes.
#[derive(Debug, Clone, PartialEq)]
pub struct Variation {
    /// The keys from the top level down.
    pub path: Vec<String>,
    /// Further key paths that change together with `path` (written after it, joined by
    /// ` & `); empty for a variation of one key. Each value then holds one part per key path,
    /// joined by `&`.
    pub linked: Vec<Vec<String>>,
    /// The values, in the order given (for linked key paths, the parts joined by `&`).
    pub values: Vec<String>,
    /// Line of the variation in the deck (`None` on the command line).
    pub line: Option<usize>,
}

impl Variation {
    /// Parses `KEY PATH=V1,V2,…` (the command line's `--vary`); linked key paths are joined
    /// by ` & ` and so are the parts of each value.
    pub fn parse(text: &str) -> Result<Variation, String> {
        let (path, values) = text.split_once('=').ok_or_else(|| {
            format!(
                "\"{text}\": expected KEY PATH=V1,V2,…, e.g. \"Blocks.My Block.Horizon=0.2,0.3\""
            )
        })?;
        Self::from_parts(path, values, None).map_err(|e| format!("\"{text}\": {e}"))
    }

    /// The variation of the key paths `paths` (joined by `&`) over `values` (separated by
    /// commas, the parts of each joined by `&` when several key paths are linked).
    fn from_parts(paths: &str, values: &str, line: Option<usize>) -> Result<Variation, String> {
        let mut paths = paths
            .split('&')
            .map(|p| split_key_path(p.trim()))
            .collect::<Result<Vec<_>, _>>()?;
        let values = split_values(values)?;
        if paths.len() > 1 {
            for value in &values {
                let parts: Vec<&str> = value.split('&').map(str::trim).collect();
                if parts.len() != paths.len() || parts.iter().any(|p| p.is_empty()) {
                    return Err(format!(
                        "the value \"{value}\" needs {} non-empty parts joined by &, one per key path",
                        paths.len()
                    ));
                }
            }
        }
        let path = paths.remove(0);
        Ok(Variation {
            path,
            linked: paths,
            values,
            line,
        })
    }

    /// The key paths joined by `.`, linked ones joined by ` & `.
    pub fn name(&self) -> String {
        std::iter::once(&self.path)
            .chain(&self.linked)
            .map(|p| p.join("."))
            .collect::<Vec<_>>()
            .join(" & ")
    }

    /// The deck changes that give this variation the value `value` (one per key path).
    pub fn assignments(&self, value: &str) -> Vec<super::Override> {
        if self.linked.is_empty() {
            return vec![super::Override {
                path: self.path.clone(),
                value: value.to_string(),
            }];
        }
        std::iter::once(&self.path)
            .chain(&self.linked)
            .zip(value.split('&'))
            .map(|(path, part)| super::Override {
                path: path.clone(),
                value: part.trim().to_string(),
            })
            .collect()
    }
}

/// Splits `a, b, f(x,y)` at the commas outside parentheses; every value must be non-empty.
pub fn split_values(text: &str) -> Result<Vec<String>, String> {
    let mut values = Vec::new();
    let mut depth = 0i32;
    let mut current = String::new();
    for c in text.chars() {
        match c {
            '(' => depth += 1,
            ')' => depth -= 1,
            _ => {}
        }
        if c == ',' && depth == 0 {
            values.push(std::mem::take(&mut current));
        } else {
            current.push(c);
        }
    }
    values.push(current);
    let values: Vec<String> = values.into_iter().map(|v| v.trim().to_string()).collect();
    if values.iter().any(String::is_empty) {
        return Err("every value between commas must be non-empty".to_string());
    }
    Ok(values)
}

/// The text of a scalar entry, whatever its type (`20` and `"20, 40"` alike).
fn text(ctx: &Ctx, f: &Field) -> Result<String, DeckError> {
    match &f.node().kind {
        NodeKind::Scalar(s) => Ok(s.text.clone()),
        NodeKind::List(_) => Err(f.err(ctx, "expected a value, found a list")),
    }
}

pub(crate) fn read(ctx: &mut Ctx, field: &Field) -> Result<Study, DeckError> {
    let mut list = field.list(ctx)?;
    let mut study = Study::default();
    if let Some(mut vary) = list.list_opt(ctx, "Vary")? {
        for f in vary.all() {
            let values = text(ctx, &f)?;
            let variation = Variation::from_parts(f.key(), &values, Some(f.line()))
                .map_err(|e| f.err(ctx, e))?;
            study.variations.push(variation);
        }
    }
    if let Some(mut measure) = list.list_opt(ctx, "Measure")? {
        for f in measure.all() {
            study.measures.push((f.key().to_string(), text(ctx, &f)?));
        }
    }
    study.jobs = list.int_opt(ctx, "Jobs", 1)?.map(|n| n as usize);
    study.threads = list.int_opt(ctx, "Threads", 1)?.map(|n| n as usize);
    list.finish(ctx, &[])?;
    Ok(study)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_split_at_commas_outside_parentheses() {
        assert_eq!(split_values("20, 40,80").unwrap(), ["20", "40", "80"]);
        assert_eq!(
            split_values("max(x,0), 1e-3*t").unwrap(),
            ["max(x,0)", "1e-3*t"]
        );
        assert!(split_values("1,,2").is_err());
    }

    #[test]
    fn a_command_line_variation_has_a_path_and_values() {
        let v = Variation::parse("Solver.Verlet.Safety Factor=0.5,0.9").unwrap();
        assert_eq!(v.path, ["Solver", "Verlet", "Safety Factor"]);
        assert_eq!(v.values, ["0.5", "0.9"]);
        assert_eq!(v.name(), "Solver.Verlet.Safety Factor");
        assert!(Variation::parse("Solver.Verlet.Safety Factor").is_err());
    }

    #[test]
    fn linked_key_paths_change_together() {
        let v = Variation::parse("D.Number Points X & D.Number Points Y=20 & 4, 40&8").unwrap();
        assert_eq!(v.path, ["D", "Number Points X"]);
        assert_eq!(v.linked, [["D", "Number Points Y"]]);
        assert_eq!(v.values, ["20 & 4", "40&8"]);
        assert_eq!(v.name(), "D.Number Points X & D.Number Points Y");
        let changes = v.assignments(&v.values[1]);
        assert_eq!(changes.len(), 2);
        assert_eq!(
            (changes[0].path.clone(), changes[0].value.as_str()),
            (vec!["D".to_string(), "Number Points X".to_string()], "40")
        );
        assert_eq!(changes[1].value, "8");
        // One part per key path, none empty.
        assert!(Variation::parse("A.B & A.C=1 & 2, 3").is_err());
        assert!(Variation::parse("A.B & A.C=1 & ").is_err());
        // A single key path keeps its value whole, & included.
        let single = Variation::parse("A.B=x&y").unwrap();
        assert_eq!(single.assignments("x&y")[0].value, "x&y");
    }
}
