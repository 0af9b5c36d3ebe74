//! `Discretization` list: where the points come from, influence function, bond filters.

use std::path::PathBuf;

use super::error::DeckError;
use super::reader::{Ctx, Field, ListReader};
use crate::model::read_bond_filter;
pub use crate::model::{BondFilter, BondFilterShape};

/// The `Discretization` list.
#[derive(Debug, Clone, PartialEq)]
pub struct Discretization {
    /// How the points are generated or read (`Type` plus its keys).
    pub source: PointSource,
    /// `Influence Function` — weight ω(ζ, δ) of a bond; default `"One"`.
    pub influence_function: InfluenceFunction,
    /// `Omit Bonds Between Blocks` — `"All"` removes every bond between different blocks;
    /// default `"None"`.
    pub omit_bonds_between_blocks: OmitBonds,
    /// `Bond Filters` — planes, disks or shell meshes that no bond may cross (file order).
    pub bond_filters: Vec<BondFilter>,
    /// `Verbose` — extra discretization output; default false.
    pub verbose: bool,
}

/// `Discretization → Type` and the keys that belong to it.
#[derive(Debug, Clone, PartialEq)]
pub enum PointSource {
    /// `Type: "Exodus"` — one point per element of an Exodus II mesh.
    Exodus {
        /// `Input Mesh File` (required), resolved relative to the deck's directory.
        input_mesh_file: PathBuf,
        /// `Store Exodus Mesh` — keep element connectivity (`Exodus_Node_*` fields); default false.
        store_exodus_mesh: bool,
        /// `Construct Interfaces` — build interface elements between blocks; default false.
        construct_interfaces: bool,
        /// `Construct Neighborhood Lists` — default true.
        construct_neighborhood_lists: bool,
        /// `Compute Element-Horizon Intersections` (partial-volume builds only) and its
        /// settings; `None` when absent or false.
        element_horizon_intersections: Option<ElementHorizonIntersections>,
    },
    /// `Type: "Text File"` — one point per line: `x y z block_id volume`.
    TextFile {
        /// `Input Mesh File` (required), resolved relative to the deck's directory.
        input_mesh_file: PathBuf,
    },
    /// `Type: "PdQuickGrid"` — a generated lattice of points (single block `block_1`).
    PdQuickGrid {
        /// `TensorProduct3DMeshGenerator` or `TensorProductCylinderMeshGenerator`.
        generator: QuickGridGenerator,
        /// `NeighborhoodType` — `"Spherical"` filters the box neighbourhood to a sphere;
        /// default (absent) is the box neighbourhood.
        spherical_neighborhood: bool,
    },
}

/// `Compute Element-Horizon Intersections` settings (only meaningful in Peridigm's `USE_PV`
/// builds).
#[derive(Debug, Clone, PartialEq)]
pub struct ElementHorizonIntersections {
    /// `Element-Horizon Intersection Partial Volume Scheme` — `PV`, `FV`, `PDLAMMPS` or `HHB`.
    pub scheme: Option<String>,
    /// `Element-Horizon Intersection Recursion Level` — default 2.
    pub recursion_level: i64,
    /// `Element-Horizon Intersection Number Of Samples` — default 2.
    pub number_of_samples: i64,
    /// `Element-Horizon Intersection Characteristic Element Length` — default 0.
    pub characteristic_element_length: f64,
    /// `Element-Horizon Intersection Use Lookup Table` — default true.
    pub use_lookup_table: bool,
}

/// A QuickGrid point generator.
#[derive(Debug, Clone, PartialEq)]
pub enum QuickGridGenerator {
    /// `TensorProduct3DMeshGenerator`: a box of `n_x × n_y × n_z` cells, a point at each cell
    /// centre `origin + (i + ½)·length/n`.
    TensorProduct3D {
        /// `X Origin`, `Y Origin`, `Z Origin` (required).
        origin: [f64; 3],
        /// `X Length`, `Y Length`, `Z Length` (required, > 0).
        length: [f64; 3],
        /// `Number Points X`, `Number Points Y`, `Number Points Z` (required, ≥ 1).
        number_of_points: [u64; 3],
    },
    /// `TensorProductCylinderMeshGenerator`: rings of points around the z axis.
    TensorProductCylinder {
        /// `Inner Radius` (required, ≥ 0).
        inner_radius: f64,
        /// `Outer Radius` (required, > inner radius).
        outer_radius: f64,
        /// `Cylinder Length` (required, > 0).
        cylinder_length: f64,
        /// `Number Points Radius` (required, ≥ 1).
        number_of_points_radius: u64,
        /// `Ring Center x`, `Ring Center y` (required).
        ring_center: [f64; 2],
        /// `Z Origin` (required).
        z_origin: f64,
    },
}

