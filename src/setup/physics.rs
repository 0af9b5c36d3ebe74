//! Materials and damage models from the deck, one instance per block.

use super::{compile, SetupError};
use crate::model::Model;
use std::sync::Arc;

use crate::damage::{DamageBlock, DamageModel, InterfaceAware, POINT_CRITICAL_STRETCH};
use crate::expression::INFLUENCE;
use crate::io::deck::{Block, Deck, Horizon, InfluenceFunction as DeckInfluence};
use crate::material::{BlockInput, InfluenceFunction, Material, MaterialError, ReferenceView};
use crate::physics::{BlockPhysics, Physics};

fn influence(deck: &Deck) -> Result<InfluenceFunction, SetupError> {
    Ok(match &deck.discretization.influence_function {
        DeckInfluence::One => InfluenceFunction::One,
        DeckInfluence::ParabolicDecay => InfluenceFunction::ParabolicDecay,
        DeckInfluence::Gaussian => InfluenceFunction::Gaussian,
        DeckInfluence::Expression(text) => {
            let expression = compile(
                deck,
                &["Discretization", "Influence Function"],
                text,
                INFLUENCE,
            )?;
            // A failing evaluation yields NaN, which the material rejects with the bond named.
            InfluenceFunction::user(move |zeta, horizon| {
                expression.eval(&[zeta, horizon]).unwrap_or(f64::NAN)
            })
        }
    })
}

/// Builds and sets up the material (and damage model) of every block, each by its registry
/// entry ([`crate::material::MATERIALS`], [`crate::damage::DAMAGE_MODELS`]).
pub fn build_physics(deck: &Deck, model: &Model) -> Result<Physics, SetupError> {
    let bond_volume = super::surface_correction::bond_weights(deck, model)?;
    let reference =
        ReferenceView::of(&model.bonds, &model.points).with_bond_volume(bond_volume.as_deref());
    let influence = influence(deck)?;
    let point_critical_stretch = point_critical_stretch(deck, model);
    let mut blocks = Vec::with_capacity(model.blocks.len());
    for block in &model.blocks {
        let entry = &deck.blocks[block.deck_block];
        let horizon = block_horizon(deck, entry)?;
        let material = build_material(deck, entry, horizon, &influence, &reference, model, block)
            .map_err(|e| name_the_point(e, &model.points.original_id))?;
        let damage = match &entry.damage_model {
            None => None,
            Some(name) => Some(build_damage(
                deck,
                entry,
                name,
                BlockConstants {
                    bulk_modulus: material.bulk_modulus(),
                    horizon,
                },
                &point_critical_stretch,
            )?),
        };
        blocks.push(BlockPhysics { material, damage });
    }
    let mut physics =
        Physics::with_bond_volume(blocks, &model.points, &model.bonds, bond_volume.clone());
    physics.prepare_damage_updates(&model.bonds, &model.points);
    physics.contact = crate::contact::Contact::from_deck(deck, model)?;
    Ok(physics)
}

/// The block's horizon δ; a horizon that varies in space is refused here.
fn block_horizon(deck: &Deck, entry: &Block) -> Result<f64, SetupError> {
    match entry.horizon {
        Horizon::Constant(value) => Ok(value),
        Horizon::Expression(_) => Err(deck
            .error_at(
                &["Blocks", &entry.name, "Horizon"],
                "a horizon that varies in space is not supported by the force kernels yet; give a number",
            )
            .into()),
    }
}

/// The [`POINT_CRITICAL_STRETCH`] field over all points, when some block's damage model
/// declares it: its s_c on the points of those blocks, 0 elsewhere.
fn point_critical_stretch(deck: &Deck, model: &Model) -> Option<Arc<[f64]>> {
    let blocks: Vec<(&[u32], f64)> = model
        .blocks
        .iter()
        .filter_map(|block| {
            let name = deck.blocks[block.deck_block].damage_model.as_ref()?;
            let damage = deck.damage_model(name)?;
            let declares = damage
                .model
                .declaration
                .fields
                .contains(&POINT_CRITICAL_STRETCH);
            let s_c = damage.parameters.critical_stretch()?;
            declares.then_some((&block.points[..], s_c))
        })
        .collect();
    (!blocks.is_empty()).then(|| InterfaceAware::field(model.points.len(), blocks))
}

