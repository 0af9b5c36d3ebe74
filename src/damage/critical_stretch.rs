//! Peridigm's `Critical Stretch` damage model (`Peridigm_CriticalStretchDamageModel.cpp`): a
//! bond breaks for good (d = 1) once its stretch `s = (|Y_j − Y_i| − ζ)/ζ` exceeds the critical
//! stretch s_c (tension only; compression never breaks a bond).
//!
//! # Both directions of a pair agree
//! Each point updates its own row (a gather, no atomics), so the bonds i→j and j→i are
//! decided by two different tasks. They agree bitwise because the stretch is computed by the
//! same expression from the same two points: `|Y_j − Y_i|` is evaluated from coordinate
//! differences, and IEEE subtraction is exactly antisymmetric (`a − b = −(b − a)`), so both
//! ends square the same numbers, add them in the same order and take the same square root; ζ
//! is the stored reference length, which [`BondList`](crate::model::BondList) guarantees to be
//! the same number in both directions. Damage only ever goes from 0 to 1, and both ends start
//! equal, so they stay equal.
//!
//! Updating each pair once (the pair-once loop of [`DamageModel::prepare`]) therefore takes
//! the same decisions as updating each direction.
//!
//! # Thermal strain
//! With a `Thermal Expansion Coefficient` α, in a run with point temperatures, the bond i→j is
//! tested with `s − α ΔT_i` (ΔT of point i only, Peridigm's rule) by the directed loop; the
//! pair-once loop and the materials' fused passes are not used then.

use std::sync::Arc;

use super::keys::{CRITICAL_STRETCH, THERMAL_EXPANSION};
use super::registry::BOND_DAMAGE;
use super::stretch_kernel::{
    update_stretch_damage, update_thermal_stretch_damage, PairPlan, StretchLimit,
};
use super::{DamageBlock, DamageBuild, DamageError, DamageKeys, DamageModel, DamageParameters};
use crate::model::ReferenceView;
use crate::model::{KeyDoc, ModelDeclaration, Reach, TangentSupport};
use crate::parameter_list::error::DeckError;
use crate::parameter_list::reader::{Ctx, ListReader};

/// `Critical Energy Release Rate` (peridyn's key).
const CRITICAL_ENERGY_RELEASE_RATE: KeyDoc = KeyDoc {
    key: "Critical Energy Release Rate",
    meaning: "G₀, instead of `Critical Stretch`: each block gets s_c = √(5G₀/(9Kδ)) with its \
              own K and δ (Silling & Askari 2005)",
    unit: "energy/area",
    default: "one of the two",
};

/// Critical stretch from the critical energy release rate G₀ (Silling & Askari 2005, "A
/// meshfree method based on the peridynamic model of solid mechanics", Computers & Structures
/// 83, §3): the work to break every PMB bond crossing a unit crack area is
/// `G₀ = π c s₀² δ⁵ / 10`; with `c = 18K/(πδ⁴)` this gives `s₀ = sqrt(5 G₀ / (9 K δ))`.
///
/// Units: G₀ energy/area, K pressure, δ length; s₀ dimensionless.
pub fn critical_stretch_from_energy_release_rate(
    energy_release_rate: f64,
    bulk_modulus: f64,
    horizon: f64,
) -> f64 {
    (5.0 * energy_release_rate / (9.0 * bulk_modulus * horizon)).sqrt()
}

/// How a deck gives the limit of `Critical Stretch`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CriticalStretchLimit {
    /// `Critical Stretch` s_c (dimensionless).
    Stretch(f64),
    /// `Critical Energy Release Rate` G₀ (energy/area), a peridyn key: each block using the
    /// model gets s_c = √(5G₀/(9Kδ)) with its own bulk modulus K and horizon δ
    /// ([`critical_stretch_from_energy_release_rate`]).
    EnergyReleaseRate(f64),
}

/// The deck parameters of `Critical Stretch`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CriticalStretchParameters {
    /// The limit: exactly one of `Critical Stretch` and `Critical Energy Release Rate` (> 0).
    pub limit: CriticalStretchLimit,
    /// `Thermal Expansion Coefficient` α; default none (no thermal stretch).
    pub thermal_expansion_coefficient: Option<f64>,
}

impl DamageParameters for CriticalStretchParameters {
    fn critical_stretch(&self) -> Option<f64> {
        match self.limit {
            CriticalStretchLimit::Stretch(s_c) => Some(s_c),
            CriticalStretchLimit::EnergyReleaseRate(_) => None,
        }
    }
}

