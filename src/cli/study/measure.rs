//! The measured quantities of a study and their errors.
//!
//! A measure is read from a run's Exodus results at the final frame:
//! * `global:NAME` — the global variable NAME (a compute class's output, e.g.
//!   `Far_End_DisplacementX`, or `Global_Kinetic_Energy`);
//! * `mean:FIELD@NODE SET` — the mean of the nodal variable FIELD (e.g. `DisplacementX`) over
//!   the points of a node set (`@all`, or no `@`, for every point);
//! * `modulus:AREA[:AXIS]` — Young's modulus of a tensile test, E = σ/ε at the final frame, from
//!   the strain gauge and load cell compute classes `peridyn modulus` reads
//!   (`Gage_Top_Initial_Position`, …, `Top_Reaction_Force`), AREA the gauge section's initial
//!   cross-section and AXIS the pulling axis (default y).
//!
//! `=VALUE` after a measure gives its exact (analytic) value; without it the reference is the
//! value of the finest run: the successful run with the most points, the last in grid order
//! among equals (so values are best listed from coarse to fine). The error is relative,
//! |v − v_ref| / |v_ref|, and absolute when v_ref = 0.

use std::path::PathBuf;

use peridyn::io::deck::normalize_name;
use peridyn::io::exodus::ExodusFile;

use crate::cli::modulus::history::History;
use crate::cli::modulus::{self, Axis, ModulusArgs};

/// What is measured.
#[derive(Debug, Clone, PartialEq)]
pub enum Quantity {
    /// A global variable at the final frame.
    Global(String),
    /// The mean of a nodal variable over a node set (`None`: every point) at the final frame.
    Mean {
        /// The nodal variable.
        field: String,
        /// The node set.
        node_set: Option<String>,
    },
    /// Young's modulus of a tensile test at the final frame.
    Modulus {
        /// Initial cross-section of the gauge section (length units squared).
        area: f64,
        /// The pulling axis.
        axis: Axis,
    },
}

/// A measured quantity with its column label and exact value, if known.
#[derive(Debug, Clone, PartialEq)]
pub struct Measure {
    /// Column label.
    pub label: String,
    /// What is measured.
    pub quantity: Quantity,
    /// The analytic value the error is taken against (`None`: the finest run).
    pub exact: Option<f64>,
}

impl Measure {
    /// Parses a measure (see the module docs); `label` names its columns.
    pub fn parse(label: &str, text: &str) -> Result<Measure, String> {
        let bad = |why: &str| {
            format!(
                "measure \"{text}\": {why}; write global:NAME, mean:FIELD@NODE SET or modulus:AREA[:AXIS], each optionally followed by =EXACT"
            )
        };
        let (spec, exact) = match text.split_once('=') {
            Some((spec, exact)) => {
                let value: f64 = exact
                    .trim()
                    .parse()
                    .map_err(|_| bad(&format!("\"{}\" is not a number", exact.trim())))?;
                (spec, Some(value))
            }
            None => (text, None),
        };
        let (kind, argument) = spec
            .split_once(':')
            .ok_or_else(|| bad("no kind before \":\""))?;
        let argument = argument.trim();
        if argument.is_empty() {
            return Err(bad("nothing after \":\""));
        }
        let quantity = match kind.trim() {
            "global" => Quantity::Global(argument.to_string()),
            "mean" => {
                let (field, set) = match argument.split_once('@') {
                    Some((field, set)) => (field.trim(), Some(set.trim())),
                    None => (argument, None),
                };
                Quantity::Mean {
                    field: field.to_string(),
                    node_set: set
                        .filter(|s| !s.eq_ignore_ascii_case("all"))
                        .map(String::from),
                }
            }
            "modulus" => {
                let (area, axis) = match argument.split_once(':') {
                    Some((area, axis)) => (area.trim(), axis.trim()),
                    None => (argument, "y"),
                };
                let area: f64 = area
                    .parse()
                    .ok()
                    .filter(|a: &f64| *a > 0.0 && a.is_finite())
                    .ok_or_else(|| {
                        bad(&format!("the area \"{area}\" must be a positive number"))
                    })?;
                let axis = match axis.to_ascii_lowercase().as_str() {
                    "x" => Axis::X,
                    "y" => Axis::Y,
                    "z" => Axis::Z,
                    other => return Err(bad(&format!("the axis \"{other}\" must be x, y or z"))),
                };
                Quantity::Modulus { area, axis }
            }
            other => return Err(bad(&format!("unknown kind \"{other}\""))),
        };
        Ok(Measure {
            label: label.to_string(),
            quantity,
            exact,
        })
    }

