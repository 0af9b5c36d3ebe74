//! The run plan `peridyn check` prints: sizes, physics, fields, memory, Δt, and what this
//! build cannot run yet.

use super::solvers::solver_lists;
use crate::backend::settings::{ImplicitSolve, LinearBackend, LinearPreconditioner};
use crate::io::deck::{
    BoundaryConditionKind, ComputeClassKind, Deck, DeckError, Horizon, PointSource,
};
use crate::io::output::{closest_name, kind_of, OutputFile, RequestedVariable, VariableKind};
use crate::model::Model;
use crate::model::{FieldCarrier, FieldDeclaration, ModelDeclaration, Reach};
use crate::plan::{
    BlockPlan, FieldPlan, MemoryPlan, NodeSetPlan, OutputPlan, ParallelPlan, PhysicsPlan, RunPlan,
    SolverPlan, TimeStepPlan,
};
use crate::solver::integrator::TimeStep;

/// Output variables this build computes for every model (the models' own outputs are declared
/// in their registry entries, see [`model_outputs`]).
const SUPPORTED_OUTPUTS: &[&str] = &[
    "Volume",
    "Radius",
    "Horizon",
    "Element_Id",
    "Block_Id",
    "Proc_Num",
    "Number_Of_Neighbors",
    "Neighborhood_Volume",
    "Model_Coordinates",
    "Coordinates",
    "Displacement",
    "Velocity",
    "Acceleration",
    "Force",
    "Force_Density",
    "External_Force_Density",
    "Contact_Force",
    "Contact_Force_Density",
    "Linear_Momentum",
    "Kinetic_Energy",
    "Stored_Elastic_Energy",
    "Stored_Elastic_Energy_Density",
    "Global_Kinetic_Energy",
    "Global_Stored_Elastic_Energy",
    "Global_Linear_Momentum",
    "Angular_Momentum",
    "Global_Angular_Momentum",
    "Deformation_Gradient",
    "Shape_Tensor_Inverse",
    "Nonlinear_Solver_Iterations",
    "Temperature",
    "Temperature_Change",
];

/// The requested variables of one output list, checked against Peridigm's catalogue and the
/// deck's compute-class labels. Unknown names are errors with a suggestion.
pub fn requested_variables(
    deck: &Deck,
    output: &crate::io::deck::Output,
) -> Result<Vec<RequestedVariable>, DeckError> {
    let mut variables = Vec::new();
    for (name, enabled) in &output.variables {
        if !enabled {
            continue;
        }
        let loaded_field = deck
            .data_loader
            .as_ref()
            .is_some_and(|loader| loader.field_name == *name);
        let kind = if let Some(kind) = kind_of(name) {
            kind
        } else if loaded_field {
            VariableKind::ElementScalar
        } else if let Some(class) = deck
            .compute_classes
            .iter()
            .find(|c| c.output_label() == Some(name.as_str()))
        {
            compute_class_kind(class)
        } else {
            let hint = closest_name(name)
                .map(|n| format!("; did you mean \"{n}\"?"))
                .unwrap_or_else(|| {
                    "; see the README for the list of output variables, or define a compute class with this Output Label".into()
                });
            return Err(deck.error_at(
                &[&output.name, "Output Variables", name],
                format!("unknown output variable \"{name}\"{hint}"),
            ));
        };
        variables.push(RequestedVariable {
            name: name.clone(),
            kind,
        });
    }
    Ok(variables)
}

/// A compute class reports a global per frame: a vector when its variable is a vector field.
pub fn compute_class_kind(class: &crate::io::deck::ComputeClass) -> VariableKind {
    let variable = match &class.kind {
        ComputeClassKind::BlockData { variable, .. }
        | ComputeClassKind::NodeSetData { variable, .. }
        | ComputeClassKind::NearestPointData { variable, .. } => variable.as_str(),
        ComputeClassKind::BondVisualization { .. } => "",
    };
    if kind_of(variable) == Some(VariableKind::NodalVector) {
        VariableKind::GlobalVector
    } else {
        VariableKind::Global
    }
}