/// `error` with a point named by its run index renamed by its number in the input (1-based).
fn name_the_point(error: SetupError, original_id: &[u32]) -> SetupError {
    let input_number = |point: usize| original_id.get(point).map_or(point, |&id| id as usize + 1);
    match error {
        SetupError::SingularPoint {
            block,
            error: MaterialError::BondLeavesBlock { model, point },
        } => SetupError::SingularPoint {
            block,
            error: MaterialError::BondLeavesBlock {
                model,
                point: input_number(point),
            },
        },
        SetupError::SingularPoint {
            block,
            error:
                MaterialError::SingularInfluenceSystem {
                    model,
                    point,
                    bonds,
                },
        } => SetupError::SingularPoint {
            block,
            error: MaterialError::SingularInfluenceSystem {
                model,
                point: input_number(point),
                bonds,
            },
        },
        SetupError::SingularPoint {
            block,
            error:
                MaterialError::SingularShapeTensor {
                    point,
                    intact_bonds,
                },
        } => SetupError::SingularPoint {
            block,
            error: MaterialError::SingularShapeTensor {
                point: original_id.get(point).map_or(point, |&id| id as usize + 1),
                intact_bonds,
            },
        },
        other => other,
    }
}

/// The block's material, built by its registry entry and set up on the block's points.
fn build_material(
    deck: &Deck,
    entry: &Block,
    horizon: f64,
    influence: &InfluenceFunction,
    reference: &ReferenceView<'_>,
    model: &Model,
    block: &super::ModelBlock,
) -> Result<Box<dyn Material>, SetupError> {
    let key_material = ["Materials", entry.material.as_str()];
    let Some(material) = deck.material(&entry.material) else {
        return Err(deck
            .error_at(&["Blocks", &entry.name, "Material"], "no such material")
            .into());
    };
    let density = material
        .density
        .ok_or_else(|| deck.error_at(&key_material, "this material needs a Density"))?;
    let input = BlockInput {
        density,
        horizon,
        influence: influence.clone(),
    };
    let Some(built) = material.model.build(&input, &*material.parameters) else {
        return Err(deck
            .error_at(
                &[&key_material[..], &["Material Model"]].concat(),
                format!(
                    "material model \"{}\" is not available in this build",
                    material.model.deck_name()
                ),
            )
            .into());
    };
    let mut built = built.map_err(|e| deck.error_at(&key_material, e.to_string()))?;
    built.input_numbering(&model.points.original_id);
    built
        .setup(reference, block.points.clone())
        .map_err(|e| match e {
            MaterialError::SingularShapeTensor { .. }
            | MaterialError::BondLeavesBlock { .. }
            | MaterialError::SingularInfluenceSystem { .. } => SetupError::SingularPoint {
                block: entry.name.clone(),
                error: e,
            },
            _ => deck.error_at(&key_material, e.to_string()).into(),
        })?;
    if let Some(coefficient) = material.thermal_expansion_coefficient {
        built.set_thermal_expansion(coefficient).map_err(|e| {
            deck.error_at(
                &[&key_material[..], &["Thermal Expansion Coefficient"]].concat(),
                e.to_string(),
            )
        })?;
    }
    // `Tangent` / `Apply Automatic Differentiation Jacobian`; otherwise the model's default.
    if let Some(method) = material.tangent {
        built
            .set_tangent_method(method)
            .map_err(|e| deck.error_at(&key_material, e.to_string()))?;
    }
    Ok(built)
}

/// What a block's damage model may derive its parameters from.
#[derive(Debug, Clone, Copy)]
struct BlockConstants {
    /// The block material's bulk modulus K.
    bulk_modulus: f64,
    /// The block's horizon δ.
    horizon: f64,
}

/// The block's damage model `name`, built by its registry entry.
fn build_damage(
    deck: &Deck,
    entry: &Block,
    name: &str,
    block: BlockConstants,
    point_critical_stretch: &Option<Arc<[f64]>>,
) -> Result<Box<dyn DamageModel>, SetupError> {
    let key = ["Damage Models", name];
    let model = deck.damage_model(name).ok_or_else(|| {
        deck.error_at(
            &["Blocks", &entry.name, "Damage Model"],
            "no such damage model",
        )
    })?;
    let bond_filters = model
        .parameters
        .bond_filters()
        .iter()
        .map(|filter| {
            let key = ["Damage Models", name, "Bond Filters", filter.name.as_str()];
            super::families::build_bond_filter(deck, &key, filter)
        })
        .collect::<Result<Vec<_>, _>>()?;
    let input = DamageBlock {
        bulk_modulus: block.bulk_modulus,
        horizon: block.horizon,
        initial_time: deck.solvers.first().map_or(0.0, |s| s.initial_time),
        point_critical_stretch: point_critical_stretch.clone(),
        bond_filters,
    };
    let Some(built) = model.model.build(&input, &*model.parameters) else {
        return Err(deck
            .error_at(
                &key,
                format!(
                    "damage model \"{}\" (with these options) is not available in this build",
                    model.model.deck_name()
                ),
            )
            .into());
    };
    built.map_err(|e| {
        let place: Vec<&str> = key.iter().copied().chain(e.key()).collect();
        deck.error_at(&place, e.to_string()).into()
    })
}
