//! From a checked deck to a model ready to run: points, blocks, horizons, node sets, families.
//!
//! Every problem found here is reported against the deck key that caused it (file, key path,
//! line), like load-time errors: a node id beyond the number of points, a node set no one
//! defines, a block the mesh does not have, an expression that does not compile.

mod bondless;
pub mod disk;
mod families;
mod geometry;
mod node_sets;
pub mod one_way_bonds;
mod physics;
pub mod quadrature;
pub mod report;
mod size_guard;
pub mod solvers;
pub mod surface_correction;
mod validate;

pub use bondless::warnings as bondless_warnings;
pub use physics::build_physics;
pub use report::unsupported_features;
pub use validate::{validate, validate_points};

use crate::boundary::{BoundaryConditions, Condition, ConditionKind};
use crate::discretization::{
    read_exodus_mesh, read_text_mesh, CylinderGrid, Discretization, FamilyRule, MeshError,
    TensorProductGrid,
};
use crate::expression::{Expression, INFLUENCE, SPACE, SPACE_TIME, TIME};
use crate::io::deck::{
    BoundaryConditionKind, Deck, DeckError, Horizon, InfluenceFunction, NodeSetSource, OmitBonds,
    PointSource, QuickGridGenerator,
};
use crate::model::{BlockInfo, BondList, Model, ModelBlock, NodeSets, PointCloud};
use crate::neighbors::{space_filling_curve_order, NeighborhoodRule};

