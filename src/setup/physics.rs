//! Materials and damage models from the deck, one instance per block.

use super::{compile, Model, SetupError};
use crate::damage::{
    critical_stretch_from_energy_release_rate, CriticalStretch, InterfaceAware,
    TimeDependentCriticalStretch,
};
use crate::expression::{INFLUENCE, TIME};
use crate::io::deck::{
    DamageKind, Deck, Horizon, InfluenceFunction as DeckInfluence, MaterialModel, StretchLimit,
};
use crate::material::{
    BondBased, BondBasedParameters, InfluenceFunction, LinearPeridynamicSolid,
    LinearPeridynamicSolidParameters, Material, ReferenceView,
};
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

/// Builds and sets up the material (and damage model) of every block.
pub fn build_physics(deck: &Deck, model: &Model) -> Result<Physics, SetupError> {
    let reference = ReferenceView {
        bonds: &model.bonds,
        position: &model.points.position,
        volume: &model.points.volume,
    };
    let influence = influence(deck)?;
    // `Interface Aware`: one critical-stretch field over all points, s_c on the points of the
    // blocks that use such a model, 0 elsewhere (Peridigm's `Critical_Stretch` field).
    let interface_aware_blocks: Vec<(&[u32], f64)> = model
        .blocks
        .iter()
        .filter_map(|block| {
            let name = deck.blocks[block.deck_block].damage_model.as_ref()?;
            match deck.damage_model(name)?.kind {
                DamageKind::InterfaceAware {
                    critical_stretch, ..
                } => Some((&block.points[..], critical_stretch)),
                _ => None,
            }
        })
        .collect();
    let interface_aware_field = (!interface_aware_blocks.is_empty())
        .then(|| InterfaceAware::field(model.points.len(), interface_aware_blocks));
    let mut blocks = Vec::with_capacity(model.blocks.len());
    for block in &model.blocks {
        let entry = &deck.blocks[block.deck_block];
        let key_material = ["Materials", entry.material.as_str()];
        let Some(material) = deck.material(&entry.material) else {
            return Err(deck
                .error_at(&["Blocks", &entry.name, "Material"], "no such material")
                .into());
        };
        let horizon = match entry.horizon {
            Horizon::Constant(value) => value,
            Horizon::Expression(_) => {
                return Err(deck
                    .error_at(
                        &["Blocks", &entry.name, "Horizon"],
                        "a horizon that varies in space is not supported by the force kernels yet; give a number",
                    )
                    .into())
            }
        };
        let density = material
            .density
            .ok_or_else(|| deck.error_at(&key_material, "this material needs a Density"))?;
        let mut built: Box<dyn Material> = match &material.model {
            MaterialModel::ElasticBondBased { modulus, planar } => {
                let bulk_modulus = modulus.bulk_modulus(planar.map(|(kind, _)| kind));
                let planar_thickness = planar.map(|(_, height)| height);
                Box::new(
                    BondBased::new(BondBasedParameters {
                        density,
                        bulk_modulus,
                        horizon,
                        planar_thickness,
                    })
                    .map_err(|e| deck.error_at(&key_material, e.to_string()))?,
                )
            }
            MaterialModel::Elastic { .. } => {
                let constants = material.elastic.ok_or_else(|| {
                    deck.error_at(&key_material, "Elastic needs two elastic constants")
                })?;
                Box::new(
                    LinearPeridynamicSolid::new(LinearPeridynamicSolidParameters {
                        density,
                        bulk_modulus: constants.bulk_modulus(),
                        shear_modulus: constants.shear_modulus(),
                        horizon,
                        influence: influence.clone(),
                    })
                    .map_err(|e| deck.error_at(&key_material, e.to_string()))?,
                )
            }
            other => {
                return Err(deck
                    .error_at(
                        &[&key_material[..], &["Material Model"]].concat(),
                        format!(
                            "material model \"{}\" is not available in this build",
                            other.deck_name()
                        ),
                    )
                    .into())
            }
        };
        built
            .setup(&reference, block.points.clone())
            .map_err(|e| deck.error_at(&key_material, e.to_string()))?;
        // `Tangent` / `Apply Automatic Differentiation Jacobian`; otherwise the model's default.
        if let Some(method) = material.tangent {
            built
                .set_tangent_method(method)
                .map_err(|e| deck.error_at(&key_material, e.to_string()))?;
        }
        let damage: Option<Box<dyn crate::damage::DamageModel>> = match &entry.damage_model {
            None => None,
            Some(name) => {
                let key = ["Damage Models", name.as_str()];
                let model = deck.damage_model(name).ok_or_else(|| {
                    deck.error_at(
                        &["Blocks", &entry.name, "Damage Model"],
                        "no such damage model",
                    )
                })?;
                match &model.kind {
                    DamageKind::CriticalStretch {
                        critical_stretch,
                        thermal_expansion_coefficient: None,
                    } => {
                        let s_c = match *critical_stretch {
                            StretchLimit::Stretch(s_c) => s_c,
                            StretchLimit::EnergyReleaseRate(g0) => {
                                critical_stretch_from_energy_release_rate(
                                    g0,
                                    built.bulk_modulus(),
                                    horizon,
                                )
                            }
                        };
                        Some(Box::new(
                            CriticalStretch::new(s_c)
                                .map_err(|e| deck.error_at(&key, e.to_string()))?,
                        ))
                    }
                    DamageKind::TimeDependentCriticalStretch {
                        critical_stretch,
                        thermal_expansion_coefficient: None,
                    } => {
                        let key_value = [key[0], key[1], "Time Dependent Critical Stretch"];
                        let expression = compile(deck, &key_value, critical_stretch, TIME)?;
                        let t0 = deck.solvers.first().map_or(0.0, |s| s.initial_time);
                        Some(Box::new(
                            TimeDependentCriticalStretch::new(expression, t0)
                                .map_err(|e| deck.error_at(&key_value, e.to_string()))?,
                        ))
                    }
                    DamageKind::InterfaceAware {
                        critical_stretch,
                        thermal_expansion_coefficient: None,
                    } => {
                        let field = interface_aware_field
                            .clone()
                            .expect("built above for every Interface Aware block");
                        Some(Box::new(
                            InterfaceAware::new(*critical_stretch, field)
                                .map_err(|e| deck.error_at(&key, e.to_string()))?,
                        ))
                    }
                    other => {
                        return Err(deck
                            .error_at(
                                &key,
                                format!("damage model \"{}\" (with these options) is not available in this build", other.deck_name()),
                            )
                            .into())
                    }
                }
            }
        };
        let mut damage = damage;
        if let Some(damage) = &mut damage {
            damage.prepare(&reference, &block.points);
        }
        blocks.push(BlockPhysics {
            material: built,
            damage,
        });
    }
    let mut physics = Physics::new(blocks, &model.points, &model.bonds);
    physics.contact = crate::contact::Contact::from_deck(deck, model)?;
    Ok(physics)
}
