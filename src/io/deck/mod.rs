//! Input decks: Peridigm-compatible YAML and XML (Teuchos `ParameterList`) files.
//!
//! [`load`] reads a deck, checks it completely once and returns a typed [`Deck`]; nothing
//! downstream needs to re-check types, ranges or cross references. Differences from Peridigm,
//! on purpose:
//!
//! * integers are accepted where doubles are expected (`Horizon: 2`; Peridigm issue #9);
//! * every key Peridigm would silently ignore is an error with a "did you mean" hint, except a
//!   few keys that Peridigm's own example decks carry without effect: those are accepted and
//!   reported in [`Deck::warnings`];
//! * `Restart: false` turns restart off (Peridigm turns it on whenever the key is present).
//!
//! Error messages name the file, the key path written with arrows and the line, e.g.
//! `wave.yaml:27: Materials → Steel → Densty: unknown key; did you mean "Density"?`.

mod belos;
mod blocks;
mod boundary;
mod contact;
mod damage;
mod discretization;
mod integrators;
mod linear_solve;
mod materials;
mod output;
mod overrides;
mod parameters;
mod solver;
#[cfg(test)]
pub(crate) use linear_solve::tests::three_point_bar_text;
mod study;
mod xml;
mod yaml;

use std::collections::HashMap;

use crate::parameter_list::{error, reader, tree};
use std::path::{Path, PathBuf};

pub use blocks::{Block, Horizon};
pub use boundary::{
    normalize_name, BoundaryCondition, BoundaryConditionKind, BoundaryConditions, Coordinate,
    NodeSetDefinition, NodeSetSource,
};
pub use contact::{Contact, ContactInteraction, ContactModel, Friction};
pub use damage::DamageModel;
pub use discretization::{
    BondFilter, BondFilterShape, Discretization, ElementHorizonIntersections, InfluenceFunction,
    OmitBonds, PointSource, QuickGridGenerator,
};
pub use error::{DeckError, KeyPath};
pub use integrators::{
    AdaptiveLoadStepping, DynamicRelaxation, Implicit, ImplicitDiffusion, Integrator, LoadSteps,
    NoxQuasiStatic, QuasiStatic, SwitchToDynamicRelaxation, SwitchToVerlet, Verlet,
};
pub use linear_solve::{
    parse_petsc_options, AlgebraicPreconditioner, BelosSettings, BelosSolver, LinearBackend,
    LinearMethod, LinearPreconditioner, LinearSolve, NonlinearMethod, PetscPreconditioner,
};
pub use materials::{Flaw, Material};
pub use output::{CalculationType, ComputeClass, ComputeClassKind, Output};
pub use overrides::{split_key_path, Override};
pub use parameters::ParameterValue;
pub use solver::{PeridigmPreconditioner, SolveFor, Solver};
pub use study::{split_values, Study, Variation};

use reader::{suggest, Ctx, Field, ListReader};
use tree::NodeKind;

/// The text format of a deck.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DeckFormat {
    /// YAML (`.yaml`, `.yml`), root key `Peridigm:` optional.
    Yaml,
    /// Teuchos `ParameterList` XML (`.xml`).
    Xml,
}

impl DeckFormat {
    /// The format named by a file's extension, if any.
    pub fn from_path(path: &Path) -> Option<DeckFormat> {
        match path.extension()?.to_str()?.to_ascii_lowercase().as_str() {
            "yaml" | "yml" => Some(DeckFormat::Yaml),
            "xml" => Some(DeckFormat::Xml),
            _ => None,
        }
    }
}

/// `Data Loader`: a nodal field read from an Exodus file and interpolated in time.
#[derive(Debug, Clone, PartialEq)]
pub struct DataLoader {
    /// `File Name` (required), resolved relative to the deck's directory.
    pub file_name: PathBuf,
    /// `Field Name` (required) — the nodal variable to read.
    pub field_name: String,
}

