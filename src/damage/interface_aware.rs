//! Peridigm's `Interface Aware` damage model (`Peridigm_InterfaceAwareDamageModel.cpp`):
//! critical stretch as a per-point field, so that bonds across the interface of two materials
//! break at the weaker one's limit.
//!
//! # The rule (Peridigm's `InterfaceAwareDamageModel`)
//! * Every point of a block with this model carries its model's `Critical Stretch`; every other
//!   point carries s_c = 0, which means "bonds to me never break".
//! * The bond i→j of a point i of the block (s_c,i > 0) is skipped when it is already broken or
//!   when s_c,j = 0; otherwise it breaks for good (d = 1) once its stretch
//!   `s = (|Y_j − Y_i| − ζ)/ζ` exceeds `min(s_c,i, s_c,j)` (tension only).
//! * The stretch is the same expression as [`CriticalStretch`](super::CriticalStretch)'s, so
//!   i→j and j→i agree bitwise when both ends use this model (their limits are the same
//!   `min`); a bond to a point of a block without damage never breaks from either end.
//!
//! # Rank-deficient points
//! Peridigm's model also lists, after every update, the points whose bond damage sums to at
//! least n_i − 2 (n_i = family size; for 0/1 damage: at most two intact bonds), adds them to the
//! node set `RANK_DEFICIENT_NODES` (all displacement components fixed at zero, so the implicit
//! tangent stays non-singular) and breaks all their bonds. That belongs to an implicit solver:
//! [`rank_deficient_points`] lists such points; it changes nothing.
//!
//! # Thermal strain
//! With a `Thermal Expansion Coefficient` α, in a run with point temperatures, the bond i→j is
//! tested with `s − α ΔT_i` against the same limit (ΔT of point i only, Peridigm's rule).

use std::sync::Arc;

use super::keys::{CRITICAL_STRETCH, THERMAL_EXPANSION};
use super::registry::{BOND_DAMAGE, POINT_CRITICAL_STRETCH};
use super::stretch_kernel::{
    update_stretch_damage, update_thermal_stretch_damage, BondLimit, PairPlan, StretchLimit,
};
use super::{DamageBlock, DamageBuild, DamageError, DamageKeys, DamageModel, DamageParameters};
use crate::model::BondList;
use crate::model::ReferenceView;
use crate::model::{ModelDeclaration, Reach, TangentSupport};
use crate::parameter_list::error::DeckError;
use crate::parameter_list::reader::{Ctx, ListReader};

/// The deck parameters of `Interface Aware`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InterfaceAwareParameters {
    /// `Critical Stretch` s_c of the block's points (> 0).
    pub critical_stretch: f64,
    /// `Thermal Expansion Coefficient` α; default none.
    pub thermal_expansion_coefficient: Option<f64>,
}

impl DamageParameters for InterfaceAwareParameters {
    fn critical_stretch(&self) -> Option<f64> {
        Some(self.critical_stretch)
    }
}

/// The `Interface Aware` damage model of one block.
#[derive(Debug, Clone)]
pub struct InterfaceAware {
    critical_stretch: f64,
    /// s_c of every point of the model (all blocks), 0 for points without this model.
    point_critical_stretch: Arc<[f64]>,
    /// The pair-once loop, once [`DamageModel::prepare`] has made one.
    plan: Option<Arc<PairPlan>>,
    /// `Thermal Expansion Coefficient` α (per degree), when the deck gives one.
    thermal_expansion: Option<f64>,
}

impl DamageKeys for InterfaceAware {
    type Parameters = InterfaceAwareParameters;

    /// `Interface Aware`: a bond's limit reads the critical stretch of both ends, and the rank-deficient rule breaks all bonds of a point from its family's damage: two hops.
    const DECLARATION: ModelDeclaration = ModelDeclaration {
        deck_name: "Interface Aware",
        aliases: &[],
        deck_keys: &[CRITICAL_STRETCH, THERMAL_EXPANSION],
        reach: Reach::TwoHop,
        fields: &[BOND_DAMAGE, POINT_CRITICAL_STRETCH],
        outputs: &["Damage"],
        tangent: TangentSupport::None,
        thermal_strain: true,
        small_displacement: false,
        example: "Critical Stretch: 0.02",
    };

    fn read(ctx: &mut Ctx, list: &mut ListReader) -> Result<InterfaceAwareParameters, DeckError> {
        Ok(InterfaceAwareParameters {
            critical_stretch: list.positive_req(ctx, CRITICAL_STRETCH.key)?,
            thermal_expansion_coefficient: list.f64_opt(ctx, THERMAL_EXPANSION.key)?,
        })
    }
}

