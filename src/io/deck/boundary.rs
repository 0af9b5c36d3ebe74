//! `Boundary Conditions` list: node-set definitions, initial/boundary conditions, body forces.

use std::path::PathBuf;

use super::error::DeckError;
use super::reader::{Ctx, Field};
use super::tree::{is_float_literal, is_integer_literal};

pub use crate::model::normalize_name;

/// The `Boundary Conditions` list.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct BoundaryConditions {
    /// Entries whose normalised name contains `NODE_SET`, in file order.
    pub node_sets: Vec<NodeSetDefinition>,
    /// The condition lists, in file order.
    pub conditions: Vec<BoundaryCondition>,
    /// `Create Node Set For Rank Deficient Nodes` — create the (initially empty) node set
    /// `RANK_DEFICIENT_NODES` held fixed in x, y, z. `None` when absent (Peridigm then creates
    /// it for implicit solvers with damage).
    pub create_rank_deficient_node_set: Option<bool>,
    /// True when some node-set list of the deck contains id 0: the deck was written for
    /// Peridigm's early 0-based numbering (e.g. `ElementVariableOutput.xml`), and every id
    /// list in it is read as 0-based. Peridigm 1.5 rejects such decks; peridyn reads them with
    /// a warning. Default false (1-based, the Exodus convention).
    pub zero_based_ids: bool,
}

/// A node set written in the deck, e.g. `Min X Node Set: "1 4 7 10"`.
#[derive(Debug, Clone, PartialEq)]
pub struct NodeSetDefinition {
    /// The key as written.
    pub name: String,
    /// The normalised name ([`normalize_name`]) under which conditions find it.
    pub normalized_name: String,
    /// The ids, or the file holding them.
    pub source: NodeSetSource,
}

/// Where a deck node set's ids come from.
#[derive(Debug, Clone, PartialEq)]
pub enum NodeSetSource {
    /// A whitespace-separated list of global point ids: 1-based, unless the deck is a legacy
    /// 0-based one ([`BoundaryConditions::zero_based_ids`]).
    Ids(Vec<u64>),
    /// A single non-numeric token: a text file of ids (one or more per line, lines starting
    /// with `#`, `/` or `*` are comments), resolved relative to the deck's directory. Not read
    /// at load time.
    File(PathBuf),
}

/// One boundary or initial condition (a sublist of `Boundary Conditions`).
#[derive(Debug, Clone, PartialEq)]
pub struct BoundaryCondition {
    /// The name of the list.
    pub name: String,
    /// `Type` (required; case and spaces/underscores are free, as in Peridigm).
    pub kind: BoundaryConditionKind,
    /// `Node Set` (required) as written; defined in this list or provided by the mesh.
    pub node_set: String,
    /// `Node Set` normalised with [`normalize_name`].
    pub node_set_normalized: String,
    /// `Coordinate` — `x`, `y` or `z`. Required for the conditions on a vector field
    /// (displacement, velocity, body force): Peridigm takes `x` when it is absent
    /// (`to_spatial_coordinate` in its `src/core/Peridigm_Enums.cpp`), which silently turns a
    /// forgotten key into an x condition, so peridyn asks for it. Omitted (or `x`) for scalar
    /// fields (temperature, fluid pressure).
    pub coordinate: Coordinate,
    /// `Value` (required) — an expression in `x y z t` kept as text; numbers keep their
    /// spelling (Peridigm converts a double to a string too).
    pub value: String,
}

/// A Cartesian direction.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Coordinate {
    /// `x` (index 0).
    X,
    /// `y` (index 1).
    Y,
    /// `z` (index 2).
    Z,
}

impl Coordinate {
    /// 0, 1 or 2.
    pub fn index(self) -> usize {
        self as usize
    }
}

/// `Type` of a boundary condition.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BoundaryConditionKind {
    /// `Prescribed Displacement`: displacement g(x, t) applied every step (as increments).
    PrescribedDisplacement,
    /// `Initial Displacement`: displacement at the start.
    InitialDisplacement,
    /// `Initial Velocity`: velocity at the start.
    InitialVelocity,
    /// `Body Force`: external force density (force per volume), every step.
    BodyForce,
    /// `Prescribed Temperature`: temperature every step (drives thermal strain).
    PrescribedTemperature,
    /// `Initial Temperature`: temperature at the start.
    InitialTemperature,
    /// `Thermal Flux`: Neumann condition on temperature.
    ThermalFlux,
    /// `Prescribed Fluid Pressure U`: multiphysics fluid pressure every step.
    PrescribedFluidPressureU,
    /// `Initial Fluid Pressure U`: multiphysics fluid pressure at the start.
    InitialFluidPressureU,
}