/// The output variables the models of this build provide beyond [`SUPPORTED_OUTPUTS`].
fn model_outputs() -> impl Iterator<Item = &'static str> {
    let materials = crate::material::MATERIALS.iter().map(|e| e.declaration);
    let damage = crate::damage::DAMAGE_MODELS.iter().map(|e| e.declaration);
    materials
        .chain(damage)
        .flat_map(|declaration| declaration.outputs.iter().copied())
}

/// The declarations of the material and damage models the blocks of `model` use, in block
/// order (materials, then damage models); `None` for a model this build does not run.
fn used_declarations(deck: &Deck, model: &Model) -> UsedModels {
    let mut used = UsedModels::default();
    for block in &model.blocks {
        let entry = &deck.blocks[block.deck_block];
        if let Some(material) = deck.material(&entry.material) {
            let found = crate::material::material_entry(material.model.deck_name());
            used.materials.push(found.map(|e| e.declaration));
        }
        if let Some(damage) = entry
            .damage_model
            .as_ref()
            .and_then(|n| deck.damage_model(n))
        {
            let found = crate::damage::damage_entry(damage.model.deck_name());
            used.damage.push(found.map(|e| e.declaration));
        }
    }
    used
}

/// The registry declarations of the models a run uses.
#[derive(Default)]
struct UsedModels {
    materials: Vec<Option<&'static ModelDeclaration>>,
    damage: Vec<Option<&'static ModelDeclaration>>,
}

impl UsedModels {
    /// The widest reach of the materials (a model this build does not run counts as two hops).
    fn material_reach(&self) -> Option<Reach> {
        self.materials
            .iter()
            .map(|d| d.map_or(Reach::TwoHop, |d| d.reach))
            .max()
    }

    /// Every field the used models declare, each once, in block order.
    fn fields(&self) -> Vec<FieldDeclaration> {
        let mut fields: Vec<FieldDeclaration> = Vec::new();
        let declared = self.materials.iter().chain(&self.damage).flatten();
        for field in declared.flat_map(|d| d.fields.iter()) {
            if !fields.iter().any(|f| f.name == field.name) {
                fields.push(*field);
            }
        }
        fields
    }
}

/// Everything in the deck that this build cannot run yet, each named exactly.
pub fn unsupported_features(deck: &Deck) -> Vec<String> {
    let mut missing = Vec::new();
    let mut note = |item: String| {
        if !missing.contains(&item) {
            missing.push(item);
        }
    };
    for list in solver_lists(deck) {
        if let Some(unavailable) = list.integrator.unavailable() {
            note(unavailable);
        }
    }
    for material in &deck.materials {
        let name = material.model.deck_name();
        if crate::material::material_entry(name).is_none() {
            note(format!("material model {name}"));
        }
    }
    for damage in &deck.damage_models {
        let name = damage.model.deck_name();
        if crate::damage::damage_entry(name).is_none() {
            note(format!("damage model {name}"));
        }
    }
    for block in &deck.blocks {
        if let Horizon::Expression(_) = block.horizon {
            note("Horizon varying in space (expression) for the force kernels".into());
        }
    }
    for bc in &deck.boundary_conditions.conditions {
        if !matches!(
            bc.kind,
            BoundaryConditionKind::PrescribedDisplacement
                | BoundaryConditionKind::InitialDisplacement
                | BoundaryConditionKind::InitialVelocity
                | BoundaryConditionKind::BodyForce
                | BoundaryConditionKind::PrescribedTemperature
                | BoundaryConditionKind::InitialTemperature
        ) {
            note(format!("boundary condition type {}", bc.kind.deck_name()));
        }
    }
    if let PointSource::Exodus {
        construct_interfaces: true,
        ..
    } = deck.discretization.source
    {
        note("Construct Interfaces".into());
    }
    if deck.multiphysics {
        note("Multiphysics".into());
    }
    if deck.data_loader.is_some() {
        note("Data Loader".into());
    }
    for class in &deck.compute_classes {
        if let ComputeClassKind::BondVisualization { .. } = class.kind {
            note("compute class Bond_Visualization".into());
        }
    }
    for output in &deck.outputs {
        for (name, enabled) in &output.variables {
            let is_label = deck
                .compute_classes
                .iter()
                .any(|c| c.output_label() == Some(name.as_str()));
            if *enabled
                && !is_label
                && kind_of(name).is_some()
                && !SUPPORTED_OUTPUTS.contains(&name.as_str())
                && !model_outputs().any(|output| output == name)
            {
                note(format!("output variable {name}"));
            }
        }
    }
    missing
}