/// A problem setting up the run from a valid deck. All are invalid input (exit code 2).
#[derive(Debug, thiserror::Error)]
pub enum SetupError {
    /// A deck key whose value does not fit the mesh (named with file, key path and line).
    #[error(transparent)]
    Deck(#[from] DeckError),
    /// The mesh or a node-set file could not be read.
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// A point of a block cannot carry its material (e.g. a singular correspondence shape
    /// tensor); `error` names the point by its number in the input.
    #[error("block \"{block}\": {error}")]
    SingularPoint {
        /// The block's name (`Blocks` entry).
        block: String,
        /// What is wrong at the point.
        error: crate::material::MaterialError,
    },
}

/// Reads or generates the discretization the deck describes.
pub fn discretize(deck: &Deck) -> Result<Discretization, SetupError> {
    let source = &deck.discretization.source;
    let discretization = match source {
        PointSource::PdQuickGrid {
            generator,
            spherical_neighborhood,
        } => {
            let spherical = *spherical_neighborhood;
            match generator {
                QuickGridGenerator::TensorProduct3D {
                    origin,
                    length,
                    number_of_points,
                } => {
                    geometry::check_box(deck, origin, length, number_of_points)?;
                    size_guard::refuse_grid_beyond_memory(deck, length, number_of_points)?;
                    let grid = TensorProductGrid {
                        origin: *origin,
                        length: *length,
                        points: number_of_points.map(|n| n as usize),
                    };
                    Discretization {
                        points: grid.generate(),
                        blocks: vec![BlockInfo::from_id(1)],
                        node_sets: NodeSets::default(),
                        family_rule: FamilyRule::Search(NeighborhoodRule::LatticeBox {
                            spacing: grid.spacing(),
                            cells: grid.points,
                            spherical,
                        }),
                    }
                }
                QuickGridGenerator::TensorProductCylinder {
                    inner_radius,
                    outer_radius,
                    cylinder_length,
                    number_of_points_radius,
                    ring_center,
                    z_origin,
                } => {
                    let grid = CylinderGrid {
                        inner_radius: *inner_radius,
                        outer_radius: *outer_radius,
                        length: *cylinder_length,
                        rings: *number_of_points_radius as usize,
                        center: *ring_center,
                        z_origin: *z_origin,
                    };
                    geometry::check_cylinder(deck, &grid)?;
                    size_guard::refuse_cylinder_beyond_memory(deck, &grid)?;
                    Discretization {
                        points: grid.generate(),
                        blocks: vec![BlockInfo::from_id(1)],
                        node_sets: NodeSets::default(),
                        family_rule: FamilyRule::Cylinder { grid, spherical },
                    }
                }
            }
        }
        PointSource::TextFile { input_mesh_file } => {
            let mesh = read_text_mesh(input_mesh_file)?;
            Discretization {
                points: mesh.points,
                blocks: mesh.blocks,
                node_sets: NodeSets::default(),
                family_rule: FamilyRule::Search(NeighborhoodRule::Sphere),
            }
        }
        PointSource::Exodus {
            input_mesh_file, ..
        } => {
            let mesh = read_exodus_mesh(input_mesh_file)?;
            Discretization {
                points: mesh.points,
                blocks: mesh.blocks,
                node_sets: mesh.node_sets,
                family_rule: FamilyRule::Search(NeighborhoodRule::Sphere),
            }
        }
    };
    Ok(discretization)
}

/// For each mesh block, the deck `Blocks` entry that covers it (by name, or `Default`).
/// Errors when the deck names a block the mesh lacks, or leaves a mesh block uncovered.
fn assign_blocks(deck: &Deck, mesh_blocks: &[BlockInfo]) -> Result<Vec<usize>, DeckError> {
    let mesh_names: Vec<&str> = mesh_blocks.iter().map(|b| b.name.as_str()).collect();
    let mut assignment: Vec<Option<usize>> = vec![None; mesh_blocks.len()];
    let mut default_entry = None;
    for (k, block) in deck.blocks.iter().enumerate() {
        for name in &block.block_names {
            if name.eq_ignore_ascii_case("default") {
                default_entry = Some(k);
                continue;
            }
            match mesh_names.iter().position(|m| m == name) {
                Some(index) => assignment[index] = Some(k),
                None => {
                    return Err(deck.error_at(
                        &["Blocks", &block.name, "Block Names"],
                        format!(
                            "the mesh has no block \"{name}\"; its blocks are {}",
                            mesh_names.join(", ")
                        ),
                    ))
                }
            }
        }
    }
    assignment
        .iter()
        .enumerate()
        .map(|(index, entry)| {
            entry.or(default_entry).ok_or_else(|| {
                deck.error_at(
                    &["Blocks"],
                    format!(
                        "mesh block \"{}\" is not named in any Blocks entry; add it to a \"Block Names\" list or use \"Default\"",
                        mesh_names[index]
                    ),
                )
            })
        })
        .collect()
}

/// Compiles an expression, reporting failures against the deck key.
pub(crate) fn compile(
    deck: &Deck,
    key_path: &[&str],
    text: &str,
    variables: &[&str],
) -> Result<Expression, DeckError> {
    Expression::parse(text, variables).map_err(|e| deck.error_at(key_path, e.to_string()))
}

/// Checks every expression in the deck that this build evaluates later (influence function,
/// time-dependent friction; a damage model's expressions are checked when its list is read),
/// so a typo fails before any work is done.
fn check_expressions(deck: &Deck) -> Result<(), DeckError> {
    if let InfluenceFunction::Expression(text) = &deck.discretization.influence_function {
        compile(
            deck,
            &["Discretization", "Influence Function"],
            text,
            INFLUENCE,
        )?;
    }
    for model in deck.contact.iter().flat_map(|c| &c.models) {
        if let crate::io::deck::Friction::TimeDependent(text) = &model.friction {
            let key = ["Contact", "Models", &model.name, "Friction Coefficient"];
            compile(deck, &key, text, TIME)?;
        }
    }
    Ok(())
}

/// Horizon of every point (input order) from its block's `Horizon` (number or expression in
/// x, y, z); every value must be positive and finite.
fn point_horizons(
    deck: &Deck,
    points: &PointCloud,
    block_entry: &[usize],
) -> Result<Vec<f64>, DeckError> {
    let mut compiled: Vec<Option<Expression>> = Vec::with_capacity(deck.blocks.len());
    for block in &deck.blocks {
        compiled.push(match &block.horizon {
            Horizon::Constant(_) => None,
            Horizon::Expression(text) => Some(compile(
                deck,
                &["Blocks", &block.name, "Horizon"],
                text,
                SPACE,
            )?),
        });
    }
    let mut horizons = Vec::with_capacity(points.len());
    for (i, x) in points.position.iter().enumerate() {
        let entry = block_entry[points.block[i] as usize];
        let block = &deck.blocks[entry];
        let value = match (&block.horizon, &compiled[entry]) {
            (Horizon::Constant(value), _) => *value,
            (_, Some(expression)) => expression
                .eval(&[x[0], x[1], x[2]])
                .map_err(|e| deck.error_at(&["Blocks", &block.name, "Horizon"], e.to_string()))?,
            (Horizon::Expression(_), None) => unreachable!("expressions were compiled above"),
        };
        if !(value.is_finite() && value > 0.0) {
            return Err(deck.error_at(
                &["Blocks", &block.name, "Horizon"],
                format!(
                    "the horizon at point {} ({:?}) is {value}; it must be a positive number",
                    points.original_id[i] + 1,
                    x
                ),
            ));
        }
        if !(geometry::SMALLEST_LENGTH..=geometry::LARGEST_LENGTH).contains(&value) {
            return Err(deck.error_at(
                &["Blocks", &block.name, "Horizon"],
                format!(
                    "the horizon {value:e} is outside the lengths peridyn computes with ({:e} to {:e} in the deck's units): the bond-based micromodulus 18K/(πδ⁴) would overflow or underflow a double; give it in the deck's units, about 3 point spacings",
                    geometry::SMALLEST_LENGTH,
                    geometry::LARGEST_LENGTH
                ),
            ));
        }
        horizons.push(value);
    }
    Ok(horizons)
}

/// Compiles the mechanical and temperature boundary conditions against the node sets (input order).
fn boundary_conditions(deck: &Deck, node_sets: &NodeSets) -> Result<BoundaryConditions, DeckError> {
    let mut conditions = Vec::new();
    for bc in &deck.boundary_conditions.conditions {
        let kind = match bc.kind {
            BoundaryConditionKind::PrescribedDisplacement => ConditionKind::PrescribedDisplacement,
            BoundaryConditionKind::InitialDisplacement => ConditionKind::InitialDisplacement,
            BoundaryConditionKind::InitialVelocity => ConditionKind::InitialVelocity,
            BoundaryConditionKind::BodyForce => ConditionKind::BodyForce,
            BoundaryConditionKind::PrescribedTemperature => ConditionKind::PrescribedTemperature,
            BoundaryConditionKind::InitialTemperature => ConditionKind::InitialTemperature,
            // Thermal flux and fluid conditions: reported as unsupported by the plan.
            _ => continue,
        };
        let points = node_sets
            .get(&bc.node_set)
            .ok_or_else(|| {
                deck.error_at(
                    &["Boundary Conditions", &bc.name, "Node Set"],
                    format!(
                        "no node set \"{}\" in the deck or the mesh; defined sets: {}",
                        bc.node_set,
                        node_sets
                            .iter()
                            .map(|(name, _)| format!("\"{name}\""))
                            .collect::<Vec<_>>()
                            .join(", ")
                    ),
                )
            })?
            .to_vec();
        if points.is_empty() {
            let from_file = match deck.node_set(&bc.node_set).map(|set| &set.source) {
                Some(NodeSetSource::File(path)) => {
                    format!(" (its file {} lists no node ids)", path.display())
                }
                _ => String::new(),
            };
            return Err(deck.error_at(
                &["Boundary Conditions", &bc.name, "Node Set"],
                format!(
                    "node set \"{}\" has no points{from_file}, so this condition would act on nothing; give the set its node ids or remove the condition",
                    bc.node_set
                ),
            ));
        }
        let value = compile(
            deck,
            &["Boundary Conditions", &bc.name, "Value"],
            &bc.value,
            SPACE_TIME,
        )?;
        if let Some(constant) = value.constant_value().filter(|v| !v.is_finite()) {
            return Err(deck.error_at(
                &["Boundary Conditions", &bc.name, "Value"],
                format!(
                    "\"{}\" evaluates to {constant}; a condition must give a finite number",
                    bc.value
                ),
            ));
        }
        conditions.push(Condition {
            name: bc.name.clone(),
            kind,
            points,
            component: bc.coordinate as usize,
            value,
        });
    }
    Ok(BoundaryConditions { conditions })
}

/// Two points at the same place have a bond of length zero (an infinite micromodulus and a
/// stable time step of zero): an error naming both, by their number in the input (1-based).
/// Exact coincidence only; the search sorts the positions, O(N log N).
fn refuse_coincident_points(deck: &Deck, points: &PointCloud) -> Result<(), DeckError> {
    if matches!(deck.discretization.source, PointSource::PdQuickGrid { .. }) {
        return Ok(());
    }
    // `+ 0.0` makes −0 and +0 one key.
    let key = |p: usize| points.position[p].map(|c| (c + 0.0).to_bits());
    let mut order: Vec<usize> = (0..points.len()).collect();
    order.sort_unstable_by_key(|&p| (key(p), p));
    for pair in order.windows(2) {
        if key(pair[0]) == key(pair[1]) {
            let [x, y, z] = points.position[pair[0]];
            return Err(deck.error_at(
                &["Discretization", "Input Mesh File"],
                format!(
                    "points {} and {} are both at ({x}, {y}, {z}); a bond of length zero has no stiffness or stable time step, so remove one of them",
                    pair[0] + 1,
                    pair[1] + 1
                ),
            ));
        }
    }
    Ok(())
}

/// The run plan `peridyn check` prints for a model set up from `deck`, after the checks
/// `peridyn run` makes too ([`validate`]), so that both accept and refuse the same decks.
pub fn plan(deck: &Deck, model: &Model) -> Result<crate::plan::RunPlan, DeckError> {
    validate(deck, model)?;
    report::plan(deck, model)
}

/// Builds the model: discretize, assign blocks, horizons, node sets, conditions, reorder along
/// a space-filling curve, and search families.
pub fn build(deck: &Deck) -> Result<Model, SetupError> {
    let (mut model, rule) = build_points(deck)?;
    build_families(deck, &mut model, &rule)?;
    Ok(model)
}

/// [`build`] without the families: `bonds` has a row per point but no bonds, and the rule
/// that finds them is returned beside the model. A distributed run keeps this global model
/// (O(points) memory) and finds the rows of its own points and ghosts with [`family_rows`].
pub fn build_points(deck: &Deck) -> Result<(Model, FamilyRule), SetupError> {
    check_expressions(deck)?;
    let discretization = discretize(deck).map_err(|e| match e {
        SetupError::Mesh(mesh) => SetupError::Deck(
            deck.error_at(&["Discretization", "Input Mesh File"], mesh.to_string()),
        ),
        other => other,
    })?;
    if !matches!(deck.discretization.source, PointSource::PdQuickGrid { .. }) {
        geometry::check_mesh_points(deck, &discretization.points)?;
    }
    refuse_coincident_points(deck, &discretization.points)?;
    let block_entry = assign_blocks(deck, &discretization.blocks)?;
    let mut points = discretization.points.clone();
    let horizons = point_horizons(deck, &points, &block_entry)?;
    let (mut node_sets, mesh_node_set_names) =
        node_sets::collect(deck, &discretization.node_sets, points.len())?;
    let mut boundary = boundary_conditions(deck, &node_sets)?;

    let order = space_filling_curve_order(&points.position);
    let mut run_index = vec![0u32; order.len()];
    for (new, &old) in order.iter().enumerate() {
        run_index[old as usize] = new as u32;
    }
    points.permute(&order);
    let horizon: Vec<f64> = order.iter().map(|&old| horizons[old as usize]).collect();
    node_sets.renumber(&run_index);
    for condition in &mut boundary.conditions {
        for p in condition.points.iter_mut() {
            *p = run_index[*p as usize];
        }
        condition.points.sort_unstable();
    }

    let bonds = BondList {
        offsets: vec![0; points.len() + 1],
        ..BondList::default()
    };
    let blocks = discretization
        .blocks
        .iter()
        .enumerate()
        .map(|(index, info)| ModelBlock {
            info: info.clone(),
            deck_block: block_entry[index],
            points: (0..points.len() as u32)
                .filter(|&p| points.block[p as usize] == index as u32)
                .collect(),
        })
        .collect();
    let min_element_radius = discretization.min_element_radius();
    Ok((
        Model {
            points,
            horizon,
            blocks,
            node_sets,
            mesh_node_set_names,
            bonds,
            run_index,
            boundary,
            min_element_radius,
        },
        discretization.family_rule,
    ))
}

/// Finds every point's family into `model.bonds` (the second half of [`build`]).
pub fn build_families(deck: &Deck, model: &mut Model, rule: &FamilyRule) -> Result<(), SetupError> {
    // `order[new] = old`, the inverse of `run_index`.
    let mut order = vec![0u32; model.run_index.len()];
    for (old, &new) in model.run_index.iter().enumerate() {
        order[new as usize] = old as u32;
    }
    // Partial-volume rules that reach cells beyond the horizon search a wider family.
    let widened = quadrature::search_horizons(deck, model)?;
    let horizons = widened.as_deref().unwrap_or(&model.horizon);
    if let FamilyRule::Search(NeighborhoodRule::Sphere) = rule {
        let block_entry: Vec<usize> = model.blocks.iter().map(|b| b.deck_block).collect();
        let same_block = deck.discretization.omit_bonds_between_blocks == OmitBonds::All;
        size_guard::refuse_mesh_beyond_memory(
            deck,
            &model.points,
            horizons,
            &block_entry,
            same_block,
        )?;
    }
    model.bonds = families::build(
        deck,
        rule,
        &model.points,
        horizons,
        &order,
        &model.run_index,
    )?;
    Ok(())
}

/// The families of `points` alone (row k is `points[k]`'s, neighbour indices in run order),
/// bitwise the rows [`build`] gives them, for a model from [`build_points`] whose families come
/// from a neighbour search (`rule`).
pub fn family_rows(
    deck: &Deck,
    model: &Model,
    rule: NeighborhoodRule,
    points: &[u32],
) -> Result<BondList, SetupError> {
    families::rows(deck, rule, &model.points, &model.horizon, points)
}
