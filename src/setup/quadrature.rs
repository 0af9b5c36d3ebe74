//! The quadrature rule of every block (`Blocks → … → Quadrature`, else Peridigm's
//! `Element-Horizon Intersection Partial Volume Scheme`, else `Exact` for a `Linear LPS Partial
//! Volume` material that asks for partial volumes, else full volume), the family reach
//! the rules need, and the per-bond quadrature volumes ([`crate::model::quadrature`]).

use super::SetupError;
use crate::io::deck::{Block, Deck};
use crate::model::quadrature::{self, QuadratureRule, QuadratureSummary};
use crate::model::Model;

/// The rule of the deck block `entry`: its `Quadrature`, else the Peridigm scheme of the
/// `Discretization`, else `Exact` when its material asks for partial volumes (`Linear LPS
/// Partial Volume` with `Use Partial Volume` or `Use Improved Quadrature`), else full volume.
pub fn block_rule(deck: &Deck, entry: &Block) -> Result<QuadratureRule, SetupError> {
    let tolerance = entry
        .quadrature_tolerance
        .unwrap_or(quadrature::DEFAULT_ADAPTIVE_TOLERANCE);
    let rule = match &entry.quadrature {
        Some(name) => QuadratureRule::from_deck_name(name, tolerance).ok_or_else(|| {
            deck.error_at(
                &["Blocks", &entry.name, "Quadrature"],
                format!("unknown quadrature rule \"{name}\""),
            )
        })?,
        None => peridigm_scheme(deck).unwrap_or_else(|| {
            // `Linear LPS Partial Volume` with `Use Partial Volume` / `Use Improved Quadrature`
            // asks for partial volumes without naming a rule: the exact cell∩sphere volumes,
            // Peridigm's own `PV` scheme.
            let asks = deck
                .material(&entry.material)
                .is_some_and(|m| m.asks_for_partial_volumes());
            if asks {
                QuadratureRule::Exact
            } else {
                QuadratureRule::default()
            }
        }),
    };
    if entry.quadrature_tolerance.is_some() && !matches!(rule, QuadratureRule::Adaptive { .. }) {
        return Err(deck
            .error_at(
                &["Blocks", &entry.name, "Quadrature Tolerance"],
                format!(
                    "the tolerance applies to Quadrature \"Adaptive\" only, and this block's rule is \"{}\"; remove it or set Quadrature: \"Adaptive\"",
                    rule.name()
                ),
            )
            .into());
    }
    Ok(rule)
}

/// The rule of `Discretization → Element-Horizon Intersection Partial Volume Scheme`, when
/// the deck gives one (Peridigm reads it only with `Compute Element-Horizon Intersections`).
fn peridigm_scheme(deck: &Deck) -> Option<QuadratureRule> {
    let crate::io::deck::PointSource::Exodus {
        element_horizon_intersections: Some(intersections),
        ..
    } = &deck.discretization.source
    else {
        return None;
    };
    QuadratureRule::from_peridigm_scheme(intersections.scheme.as_deref()?)
}

/// The deck blocks whose rule reaches past the horizon (HHB, exact, adaptive), with the rule.
pub fn widening_blocks(deck: &Deck) -> Vec<(&str, QuadratureRule)> {
    deck.blocks
        .iter()
        .filter_map(|entry| {
            let rule = block_rule(deck, entry).ok()?;
            (rule.family_reach(1.0, 1.0) > 1.0).then_some((entry.name.as_str(), rule))
        })
        .collect()
}

/// The rule of every point of `model` (by its block).
pub(super) fn point_rules(deck: &Deck, model: &Model) -> Result<Vec<QuadratureRule>, SetupError> {
    let rules = model
        .blocks
        .iter()
        .map(|block| block_rule(deck, &deck.blocks[block.deck_block]))
        .collect::<Result<Vec<_>, _>>()?;
    Ok(model
        .points
        .block
        .iter()
        .map(|&b| rules[b as usize])
        .collect())
}

/// The radius each point's family search needs: its horizon δ, widened by its block's rule
/// (δ + Δx/2 for HHB, δ + √3/2·Δx for exact and adaptive, Δx = V^{1/3} of the point), or
/// `None` when no rule widens any family.
pub fn search_horizons(deck: &Deck, model: &Model) -> Result<Option<Vec<f64>>, SetupError> {
    let rules = point_rules(deck, model)?;
    let widened: Vec<f64> = (0..model.points.len())
        .map(|p| rules[p].family_reach(model.horizon[p], model.points.volume[p].cbrt()))
        .collect();
    Ok((widened != model.horizon).then_some(widened))
}

/// The per-bond quadrature volumes of `model` (global bond index) with what they cost in
/// accuracy, or `None` when every block uses the full volume.
pub fn bond_volumes(
    deck: &Deck,
    model: &Model,
) -> Result<Option<(Vec<f64>, QuadratureSummary)>, SetupError> {
    let rules = point_rules(deck, model)?;
    if rules.iter().all(QuadratureRule::is_full_volume) {
        return Ok(None);
    }
    for block in &model.blocks {
        let entry = &deck.blocks[block.deck_block];
        if let crate::io::deck::Horizon::Expression(_) = entry.horizon {
            if !block_rule(deck, entry)?.is_full_volume() {
                return Err(deck
                    .error_at(
                        &["Blocks", &entry.name, "Quadrature"],
                        "partial-volume rules need a constant horizon; give the Horizon as a number or use Quadrature: \"Full Volume\"",
                    )
                    .into());
            }
        }
    }
    Ok(quadrature::bond_volumes(
        &model.bonds,
        &model.points.position,
        &model.points.volume,
        &rules,
        &model.horizon,
    ))
}