/// Peridigm's critical time step over all blocks ([`crate::material::critical_time_step`] with
/// each block's density, bulk modulus and horizon); `None` if no point has a neighbour.
pub fn critical_time_step(deck: &Deck, model: &Model) -> Option<f64> {
    let volumes = super::surface_correction::bond_weights(deck, model)
        .ok()
        .flatten();
    let reference = crate::material::ReferenceView::of(&model.bonds, &model.points)
        .with_bond_volume(volumes.as_deref());
    model
        .blocks
        .iter()
        .filter_map(|block| {
            let entry = &deck.blocks[block.deck_block];
            let material = deck.material(&entry.material)?;
            let (bulk, density) = (material.bulk_modulus()?, material.density?);
            let horizon = match entry.horizon {
                Horizon::Constant(value) => value,
                Horizon::Expression(_) => block
                    .points
                    .iter()
                    .map(|&p| model.horizon[p as usize])
                    .fold(0.0, f64::max),
            };
            crate::material::critical_time_step(&reference, &block.points, density, bulk, horizon)
        })
        .reduce(f64::min)
}

/// Number of distinct points reachable in two hops (the state-based tangent pattern), exact
/// when cheap, otherwise extrapolated from a sample of points. A sampled point costs about
/// (family size)² visits, so the sample shrinks as families grow (at most
/// [`TWO_HOP_VISITS`] visits in all, at most 2,000 points), and a point whose reach is already
/// the whole body stops counting: `check` answers in seconds for any horizon.
fn two_hop_nonzero_blocks(model: &Model) -> u64 {
    let n = model.points.len();
    if n == 0 {
        return 0;
    }
    let bonds = &model.bonds;
    let family = bonds.num_bonds() as f64 / n as f64;
    let samples = (TWO_HOP_VISITS / (1.0 + family * family)).clamp(16.0, 2000.0) as usize;
    let stride = (n / samples).max(1);
    let mut mark = vec![usize::MAX; n];
    let mut sampled = 0u64;
    let mut count = 0u64;
    for i in (0..n).step_by(stride) {
        sampled += 1;
        let mut reach = 0u64;
        let mut visit = |j: usize| {
            if mark[j] != i {
                mark[j] = i;
                reach += 1;
            }
            reach == n as u64
        };
        visit(i);
        'row: for &j in bonds.family(i) {
            if visit(j as usize) {
                break;
            }
            for &k in bonds.family(j as usize) {
                if visit(k as usize) {
                    break 'row;
                }
            }
        }
        count += reach;
    }
    count * n as u64 / sampled
}

/// The visits [`two_hop_nonzero_blocks`] may make: what 2,000 sampled points cost with
/// families of 100 bonds; larger families get a smaller sample (at least 16 points).
const TWO_HOP_VISITS: f64 = 2e7;

/// What a run of `deck` on several ranks holds and exchanges (see
/// [`crate::simulation::run_distributed`]).
fn parallel_plan(deck: &Deck, model: &Model, explicit: bool, implicit: bool) -> ParallelPlan {
    let mut exchanged = Vec::new();
    if explicit {
        exchanged.push("ghost positions, every explicit step (3 f64 per ghost)".to_string());
    }
    if implicit {
        exchanged.push(
            "ghost displacements, before every residual evaluation (3 f64 per ghost)".to_string(),
        );
    }
    if deck.contact.is_some() {
        exchanged.push(
            "contact points' positions to every rank at each contact search; contact partners' positions and velocities, every step"
                .to_string(),
        );
    }
    let families = match crate::parallel::global_families_reason(deck) {
        Some(reason) => format!("global on every rank ({reason})"),
        None => "searched per rank: owned points and ghosts only".to_string(),
    };
    ParallelPlan {
        ghost_depth: crate::parallel::halo_depth(deck),
        exchanged,
        families,
        refused: super::solvers::check_ranks(deck, 2)
            .and_then(|()| crate::parallel::check_distributable(deck, 2))
            .err()
            .map(|e| e.to_string()),
        solvers: solver_lists(deck)
            .iter()
            .filter_map(|list| {
                let how = petsc_on_ranks(list.integrator.solve()?, model)?;
                Some(format!("{}: {how}", list.settings.name))
            })
            .collect(),
    }
}