/// The `Critical Stretch` damage model of one block.
#[derive(Debug, Clone)]
pub struct CriticalStretch {
    critical_stretch: f64,
    /// The pair-once loop, once [`DamageModel::prepare`] has made one.
    plan: Option<Arc<PairPlan>>,
    /// `Thermal Expansion Coefficient` α (per degree), when the deck gives one.
    thermal_expansion: Option<f64>,
}

impl DamageKeys for CriticalStretch {
    type Parameters = CriticalStretchParameters;

    /// `Critical Stretch`: a bond breaks on its own stretch alone, so the rule reaches one hop.
    const DECLARATION: ModelDeclaration = ModelDeclaration {
        deck_name: "Critical Stretch",
        aliases: &[],
        deck_keys: &[
            KeyDoc {
                default: "one of the two",
                ..CRITICAL_STRETCH
            },
            CRITICAL_ENERGY_RELEASE_RATE,
            THERMAL_EXPANSION,
        ],
        reach: Reach::OneHop,
        fields: &[BOND_DAMAGE],
        outputs: &["Damage"],
        tangent: TangentSupport::None,
        thermal_strain: true,
        small_displacement: false,
        example: "Critical Stretch: 0.02",
    };

    /// Exactly one of `Critical Stretch` and `Critical Energy Release Rate`.
    fn read(ctx: &mut Ctx, list: &mut ListReader) -> Result<CriticalStretchParameters, DeckError> {
        let stretch = list.positive_opt(ctx, CRITICAL_STRETCH.key)?;
        let energy = list.positive_opt(ctx, CRITICAL_ENERGY_RELEASE_RATE.key)?;
        let limit = match (stretch, energy) {
            (Some(s), None) => CriticalStretchLimit::Stretch(s),
            (None, Some(g)) => CriticalStretchLimit::EnergyReleaseRate(g),
            _ => {
                return Err(ctx.error(
                    Some(list.line),
                    &list.path,
                    "give exactly one of \"Critical Stretch\" and \"Critical Energy Release \
                     Rate\" (the second derives s_c = sqrt(5 G0 / (9 K horizon)) for each block)",
                ))
            }
        };
        Ok(CriticalStretchParameters {
            limit,
            thermal_expansion_coefficient: list.f64_opt(ctx, THERMAL_EXPANSION.key)?,
        })
    }
}

impl DamageBuild for CriticalStretch {
    fn build(
        block: &DamageBlock,
        parameters: &CriticalStretchParameters,
    ) -> Result<Box<dyn DamageModel>, DamageError> {
        let s_c = match parameters.limit {
            CriticalStretchLimit::Stretch(s_c) => s_c,
            CriticalStretchLimit::EnergyReleaseRate(g0) => {
                critical_stretch_from_energy_release_rate(g0, block.bulk_modulus, block.horizon)
            }
        };
        let mut model = Self::new(s_c)?;
        if let Some(alpha) = parameters.thermal_expansion_coefficient {
            model.set_thermal_expansion(alpha)?;
        }
        Ok(Box::new(model))
    }
}

impl CriticalStretch {
    /// Model with critical stretch s_c (`Critical Stretch`, positive and finite).
    pub fn new(critical_stretch: f64) -> Result<Self, DamageError> {
        if critical_stretch.is_finite() && critical_stretch > 0.0 {
            Ok(Self {
                critical_stretch,
                plan: None,
                thermal_expansion: None,
            })
        } else {
            Err(DamageError::NotPositive {
                key: "Critical Stretch",
                value: critical_stretch,
            })
        }
    }

    /// The critical stretch s_c.
    pub fn critical_stretch(&self) -> f64 {
        self.critical_stretch
    }

    /// Replaces s_c by an already validated value (time-dependent limits), keeping the plan.
    pub(super) fn set_critical_stretch(&mut self, other: &CriticalStretch) {
        self.critical_stretch = other.critical_stretch;
    }

    /// True once [`DamageModel::prepare`] has made a pair-once plan.
    pub fn is_prepared(&self) -> bool {
        self.plan.is_some()
    }
}