impl DamageBuild for InterfaceAware {
    /// With the block's [`POINT_CRITICAL_STRETCH`] field, which the set-up fills for the
    /// models that declare it.
    fn build(
        block: &DamageBlock,
        parameters: &InterfaceAwareParameters,
    ) -> Result<Box<dyn DamageModel>, DamageError> {
        let field = block
            .point_critical_stretch
            .clone()
            .ok_or(DamageError::Missing {
                key: CRITICAL_STRETCH.key,
            })?;
        let mut model = Self::new(parameters.critical_stretch, field)?;
        if let Some(alpha) = parameters.thermal_expansion_coefficient {
            model.set_thermal_expansion(alpha)?;
        }
        Ok(Box::new(model))
    }
}

impl InterfaceAware {
    /// The model of one block with critical stretch `critical_stretch` (`Critical Stretch`,
    /// positive and finite), and the field `point_critical_stretch` of every point of the
    /// model (see [`InterfaceAware::field`]), shared by the blocks that use this model; it
    /// must give this block's points `critical_stretch`, and every entry must be 0 or a
    /// positive finite number.
    pub fn new(
        critical_stretch: f64,
        point_critical_stretch: Arc<[f64]>,
    ) -> Result<Self, DamageError> {
        if !(critical_stretch.is_finite() && critical_stretch > 0.0) {
            return Err(DamageError::NotPositive {
                key: "Critical Stretch",
                value: critical_stretch,
            });
        }
        if let Some(&bad) = point_critical_stretch
            .iter()
            .find(|s| !(s.is_finite() && **s >= 0.0))
        {
            return Err(DamageError::NotPositive {
                key: "Critical Stretch",
                value: bad,
            });
        }
        Ok(Self {
            critical_stretch,
            point_critical_stretch,
            plan: None,
            thermal_expansion: None,
        })
    }

    /// The per-point field of `num_points` points: `critical_stretch` on the points of each
    /// `(points, critical_stretch)` entry (the blocks with an `Interface Aware` model), 0
    /// elsewhere. Later entries win where lists overlap (blocks do not overlap).
    pub fn field<'a>(
        num_points: usize,
        blocks: impl IntoIterator<Item = (&'a [u32], f64)>,
    ) -> Arc<[f64]> {
        let mut field = vec![0.0; num_points];
        for (points, critical_stretch) in blocks {
            for &p in points {
                field[p as usize] = critical_stretch;
            }
        }
        field.into()
    }

    /// This block's critical stretch s_c.
    pub fn critical_stretch(&self) -> f64 {
        self.critical_stretch
    }

    /// The critical stretch of every point (0 = bonds to this point never break).
    pub fn point_critical_stretch(&self) -> &[f64] {
        &self.point_critical_stretch
    }
}

/// min(s_c,i, s_c,j), none when either is 0 (symmetric, as the pair-once loop needs; s_c,i is
/// the block's own value for the block's points).
struct PerPointLimit<'a> {
    field: &'a [f64],
}

impl BondLimit for PerPointLimit<'_> {
    #[inline(always)]
    fn limit(&self, i: usize, j: usize) -> Option<StretchLimit> {
        let (mine, theirs) = (self.field[i], self.field[j]);
        if mine == 0.0 || theirs == 0.0 {
            None
        } else {
            Some(StretchLimit::new(mine.min(theirs)))
        }
    }
}

impl DamageModel for InterfaceAware {
    fn declaration(&self) -> &'static ModelDeclaration {
        &Self::DECLARATION
    }

    fn prepare(&mut self, reference: &ReferenceView<'_>, points: &[u32]) {
        self.plan = PairPlan::new(reference, points).map(Arc::new);
    }

    fn set_thermal_expansion(&mut self, coefficient: f64) -> Result<(), DamageError> {
        self.thermal_expansion = Some(super::finite("Thermal Expansion Coefficient", coefficient)?);
        Ok(())
    }

    fn update_at_temperature(
        &self,
        reference: &ReferenceView<'_>,
        current_position: &[[f64; 3]],
        temperature_change: &[f64],
        points: &[u32],
        bond_damage: &mut [f32],
    ) -> usize {
        let Some(alpha) = self.thermal_expansion else {
            return self.update(reference, current_position, points, bond_damage);
        };
        let limit = PerPointLimit {
            field: &self.point_critical_stretch,
        };
        update_thermal_stretch_damage(
            reference,
            current_position,
            points,
            bond_damage,
            &limit,
            alpha,
            temperature_change,
        )
    }

    fn update(
        &self,
        reference: &ReferenceView<'_>,
        current_position: &[[f64; 3]],
        points: &[u32],
        bond_damage: &mut [f32],
    ) -> usize {
        assert_eq!(
            self.point_critical_stretch.len(),
            current_position.len(),
            "the Interface Aware field must cover every point of the model"
        );
        let limit = PerPointLimit {
            field: &self.point_critical_stretch,
        };
        update_stretch_damage(
            reference,
            current_position,
            points,
            bond_damage,
            &limit,
            self.plan.as_deref(),
        )
    }
}