/// How a `Backend: "PETSc"` list runs on several ranks (`None` for other lists, or when PETSc
/// refuses its settings, which the solver section reports).
#[cfg(feature = "petsc")]
fn petsc_on_ranks(solve: &ImplicitSolve, model: &Model) -> Option<String> {
    crate::backend::petsc::list::on_ranks(solve, 3 * model.points.len())
}

#[cfg(not(feature = "petsc"))]
fn petsc_on_ranks(_solve: &ImplicitSolve, _model: &Model) -> Option<String> {
    None
}

/// Builds the plan for a model set up from `deck` (validated by [`super::plan`]).
pub(super) fn plan(deck: &Deck, model: &Model) -> Result<RunPlan, DeckError> {
    let used = used_declarations(deck, model);
    let physics = physics_plan(deck, model, &used);
    let fields = field_plans(model, &used, physics.contact);
    let memory = memory_plans(deck, model, &fields, physics.state_based);
    let mut outputs = Vec::new();
    for output in &deck.outputs {
        let variables = requested_variables(deck, output)?;
        outputs.push(OutputPlan {
            name: output.name.clone(),
            file: OutputFile::file_name(&output.filename, &variables),
            frequency: output.frequency,
            variables: variables.into_iter().map(|v| v.name).collect(),
        });
    }
    Ok(RunPlan {
        deck: deck.path.display().to_string(),
        discretization: match &deck.discretization.source {
            PointSource::Exodus { .. } => "Exodus",
            PointSource::TextFile { .. } => "Text File",
            PointSource::PdQuickGrid { .. } => "PdQuickGrid",
        }
        .into(),
        points: model.points.len(),
        bonds: model.bonds.num_bonds(),
        warnings: deck
            .warnings
            .iter()
            .cloned()
            .chain(super::bondless::warnings(deck, model))
            .collect(),
        unsupported: unsupported_features(deck),
        blocks: block_plans(deck, model),
        node_sets: node_set_plans(model),
        parallel: parallel_plan(deck, model, physics.explicit, physics.implicit),
        physics,
        fields,
        memory_total: memory.iter().map(|m| m.bytes).sum(),
        bytes_per_bond: bytes_per_bond(memory.iter().map(|m| m.bytes).sum(), model),
        memory,
        solvers: solver_lists(deck)
            .iter()
            .map(|list| SolverPlan {
                name: list.settings.name.clone(),
                kind: list.integrator.name().into(),
                initial_time: list.settings.initial_time,
                final_time: list.settings.final_time,
                resolved: list.integrator.solve().and_then(|solve| {
                    petsc_resolution(solve, model)
                        .or_else(|| newton_resolution(solve, model.points.len()))
                }),
                step_strategy: list.integrator.step_strategy(),
            })
            .collect(),
        time_step: time_step_plan(deck, model),
        outputs,
        disk: None,
    })
}

/// What the PETSc backend makes of a `Backend: "PETSc"` list (its error when PETSc refuses
/// the options; validation reports that as an input error first).
#[cfg(feature = "petsc")]
fn petsc_resolution(solve: &ImplicitSolve, model: &Model) -> Option<String> {
    crate::backend::petsc::list::resolve(solve, 3 * model.points.len())
        .map(|r| r.unwrap_or_else(|e| format!("PETSc refuses the settings: {e}")))
}

#[cfg(not(feature = "petsc"))]
fn petsc_resolution(_solve: &ImplicitSolve, _model: &Model) -> Option<String> {
    None
}

/// The linear strategy peridyn's Newton runs for an implicit list solving as `solve` on the
/// native backend over `points` points (what `Linear Solver: "Automatic"` chose, for
/// instance); `None` on other backends.
fn newton_resolution(solve: &ImplicitSolve, points: usize) -> Option<String> {
    use crate::backend::factory::{nonlinear_backend, NonlinearBackend};
    if solve.linear.backend != LinearBackend::Native
        || nonlinear_backend(solve) != Ok(NonlinearBackend::Newton)
    {
        return None;
    }
    crate::solver::linear::strategy(solve, points)
        .ok()
        .map(|strategy| format!("peridyn Newton, {}", strategy.describe()))
}