/// `Influence Function` — ω as a function of bond length ζ and horizon δ.
#[derive(Debug, Clone, PartialEq)]
pub enum InfluenceFunction {
    /// `"One"`: ω = 1 (the default).
    One,
    /// `"Parabolic Decay"`: ω = 1 for ζ/δ < ½, else −4(ζ/δ)² + 4(ζ/δ).
    ParabolicDecay,
    /// `"Gaussian"`: ω = exp(−ζ² / (0.4 δ)²).
    Gaussian,
    /// Any other string: an expression in `zeta` and `horizon` (validated after loading).
    Expression(String),
}

/// `Omit Bonds Between Blocks`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OmitBonds {
    /// `"None"` (default): bonds may connect points of different blocks.
    None,
    /// `"All"`: no bond connects points of different blocks.
    All,
}

pub(crate) fn read(ctx: &mut Ctx, field: &Field) -> Result<Discretization, DeckError> {
    let mut list = field.list(ctx)?;
    let type_field = list.require(ctx, "Type", "\"Exodus\", \"Text File\" or \"PdQuickGrid\"")?;
    if type_field.string(ctx)?.trim() == "Albany" {
        return Err(type_field.err(
            ctx,
            "the Albany discretization exists only when Peridigm is coupled to Albany; use Exodus, Text File or PdQuickGrid",
        ));
    }
    let kind = type_field.choice(ctx, &["Exodus", "Text File", "PdQuickGrid"])?;
    if let Some(h) = list.peek("Horizon") {
        return Err(h.err(
            ctx,
            "the horizon is not set here; put `Horizon` in each list under `Blocks`",
        ));
    }
    let source = match kind {
        "Exodus" => read_exodus_source(ctx, &mut list)?,
        "Text File" => {
            let mesh = list.name_req(ctx, "Input Mesh File")?;
            PointSource::TextFile {
                input_mesh_file: ctx.resolve(&mesh),
            }
        }
        "PdQuickGrid" => {
            let spherical = match list.get("NeighborhoodType") {
                Some(f) => f.choice(ctx, &["Spherical"])? == "Spherical",
                None => false,
            };
            let generator = read_quick_grid(ctx, &mut list)?;
            PointSource::PdQuickGrid {
                generator,
                spherical_neighborhood: spherical,
            }
        }
        _ => unreachable!("choice() returns one of the listed types"),
    };
    let influence_function = read_influence_function(ctx, &mut list)?;
    let omit_bonds_between_blocks = match list.get("Omit Bonds Between Blocks") {
        None => OmitBonds::None,
        Some(f) => match f.choice(ctx, &["None", "All"])? {
            "All" => OmitBonds::All,
            _ => OmitBonds::None,
        },
    };
    let bond_filters = read_bond_filters(ctx, &mut list, kind)?;
    let verbose = list.flag_without_effect(
        ctx,
        "Verbose",
        false,
        true,
        "peridyn prints no extra discretization output (`peridyn check` lists the points, bonds and families)",
    )?;
    // Peridigm's other discretizations never read the Exodus options.
    let exodus_only = "only the Exodus discretization reads it";
    list.finish(
        ctx,
        &[
            ("Store Exodus Mesh", exodus_only),
            ("Construct Neighborhood Lists", exodus_only),
        ],
    )?;
    Ok(Discretization {
        source,
        influence_function,
        omit_bonds_between_blocks,
        bond_filters,
        verbose,
    })
}

/// The keys of `Type: "Exodus"`: the mesh file and its options.
fn read_exodus_source(ctx: &mut Ctx, list: &mut ListReader) -> Result<PointSource, DeckError> {
    let mesh = list.name_req(ctx, "Input Mesh File")?;
    let intersections = if list.bool_or(ctx, "Compute Element-Horizon Intersections", false)? {
        Some(read_element_horizon_intersections(ctx, list)?)
    } else {
        None
    };
    Ok(PointSource::Exodus {
        input_mesh_file: ctx.resolve(&mesh),
        store_exodus_mesh: list.flag_without_effect(
            ctx,
            "Store Exodus Mesh",
            false,
            true,
            "peridyn does not keep the element connectivity (Peridigm's Exodus_Node_* fields)",
        )?,
        construct_interfaces: list.bool_or(ctx, "Construct Interfaces", false)?,
        construct_neighborhood_lists: list.flag_without_effect(
            ctx,
            "Construct Neighborhood Lists",
            true,
            false,
            "peridyn always builds the neighbour lists",
        )?,
        element_horizon_intersections: intersections,
    })
}

/// The `Element-Horizon Intersection ...` keys, read when the intersections are computed.
fn read_element_horizon_intersections(
    ctx: &mut Ctx,
    list: &mut ListReader,
) -> Result<ElementHorizonIntersections, DeckError> {
    Ok(ElementHorizonIntersections {
        scheme: list
            .get("Element-Horizon Intersection Partial Volume Scheme")
            .map(|f| {
                f.choice(ctx, &["PV", "FV", "PDLAMMPS", "HHB"])
                    .map(str::to_string)
            })
            .transpose()?,
        recursion_level: list
            .int_opt(ctx, "Element-Horizon Intersection Recursion Level", 0)?
            .unwrap_or(2),
        number_of_samples: list
            .int_opt(ctx, "Element-Horizon Intersection Number Of Samples", 1)?
            .unwrap_or(2),
        characteristic_element_length: list
            .non_negative_opt(
                ctx,
                "Element-Horizon Intersection Characteristic Element Length",
            )?
            .unwrap_or(0.0),
        use_lookup_table: list.bool_or(
            ctx,
            "Element-Horizon Intersection Use Lookup Table",
            true,
        )?,
    })
}