/// A complete, checked input deck.
///
/// Two decks compare equal when their content is equal; the file they came from, its format,
/// the line numbers and the warnings are not compared (so a YAML deck and its XML twin are
/// equal).
#[derive(Debug, Clone)]
pub struct Deck {
    /// The deck file as given to [`load`] (or the `origin` of [`parse_str`]).
    pub path: PathBuf,
    /// The format the deck was read from.
    pub format: DeckFormat,
    /// `Verbose` (top level) — default false.
    pub verbose: bool,
    /// `Multiphysics: 1` — adds a fluid-pressure unknown; default off (only 1 is accepted).
    pub multiphysics: bool,
    /// `Restart` — write restart files (after each solver list, every `Frequency` steps, every
    /// `Wall Clock Interval` seconds and on a stop signal) and resume from the newest; present
    /// and not `false` turns it on; default off (`None`).
    pub restart: Option<Restart>,
    /// `Discretization` (required).
    pub discretization: Discretization,
    /// `Materials` (required, ≥ 1), file order.
    pub materials: Vec<Material>,
    /// `Damage Models`, file order; default none.
    pub damage_models: Vec<DamageModel>,
    /// `Blocks` (required, ≥ 1), file order.
    pub blocks: Vec<Block>,
    /// `Contact`; default none.
    pub contact: Option<Contact>,
    /// `Boundary Conditions`; default empty.
    pub boundary_conditions: BoundaryConditions,
    /// Every top-level list whose name contains `Solver` (≥ 1), in file order.
    pub solvers: Vec<Solver>,
    /// Every top-level list whose name contains `Output`, in file order; default none.
    pub outputs: Vec<Output>,
    /// `Compute Class Parameters`, file order; default none.
    pub compute_classes: Vec<ComputeClass>,
    /// `Data Loader`; default none.
    pub data_loader: Option<DataLoader>,
    /// `Study`: the variations `peridyn study` runs; `run` and `check` ignore it. Default none.
    pub study: Option<Study>,
    /// Accepted keys that have no effect, and other remarks, each as `file:line: path: text`.
    pub warnings: Vec<String>,
    lines: HashMap<Vec<String>, usize>,
}

/// The `Restart` list: when restart files are written besides the end of every solver list
/// (Peridigm's only moment) and a stop signal.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Restart {
    /// `Frequency` (peridyn's key): also write one every this many steps of an explicit list
    /// or accepted load steps of a quasi-static list; default none.
    pub every_steps: Option<u64>,
    /// `Wall Clock Interval` (peridyn's key, seconds of wall-clock time): also write one after
    /// the first step that ends this long after the last restart file (or the start); default
    /// none.
    pub every_seconds: Option<f64>,
}

impl PartialEq for Deck {
    fn eq(&self, other: &Self) -> bool {
        self.verbose == other.verbose
            && self.multiphysics == other.multiphysics
            && self.restart == other.restart
            && self.discretization == other.discretization
            && self.materials == other.materials
            && self.damage_models == other.damage_models
            && self.blocks == other.blocks
            && self.contact == other.contact
            && self.boundary_conditions == other.boundary_conditions
            && self.solvers == other.solvers
            && self.outputs == other.outputs
            && self.compute_classes == other.compute_classes
            && self.data_loader == other.data_loader
            && self.study == other.study
    }
}

impl Deck {
    /// The directory of the deck file; relative file names in the deck are relative to it.
    pub fn directory(&self) -> &Path {
        self.path.parent().unwrap_or(Path::new(""))
    }

    /// The 1-based line where the key at `path` is written (root excluded), e.g.
    /// `deck.line_of(&["Boundary Conditions", "Node Set One"])`.
    pub fn line_of(&self, path: &[&str]) -> Option<usize> {
        let key: Vec<String> = path.iter().map(|s| s.to_string()).collect();
        self.lines.get(&key).copied()
    }

