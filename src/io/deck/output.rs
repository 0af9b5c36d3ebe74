//! Top-level lists whose name contains `Output`, and `Compute Class Parameters`.

use super::error::DeckError;
use super::reader::{Ctx, Field};

/// One `Output*` list (an Exodus II results file).
#[derive(Debug, Clone, PartialEq)]
pub struct Output {
    /// The list's name (`Output`, `Output1`, `Output Data`, ...).
    pub name: String,
    /// `Output File Type` — only `"ExodusII"`; default `"ExodusII"`.
    pub file_type: String,
    /// `Output Format` — only `"BINARY"` (Peridigm rejects `"ASCII"`); default `"BINARY"`.
    pub format: String,
    /// `Output Filename` — base name of the file (`<base>.e`, or `<base>.h` for global data
    /// only); default `"dump"`. Relative to the working directory, as in Peridigm.
    pub filename: String,
    /// `Output Frequency` — write when `(call − 1) % frequency == 0` (call 1 = initial state);
    /// default −1 = never. Any other value must be ≥ 1.
    pub frequency: i64,
    /// `Initial Output Step` — default 1.
    pub initial_output_step: i64,
    /// `Final Output Step` — default `i32::MAX − 1` (2147483646).
    pub final_output_step: i64,
    /// `Parallel Write` — accepted, unused; default true.
    pub parallel_write: bool,
    /// `Bond Family` — write bond families (serial only); default false.
    pub bond_family: bool,
    /// `Output Variables` — (name, enabled) in file order.
    pub variables: Vec<(String, bool)>,
}

impl Output {
    /// Names of the enabled output variables, in file order.
    pub fn enabled_variables(&self) -> impl Iterator<Item = &str> {
        self.variables
            .iter()
            .filter(|(_, on)| *on)
            .map(|(n, _)| n.as_str())
    }
}

pub(crate) fn read_output(ctx: &mut Ctx, field: &Field) -> Result<Output, DeckError> {
    let mut list = field.list(ctx)?;
    let file_type = match list.get("Output File Type") {
        Some(f) => f.choice(ctx, &["ExodusII"])?.to_string(),
        None => "ExodusII".to_string(),
    };
    let format = match list.get("Output Format") {
        Some(f) => {
            let s = f.name(ctx)?;
            if s == "ASCII" {
                return Err(f.err(
                    ctx,
                    "ASCII Exodus output is not supported (as in Peridigm); use \"BINARY\"",
                ));
            }
            f.choice(ctx, &["BINARY"])?.to_string()
        }
        None => "BINARY".to_string(),
    };
    let filename = list
        .name_opt(ctx, "Output Filename")?
        .unwrap_or_else(|| "dump".to_string());
    let frequency = match list.get("Output Frequency") {
        None => -1,
        Some(f) => {
            let v = f.i64(ctx)?;
            if v != -1 && v < 1 {
                return Err(f.err(ctx, format!("must be ≥ 1 (or -1 for no output), found {v}")));
            }
            v
        }
    };
    let initial_output_step = list.int_opt(ctx, "Initial Output Step", 1)?.unwrap_or(1);
    let final_field = list.get("Final Output Step");
    let final_output_step = match &final_field {
        Some(f) => f.int_at_least(ctx, 1)?,
        None => i64::from(i32::MAX) - 1,
    };
    if final_output_step < initial_output_step {
        let f = final_field.expect("the default is never below the initial step");
        return Err(f.err(
            ctx,
            format!("must not be smaller than Initial Output Step ({initial_output_step})"),
        ));
    }
    let parallel_write = list.bool_or(ctx, "Parallel Write", true)?;
    let bond_family = list.flag_without_effect(
        ctx,
        "Bond Family",
        false,
        true,
        "peridyn does not write bond families",
    )?;
    let mut variables = Vec::new();
    if let Some(mut vars) = list.list_opt(ctx, "Output Variables")? {
        for v in vars.all() {
            variables.push((v.key().to_string(), v.bool(ctx)?));
        }
    }
    list.finish(ctx, &[])?;
    Ok(Output {
        name: field.key().to_string(),
        file_type,
        format,
        filename,
        frequency,
        initial_output_step,
        final_output_step,
        parallel_write,
        bond_family,
        variables,
    })
}

/// One entry of `Compute Class Parameters`: a user-configured global output quantity.
#[derive(Debug, Clone, PartialEq)]
pub struct ComputeClass {
    /// The name of the list.
    pub name: String,
    /// `Compute Class` and its keys.
    pub kind: ComputeClassKind,
}

