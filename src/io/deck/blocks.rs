//! `Blocks` list: which material, damage model and horizon each mesh block uses.

use super::error::DeckError;
use super::reader::{Ctx, Field};
use super::tree::{NodeKind, ScalarKind};

/// One named group of blocks (an entry of `Blocks`).
#[derive(Debug, Clone, PartialEq)]
pub struct Block {
    /// The name of the list (free text, only used in messages).
    pub name: String,
    /// `Block Names` (required) — mesh block names such as `block_1`, split at whitespace; the
    /// single name `Default`/`default` stands for every block not listed in another group.
    pub block_names: Vec<String>,
    /// `Material` (required) — name of an entry of `Materials`.
    pub material: String,
    /// `Damage Model` — name of an entry of `Damage Models`; `None` when absent or `"None"`.
    pub damage_model: Option<String>,
    /// `Horizon` (required) — a positive number, or an expression in `x y z`.
    pub horizon: Horizon,
    /// `Quadrature` (ours) — how the block's family sums weigh each bond: `Full Volume`,
    /// `PDLAMMPS`, `HHB`, `Exact` or `Adaptive` (see [`crate::model::quadrature`]). `None`
    /// when absent: Peridigm's `Discretization → Element-Horizon Intersection Partial Volume
    /// Scheme` decides, else `Full Volume`.
    pub quadrature: Option<String>,
    /// `Quadrature Tolerance` (ours) — the relative accuracy EPS of `Quadrature: Adaptive`
    /// (a positive number; default 1e-4).
    pub quadrature_tolerance: Option<f64>,
    /// `Surface Correction` (ours) — how the stiffness of points near free surfaces is
    /// restored: `None` (default) or `Force Normalization` (Macek & Silling 2007; see
    /// [`crate::model::surface_correction`]). `None` when absent.
    pub surface_correction: Option<String>,
}

/// The values of `Blocks → … → Quadrature`.
pub const QUADRATURE_NAMES: [&str; 5] = ["Full Volume", "PDLAMMPS", "HHB", "Exact", "Adaptive"];

/// The values of `Blocks → … → Surface Correction`.
pub const SURFACE_CORRECTION_NAMES: [&str; 2] = ["None", "Force Normalization"];

impl Block {
    /// True when `Block Names` is `Default`/`default`: the group takes every block not named
    /// elsewhere.
    pub fn is_default(&self) -> bool {
        self.block_names.len() == 1
            && (self.block_names[0] == "Default" || self.block_names[0] == "default")
    }
}

/// `Horizon` δ of a block.
#[derive(Debug, Clone, PartialEq)]
pub enum Horizon {
    /// A number (> 0). Integers are accepted (`Horizon: 2` is 2.0; Peridigm issue #9).
    Constant(f64),
    /// An expression in the reference coordinates `x y z` (validated after loading).
    Expression(String),
}

pub(crate) fn read(ctx: &mut Ctx, field: &Field) -> Result<Block, DeckError> {
    let mut list = field.list(ctx)?;
    let names_field = list.require(
        ctx,
        "Block Names",
        "space-separated block names such as \"block_1 block_2\"",
    )?;
    let block_names: Vec<String> = names_field
        .string(ctx)?
        .split_whitespace()
        .map(str::to_string)
        .collect();
    if block_names.is_empty() {
        return Err(names_field.err(ctx, "no block names given; list mesh blocks such as \"block_1 block_2\" or write \"Default\""));
    }
    let material = list.name_req(ctx, "Material")?;
    let damage_model = list.name_opt(ctx, "Damage Model")?.filter(|d| d != "None");
    let horizon_field = list.require(
        ctx,
        "Horizon",
        "a positive number or an expression in x, y, z",
    )?;
    let horizon = match &horizon_field.node().kind {
        NodeKind::Scalar(s) if matches!(s.kind, ScalarKind::String) => {
            let text = s.text.trim();
            if text.is_empty() {
                return Err(horizon_field.err(ctx, "the horizon expression is empty"));
            }
            // A quoted plain number is the same constant horizon (Peridigm evaluates the
            // expression, which gives the number).
            match text.parse::<f64>() {
                Ok(v)
                    if super::tree::is_float_literal(text)
                        || super::tree::is_integer_literal(text) =>
                {
                    if v <= 0.0 || !v.is_finite() {
                        return Err(
                            horizon_field.err(ctx, format!("must be a positive number, found {v}"))
                        );
                    }
                    Horizon::Constant(v)
                }
                _ => Horizon::Expression(s.text.clone()),
            }
        }
        _ => Horizon::Constant(horizon_field.positive(ctx)?),
    };
    let quadrature = list
        .get("Quadrature")
        .map(|f| f.choice(ctx, &QUADRATURE_NAMES).map(str::to_string))
        .transpose()?;
    let quadrature_tolerance = list
        .get("Quadrature Tolerance")
        .map(|f| f.positive(ctx))
        .transpose()?;
    let surface_correction = list
        .get("Surface Correction")
        .map(|f| f.choice(ctx, &SURFACE_CORRECTION_NAMES).map(str::to_string))
        .transpose()?;
    list.finish(ctx, &[])?;
    Ok(Block {
        name: field.key().to_string(),
        block_names,
        material,
        damage_model,
        horizon,
        quadrature,
        quadrature_tolerance,
        surface_correction,
    })
}