/// `Influence Function`: one of the named functions or an expression (default `One`).
fn read_influence_function(
    ctx: &mut Ctx,
    list: &mut ListReader,
) -> Result<InfluenceFunction, DeckError> {
    Ok(match list.get("Influence Function") {
        None => InfluenceFunction::One,
        Some(f) => {
            let s = f.name(ctx)?;
            match s.as_str() {
                "One" => InfluenceFunction::One,
                "Parabolic Decay" => InfluenceFunction::ParabolicDecay,
                "Gaussian" => InfluenceFunction::Gaussian,
                _ => InfluenceFunction::Expression(s),
            }
        }
    })
}

/// `Bond Filters` (not with PdQuickGrid).
fn read_bond_filters(
    ctx: &mut Ctx,
    list: &mut ListReader,
    kind: &str,
) -> Result<Vec<BondFilter>, DeckError> {
    let mut bond_filters = Vec::new();
    if let Some(mut filters) = list.list_opt(ctx, "Bond Filters")? {
        if matches!(kind, "PdQuickGrid") {
            return Err(ctx.error(
                Some(filters.line),
                &filters.path,
                "bond filters are not supported with PdQuickGrid; use an Exodus or Text File discretization",
            ));
        }
        for f in filters.all() {
            bond_filters.push(read_bond_filter(
                ctx,
                &f,
                &["Rectangular_Plane", "Disk", "Exodus Mesh"],
            )?);
        }
    }
    Ok(bond_filters)
}

fn read_quick_grid(ctx: &mut Ctx, list: &mut ListReader) -> Result<QuickGridGenerator, DeckError> {
    let cube = list.get("TensorProduct3DMeshGenerator");
    let cylinder = list.get("TensorProductCylinderMeshGenerator");
    let count = |ctx: &Ctx, g: &mut ListReader, key: &'static str| -> Result<u64, DeckError> {
        Ok(g.int_req(ctx, key, 1)? as u64)
    };
    let generator = match (cube, cylinder) {
        (Some(_), Some(c)) => {
            return Err(c.err(
                ctx,
                "give either TensorProduct3DMeshGenerator or TensorProductCylinderMeshGenerator, not both",
            ))
        }
        (None, None) => {
            return Err(list.missing(
                ctx,
                "TensorProduct3DMeshGenerator",
                "a list with X/Y/Z Origin, X/Y/Z Length, Number Points X/Y/Z; or TensorProductCylinderMeshGenerator",
            ))
        }
        (Some(f), None) => {
            let mut g = f.list(ctx)?;
            g.expect(&[
                "X Origin", "Y Origin", "Z Origin", "X Length", "Y Length", "Z Length",
                "Number Points X", "Number Points Y", "Number Points Z",
            ]);
            let generator = QuickGridGenerator::TensorProduct3D {
                origin: [g.f64_req(ctx, "X Origin")?, g.f64_req(ctx, "Y Origin")?, g.f64_req(ctx, "Z Origin")?],
                length: [
                    g.positive_req(ctx, "X Length")?,
                    g.positive_req(ctx, "Y Length")?,
                    g.positive_req(ctx, "Z Length")?,
                ],
                number_of_points: [
                    count(ctx, &mut g, "Number Points X")?,
                    count(ctx, &mut g, "Number Points Y")?,
                    count(ctx, &mut g, "Number Points Z")?,
                ],
            };
            g.finish(ctx, &[("Type", "the generator's type is given by its list name")])?;
            generator
        }
        (None, Some(f)) => {
            let mut g = f.list(ctx)?;
            let inner_radius = g.require(ctx, "Inner Radius", "a number ≥ 0")?.non_negative(ctx)?;
            let outer = g.require(ctx, "Outer Radius", "a positive number")?;
            let outer_radius = outer.positive(ctx)?;
            if outer_radius <= inner_radius {
                return Err(outer.err(ctx, format!("must be larger than Inner Radius ({inner_radius})")));
            }
            let generator = QuickGridGenerator::TensorProductCylinder {
                inner_radius,
                outer_radius,
                cylinder_length: g.positive_req(ctx, "Cylinder Length")?,
                number_of_points_radius: count(ctx, &mut g, "Number Points Radius")?,
                ring_center: [g.f64_req(ctx, "Ring Center x")?, g.f64_req(ctx, "Ring Center y")?],
                z_origin: g.f64_req(ctx, "Z Origin")?,
            };
            g.finish(ctx, &[("Type", "the generator's type is given by its list name")])?;
            generator
        }
    };
    Ok(generator)
}