impl ComputeClass {
    /// The `Output Label` (the name to list under `Output Variables`), if the class has one.
    pub fn output_label(&self) -> Option<&str> {
        match &self.kind {
            ComputeClassKind::BlockData { output_label, .. }
            | ComputeClassKind::NodeSetData { output_label, .. }
            | ComputeClassKind::NearestPointData { output_label, .. } => Some(output_label),
            ComputeClassKind::BondVisualization { .. } => None,
        }
    }
}

/// `Calculation Type` of the data-reduction compute classes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CalculationType {
    /// `"Minimum"`.
    Minimum,
    /// `"Maximum"`.
    Maximum,
    /// `"Sum"`.
    Sum,
}

/// `Compute Class` and its parameters.
#[derive(Debug, Clone, PartialEq)]
pub enum ComputeClassKind {
    /// `"Block_Data"`: min/max/sum of a field over one block.
    BlockData {
        /// `Block` (required) — mesh block name.
        block: String,
        /// `Variable` (required) — field name.
        variable: String,
        /// `Calculation Type` (required).
        calculation_type: CalculationType,
        /// `Output Label` (required).
        output_label: String,
    },
    /// `"Node_Set_Data"`: min/max/sum of a field over a mesh node set.
    NodeSetData {
        /// `Node Set` (required) — a discretization node set (deck node sets are not visible
        /// to this class in Peridigm, issue #73).
        node_set: String,
        /// `Variable` (required).
        variable: String,
        /// `Calculation Type` (required).
        calculation_type: CalculationType,
        /// `Output Label` (required).
        output_label: String,
    },
    /// `"Nearest_Point_Data"`: a field at the point nearest to (X, Y, Z) (smallest id wins ties).
    NearestPointData {
        /// `X`, `Y`, `Z` (required).
        position: [f64; 3],
        /// `Variable` (required).
        variable: String,
        /// `Output Label` (required).
        output_label: String,
        /// `Verbose` — default false.
        verbose: bool,
    },
    /// `"Bond_Visualization"`: writes the bonds of one point.
    BondVisualization {
        /// `File Name` (required).
        file_name: String,
        /// `Node Id` (required, 1-based ≥ 1).
        node_id: u64,
    },
}

const COMPUTE_CLASSES: &[&str] = &[
    "Block_Data",
    "Node_Set_Data",
    "Nearest_Point_Data",
    "Bond_Visualization",
];

pub(crate) fn read_compute_class(ctx: &mut Ctx, field: &Field) -> Result<ComputeClass, DeckError> {
    let mut list = field.list(ctx)?;
    let class = list
        .require(ctx, "Compute Class", "e.g. \"Block_Data\"")?
        .choice(ctx, COMPUTE_CLASSES)?;
    let calculation =
        |ctx: &Ctx, list: &mut super::reader::ListReader| -> Result<CalculationType, DeckError> {
            Ok(
                match list
                    .require(
                        ctx,
                        "Calculation Type",
                        "\"Minimum\", \"Maximum\" or \"Sum\"",
                    )?
                    .choice(ctx, &["Minimum", "Maximum", "Sum"])?
                {
                    "Minimum" => CalculationType::Minimum,
                    "Maximum" => CalculationType::Maximum,
                    _ => CalculationType::Sum,
                },
            )
        };
    let kind = match class {
        "Block_Data" => ComputeClassKind::BlockData {
            block: list.name_req(ctx, "Block")?,
            variable: list.name_req(ctx, "Variable")?,
            calculation_type: calculation(ctx, &mut list)?,
            output_label: list.name_req(ctx, "Output Label")?,
        },
        "Node_Set_Data" => ComputeClassKind::NodeSetData {
            node_set: list.name_req(ctx, "Node Set")?,
            variable: list.name_req(ctx, "Variable")?,
            calculation_type: calculation(ctx, &mut list)?,
            output_label: list.name_req(ctx, "Output Label")?,
        },
        "Nearest_Point_Data" => ComputeClassKind::NearestPointData {
            position: [
                list.f64_req(ctx, "X")?,
                list.f64_req(ctx, "Y")?,
                list.f64_req(ctx, "Z")?,
            ],
            variable: list.name_req(ctx, "Variable")?,
            output_label: list.name_req(ctx, "Output Label")?,
            verbose: list.bool_or(ctx, "Verbose", false)?,
        },
        "Bond_Visualization" => ComputeClassKind::BondVisualization {
            file_name: list.name_req(ctx, "File Name")?,
            node_id: list.int_req(ctx, "Node Id", 1)? as u64,
        },
        _ => unreachable!("choice() returns one of COMPUTE_CLASSES"),
    };
    list.finish(ctx, &[])?;
    Ok(ComputeClass {
        name: field.key().to_string(),
        kind,
    })
}