    /// Adds a warning about the key at `path`, in the style of the load-time warnings
    /// (`file:line: key → path: message`), for what is found after loading.
    pub fn warn_at(&mut self, path: &[&str], message: &str) {
        let line = self
            .line_of(path)
            .map_or(String::new(), |line| format!("{line}:"));
        self.warnings.push(format!(
            "{}:{line} {}: {message}",
            self.path.display(),
            KeyPath(path.iter().map(|s| s.to_string()).collect())
        ));
    }

    /// An error about the key at `path`, in the same style as load-time errors (for problems
    /// found later, such as a node id beyond the number of points or a missing mesh file).
    pub fn error_at(&self, path: &[&str], message: impl Into<String>) -> DeckError {
        DeckError::Invalid {
            file: self.path.clone(),
            line: self.line_of(path),
            key_path: KeyPath(path.iter().map(|s| s.to_string()).collect()),
            message: message.into(),
        }
    }

    /// The material named `name`.
    pub fn material(&self, name: &str) -> Option<&Material> {
        self.materials.iter().find(|m| m.name == name)
    }

    /// The damage model named `name`.
    pub fn damage_model(&self, name: &str) -> Option<&DamageModel> {
        self.damage_models.iter().find(|d| d.name == name)
    }

    /// The deck-defined node set whose normalised name ([`normalize_name`]) equals that of `name`.
    pub fn node_set(&self, name: &str) -> Option<&NodeSetDefinition> {
        let wanted = normalize_name(name);
        self.boundary_conditions
            .node_sets
            .iter()
            .find(|s| s.normalized_name == wanted)
    }
}

/// Reads and checks the deck at `path`; the format comes from the extension.
pub fn load(path: &Path) -> Result<Deck, DeckError> {
    load_with(path, &[])
}

/// [`load`] with `overrides` applied to the deck's values before it is checked
/// (`peridyn run --set`, the variants of `peridyn study`).
pub fn load_with(path: &Path, overrides: &[Override]) -> Result<Deck, DeckError> {
    let format = DeckFormat::from_path(path).ok_or_else(|| DeckError::UnknownFormat {
        file: path.to_path_buf(),
    })?;
    let text = std::fs::read_to_string(path).map_err(|source| DeckError::Io {
        file: path.to_path_buf(),
        source,
    })?;
    parse_str_with(&text, format, path, overrides)
}

/// Parses and checks deck text; `origin` names the file in messages and anchors relative paths.
pub fn parse_str(text: &str, format: DeckFormat, origin: &Path) -> Result<Deck, DeckError> {
    parse_str_with(text, format, origin, &[])
}

/// [`parse_str`] with `overrides` applied to the parsed values before they are checked.
pub fn parse_str_with(
    text: &str,
    format: DeckFormat,
    origin: &Path,
    overrides: &[Override],
) -> Result<Deck, DeckError> {
    // Editors on Windows may start a UTF-8 file with a byte-order mark; it is not content.
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let (mut root, parse_warnings) = match format {
        DeckFormat::Yaml => yaml::parse(text, origin)?,
        DeckFormat::Xml => xml::parse(text, origin)?,
    };
    if !overrides.is_empty() {
        let line = root.line;
        if let NodeKind::List(entries) = &mut root.kind {
            overrides::apply(entries, line, overrides, origin)?;
        }
    }
    let entries = match &root.kind {
        NodeKind::List(entries) => entries.as_slice(),
        NodeKind::Scalar(_) => unreachable!("both parsers return a list as the root"),
    };
    let mut ctx = Ctx::new(origin);
    ctx.warnings = parse_warnings;
    let mut deck = read_top(
        &mut ctx,
        ListReader::new(entries, Vec::new(), root.line),
        format,
    )?;
    deck.lines = tree::index_lines(entries);
    cross_check(&mut ctx, &deck)?;
    deck.warnings = std::mem::take(&mut ctx.warnings);
    Ok(deck)
}

const TOP_LEVEL: &[&str] = &[
    "Verbose",
    "Multiphysics",
    "Restart",
    "Discretization",
    "Materials",
    "Damage Models",
    "Blocks",
    "Contact",
    "Boundary Conditions",
    "Compute Class Parameters",
    "Data Loader",
    "Solver",
    "Output",
    "Study",
];

