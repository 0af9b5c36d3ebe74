//! Isotropic elastic constants from any two of K, μ, E, ν (Peridigm's conversion table), and
//! the reader of the pair in a model's deck list.

use crate::parameter_list::error::DeckError;
use crate::parameter_list::reader::{Ctx, ListReader};

/// The elastic constants a deck may give; exactly two must be `Some` (bond-based: one).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ElasticInput {
    /// `Bulk Modulus` K (pressure units).
    pub bulk_modulus: Option<f64>,
    /// `Shear Modulus` μ (pressure units).
    pub shear_modulus: Option<f64>,
    /// `Young's Modulus` E (pressure units).
    pub youngs_modulus: Option<f64>,
    /// `Poisson's Ratio` ν (dimensionless, −1 < ν < ½).
    pub poissons_ratio: Option<f64>,
}

/// Which 2D assumption changes the bulk modulus (only `Elastic Bond Based` uses it).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum PlanarAssumption {
    /// Full 3D: K = E/(3(1−2ν)).
    #[default]
    None,
    /// `Plane Strain: true`: K = E/(2(1+ν)(1−2ν)).
    PlaneStrain,
    /// `Plane Stress: true`: K = E/(2(1−ν)).
    PlaneStress,
}

/// Bulk and shear modulus of an isotropic material.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ElasticConstants {
    /// Bulk modulus K.
    pub bulk_modulus: f64,
    /// Shear modulus μ.
    pub shear_modulus: f64,
}

impl ElasticConstants {
    /// K and μ from exactly two given constants, with Peridigm's formulas
    /// (`Material::calculateBulkModulus/ShearModulus` in Peridigm's `Peridigm_Material.cpp`):
    ///
    /// | given | K | μ |
    /// |---|---|---|
    /// | K, μ | K | μ |
    /// | E, μ | Eμ/(3(3μ−E)) | μ |
    /// | E, ν | E/(3(1−2ν)) (planar variants above) | E/(2(1+ν)) |
    /// | μ, ν | 2μ(1+ν)/(3(1−2ν)) | μ |
    /// | K, E | K | 3KE/(9K−E) |
    /// | K, ν | K | 3K(1−2ν)/(2(1+ν)) |
    ///
    /// Errors (as text for the deck layer to place) when not exactly two are given or the
    /// result is not positive.
    pub fn from_pair(input: ElasticInput, planar: PlanarAssumption) -> Result<Self, String> {
        let ElasticInput {
            bulk_modulus: k,
            shear_modulus: mu,
            youngs_modulus: e,
            poissons_ratio: nu,
        } = input;
        let given = [k, mu, e, nu].iter().filter(|v| v.is_some()).count();
        if given != 2 {
            return Err(format!(
                "give exactly two of Bulk Modulus, Shear Modulus, Young's Modulus, Poisson's Ratio ({given} given)"
            ));
        }
        let (bulk, shear) = match (k, mu, e, nu) {
            (Some(k), Some(mu), None, None) => (k, mu),
            (None, Some(mu), Some(e), None) => (e * mu / (3.0 * (3.0 * mu - e)), mu),
            (None, None, Some(e), Some(nu)) => {
                let bulk = match planar {
                    PlanarAssumption::None => e / (3.0 * (1.0 - 2.0 * nu)),
                    PlanarAssumption::PlaneStrain => e / (2.0 * (1.0 + nu) * (1.0 - 2.0 * nu)),
                    PlanarAssumption::PlaneStress => e / (2.0 * (1.0 - nu)),
                };
                (bulk, e / (2.0 * (1.0 + nu)))
            }
            (None, Some(mu), None, Some(nu)) => {
                (2.0 * mu * (1.0 + nu) / (3.0 * (1.0 - 2.0 * nu)), mu)
            }
            (Some(k), None, Some(e), None) => (k, 3.0 * k * e / (9.0 * k - e)),
            (Some(k), None, None, Some(nu)) => (k, 3.0 * k * (1.0 - 2.0 * nu) / (2.0 * (1.0 + nu))),
            _ => unreachable!("exactly two constants are present"),
        };
        if !(bulk.is_finite() && bulk > 0.0 && shear.is_finite() && shear > 0.0) {
            return Err(format!(
                "these constants give K = {bulk:e}, μ = {shear:e}; both must be positive (check E < 9K, E < 3μ)"
            ));
        }
        Ok(Self {
            bulk_modulus: bulk,
            shear_modulus: shear,
        })
    }
}

