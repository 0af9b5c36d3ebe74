//! The surface correction of every block (`Blocks → … → Surface Correction`, default `None`)
//! and the bond weights every material reads: the quadrature volumes of
//! [`super::quadrature`], scaled by the correction's factors
//! ([`crate::model::surface_correction`]) when some block asks for it.

use super::SetupError;
use crate::io::deck::{Block, Deck, DeckError};
use crate::model::surface_correction::{self, SurfaceCorrection};
use crate::model::Model;

/// The correction of the deck block `entry` (`None` when the key is absent). A planar
/// (2-D) material and PdQuickGrid's box-shaped families are refused: the bulk reference is
/// a spherical family in a 3-D lattice.
pub fn block_correction(deck: &Deck, entry: &Block) -> Result<SurfaceCorrection, DeckError> {
    let Some(name) = &entry.surface_correction else {
        return Ok(SurfaceCorrection::None);
    };
    let key = ["Blocks", entry.name.as_str(), "Surface Correction"];
    let correction = SurfaceCorrection::from_deck_name(name)
        .ok_or_else(|| deck.error_at(&key, format!("unknown surface correction \"{name}\"")))?;
    let planar = deck
        .material(&entry.material)
        .and_then(|m| m.planar_thickness())
        .is_some();
    if correction.is_active() && planar {
        return Err(deck.error_at(
            &key,
            format!(
                "\"{}\" compares each point with a 3-D bulk lattice and does not apply to the planar material \"{}\"; remove the key or use a 3-D material",
                correction.name(),
                entry.material
            ),
        ));
    }
    let box_families = matches!(
        deck.discretization.source,
        crate::io::deck::PointSource::PdQuickGrid {
            spherical_neighborhood: false,
            ..
        }
    );
    if correction.is_active() && box_families {
        return Err(deck.error_at(
            &key,
            format!(
                "\"{}\" compares each family with a spherical bulk family, and this PdQuickGrid builds box-shaped families; add `NeighborhoodType: \"Spherical\"` to the Discretization or remove the key",
                correction.name()
            ),
        ));
    }
    Ok(correction)
}

/// The deck blocks with an active surface correction, with the correction (invalid entries
/// are left out: setup reports them).
pub fn corrected_blocks(deck: &Deck) -> Vec<(&str, SurfaceCorrection)> {
    deck.blocks
        .iter()
        .filter_map(|entry| {
            let correction = block_correction(deck, entry).ok()?;
            correction
                .is_active()
                .then_some((entry.name.as_str(), correction))
        })
        .collect()
}

/// The correction of every point of `model` (by its block).
fn point_corrections(deck: &Deck, model: &Model) -> Result<Vec<SurfaceCorrection>, SetupError> {
    let corrections = model
        .blocks
        .iter()
        .map(|block| block_correction(deck, &deck.blocks[block.deck_block]))
        .collect::<Result<Vec<_>, DeckError>>()?;
    Ok(model
        .points
        .block
        .iter()
        .map(|&b| corrections[b as usize])
        .collect())
}

/// The factor g_i of every point and every point's correction (see [`point_factors`]).
pub type PointFactors = (Vec<f64>, Vec<SurfaceCorrection>);

/// The factor g_i of every point (1 outside corrected blocks) and every point's correction,
/// or `None` when no block is corrected. `quadrature` are the bond volumes of
/// [`super::quadrature::bond_volumes`] (`None`: full cell volumes).
pub fn point_factors(
    deck: &Deck,
    model: &Model,
    quadrature: Option<&[f64]>,
) -> Result<Option<PointFactors>, SetupError> {
    let corrections = point_corrections(deck, model)?;
    if !corrections.iter().any(SurfaceCorrection::is_active) {
        return Ok(None);
    }
    let rules = super::quadrature::point_rules(deck, model)?;
    let factors = surface_correction::point_factors(
        &model.bonds,
        &model.points.position,
        crate::model::BondVolumes::new(&model.points.volume, quadrature),
        &corrections,
        &rules,
        &model.horizon,
        &model.points.volume,
    );
    Ok(Some((factors, corrections)))
}

/// The weight w_ij of every bond (global bond index) that the materials read: the
/// quadrature volume, times `(g_i + g_j)/2` when some block has a surface correction; `None`
/// when every block uses the full cell volume without correction (no per-bond array then).
pub fn bond_weights(deck: &Deck, model: &Model) -> Result<Option<Vec<f64>>, SetupError> {
    let quadrature = super::quadrature::bond_volumes(deck, model)?.map(|(weights, _)| weights);
    let Some((factors, _)) = point_factors(deck, model, quadrature.as_deref())? else {
        return Ok(quadrature);
    };
    let bonds = &model.bonds;
    let mut weights = quadrature.unwrap_or_else(|| {
        bonds
            .neighbor
            .iter()
            .map(|&j| model.points.volume[j as usize])
            .collect()
    });
    surface_correction::scale_bond_volumes(bonds, &factors, &mut weights);
    Ok(Some(weights))
}