impl DamageModel for CriticalStretch {
    fn declaration(&self) -> &'static ModelDeclaration {
        &Self::DECLARATION
    }

    fn prepare(&mut self, reference: &ReferenceView<'_>, points: &[u32]) {
        self.plan = PairPlan::new(reference, points).map(Arc::new);
    }

    /// Only without thermal expansion: the fused passes test the stretch without ΔT.
    fn fusable_critical_stretch(&self) -> Option<f64> {
        self.thermal_expansion
            .is_none()
            .then_some(self.critical_stretch)
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
        match self.thermal_expansion {
            None => self.update(reference, current_position, points, bond_damage),
            Some(alpha) => update_thermal_stretch_damage(
                reference,
                current_position,
                points,
                bond_damage,
                &StretchLimit::new(self.critical_stretch),
                alpha,
                temperature_change,
            ),
        }
    }

    fn update(
        &self,
        reference: &ReferenceView<'_>,
        current_position: &[[f64; 3]],
        points: &[u32],
        bond_damage: &mut [f32],
    ) -> usize {
        update_stretch_damage(
            reference,
            current_position,
            points,
            bond_damage,
            &StretchLimit::new(self.critical_stretch),
            self.plan.as_deref(),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::damage::point_damage;
    use crate::model::test_support::{brute_force_bonds, random_cloud, Rng};
    use crate::model::BondList;

    fn two_points() -> (Vec<[f64; 3]>, Vec<f64>, BondList) {
        let x = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]];
        let bonds = brute_force_bonds(&x, 1.5);
        (x, vec![1.0, 1.0], bonds)
    }

    #[test]
    fn breaks_only_above_critical_stretch_and_never_heals() {
        // ζ = 1, s_c = ¼: Y_1 = (1.25, 0, 0) gives |Y| = 1.25 and s = 0.25/1 = s_c exactly (all
        // values are binary fractions), which is not "> s_c": the bond stays intact.
        let (x, v, bonds) = two_points();
        let reference = ReferenceView {
            bonds: &bonds,
            position: &x,
            volume: &v,
            bond_volume: None,
        };
        let model = CriticalStretch::new(0.25).unwrap();
        let mut d = vec![0.0f32; bonds.num_bonds()];
        let at = vec![[0.0, 0.0, 0.0], [1.25, 0.0, 0.0]];
        assert_eq!(model.update(&reference, &at, &[0, 1], &mut d), 0);
        assert_eq!(d, vec![0.0, 0.0]);
        // Next representable length above 1.25: s exceeds s_c by one ulp → both ends break.
        let above = vec![
            [0.0, 0.0, 0.0],
            [f64::from_bits(1.25f64.to_bits() + 1), 0.0, 0.0],
        ];
        assert_eq!(model.update(&reference, &above, &[0, 1], &mut d), 2);
        assert_eq!(d, vec![1.0, 1.0]);
        // Back to the reference configuration: broken bonds stay broken.
        assert_eq!(model.update(&reference, &x, &[0, 1], &mut d), 0);
        assert_eq!(d, vec![1.0, 1.0]);
        // Point damage = broken/total = 1/1.
        let mut damage = vec![0.0; 2];
        point_damage(&bonds, &d, &[0, 1], &mut damage);
        assert_eq!(damage, vec![1.0, 1.0]);
    }

    #[test]
    fn with_thermal_expansion_a_bond_breaks_when_s_minus_alpha_delta_t_exceeds_s_c() {
        // ζ = 1, s = 0.03, s_c = 0.02, α = 1e-4. The bond i→j is tested with s − αΔT_i:
        // ΔT = 150 gives 0.015 (intact), ΔT = 50 gives 0.025 (breaks), ΔT = 0 gives 0.03
        // (breaks, as without thermal strain). Margins of 5e-3 dwarf any rounding.
        let (x, v, bonds) = two_points();
        let reference = ReferenceView {
            bonds: &bonds,
            position: &x,
            volume: &v,
            bond_volume: None,
        };
        let mut model = CriticalStretch::new(0.02).unwrap();
        model.set_thermal_expansion(1e-4).unwrap();
        // The fused passes of the materials do not know ΔT: the model declines them.
        assert_eq!(model.fusable_critical_stretch(), None);
        let y = vec![[0.0, 0.0, 0.0], [1.03, 0.0, 0.0]];
        let mut d = vec![0.0f32; 2];
        let hot = [150.0, 150.0];
        assert_eq!(
            model.update_at_temperature(&reference, &y, &hot, &[0, 1], &mut d),
            0
        );
        assert_eq!(d, vec![0.0, 0.0]);
        // ΔT of point i alone decides bond i→j (Peridigm): the cooler end's bond breaks first.
        let mixed = [150.0, 50.0];
        assert_eq!(
            model.update_at_temperature(&reference, &y, &mixed, &[0, 1], &mut d),
            1
        );
        assert_eq!(d, vec![0.0, 1.0]);
        let warm = [50.0, 50.0];
        assert_eq!(
            model.update_at_temperature(&reference, &y, &warm, &[0, 1], &mut d),
            1
        );
        assert_eq!(d, vec![1.0, 1.0]);
        // Without point temperatures the thermal term is absent: s = 0.03 > s_c.
        let mut plain = vec![0.0f32; 2];
        assert_eq!(model.update(&reference, &y, &[0, 1], &mut plain), 2);
        // A cooled bond at rest breaks on thermal strain alone: s − αΔT = 0 + 0.025 > s_c.
        let mut cold = vec![0.0f32; 2];
        let at_rest =
            model.update_at_temperature(&reference, &x, &[-250.0, -250.0], &[0, 1], &mut cold);
        assert_eq!(at_rest, 2);
        assert!(model.set_thermal_expansion(f64::INFINITY).is_err());
    }

    #[test]
    fn compression_never_breaks() {
        // s = (0.1 − 1)/1 = −0.9, far below any positive s_c.
        let (x, v, bonds) = two_points();
        let reference = ReferenceView {
            bonds: &bonds,
            position: &x,
            volume: &v,
            bond_volume: None,
        };
        let mut d = vec![0.0f32; 2];
        let squeezed = vec![[0.0, 0.0, 0.0], [0.1, 0.0, 0.0]];
        let model = CriticalStretch::new(1e-6).unwrap();
        assert_eq!(model.update(&reference, &squeezed, &[0, 1], &mut d), 0);
    }

    #[test]
    fn both_directions_of_every_pair_agree() {
        // Random cloud, displacements of the order of s_c·ζ so that roughly half the bonds
        // break; every pair must be broken from both ends or from neither.
        let mut rng = Rng::new(7);
        let (x, v) = random_cloud(&mut rng, 400, 4.0);
        let bonds = brute_force_bonds(&x, 1.2);
        let reference = ReferenceView {
            bonds: &bonds,
            position: &x,
            volume: &v,
            bond_volume: None,
        };
        let y: Vec<[f64; 3]> = x
            .iter()
            .map(|p| [p[0] + 0.05 * rng.normal(), p[1] + 0.05 * rng.normal(), p[2]])
            .collect();
        let model = CriticalStretch::new(0.02).unwrap();
        let mut d = vec![0.0f32; bonds.num_bonds()];
        let points: Vec<u32> = (0..x.len() as u32).collect();
        let broken = model.update(&reference, &y, &points, &mut d);
        assert!(broken > 0 && broken < bonds.num_bonds(), "{broken}");
        assert_eq!(broken % 2, 0, "pairs break together");
        for i in 0..x.len() {
            for b in bonds.range(i) {
                let j = bonds.neighbor[b] as usize;
                let back = bonds
                    .range(j)
                    .find(|&c| bonds.neighbor[c] as usize == i)
                    .expect("symmetric families");
                assert_eq!(d[b], d[back], "bond {i}→{j}");
            }
        }
        // Point damage of point 0 = its broken fraction.
        let mut damage = vec![0.0; x.len()];
        point_damage(&bonds, &d, &points, &mut damage);
        let row = &d[bonds.range(0)];
        let expected = row.iter().filter(|&&b| b == 1.0).count() as f64 / row.len() as f64;
        assert!((damage[0] - expected).abs() < 1e-15);
    }

    #[test]
    fn energy_release_rate_conversion() {
        // s₀ = sqrt(5·G₀/(9·K·δ)) with G₀ = 9, K = 5, δ = 1 → sqrt(45/45) = 1.
        assert!((critical_stretch_from_energy_release_rate(9.0, 5.0, 1.0) - 1.0).abs() < 1e-15);
        // Consistency with G₀ = π c s₀² δ⁵/10, c = 18K/(πδ⁴), for K = 2e9, δ = 3e-3, G₀ = 100.
        let (g0, k, delta) = (100.0, 2e9, 3e-3);
        let s0 = critical_stretch_from_energy_release_rate(g0, k, delta);
        let c = 18.0 * k / (std::f64::consts::PI * delta.powi(4));
        let g_back = std::f64::consts::PI * c * s0 * s0 * delta.powi(5) / 10.0;
        assert!((g_back - g0).abs() < 1e-12 * g0);
    }

    #[test]
    fn rejects_non_positive_critical_stretch() {
        assert!(CriticalStretch::new(0.0).is_err());
        assert!(CriticalStretch::new(f64::NAN).is_err());
        let msg = CriticalStretch::new(-1.0).unwrap_err().to_string();
        assert!(msg.contains("Critical Stretch"), "{msg}");
    }
}