/// The elastic pair of a model's deck list: exactly two of `Bulk Modulus`, `Shear Modulus`,
/// `Young's Modulus`, `Poisson's Ratio` ([`super::keys::ELASTIC`]), as K and μ by Peridigm's
/// 3D conversions ([`ElasticConstants::from_pair`]). Errors name the offending key and line.
pub(crate) fn read(ctx: &Ctx, list: &mut ListReader) -> Result<ElasticConstants, DeckError> {
    let mut given = Vec::new();
    let mut values = [None; 4];
    for (i, key) in super::keys::ELASTIC.iter().enumerate() {
        if let Some(f) = list.get(key.key) {
            let v = if i == 3 {
                let nu = f.f64(ctx)?;
                if !(nu > -1.0 && nu < 0.5) {
                    return Err(f.err(
                        ctx,
                        format!("Poisson's ratio must lie strictly between -1 and 0.5, found {nu}"),
                    ));
                }
                nu
            } else {
                f.positive(ctx)?
            };
            values[i] = Some(v);
            given.push(f);
        }
    }
    if given.len() != 2 {
        let names = given
            .iter()
            .map(|f| format!("\"{}\"", f.key()))
            .collect::<Vec<_>>()
            .join(", ");
        let message = format!(
            "exactly two of \"Bulk Modulus\", \"Shear Modulus\", \"Young's Modulus\", \"Poisson's Ratio\" must be given, found {}{}",
            given.len(),
            if given.is_empty() { String::new() } else { format!(" ({names})") }
        );
        return Err(match given.get(2) {
            Some(third) => third.err(ctx, message),
            None => ctx.error(Some(list.line), &list.path, message),
        });
    }
    let input = ElasticInput {
        bulk_modulus: values[0],
        shear_modulus: values[1],
        youngs_modulus: values[2],
        poissons_ratio: values[3],
    };
    ElasticConstants::from_pair(input, PlanarAssumption::None)
        .map_err(|message| given[1].err(ctx, message))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() <= 1e-12 * b.abs()
    }

    #[test]
    fn every_pair_recovers_the_same_material() {
        // Reference material E = 200, ν = 0.25 → K = E/(3(1−2ν)) = 133.33…, μ = E/(2(1+ν)) = 80.
        let (k, mu, e, nu) = (200.0 / 1.5, 80.0, 200.0, 0.25);
        let pairs = [
            ElasticInput {
                bulk_modulus: Some(k),
                shear_modulus: Some(mu),
                ..Default::default()
            },
            ElasticInput {
                shear_modulus: Some(mu),
                youngs_modulus: Some(e),
                ..Default::default()
            },
            ElasticInput {
                youngs_modulus: Some(e),
                poissons_ratio: Some(nu),
                ..Default::default()
            },
            ElasticInput {
                shear_modulus: Some(mu),
                poissons_ratio: Some(nu),
                ..Default::default()
            },
            ElasticInput {
                bulk_modulus: Some(k),
                youngs_modulus: Some(e),
                ..Default::default()
            },
            ElasticInput {
                bulk_modulus: Some(k),
                poissons_ratio: Some(nu),
                ..Default::default()
            },
        ];
        for input in pairs {
            let c = ElasticConstants::from_pair(input, PlanarAssumption::None).unwrap();
            assert!(
                close(c.bulk_modulus, k) && close(c.shear_modulus, mu),
                "{input:?} → {c:?}"
            );
        }
    }

    #[test]
    fn planar_assumptions_change_only_k() {
        let input = ElasticInput {
            youngs_modulus: Some(1.0),
            poissons_ratio: Some(0.25),
            ..Default::default()
        };
        // Plane strain: 1/(2·1.25·0.5) = 0.8; plane stress: 1/(2·0.75) = 2/3.
        let strain = ElasticConstants::from_pair(input, PlanarAssumption::PlaneStrain).unwrap();
        let stress = ElasticConstants::from_pair(input, PlanarAssumption::PlaneStress).unwrap();
        assert!(close(strain.bulk_modulus, 0.8));
        assert!(close(stress.bulk_modulus, 2.0 / 3.0));
        assert!(close(strain.shear_modulus, 0.4));
    }

    #[test]
    fn wrong_counts_and_impossible_pairs_are_errors() {
        let three = ElasticInput {
            bulk_modulus: Some(1.0),
            shear_modulus: Some(1.0),
            youngs_modulus: Some(1.0),
            poissons_ratio: None,
        };
        assert!(ElasticConstants::from_pair(three, PlanarAssumption::None)
            .unwrap_err()
            .contains("3 given"));
        // E = 3μ makes Eμ/(3(3μ−E)) infinite.
        let bad = ElasticInput {
            shear_modulus: Some(1.0),
            youngs_modulus: Some(3.0),
            ..Default::default()
        };
        assert!(ElasticConstants::from_pair(bad, PlanarAssumption::None).is_err());
    }
}