/// Points of `points` (strictly increasing) whose bond damage sums to at least n_i − 2, where
/// n_i is the family size: with 0/1 damage, points left with at most two intact bonds (points
/// with at most two bonds at all are always listed). This is Peridigm's test for
/// `RANK_DEFICIENT_NODES` in its `Interface Aware` model: such a point's stiffness is singular
/// in at least one direction, so an implicit solver fixes all its displacement components (and
/// Peridigm breaks all its bonds). Returned in the order of `points`.
pub fn rank_deficient_points(bonds: &BondList, bond_damage: &[f32], points: &[u32]) -> Vec<u32> {
    points
        .iter()
        .copied()
        .filter(|&i| {
            let range = bonds.range(i as usize);
            let n = range.len() as f64;
            // Summed in f64 as Peridigm does (its bond damage is double).
            let total: f64 = bond_damage[range].iter().map(|&d| f64::from(d)).sum();
            total >= n - 2.0
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::BondList;

    /// A bar of `n` points on the x axis, spacing 1, families within `horizon`, ζ = |i − j|.
    fn bar(n: usize, horizon: f64) -> (Vec<[f64; 3]>, BondList) {
        let x: Vec<[f64; 3]> = (0..n).map(|i| [i as f64, 0.0, 0.0]).collect();
        let mut bonds = BondList {
            offsets: vec![0],
            ..Default::default()
        };
        for i in 0..n {
            for j in 0..n {
                let zeta = (i as f64 - j as f64).abs();
                if i != j && zeta <= horizon {
                    bonds.neighbor.push(j as u32);
                    bonds.reference_length.push(zeta);
                }
            }
            bonds.offsets.push(bonds.neighbor.len());
        }
        (x, bonds)
    }

    fn bond(bonds: &BondList, i: usize, j: usize) -> usize {
        bonds.offsets[i] + bonds.family(i).binary_search(&(j as u32)).expect("bonded")
    }

    #[test]
    fn two_block_bar_breaks_only_across_the_interface_at_the_smaller_limit() {
        // Bar of 8 points, horizon 1 (nearest neighbours only): block A = points 0..4 with
        // s_c = 0.1, block B = points 4..8 with s_c = 0.3. Bonds inside A are stretched by 5 %
        // (below 0.1), the interface gap 3–4 and the bonds inside B by 20 %. Inside B the limit
        // is min(0.3, 0.3) = 0.3 > 0.2: intact. Across the interface it is min(0.1, 0.3) = 0.1
        // < 0.2: broken, from both ends. (The stretches are 0.05 and 0.2 up to rounding, far
        // from either limit.)
        let (x, bonds) = bar(8, 1.0);
        let reference = ReferenceView {
            bonds: &bonds,
            position: &x,
            volume: &[1.0; 8],
            bond_volume: None,
        };
        let a: Vec<u32> = (0..4).collect();
        let b: Vec<u32> = (4..8).collect();
        let field = InterfaceAware::field(8, [(&a[..], 0.1), (&b[..], 0.3)]);
        let model_a = InterfaceAware::new(0.1, field.clone()).unwrap();
        let model_b = InterfaceAware::new(0.3, field).unwrap();
        // Positions: A spaced 1.05 (s = 0.05), then gaps of 1.2 (s = 0.2) from point 3 on.
        let mut y = vec![[0.0; 3]; 8];
        for i in 1..8 {
            let gap = if i <= 3 { 1.05 } else { 1.2 };
            y[i] = [y[i - 1][0] + gap, 0.0, 0.0];
        }
        let mut d = vec![0.0f32; bonds.num_bonds()];
        let broken_a = model_a.update(&reference, &y, &a, &mut d);
        let broken_b = model_b.update(&reference, &y, &b, &mut d);
        // One pair (3–4), broken from both ends.
        assert_eq!((broken_a, broken_b), (1, 1));
        assert_eq!(d[bond(&bonds, 3, 4)], 1.0);
        assert_eq!(d[bond(&bonds, 4, 3)], 1.0);
        let total: f32 = d.iter().sum();
        assert_eq!(total, 2.0, "only the interface pair breaks: {d:?}");
    }

    #[test]
    fn a_neighbour_without_the_model_never_breaks_and_damage_is_irreversible() {
        // Three points 0–1–2, horizon 1. Points 0 and 1 use the model (s_c = 0.1); point 2 is
        // in a block without it (field 0). Stretch everything by 50 %: bond 0–1 breaks
        // (0.5 > 0.1), bond 1–2 never breaks because s_c,2 = 0 ("never breaks" in Peridigm).
        let (x, bonds) = bar(3, 1.0);
        let reference = ReferenceView {
            bonds: &bonds,
            position: &x,
            volume: &[1.0; 3],
            bond_volume: None,
        };
        let block: Vec<u32> = vec![0, 1];
        let field = InterfaceAware::field(3, [(&block[..], 0.1)]);
        assert_eq!(&field[..], &[0.1, 0.1, 0.0]);
        let model = InterfaceAware::new(0.1, field).unwrap();
        let stretched = vec![[0.0; 3], [1.5, 0.0, 0.0], [3.0, 0.0, 0.0]];
        let mut d = vec![0.0f32; bonds.num_bonds()];
        assert_eq!(model.update(&reference, &stretched, &block, &mut d), 2);
        assert_eq!(d[bond(&bonds, 0, 1)], 1.0);
        assert_eq!(d[bond(&bonds, 1, 0)], 1.0);
        assert_eq!(d[bond(&bonds, 1, 2)], 0.0);
        // Pulled a hundred times its length: still intact.
        let far = vec![[0.0; 3], [1.5, 0.0, 0.0], [100.0, 0.0, 0.0]];
        assert_eq!(model.update(&reference, &far, &block, &mut d), 0);
        assert_eq!(d[bond(&bonds, 1, 2)], 0.0);
        // Back to the reference configuration: the broken pair stays broken.
        assert_eq!(model.update(&reference, &x, &block, &mut d), 0);
        assert_eq!(d[bond(&bonds, 0, 1)], 1.0);
        assert_eq!(d[bond(&bonds, 1, 0)], 1.0);
    }

    #[test]
    fn limit_is_exclusive_as_in_critical_stretch() {
        // ζ = 1, s_c = ¼ on both points: |Y| = 1.25 gives s = 0.25 exactly (binary
        // fractions), not "> s_c"; one ulp more breaks both directions.
        let (x, bonds) = bar(2, 1.0);
        let reference = ReferenceView {
            bonds: &bonds,
            position: &x,
            volume: &[1.0; 2],
            bond_volume: None,
        };
        let all: Vec<u32> = vec![0, 1];
        let model =
            InterfaceAware::new(0.25, InterfaceAware::field(2, [(&all[..], 0.25)])).unwrap();
        let mut d = vec![0.0f32; 2];
        let at = vec![[0.0; 3], [1.25, 0.0, 0.0]];
        assert_eq!(model.update(&reference, &at, &all, &mut d), 0);
        let above = vec![[0.0; 3], [f64::from_bits(1.25f64.to_bits() + 1), 0.0, 0.0]];
        assert_eq!(model.update(&reference, &above, &all, &mut d), 2);
    }

    #[test]
    fn rank_deficient_points_have_at_most_two_intact_bonds() {
        // Bar of 5 points, horizon 2: families of 2, 3, 4, 3, 2 bonds. With nothing broken the
        // end points (2 bonds: Σd = 0 ≥ 2 − 2) are listed, as in Peridigm. Breaking one bond of
        // point 1 (3 bonds → 2 intact) lists it too; point 2 (4 bonds) with one broken has 3
        // intact and is not listed.
        let (_, bonds) = bar(5, 2.0);
        let all: Vec<u32> = (0..5).collect();
        let mut d = vec![0.0f32; bonds.num_bonds()];
        assert_eq!(rank_deficient_points(&bonds, &d, &all), vec![0, 4]);
        d[bond(&bonds, 1, 3)] = 1.0;
        d[bond(&bonds, 2, 0)] = 1.0;
        assert_eq!(rank_deficient_points(&bonds, &d, &all), vec![0, 1, 4]);
        // Only the listed subset is examined.
        assert_eq!(rank_deficient_points(&bonds, &d, &[1, 2]), vec![1]);
    }

    #[test]
    fn rejects_non_positive_critical_stretch() {
        let field: Arc<[f64]> = Arc::from(vec![0.0; 2]);
        assert!(InterfaceAware::new(0.0, field.clone()).is_err());
        let msg = InterfaceAware::new(f64::NAN, field)
            .unwrap_err()
            .to_string();
        assert!(msg.contains("Critical Stretch"), "{msg}");
    }
}

#[cfg(test)]
mod setup_tests {
    use crate::io::deck;
    use crate::setup;

    #[test]
    fn deck_blocks_get_the_field_and_bonds_break_by_the_smaller_limit() {
        // Bar of 9 points (x = 0..8, spacing 1, horizon 1.5: nearest neighbours only) in three
        // blocks: points 0–2 Interface Aware s_c = 0.1, points 3–5 Interface Aware s_c = 0.3,
        // points 6–8 without damage (s_c = 0 in the field). Stretching every gap by 20 %
        // breaks the pairs 0–1 and 1–2 (0.2 > 0.1), the interface 2–3 (min(0.1, 0.3) = 0.1),
        // and nothing else: 3–4 and 4–5 hold (0.2 < 0.3), 5–6 never breaks (s_c,6 = 0),
        // block 3 has no model. Six directed bonds.
        let dir = tempfile::tempdir().unwrap();
        let mesh: Vec<String> = (0..9)
            .map(|k| format!("{k}.0 0.0 0.0 {} 1.0", 1 + k / 3))
            .collect();
        std::fs::write(dir.path().join("mesh.txt"), mesh.join("\n")).unwrap();
        let text = r#"Peridigm:
  Discretization:
    Type: "Text File"
    Input Mesh File: "mesh.txt"
  Materials:
    Soft:
      Material Model: "Elastic Bond Based"
      Density: 1.0
      Bulk Modulus: 1.0
  Damage Models:
    Weak:
      Damage Model: "Interface Aware"
      Critical Stretch: 0.1
    Strong:
      Damage Model: "Interface Aware"
      Critical Stretch: 0.3
  Blocks:
    One:
      Block Names: "block_1"
      Material: "Soft"
      Damage Model: "Weak"
      Horizon: 1.5
    Two:
      Block Names: "block_2"
      Material: "Soft"
      Damage Model: "Strong"
      Horizon: 1.5
    Three:
      Block Names: "block_3"
      Material: "Soft"
      Horizon: 1.5
  Solver:
    Final Time: 1.0
    Verlet:
      Fixed dt: 1.0e-3
"#;
        let path = dir.path().join("deck.yaml");
        std::fs::write(&path, text).unwrap();
        let deck = deck::load(&path).unwrap_or_else(|e| panic!("{e}"));
        assert!(setup::unsupported_features(&deck).is_empty());
        let model = setup::build(&deck).unwrap_or_else(|e| panic!("{e}"));
        let mut physics = setup::build_physics(&deck, &model).unwrap_or_else(|e| panic!("{e}"));
        let names: Vec<Option<&str>> = physics
            .blocks
            .iter()
            .map(|b| b.damage.as_ref().map(|d| d.model_name()))
            .collect();
        assert_eq!(
            names,
            vec![Some("Interface Aware"), Some("Interface Aware"), None]
        );
        let stretched: Vec<[f64; 3]> = model
            .points
            .position
            .iter()
            .map(|x| [1.2 * x[0], x[1], x[2]])
            .collect();
        let mut force = vec![[0.0; 3]; model.points.len()];
        let mut damage = vec![0.0f32; model.bonds.num_bonds()];
        let broken = physics.internal_force(
            &model.bonds,
            &model.points,
            &stretched,
            Some(&mut damage),
            &mut crate::history::History::empty(),
            &mut force,
        );
        assert_eq!(broken, 6);
        let original = |run: usize| model.points.original_id[run] as usize;
        for i in 0..model.points.len() {
            for b in model.bonds.range(i) {
                let j = model.bonds.neighbor[b] as usize;
                let (a, c) = (original(i).min(original(j)), original(i).max(original(j)));
                let expected = if c <= 3 && c == a + 1 { 1.0 } else { 0.0 };
                assert_eq!(damage[b], expected, "bond {a}–{c}");
            }
        }
        // Irreversible: back to the reference configuration, nothing heals or breaks.
        let again = physics.internal_force(
            &model.bonds,
            &model.points,
            &model.points.position.clone(),
            Some(&mut damage),
            &mut crate::history::History::empty(),
            &mut force,
        );
        assert_eq!(again, 0);
        assert_eq!(damage.iter().sum::<f32>(), 6.0);
    }
}