fn named_lists<T>(
    ctx: &mut Ctx,
    field: &Field,
    what: &str,
    read: impl Fn(&mut Ctx, &Field) -> Result<T, DeckError>,
) -> Result<Vec<T>, DeckError> {
    let mut list = field.list(ctx)?;
    let mut out = Vec::new();
    for f in list.all() {
        if !f.is_list() {
            return Err(f.err(
                ctx,
                format!("expected a list describing one {what}, found a single value"),
            ));
        }
        out.push(read(ctx, &f)?);
    }
    Ok(out)
}

fn read_top(ctx: &mut Ctx, mut top: ListReader, format: DeckFormat) -> Result<Deck, DeckError> {
    let mut deck = empty_deck(ctx, format);
    let mut seen = Vec::new();
    for f in top.all() {
        seen.push(f.key());
        read_top_entry(ctx, &mut deck, &f)?;
    }
    check_required_sections(ctx, &top, &seen, &deck)?;
    Ok(deck)
}

/// A deck with nothing read yet; the required sections replace the placeholders.
fn empty_deck(ctx: &Ctx, format: DeckFormat) -> Deck {
    Deck {
        path: ctx.file.clone(),
        format,
        verbose: false,
        multiphysics: false,
        restart: None,
        discretization: Discretization {
            source: PointSource::TextFile {
                input_mesh_file: PathBuf::new(),
            },
            influence_function: InfluenceFunction::One,
            omit_bonds_between_blocks: OmitBonds::None,
            bond_filters: Vec::new(),
            verbose: false,
        },
        materials: Vec::new(),
        damage_models: Vec::new(),
        blocks: Vec::new(),
        contact: None,
        boundary_conditions: BoundaryConditions::default(),
        solvers: Vec::new(),
        outputs: Vec::new(),
        compute_classes: Vec::new(),
        data_loader: None,
        study: None,
        warnings: Vec::new(),
        lines: HashMap::new(),
    }
}