/// Points, bonds, family sizes and horizons of every block.
fn block_plans(deck: &Deck, model: &Model) -> Vec<BlockPlan> {
    let mut plans = Vec::new();
    let volumes = super::quadrature::bond_volumes(deck, model).ok().flatten();
    let factors = super::surface_correction::point_factors(
        deck,
        model,
        volumes.as_ref().map(|(weights, _)| &weights[..]),
    )
    .ok()
    .flatten();
    for block in &model.blocks {
        let entry = &deck.blocks[block.deck_block];
        let quadrature = volumes
            .as_ref()
            .and_then(|(weights, summary)| quadrature_plan(deck, model, block, weights, summary));
        let sizes: Vec<usize> = block
            .points
            .iter()
            .map(|&p| model.bonds.family_size(p as usize))
            .collect();
        let horizons = block.points.iter().map(|&p| model.horizon[p as usize]);
        let material_model = deck
            .material(&entry.material)
            .map(|m| m.model.deck_name().to_string())
            .unwrap_or_default();
        plans.push(BlockPlan {
            name: block.info.name.clone(),
            id: block.info.id,
            material: entry.material.clone(),
            material_model,
            damage_model: entry.damage_model.clone(),
            points: block.points.len(),
            bonds: sizes.iter().sum(),
            family_min: sizes.iter().copied().min().unwrap_or(0),
            family_max: sizes.iter().copied().max().unwrap_or(0),
            family_mean: if sizes.is_empty() {
                0.0
            } else {
                sizes.iter().sum::<usize>() as f64 / sizes.len() as f64
            },
            horizon_min: horizons.clone().fold(f64::INFINITY, f64::min),
            horizon_max: horizons.fold(0.0, f64::max),
            quadrature,
            surface_correction: factors
                .as_ref()
                .and_then(|(factors, corrections)| correction_plan(block, factors, corrections)),
        });
    }
    plans
}

/// The `quadrature` line of a block whose rule is not the full volume: the rule, how many
/// bonds carry a partial volume, the horizon-volume error of its fullest point
/// `(V_i + Σ_j w_ij)/(4/3 π δ³) − 1` (an interior point on a uniform grid), and for the
/// adaptive rule the largest error estimate relative to a cell (over all blocks).
fn quadrature_plan(
    deck: &Deck,
    model: &Model,
    block: &crate::model::ModelBlock,
    weights: &[f64],
    summary: &crate::model::quadrature::QuadratureSummary,
) -> Option<String> {
    let rule = super::quadrature::block_rule(deck, &deck.blocks[block.deck_block]).ok()?;
    if rule.is_full_volume() {
        return None;
    }
    let bonds = &model.bonds;
    let mut partial = 0;
    let mut fullest = 0.0f64;
    for &p in &block.points {
        let p = p as usize;
        let mut sum = model.points.volume[p];
        for b in bonds.range(p) {
            let j = bonds.neighbor[b] as usize;
            partial += usize::from(weights[b] != model.points.volume[j]);
            sum += weights[b];
        }
        let sphere = 4.0 / 3.0 * std::f64::consts::PI * model.horizon[p].powi(3);
        fullest = fullest.max(sum / sphere);
    }
    let mut line = format!(
        "\"{}\": {partial} bonds with a partial volume, horizon volume error {:+.3e} (fullest point)",
        rule.name(),
        fullest - 1.0
    );
    if let crate::model::quadrature::QuadratureRule::Adaptive { tolerance } = rule {
        line.push_str(&format!(
            ", adaptive tolerance {tolerance:e}: largest error estimate {:.2e} of a cell, {} bonds unconverged",
            summary.largest_relative_error, summary.unconverged_bonds
        ));
    }
    Some(line)
}