    /// The quantity in the run's Exodus results at the final frame.
    pub fn evaluate(&self, file: &ExodusFile) -> Result<f64, String> {
        let last = file
            .times
            .len()
            .checked_sub(1)
            .ok_or_else(|| format!("{}: no output frame", file.path.display()))?;
        let exodus = |e: peridyn::io::exodus::ExodusError| e.to_string();
        match &self.quantity {
            Quantity::Global(name) => {
                let index = global_index(file, name)?;
                Ok(file.global_values(last).map_err(exodus)?[index])
            }
            Quantity::Mean { field, node_set } => {
                let variable = file.nodal_variable_index(field).ok_or_else(|| {
                    format!(
                        "{}: no nodal variable \"{field}\" (the file has: {})",
                        file.path.display(),
                        file.nodal_variable_names.join(", ")
                    )
                })?;
                let values = file.nodal_values(last, variable).map_err(exodus)?;
                let chosen: Vec<f64> = match node_set {
                    None => values,
                    Some(name) => {
                        let wanted = normalize_name(name);
                        let set = file
                            .node_sets
                            .iter()
                            .find(|s| normalize_name(&s.name) == wanted)
                            .ok_or_else(|| {
                                format!(
                                    "{}: no node set \"{name}\" (the file has: {})",
                                    file.path.display(),
                                    file.node_sets
                                        .iter()
                                        .map(|s| s.name.as_str())
                                        .collect::<Vec<_>>()
                                        .join(", ")
                                )
                            })?;
                        set.nodes.iter().map(|&k| values[k as usize]).collect()
                    }
                };
                if chosen.is_empty() {
                    return Err(format!("{}: the node set is empty", file.path.display()));
                }
                Ok(chosen.iter().sum::<f64>() / chosen.len() as f64)
            }
            Quantity::Modulus { area, axis } => modulus_at_last_frame(file, *area, *axis),
        }
    }
}

/// Index of a global variable: the exact name, else the one name equal ignoring case.
fn global_index(file: &ExodusFile, name: &str) -> Result<usize, String> {
    let names = &file.global_variable_names;
    names
        .iter()
        .position(|n| n == name)
        .or_else(|| names.iter().position(|n| n.eq_ignore_ascii_case(name)))
        .ok_or_else(|| {
            format!(
                "{}: no global variable \"{name}\" (the file has: {})",
                file.path.display(),
                if names.is_empty() {
                    "none".to_string()
                } else {
                    names.join(", ")
                }
            )
        })
}

/// E = σ/ε of the final frame, computed as `peridyn modulus` does from the globals of every
/// frame (read here from the Exodus file instead of the CSV).
fn modulus_at_last_frame(file: &ExodusFile, area: f64, axis: Axis) -> Result<f64, String> {
    let mut names = vec!["Time".to_string()];
    names.extend(file.global_variable_names.iter().cloned());
    let rows = (0..file.times.len())
        .map(|step| {
            let mut row = vec![file.times[step]];
            row.extend(file.global_values(step).map_err(|e| e.to_string())?);
            Ok(row)
        })
        .collect::<Result<Vec<_>, String>>()?;
    let history = History {
        path: file.path.clone(),
        names,
        rows,
    };
    let args = ModulusArgs::with_default_labels(PathBuf::from(&file.path), area, axis);
    let samples = modulus::samples(&history, &args).map_err(|e| e.to_string())?;
    samples
        .last()
        .map(|s| s.modulus())
        .ok_or_else(|| format!("{}: no loaded frame", file.path.display()))
}

/// Where a measure's reference value comes from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Reference {
    /// The analytic value given with the measure.
    Exact(f64),
    /// The value of the finest run (its position in the list of runs).
    Finest {
        /// The reference value.
        value: f64,
        /// The run it comes from.
        run: usize,
    },
}

impl Reference {
    /// The reference value.
    pub fn value(self) -> f64 {
        match self {
            Reference::Exact(value) | Reference::Finest { value, .. } => value,
        }
    }
}

/// The reference of a measure: its exact value if given, else the value of the run with the
/// most points among those with a finite value (the last of them in grid order among equals).
/// `runs` holds each run's point count and value; `None` when no run has a value.
pub fn reference(exact: Option<f64>, runs: &[(Option<u64>, Option<f64>)]) -> Option<Reference> {
    if let Some(value) = exact {
        return Some(Reference::Exact(value));
    }
    runs.iter()
        .enumerate()
        .filter_map(|(k, (points, value))| {
            value
                .filter(|v| v.is_finite())
                .map(|v| (k, points.unwrap_or(0), v))
        })
        .max_by_key(|(k, points, _)| (*points, *k))
        .map(|(run, _, value)| Reference::Finest { value, run })
}