impl BoundaryConditionKind {
    const ALL: [(&'static str, BoundaryConditionKind); 9] = [
        ("Prescribed Displacement", Self::PrescribedDisplacement),
        ("Initial Displacement", Self::InitialDisplacement),
        ("Initial Velocity", Self::InitialVelocity),
        ("Body Force", Self::BodyForce),
        ("Prescribed Temperature", Self::PrescribedTemperature),
        ("Initial Temperature", Self::InitialTemperature),
        ("Thermal Flux", Self::ThermalFlux),
        (
            "Prescribed Fluid Pressure U",
            Self::PrescribedFluidPressureU,
        ),
        ("Initial Fluid Pressure U", Self::InitialFluidPressureU),
    ];

    /// True for conditions on a scalar field (only `Coordinate: x` allowed).
    pub fn is_scalar_field(self) -> bool {
        matches!(
            self,
            Self::PrescribedTemperature
                | Self::InitialTemperature
                | Self::ThermalFlux
                | Self::PrescribedFluidPressureU
                | Self::InitialFluidPressureU
        )
    }

    /// The deck spelling, e.g. `"Prescribed Displacement"`.
    pub fn deck_name(self) -> &'static str {
        Self::ALL
            .iter()
            .find(|(_, k)| *k == self)
            .map(|(n, _)| *n)
            .expect("every kind is listed")
    }
}

const RANK_DEFICIENT_KEY: &str = "Create Node Set For Rank Deficient Nodes";

fn read_node_set(ctx: &Ctx, field: &Field) -> Result<NodeSetDefinition, DeckError> {
    if field.is_list() {
        return Err(field.err(
            ctx,
            "a name containing \"Node Set\" defines a node set and must be a string of ids or a file name; \
             rename this list if it is a boundary condition",
        ));
    }
    let text = field.string(ctx)?;
    let tokens: Vec<&str> = text.split_whitespace().collect();
    let source = match tokens.as_slice() {
        [] => {
            return Err(field.err(
                ctx,
                "empty node set; give 1-based point ids (\"1 2 3\") or a file name",
            ))
        }
        [single] if !is_integer_literal(single) && !is_float_literal(single) => {
            NodeSetSource::File(ctx.resolve(single))
        }
        _ => {
            let mut ids = Vec::with_capacity(tokens.len());
            for token in &tokens {
                if !is_integer_literal(token) {
                    return Err(field.err(ctx, format!("node id \"{token}\" is not an integer; node sets list 1-based point ids")));
                }
                match token.parse::<i64>() {
                    // 0 is accepted here: a deck that lists it was written for Peridigm's early
                    // 0-based numbering, which the caller switches to for the whole deck.
                    Ok(id) if id >= 0 => ids.push(id as u64),
                    _ => {
                        return Err(field.err(
                            ctx,
                            format!("node id {token} is out of range; node numbering starts at 1 (Exodus convention)"),
                        ))
                    }
                }
            }
            NodeSetSource::Ids(ids)
        }
    };
    Ok(NodeSetDefinition {
        name: field.key().to_string(),
        normalized_name: normalize_name(field.key()),
        source,
    })
}