/// Reads one top-level key into `deck`.
fn read_top_entry(ctx: &mut Ctx, deck: &mut Deck, f: &Field) -> Result<(), DeckError> {
    let key = f.key();
    match key {
        "Verbose" => deck.verbose = f.bool(ctx)?,
        "Multiphysics" => {
            let v = f.i64(ctx)?;
            if v != 1 {
                return Err(f.err(ctx, format!("only `Multiphysics: 1` is accepted (found {v}); remove the key to turn multiphysics off")));
            }
            deck.multiphysics = true;
        }
        "Restart" => deck.restart = read_restart(ctx, f)?,
        "Discretization" => deck.discretization = discretization::read(ctx, f)?,
        "Materials" => deck.materials = named_lists(ctx, f, "material", materials::read)?,
        "Damage Models" => deck.damage_models = named_lists(ctx, f, "damage model", damage::read)?,
        "Blocks" => deck.blocks = named_lists(ctx, f, "group of blocks", blocks::read)?,
        "Contact" => deck.contact = Some(contact::read(ctx, f)?),
        "Boundary Conditions" => deck.boundary_conditions = boundary::read(ctx, f)?,
        "Compute Class Parameters" => {
            deck.compute_classes = named_lists(ctx, f, "compute class", output::read_compute_class)?
        }
        "Data Loader" => deck.data_loader = Some(read_data_loader(ctx, f)?),
        "Study" => deck.study = Some(study::read(ctx, f)?),
        // Read by Peridigm's parameter list but used by no model it ships (the bond-associated
        // correspondence models read their own keys).
        "Enable Bond-Associated Hypoelastic Model" => {
            f.bool(ctx)?;
            ctx.warn(
                f.line(),
                &[key.to_string()],
                "accepted but has no effect: no material model reads this top-level key",
            );
        }
        // Read by Peridigm only when it is coupled to Albany (it then allocates a tangent).
        "Optimization Based Coupling" => ctx.warn(
            f.line(),
            &[key.to_string()],
            "accepted but has no effect: it only matters when Peridigm is coupled to Albany",
        ),
        _ if key.contains("Solver") && key.contains("Output") => {
            return Err(f.err(ctx, "the name contains both \"Solver\" and \"Output\", so Peridigm would read it as both; rename it"));
        }
        _ if key.contains("Solver") => {
            let first = deck.solvers.is_empty();
            deck.solvers.push(solver::read(ctx, f, first)?);
        }
        _ if key.contains("Output") => deck.outputs.push(output::read_output(ctx, f)?),
        _ => {
            let hint = match suggest(key, TOP_LEVEL.iter().copied()) {
                Some(s) => format!("did you mean \"{s}\"?"),
                None => format!(
                    "valid top-level keys are {}, and any name containing \"Solver\" or \"Output\"",
                    TOP_LEVEL[..11]
                        .iter()
                        .map(|k| format!("\"{k}\""))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            };
            return Err(f.err(ctx, format!("unknown key; {hint}")));
        }
    }
    Ok(())
}

/// `Restart`: a flag, an empty entry (on) or a list with a `Restart` flag and peridyn's
/// `Frequency` (steps) and `Wall Clock Interval` (seconds) keys.
fn read_restart(ctx: &mut Ctx, f: &Field) -> Result<Option<Restart>, DeckError> {
    let mut restart = Restart::default();
    let on = if f.is_list() {
        let mut l = f.list(ctx)?;
        let on = l.bool_or(ctx, "Restart", true)?;
        restart.every_steps = l.int_opt(ctx, "Frequency", 1)?.map(|n| n as u64);
        restart.every_seconds = l.positive_opt(ctx, "Wall Clock Interval")?;
        l.finish(ctx, &[])?;
        on
    } else {
        match &f.node().kind {
            NodeKind::Scalar(s) if matches!(s.kind, tree::ScalarKind::Null) => true,
            _ => f.bool(ctx)?,
        }
    };
    if !on {
        ctx.warn(f.line(), &f.path, "restart is off; note that Peridigm would turn restart on whenever a Restart entry is present, even when false");
    }
    Ok(on.then_some(restart))
}

/// `Data Loader`: the file and the field it loads.
fn read_data_loader(ctx: &mut Ctx, f: &Field) -> Result<DataLoader, DeckError> {
    let mut l = f.list(ctx)?;
    let file = l.name_req(ctx, "File Name")?;
    let field_name = l.name_req(ctx, "Field Name")?;
    l.finish(ctx, &[])?;
    Ok(DataLoader {
        file_name: ctx.resolve(&file),
        field_name,
    })
}

/// The sections every deck needs: a discretization, materials, blocks and a solver.
fn check_required_sections(
    ctx: &Ctx,
    top: &ListReader,
    seen: &[&str],
    deck: &Deck,
) -> Result<(), DeckError> {
    for (key, what) in [
        ("Discretization", "a list with Type and its keys"),
        ("Materials", "a list of named materials"),
        ("Blocks", "a list of named block groups"),
    ] {
        if !seen.contains(&key) {
            return Err(top.missing(ctx, key, what));
        }
    }
    if deck.materials.is_empty() {
        let line = top.peek("Materials").map(|f| f.line());
        return Err(ctx.error(
            line,
            &["Materials".to_string()],
            "no material defined; add at least one named material",
        ));
    }
    if deck.blocks.is_empty() {
        let line = top.peek("Blocks").map(|f| f.line());
        return Err(ctx.error(
            line,
            &["Blocks".to_string()],
            "no block group defined; add at least one",
        ));
    }
    if deck.solvers.is_empty() {
        return Err(top.missing(
            ctx,
            "Solver",
            "a list with Initial Time, Final Time and one integrator such as Verlet",
        ));
    }
    Ok(())
}

/// Checks that need more than one list: names referring to other lists, duplicates, switches.
fn cross_check(ctx: &mut Ctx, deck: &Deck) -> Result<(), DeckError> {
    let mut groups = BlockGroupNames {
        quick_grid: matches!(deck.discretization.source, PointSource::PdQuickGrid { .. }),
        claimed: Vec::new(),
        default_group: None,
    };
    for block in &deck.blocks {
        check_block_material(ctx, deck, block)?;
        check_block_damage_model(ctx, deck, block)?;
        groups.claim(ctx, deck, block)?;
    }
    warn_unused_materials(ctx, deck);
    check_condition_node_sets(ctx, deck)?;
    warn_unwritten_compute_classes(ctx, deck);
    Ok(())
}

/// A key path of string slices as the owned path of messages.
fn owned(path: &[&str]) -> Vec<String> {
    path.iter().map(|s| s.to_string()).collect()
}

/// `"a", "b", "c"`.
fn quoted_list(names: Vec<&str>) -> String {
    names
        .iter()
        .map(|n| format!("\"{n}\""))
        .collect::<Vec<_>>()
        .join(", ")
}

/// A block group's `Material` names a defined material, and a multiphysics one only in a
/// multiphysics deck.
fn check_block_material(ctx: &Ctx, deck: &Deck, block: &Block) -> Result<(), DeckError> {
    let path = ["Blocks", block.name.as_str(), "Material"];
    match deck.material(&block.material) {
        None => {
            let names: Vec<&str> = deck.materials.iter().map(|m| m.name.as_str()).collect();
            let hint = match suggest(&block.material, names.iter().copied()) {
                Some(s) => format!("did you mean \"{s}\"?"),
                None => format!(
                    "the materials defined under `Materials` are {}",
                    quoted_list(names)
                ),
            };
            Err(ctx.error(
                deck.line_of(&path),
                &owned(&path),
                format!("no material named \"{}\"; {hint}", block.material),
            ))
        }
        Some(material) => {
            if material.parameters.requires_multiphysics() && !deck.multiphysics {
                let path = ["Materials", material.name.as_str(), "Material Model"];
                return Err(ctx.error(
                    deck.line_of(&path),
                    &owned(&path),
                    "the Multiphysics Elastic model needs `Multiphysics: 1` at the top level of the deck",
                ));
            }
            Ok(())
        }
    }
}

/// A block group's `Damage Model`, when given, names a defined damage model.
fn check_block_damage_model(ctx: &Ctx, deck: &Deck, block: &Block) -> Result<(), DeckError> {
    let Some(damage) = &block.damage_model else {
        return Ok(());
    };
    if deck.damage_model(damage).is_some() {
        return Ok(());
    }
    let path = ["Blocks", block.name.as_str(), "Damage Model"];
    let names: Vec<&str> = deck.damage_models.iter().map(|d| d.name.as_str()).collect();
    let hint = match suggest(damage, names.iter().copied()) {
        Some(s) => format!("did you mean \"{s}\"?"),
        None if names.is_empty() => {
            "define it under `Damage Models`, or write \"None\"".to_string()
        }
        None => format!(
            "the damage models defined are {} (or \"None\")",
            quoted_list(names)
        ),
    };
    Err(ctx.error(
        deck.line_of(&path),
        &owned(&path),
        format!("no damage model named \"{damage}\"; {hint}"),
    ))
}

/// The block names the groups claimed so far: each block belongs to one group, and one group
/// at most is the `Default`.
struct BlockGroupNames<'d> {
    /// A PdQuickGrid discretization has the single block `block_1`.
    quick_grid: bool,
    /// (block name, group name).
    claimed: Vec<(&'d str, &'d str)>,
    default_group: Option<&'d str>,
}