/// The error of `value` against `reference`: relative, or absolute when the reference is 0.
pub fn error(value: f64, reference: f64) -> f64 {
    if reference == 0.0 {
        (value - reference).abs()
    } else {
        ((value - reference) / reference).abs()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn measures_parse_with_and_without_an_exact_value() {
        let global = Measure::parse("KE", "global:Global_Kinetic_Energy=0.125").unwrap();
        assert_eq!(
            global.quantity,
            Quantity::Global("Global_Kinetic_Energy".into())
        );
        assert_eq!(global.exact, Some(0.125));
        let mean = Measure::parse("tip", "mean:DisplacementX@Right Face").unwrap();
        assert_eq!(
            mean.quantity,
            Quantity::Mean {
                field: "DisplacementX".into(),
                node_set: Some("Right Face".into())
            }
        );
        assert_eq!(mean.exact, None);
        let all = Measure::parse("u", "mean:DisplacementX@all").unwrap();
        assert!(matches!(
            all.quantity,
            Quantity::Mean { node_set: None, .. }
        ));
        let e = Measure::parse("E", "modulus:0.2:x=2e12").unwrap();
        assert_eq!(
            e.quantity,
            Quantity::Modulus {
                area: 0.2,
                axis: Axis::X
            }
        );
        for bad in [
            "global",
            "max:Force",
            "modulus:-1",
            "global:KE=abc",
            "mean:",
        ] {
            assert!(Measure::parse(bad, bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn the_reference_is_the_exact_value_or_the_finest_run() {
        let runs = [
            (Some(100), Some(1.0)),
            (Some(800), Some(2.0)),
            (Some(800), Some(3.0)),
            (Some(6400), Some(f64::NAN)),
            (None, None),
        ];
        assert_eq!(reference(Some(0.5), &runs), Some(Reference::Exact(0.5)));
        // 6400 points but not finite; of the two 800-point runs the later one.
        assert_eq!(
            reference(None, &runs),
            Some(Reference::Finest { value: 3.0, run: 2 })
        );
        assert_eq!(reference(None, &[(None, None)]), None);
    }

    /// Three points; node set `Right_Node_Set` = points 2 and 3; `DisplacementX` and the
    /// tensile-test globals in two frames. Frame 1: gauge points at y = ±1 (L₀ = 2) moved by
    /// ±0.001 (ε = 1e-3) under a grip reaction of −4e8 on A = 0.2 (σ = 2e9): E = 2e12.
    fn results(dir: &std::path::Path) -> ExodusFile {
        use peridyn::io::exodus::{ExodusWriter, OutputBlock, OutputLayout, OutputNodeSet};
        let globals: Vec<String> = [
            "Gage_Top_Initial_Position",
            "Gage_Bottom_Initial_Position",
            "Gage_Top_Displacement",
            "Gage_Bottom_Displacement",
            "Top_Reaction_Force",
        ]
        .iter()
        .flat_map(|name| ["X", "Y", "Z"].map(|c| format!("{name}{c}")))
        .collect();
        let layout = OutputLayout {
            title: "study measures".to_string(),
            node_ids: vec![1, 2, 3],
            coordinates: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]],
            blocks: vec![OutputBlock {
                id: 1,
                name: "block_1".to_string(),
                nodes: vec![0, 1, 2],
                undefined: Vec::new(),
            }],
            node_sets: vec![OutputNodeSet {
                id: 1,
                name: "Right_Node_Set".to_string(),
                nodes: vec![1, 2],
            }],
            nodal_variables: vec!["DisplacementX".to_string()],
            element_variables: Vec::new(),
            global_variables: globals,
        };
        let path = dir.join("run.e");
        let mut writer = ExodusWriter::create(&path, &layout).unwrap();
        let still = [
            0.0, 1.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
        ];
        writer.write_frame(0.0, &[&[0.0; 3]], &[], &still).unwrap();
        let pulled = [
            0.0, 1.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.001, 0.0, 0.0, -0.001, 0.0, 0.0, -4e8, 0.0,
        ];
        writer
            .write_frame(1.0, &[&[0.0, 0.3, 0.6]], &[], &pulled)
            .unwrap();
        writer.finish().unwrap();
        ExodusFile::open(&path).unwrap()
    }

    #[test]
    fn measures_are_read_at_the_final_frame() {
        let dir = tempfile::tempdir().unwrap();
        let file = results(dir.path());
        let value = |text: &str| Measure::parse(text, text).unwrap().evaluate(&file);
        assert_eq!(value("global:Top_Reaction_ForceY").unwrap(), -4e8);
        assert_eq!(value("global:top_reaction_forcey").unwrap(), -4e8);
        // (0.3 + 0.6) / 2 over the set, (0 + 0.3 + 0.6) / 3 over all points.
        assert!((value("mean:DisplacementX@Right Node Set").unwrap() - 0.45).abs() < 1e-15);
        assert!((value("mean:DisplacementX").unwrap() - 0.3).abs() < 1e-15);
        let modulus = value("modulus:0.2").unwrap();
        assert!((modulus / 2e12 - 1.0).abs() < 1e-12, "{modulus}");
        let missing = value("global:Kinetic").unwrap_err();
        assert!(missing.contains("Top_Reaction_ForceY"), "{missing}");
        let no_set = value("mean:DisplacementX@Left").unwrap_err();
        assert!(no_set.contains("Right_Node_Set"), "{no_set}");
    }

    #[test]
    fn the_error_is_relative_unless_the_reference_is_zero() {
        assert!((error(1.1, 1.0) - 0.1).abs() < 1e-15);
        assert_eq!(error(-3.0, -4.0), 0.25);
        assert_eq!(error(0.5, 0.0), 0.5);
    }
}
