//! Peridigm's `Initial Damage` damage model: a pre-crack made of broken bonds.
//!
//! At the start of the run every bond of the block whose reference segment X_i→X_j crosses one
//! of the model's `Bond Filters` (`Rectangular_Plane` or `Exodus Mesh`, the geometry of
//! [`crate::neighbors::BondFilter`]) gets bond damage d = 1. Unlike a filter of the
//! `Discretization`, which never creates such bonds, the bonds stay in the families: point
//! `Damage` counts them (a point next to the crack shows the fraction of its bonds that cross
//! it), and they still exclude their two points from contact as bonded pairs.
//!
//! Nothing else ever breaks a bond of the block: as in Peridigm, a block has one damage model,
//! and this one only sets the initial state (the crack does not grow). A bond to another block
//! breaks from both ends (see [`crate::physics::Physics`]).

use super::registry::BOND_DAMAGE;
use super::{DamageBlock, DamageBuild, DamageError, DamageKeys, DamageModel, DamageParameters};
use crate::model::point_chunks::for_each_chunk;
use crate::model::{read_bond_filter, ReferenceView};
use crate::model::{KeyDoc, ModelDeclaration, Reach, TangentSupport};
use crate::neighbors::BondFilter;
use crate::parameter_list::error::DeckError;
use crate::parameter_list::reader::{Ctx, ListReader};

/// `Bond Filters`.
const BOND_FILTERS: KeyDoc = KeyDoc {
    key: "Bond Filters",
    meaning: "a list of `Rectangular_Plane` or `Exodus Mesh` filters: every bond crossing one \
              starts broken",
    unit: "a list",
    default: "required (at least one)",
};

/// The deck parameters of `Initial Damage`.
#[derive(Debug, Clone, PartialEq)]
pub struct InitialDamageParameters {
    /// `Bond Filters`: `Rectangular_Plane` or `Exodus Mesh` entries (at least one).
    pub bond_filters: Vec<crate::model::BondFilter>,
}

impl DamageParameters for InitialDamageParameters {
    fn bond_filters(&self) -> &[crate::model::BondFilter] {
        &self.bond_filters
    }
}

/// The `Initial Damage` model of one block.
#[derive(Debug, Clone)]
pub struct InitialDamage {
    filters: Vec<BondFilter>,
}

impl DamageKeys for InitialDamage {
    type Parameters = InitialDamageParameters;

    /// `Initial Damage`: a bond's damage depends on its own segment alone: one hop.
    const DECLARATION: ModelDeclaration = ModelDeclaration {
        deck_name: "Initial Damage",
        aliases: &[],
        deck_keys: &[BOND_FILTERS],
        reach: Reach::OneHop,
        fields: &[BOND_DAMAGE],
        outputs: &["Damage"],
        tangent: TangentSupport::None,
        thermal_strain: false,
        small_displacement: false,
        example: "Bond Filters:\n  Crack:\n    Type: \"Rectangular_Plane\"\n    Normal_X: 1.0\n    Normal_Y: 0.0\n    Normal_Z: 0.0\n    Lower_Left_Corner_X: 2.5\n    Lower_Left_Corner_Y: -1.0\n    Lower_Left_Corner_Z: 2.5\n    Bottom_Unit_Vector_X: 0.0\n    Bottom_Unit_Vector_Y: 1.0\n    Bottom_Unit_Vector_Z: 0.0\n    Bottom_Length: 4.0\n    Side_Length: 8.0",
    };

    /// At least one `Rectangular_Plane` or `Exodus Mesh` bond filter.
    fn read(ctx: &mut Ctx, list: &mut ListReader) -> Result<InitialDamageParameters, DeckError> {
        let mut filters = list.list_req(ctx, BOND_FILTERS.key)?;
        let mut bond_filters = Vec::new();
        for f in filters.all() {
            bond_filters.push(read_bond_filter(
                ctx,
                &f,
                &["Rectangular_Plane", "Exodus Mesh"],
            )?);
        }
        if bond_filters.is_empty() {
            return Err(ctx.error(
                Some(filters.line),
                &filters.path,
                "Initial Damage needs at least one bond filter",
            ));
        }
        Ok(InitialDamageParameters { bond_filters })
    }
}

impl DamageBuild for InitialDamage {
    /// With the geometry of its bond filters, which the set-up builds from the parameters.
    fn build(
        block: &DamageBlock,
        _parameters: &InitialDamageParameters,
    ) -> Result<Box<dyn DamageModel>, DamageError> {
        if block.bond_filters.is_empty() {
            return Err(DamageError::Missing {
                key: BOND_FILTERS.key,
            });
        }
        Ok(Box::new(Self::new(block.bond_filters.clone())))
    }
}