impl<'d> BlockGroupNames<'d> {
    /// Claims the `Block Names` of `block` for its group.
    fn claim(&mut self, ctx: &Ctx, deck: &Deck, block: &'d Block) -> Result<(), DeckError> {
        let names_path = ["Blocks", block.name.as_str(), "Block Names"];
        if block.is_default() {
            if let Some(other) = self.default_group {
                return Err(ctx.error(
                    deck.line_of(&names_path),
                    &owned(&names_path),
                    format!("only one group may use \"Default\"; \"{other}\" already does"),
                ));
            }
            self.default_group = Some(&block.name);
            return Ok(());
        }
        for name in &block.block_names {
            if let Some((_, other)) = self.claimed.iter().find(|(n, _)| n == name) {
                return Err(ctx.error(
                    deck.line_of(&names_path),
                    &owned(&names_path),
                    format!("block \"{name}\" is already assigned by the group \"{other}\"; each block belongs to one group"),
                ));
            }
            if self.quick_grid && name != "block_1" {
                return Err(ctx.error(
                    deck.line_of(&names_path),
                    &owned(&names_path),
                    format!("a PdQuickGrid discretization has the single block \"block_1\", found \"{name}\""),
                ));
            }
            self.claimed.push((name, &block.name));
        }
        Ok(())
    }
}