/// The `surface correction` line of a corrected block: the correction, how many points it
/// changes and the range of their factors g_i.
fn correction_plan(
    block: &crate::model::ModelBlock,
    factors: &[f64],
    corrections: &[crate::model::surface_correction::SurfaceCorrection],
) -> Option<String> {
    let first = *block.points.first()? as usize;
    if !corrections[first].is_active() {
        return None;
    }
    let of_block: Vec<f64> = block.points.iter().map(|&p| factors[p as usize]).collect();
    let summary = crate::model::surface_correction::summarize(
        &of_block,
        &vec![corrections[first]; of_block.len()],
    );
    Some(format!(
        "\"{}\": {} of {} points corrected, factors {:.4}–{:.4}",
        corrections[first].name(),
        summary.corrected_points,
        of_block.len(),
        summary.factor_range[0],
        summary.factor_range[1]
    ))
}

/// Every node set, with whether the mesh or the deck defines it.
fn node_set_plans(model: &Model) -> Vec<NodeSetPlan> {
    model
        .node_sets
        .iter()
        .map(|(name, points)| NodeSetPlan {
            name: name.to_string(),
            points: points.len(),
            source: if model.mesh_node_set_names.iter().any(|m| m == name) {
                "mesh"
            } else {
                "deck"
            }
            .into(),
        })
        .collect()
}

/// Which passes the run needs (state-based dilatation, damage, contact, explicit and
/// implicit solvers with the tangent pattern).
fn physics_plan(deck: &Deck, model: &Model, used: &UsedModels) -> PhysicsPlan {
    let reach = used.material_reach().unwrap_or(Reach::OneHop);
    let damage = model
        .blocks
        .iter()
        .any(|b| deck.blocks[b.deck_block].damage_model.is_some());
    let lists = solver_lists(deck);
    let implicit = lists.iter().any(|l| l.integrator.is_implicit());
    PhysicsPlan {
        state_based: reach == Reach::TwoHop,
        damage,
        contact: deck.contact.is_some(),
        explicit: lists.iter().any(|l| !l.integrator.is_implicit()),
        implicit,
        tangent_pattern: implicit.then(|| reach.pattern_name().to_string()),
    }
}

/// The fields the run allocates, per point and per bond, with their bytes.
fn field_plans(model: &Model, used: &UsedModels, contact: bool) -> Vec<FieldPlan> {
    let n = model.points.len() as u64;
    let bonds = model.bonds.num_bonds() as u64;
    let mut fields = Vec::new();
    let vector = 24 * n;
    let mut field = |name: &str, per: &str, bytes: u64| {
        fields.push(FieldPlan {
            name: name.into(),
            per: per.into(),
            bytes,
        })
    };
    field("Model_Coordinates", "point", vector);
    field("Volume", "point", 8 * n);
    field("Horizon", "point", 8 * n);
    field("Block_Id, original id", "point", 8 * n);
    field("Displacement", "point", vector);
    field("Velocity", "point", vector);
    field("Force_Density", "point", vector);
    if model.boundary.has_body_force() {
        field("External_Force_Density", "point", vector);
    }
    if model.boundary.has_temperature() {
        field(
            "Temperature, Temperature_Change, thermal strain",
            "point",
            24 * n,
        );
    }
    let declared = used.fields();
    let declared_on = |carrier: FieldCarrier| {
        declared
            .iter()
            .filter(move |f| f.carrier == carrier)
            .map(|f| (f.name, f.bytes_per_value))
    };
    for (name, bytes) in declared_on(FieldCarrier::Point) {
        field(name, "point", bytes * n);
    }
    field("bond neighbour + length", "bond", 12 * bonds + 8 * (n + 1));
    for (name, bytes) in declared_on(FieldCarrier::Bond) {
        field(name, "bond", bytes * bonds);
    }
    if contact {
        field("Contact_Force_Density", "point", vector);
    }
    fields
}