impl InitialDamage {
    /// The model breaking the bonds that cross any of `filters` (in the reference
    /// configuration).
    pub fn new(filters: Vec<BondFilter>) -> Self {
        Self { filters }
    }
}

impl DamageModel for InitialDamage {
    fn declaration(&self) -> &'static ModelDeclaration {
        &Self::DECLARATION
    }

    fn initialize(&self, reference: &ReferenceView<'_>, points: &[u32], bond_damage: &mut [f32]) {
        let bonds = reference.bonds;
        let position = reference.position;
        let filters = &self.filters;
        for_each_chunk(
            points,
            bond_damage,
            &|i| bonds.offsets[i as usize],
            &|chunk: &[u32], base: usize, out: &mut [f32]| {
                for &i in chunk {
                    let i = i as usize;
                    let a = position[i];
                    for b in bonds.range(i) {
                        let z = position[bonds.neighbor[b] as usize];
                        if filters.iter().any(|f| f.cuts(a, z)) {
                            out[b - base] = 1.0;
                        }
                    }
                }
            },
        );
    }

    fn update(
        &self,
        _reference: &ReferenceView<'_>,
        _current_position: &[[f64; 3]],
        _points: &[u32],
        _bond_damage: &mut [f32],
    ) -> usize {
        0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::damage::point_damage;
    use crate::model::test_support::brute_force_bonds;
    use crate::neighbors::RectangularPlane;

    #[test]
    fn bonds_across_the_plane_start_broken_and_stay_in_the_families() {
        // Four points on the x axis at 0, 1, 2, 3; horizon 1.5 gives the bonds 0–1, 1–2, 2–3.
        // A square in the plane x = 1.5 (normal x, bottom y, side = bottom × normal = −z, so
        // y ∈ [−1, 1], z ∈ [−1, 1] from the corner (1.5, −1, 1)) cuts only 1–2.
        let x: Vec<[f64; 3]> = (0..4).map(|k| [k as f64, 0.0, 0.0]).collect();
        let bonds = brute_force_bonds(&x, 1.5);
        let reference = ReferenceView {
            bonds: &bonds,
            position: &x,
            volume: &[1.0; 4],
            bond_volume: None,
        };
        let plane =
            RectangularPlane::new([1.0, 0.0, 0.0], [1.5, -1.0, 1.0], [0.0, 1.0, 0.0], 2.0, 2.0)
                .unwrap();
        let model = InitialDamage::new(vec![plane.into()]);
        let mut d = vec![0.0f32; bonds.num_bonds()];
        model.initialize(&reference, &[0, 1, 2, 3], &mut d);
        assert_eq!(bonds.num_bonds(), 6, "the families keep every bond");
        let broken: Vec<(usize, u32)> = (0..4)
            .flat_map(|i| bonds.range(i).map(move |b| (i, b)))
            .filter(|&(_, b)| d[b] == 1.0)
            .map(|(i, b)| (i, bonds.neighbor[b]))
            .collect();
        assert_eq!(broken, vec![(1, 2), (2, 1)]);
        // Point Damage: points 1 and 2 have two bonds, one across the plane: ½; the ends none.
        let mut damage = vec![0.0; 4];
        point_damage(&bonds, &d, &[0, 1, 2, 3], &mut damage);
        assert_eq!(damage, vec![0.0, 0.5, 0.5, 0.0]);
        // No later update breaks anything, however far the points move.
        let far: Vec<[f64; 3]> = x.iter().map(|p| [10.0 * p[0], 0.0, 0.0]).collect();
        assert_eq!(model.update(&reference, &far, &[0, 1, 2, 3], &mut d), 0);
        assert_eq!(d.iter().filter(|&&v| v == 1.0).count(), 2);
    }

    #[test]
    fn only_the_rows_of_the_given_points_are_written() {
        let x: Vec<[f64; 3]> = (0..4).map(|k| [k as f64, 0.0, 0.0]).collect();
        let bonds = brute_force_bonds(&x, 1.5);
        let reference = ReferenceView {
            bonds: &bonds,
            position: &x,
            volume: &[1.0; 4],
            bond_volume: None,
        };
        let plane =
            RectangularPlane::new([1.0, 0.0, 0.0], [1.5, -1.0, 1.0], [0.0, 1.0, 0.0], 2.0, 2.0)
                .unwrap();
        let model = InitialDamage::new(vec![plane.into()]);
        let mut d = vec![0.0f32; bonds.num_bonds()];
        // Only point 1's row: its bond to 2 breaks, 2's bond to 1 is another block's business.
        model.initialize(&reference, &[1], &mut d);
        assert_eq!(d.iter().filter(|&&v| v == 1.0).count(), 1);
    }
}