/// Warns about materials no block group uses.
fn warn_unused_materials(ctx: &mut Ctx, deck: &Deck) {
    for material in &deck.materials {
        if !deck.blocks.iter().any(|b| b.material == material.name) {
            let path = ["Materials", material.name.as_str()];
            if let Some(line) = deck.line_of(&path) {
                ctx.warn(
                    line,
                    &owned(&path),
                    "this material is not used by any block",
                );
            }
        }
    }
}

/// Node sets: Exodus meshes bring their own (checked once the mesh is read); the other
/// discretizations have none, so every name must be defined in the deck.
fn check_condition_node_sets(ctx: &mut Ctx, deck: &Deck) -> Result<(), DeckError> {
    let mesh_has_node_sets = matches!(deck.discretization.source, PointSource::Exodus { .. });
    let rank_deficient = deck.boundary_conditions.create_rank_deficient_node_set == Some(true);
    for bc in &deck.boundary_conditions.conditions {
        if deck.node_set(&bc.node_set).is_some()
            || (rank_deficient && bc.node_set_normalized == "RANK_DEFICIENT_NODES")
        {
            continue;
        }
        let path = ["Boundary Conditions", bc.name.as_str(), "Node Set"];
        let names: Vec<&str> = deck
            .boundary_conditions
            .node_sets
            .iter()
            .map(|s| s.name.as_str())
            .collect();
        let near = suggest(&bc.node_set, names.iter().copied());
        if mesh_has_node_sets {
            if let (Some(s), Some(line)) = (near, deck.line_of(&path)) {
                ctx.warn(
                    line,
                    &owned(&path),
                    format!("\"{}\" is not defined in the deck, so the mesh must provide it; did you mean \"{s}\"?", bc.node_set),
                );
            }
            continue;
        }
        let hint = match near {
            Some(s) => format!("did you mean \"{s}\"?"),
            None if names.is_empty() => {
                "define it in `Boundary Conditions`, e.g. `Min X Node Set: \"1 2 3\"`".to_string()
            }
            None => format!("the node sets defined are {}", quoted_list(names)),
        };
        return Err(ctx.error(
            deck.line_of(&path),
            &owned(&path),
            format!(
                "no node set named \"{}\" (this discretization has no mesh node sets); {hint}",
                bc.node_set
            ),
        ));
    }
    Ok(())
}

/// Warns about compute classes whose output label no output writes.
fn warn_unwritten_compute_classes(ctx: &mut Ctx, deck: &Deck) {
    for class in &deck.compute_classes {
        if let Some(label) = class.output_label() {
            if !deck
                .outputs
                .iter()
                .any(|o| o.enabled_variables().any(|v| v == label))
            {
                let path = [
                    "Compute Class Parameters",
                    class.name.as_str(),
                    "Output Label",
                ];
                if let Some(line) = deck.line_of(&path) {
                    ctx.warn(line, &owned(&path), format!("\"{label}\" is computed but not listed under any Output Variables, so it is never written"));
                }
            }
        }
    }
}