/// Memory by part: the `fields` per point and per bond, and the tangent of implicit solvers
/// (assembled, two-hop when `state_based`, or only its diagonal blocks when Jacobian-free).
fn memory_plans(
    deck: &Deck,
    model: &Model,
    fields: &[FieldPlan],
    state_based: bool,
) -> Vec<MemoryPlan> {
    let n = model.points.len() as u64;
    let bonds = model.bonds.num_bonds() as u64;
    let total = |per: &str| -> u64 {
        fields
            .iter()
            .filter(|f| f.per == per)
            .map(|f| f.bytes)
            .sum()
    };
    let mut memory = vec![
        ("points and state", total("point")),
        ("bonds", total("bond")),
    ];
    let points = model.points.len();
    let lists = solver_lists(deck);
    let solves = || lists.iter().filter_map(|l| l.integrator.solve());
    let assembled = lists.iter().any(|l| {
        l.integrator.is_implicit()
            && l.integrator.solve().is_none_or(|s| {
                crate::backend::factory::jacobian_free_preconditioner(s, points).is_none()
            })
    });
    if assembled {
        let blocks = if state_based {
            two_hop_nonzero_blocks(model)
        } else {
            bonds + n
        };
        // The block tangent (a 3×3 block of 8-byte values and a 4-byte column per block) and
        // its scalar CSR copy over the free dofs (9 entries of an 8-byte value and an 8-byte
        // column per block) that the linear solver receives, plus their row starts.
        memory.push((
            "tangent matrix (blocks + CSR)",
            blocks * (9 * 8 + 4) + blocks * 9 * 16 + 8 * (4 * n + 2),
        ));
    } else if solves().any(|s| {
        crate::backend::factory::jacobian_free_preconditioner(s, points)
            .is_some_and(|p| p != LinearPreconditioner::Amg)
    }) {
        // Jacobian-free Newton–Krylov with block 3×3 keeps only the 3×3 diagonal blocks (with
        // AMG the hierarchy below holds its own).
        memory.push(("block-diagonal tangent (Jacobian-free)", n * 9 * 8));
    }
    if let Some(vectors) = solves().filter_map(|s| gmres_basis_vectors(s, 3 * n)).max() {
        // The GMRES basis grows one vector of the unknowns per iteration up to the restart
        // length, so this is its largest size; a solve that converges sooner holds less.
        memory.push(("GMRES basis (at most)", vectors * 3 * n * 8));
    }
    if solves().any(|s| crate::backend::factory::uses_multigrid(s, model.points.len())) {
        let amg = crate::backend::native::multigrid_memory_estimate(n, bonds);
        memory.push(("one-hop operator (AMG setup)", amg.operator));
        memory.push(("AMG setup products", amg.setup_products));
        memory.push(("AMG hierarchy", amg.hierarchy));
    }
    memory
        .into_iter()
        .map(|(part, bytes)| MemoryPlan {
            part: part.into(),
            bytes,
        })
        .collect()
}

/// Vectors of `unknowns` entries the GMRES basis of the Jacobian-free solve `solve` holds
/// at most: the restart length that solve runs + 1, or its iteration limit + 1 when that is
/// smaller ([`crate::backend::factory::matrix_free_gmres`]); `None` without such a solve.
fn gmres_basis_vectors(solve: &ImplicitSolve, unknowns: u64) -> Option<u64> {
    let unknowns = usize::try_from(unknowns).unwrap_or(usize::MAX);
    let (restart, limit) = crate::backend::factory::matrix_free_gmres(solve, unknowns)?;
    Some(restart.min(limit) as u64 + 1)
}

/// The planned memory per directed bond (`None` without bonds).
fn bytes_per_bond(total: u64, model: &Model) -> Option<f64> {
    let bonds = model.bonds.num_bonds();
    (bonds > 0).then(|| total as f64 / bonds as f64)
}

/// The time step of the first explicit solver (whose time step scales the stable estimate):
/// the estimate, the safety factor and the steps it gives (none without such a solver or an
/// estimate).
fn time_step_plan(deck: &Deck, model: &Model) -> Option<TimeStepPlan> {
    let (list, fixed, safety_factor) =
        solver_lists(deck)
            .into_iter()
            .find_map(|list| match list.integrator.time_step()? {
                TimeStep::Stable {
                    fixed,
                    safety_factor,
                } => Some((list, fixed, safety_factor)),
                TimeStep::Fixed(_) => None,
            })?;
    let estimate = critical_time_step(deck, model)?;
    let used = safety_factor * fixed.unwrap_or(estimate);
    Some(TimeStepPlan {
        estimate,
        safety_factor,
        fixed,
        used,
        steps: crate::solver::step_count(list.settings.span(), used)?,
    })
}
