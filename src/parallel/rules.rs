//! What a run on several ranks can do and how it holds its families: the rules `peridyn run`
//! applies before any message is sent and `peridyn check` reports in its run plan.

use crate::backend::Unsupported;
use crate::io::deck::{Deck, PointSource, QuickGridGenerator};

/// Refuses, before any message is sent, what a distributed run cannot do yet besides its
/// solver lists (whose integrators say, `crate::setup::solvers::check_ranks`): contact in a
/// deck with an implicit solver (contact acts only in `Verlet` steps, where [`crate::contact::Contact::on_ranks`]
/// gives every rank the one-rank candidates and forces), materials with history (its
/// staged fields are not exchanged between ranks), and `Pals` (its per-point influence
/// functions need whole families).
pub fn check_distributable(deck: &Deck, ranks: usize) -> Result<(), Unsupported> {
    for material in &deck.materials {
        let declared = crate::material::material_entry(material.model.deck_name())
            .map(|entry| entry.declaration);
        if let Some(declaration) = declared.filter(|d| d.fields.iter().any(|f| f.staged)) {
            return Err(Unsupported(format!(
                "material \"{}\" ({}) on {ranks} ranks is not available: its history fields are not exchanged between ranks yet; run on one rank (threads: `--threads`)",
                material.name, declaration.deck_name
            )));
        }
        if declared == Some(&<crate::material::Pals as crate::material::MaterialKeys>::DECLARATION)
        {
            return Err(Unsupported(format!(
                "material \"{}\" (Pals) on {ranks} ranks is not available: its influence functions are fitted to whole families, which a rank's ghost points do not have; run on one rank (threads: `--threads`)",
                material.name
            )));
        }
    }
    if deck.contact.is_some() {
        if let Some(solver) = deck.solvers.iter().find(|s| s.integrator.is_implicit()) {
            return Err(Unsupported(format!(
                "Contact with solver \"{}\" ({}) on {ranks} ranks is not available (contact on several ranks runs in Verlet steps only); run on one rank",
                solver.name,
                solver.integrator.deck_name()
            )));
        }
    }
    Ok(())
}

/// Why every rank of a distributed run of `deck` holds the global families, if it must.
pub fn global_families_reason(deck: &Deck) -> Option<&'static str> {
    let cylinder = matches!(
        &deck.discretization.source,
        PointSource::PdQuickGrid {
            generator: QuickGridGenerator::TensorProductCylinder { .. },
            ..
        }
    );
    if deck.contact.is_some() {
        Some("the contact search reads the global bonds")
    } else if cylinder {
        Some("the QuickGrid cylinder builds them in index space")
    } else {
        None
    }
}