fn read_condition(ctx: &mut Ctx, field: &Field) -> Result<BoundaryCondition, DeckError> {
    let mut list = field.list(ctx)?;
    let type_field = list.require(ctx, "Type", "e.g. \"Prescribed Displacement\"")?;
    let type_text = type_field.name(ctx)?;
    let normalized = normalize_name(&type_text);
    let kind = BoundaryConditionKind::ALL
        .iter()
        .find(|(name, _)| normalize_name(name) == normalized)
        .map(|(_, k)| *k)
        .ok_or_else(|| {
            let names: Vec<&str> = BoundaryConditionKind::ALL.iter().map(|(n, _)| *n).collect();
            let list = names.iter().map(|n| format!("\"{n}\"")).collect::<Vec<_>>().join(", ");
            let t = type_text.as_str();
            let message = if normalized.contains("VELOCITY") && normalized.contains("PRESCRIBED") {
                format!(
                    "unknown boundary condition type \"{t}\"; Peridigm has no prescribed velocity: use \"Prescribed Displacement\" with a value linear in t"
                )
            } else {
                match super::reader::suggest(t, names.iter().copied()) {
                    Some(s) => format!("unknown boundary condition type \"{t}\"; did you mean \"{s}\"? (valid types: {list})"),
                    None => format!("unknown boundary condition type \"{t}\"; valid types are {list}"),
                }
            };
            type_field.err(ctx, message)
        })?;
    let node_set = list.name_req(ctx, "Node Set")?;
    let coordinate = match list.get("Coordinate") {
        None if kind.is_scalar_field() => Coordinate::X,
        None => {
            let what = format!(
                "\"x\", \"y\" or \"z\": the component this \"{}\" sets; peridyn does not take a missing one as \"x\"",
                kind.deck_name()
            );
            return Err(list.missing(ctx, "Coordinate", &what));
        }
        Some(f) => {
            let c = match f.name(ctx)?.as_str() {
                "x" | "X" => Coordinate::X,
                "y" | "Y" => Coordinate::Y,
                "z" | "Z" => Coordinate::Z,
                other => {
                    return Err(f.err(
                        ctx,
                        format!("coordinate must be \"x\", \"y\" or \"z\", found \"{other}\""),
                    ))
                }
            };
            if kind.is_scalar_field() && c != Coordinate::X {
                return Err(f.err(
                    ctx,
                    format!(
                        "\"{}\" acts on a scalar field; omit `Coordinate` (or write \"x\")",
                        kind.deck_name()
                    ),
                ));
            }
            c
        }
    };
    let value_field = list.require(ctx, "Value", "an expression in x, y, z, t, or a number")?;
    let value = value_field.string(ctx)?;
    if value.trim().is_empty() {
        return Err(value_field.err(
            ctx,
            "the value is empty; write an expression in x, y, z, t or a number",
        ));
    }
    list.finish(ctx, &[])?;
    Ok(BoundaryCondition {
        name: field.key().to_string(),
        kind,
        node_set_normalized: normalize_name(&node_set),
        node_set,
        coordinate,
        value,
    })
}

pub(crate) fn read(ctx: &mut Ctx, field: &Field) -> Result<BoundaryConditions, DeckError> {
    let mut list = field.list(ctx)?;
    let mut out = BoundaryConditions {
        create_rank_deficient_node_set: list
            .get(RANK_DEFICIENT_KEY)
            .map(|f| f.bool(ctx))
            .transpose()?,
        ..Default::default()
    };
    for f in list.take_rest() {
        if normalize_name(f.key()).contains("NODE_SET") {
            let set = read_node_set(ctx, &f)?;
            if let Some(previous) = out
                .node_sets
                .iter()
                .find(|s| s.normalized_name == set.normalized_name)
            {
                return Err(f.err(
                    ctx,
                    format!("node set \"{}\" is defined twice (also as \"{}\"; names are compared in upper case with spaces as underscores)", set.name, previous.name),
                ));
            }
            if matches!(&set.source, NodeSetSource::Ids(ids) if ids.contains(&0))
                && !out.zero_based_ids
            {
                out.zero_based_ids = true;
                ctx.warn(
                    f.line(),
                    &[field.key().to_string(), f.key().to_string()],
                    "node id 0: this deck uses Peridigm's old 0-based node numbering, so every node-set id list in it is read as 0-based (Peridigm 1.5 rejects such decks)",
                );
            }
            out.node_sets.push(set);
        } else if f.is_list() {
            out.conditions.push(read_condition(ctx, &f)?);
        } else {
            let hint = match super::reader::suggest(f.key(), [RANK_DEFICIENT_KEY]) {
                Some(s) => format!("did you mean \"{s}\"?"),
                None => "boundary conditions are lists with Type, Node Set, Coordinate and Value, and node-set definitions \
                         need \"Node Set\" in their name"
                    .to_string(),
            };
            return Err(f.err(ctx, format!("unknown key; {hint}")));
        }
    }
    Ok(out)
}
