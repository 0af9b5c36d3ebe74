//! `Damage Models` list.

use super::discretization::{read_bond_filter, BondFilter};
use super::error::DeckError;
use super::reader::{Ctx, Field, ListReader};

/// One named damage model (an entry of `Damage Models`).
#[derive(Debug, Clone, PartialEq)]
pub struct DamageModel {
    /// The name of the list; blocks refer to it with `Damage Model`.
    pub name: String,
    /// `Damage Model` and its parameters.
    pub kind: DamageKind,
}

/// How the limit of `Critical Stretch` is given.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum StretchLimit {
    /// `Critical Stretch` s_c (dimensionless).
    Stretch(f64),
    /// `Critical Energy Release Rate` G₀ (energy/area), a peridyn key: each block using the
    /// model gets s_c = √(5G₀/(9Kδ)) with its own bulk modulus K and horizon δ (Silling &
    /// Askari 2005; [`crate::damage::critical_stretch_from_energy_release_rate`]).
    EnergyReleaseRate(f64),
}

/// `Damage Model` and its parameters (Peridigm 1.5 damage-model factory).
#[derive(Debug, Clone, PartialEq)]
pub enum DamageKind {
    /// `"Critical Stretch"`: a bond breaks for good when its stretch
    /// `(|Y| − ζ − α ΔT ζ)/ζ` exceeds `Critical Stretch` (tension only).
    CriticalStretch {
        /// The limit: `Critical Stretch` s_c, or (peridyn's addition) `Critical Energy Release
        /// Rate` G₀ from which s_c is derived per block; exactly one of the two (> 0).
        critical_stretch: StretchLimit,
        /// `Thermal Expansion Coefficient` α; default none (no thermal stretch).
        thermal_expansion_coefficient: Option<f64>,
    },
    /// `"Time Dependent Critical Stretch"`: as Critical Stretch with s_c(t) an expression in `t`.
    TimeDependentCriticalStretch {
        /// `Time Dependent Critical Stretch` — expression in `t` (required; validated later).
        critical_stretch: String,
        /// `Thermal Expansion Coefficient` α; default none.
        thermal_expansion_coefficient: Option<f64>,
    },
    /// `"Interface Aware"`: per-point critical stretch, bond uses the smaller of its two ends.
    InterfaceAware {
        /// `Critical Stretch` (required, > 0).
        critical_stretch: f64,
        /// `Thermal Expansion Coefficient` α; default none.
        thermal_expansion_coefficient: Option<f64>,
    },
    /// `"Initial Damage"`: bonds crossing the filters start broken (d = 1).
    InitialDamage {
        /// `Bond Filters` — `Rectangular_Plane` or `Exodus Mesh` entries (required, ≥ 1).
        bond_filters: Vec<BondFilter>,
    },
    /// `"Johnson Cook"`: bond damage from plastic strain over the failure strain
    /// `ε_f = d₁ + d₂ exp(−d₃ η)` (needs a bond-associated plastic material).
    JohnsonCook {
        /// `Damage Parameter 1`, `Damage Parameter 2`, `Damage Parameter 3` (required).
        damage_parameters: [f64; 3],
        /// `Critical Damage` (required, in (0, 1]).
        critical_damage: f64,
        /// `Threshold Damage` (required, in [0, critical damage)).
        threshold_damage: f64,
        /// `Critical Damage To Neglect Material Point` — default 0.95.
        critical_damage_to_neglect: f64,
    },
    /// `"Von Mises Stress"`: bond damage ramps from 0 at σ_vm/σ_c = threshold to 1 at critical.
    VonMisesStress {
        /// `Critical Von Mises Stress` σ_c (required, > 0).
        critical_von_mises_stress: f64,
        /// `Critical Damage` — default 1.0.
        critical_damage: f64,
        /// `Threshold Damage` — default 0.99.
        threshold_damage: f64,
        /// `Critical Damage To Neglect Material Point` — default 0.95.
        critical_damage_to_neglect: f64,
    },
}

const MODELS: &[&str] = &[
    "Critical Stretch",
    "Time Dependent Critical Stretch",
    "Interface Aware",
    "Initial Damage",
    "Johnson Cook",
    "Von Mises Stress",
];

/// The parameters of all damage models (a model reads its own; the others are ignored with a
/// warning).
const DAMAGE_KEYS: &[&str] = &[
    "Critical Stretch",
    "Critical Energy Release Rate",
    "Time Dependent Critical Stretch",
    "Thermal Expansion Coefficient",
    "Bond Filters",
    "Damage Parameter 1",
    "Damage Parameter 2",
    "Damage Parameter 3",
    "Critical Damage",
    "Threshold Damage",
    "Critical Damage To Neglect Material Point",
    "Critical Von Mises Stress",
];

pub(crate) fn read(ctx: &mut Ctx, field: &Field) -> Result<DamageModel, DeckError> {
    let mut list = field.list(ctx)?;
    let model = list
        .require(ctx, "Damage Model", "the damage law")?
        .choice(ctx, MODELS)?;
    let kind = match model {
        "Critical Stretch" => read_critical_stretch(ctx, &mut list)?,
        "Interface Aware" => {
            let critical_stretch = list.positive_req(ctx, "Critical Stretch")?;
            DamageKind::InterfaceAware {
                critical_stretch,
                thermal_expansion_coefficient: list
                    .f64_opt(ctx, "Thermal Expansion Coefficient")?,
            }
        }
        "Time Dependent Critical Stretch" => DamageKind::TimeDependentCriticalStretch {
            critical_stretch: list
                .require(ctx, "Time Dependent Critical Stretch", "an expression in t")?
                .name(ctx)?,
            thermal_expansion_coefficient: list.f64_opt(ctx, "Thermal Expansion Coefficient")?,
        },
        "Initial Damage" => read_initial_damage(ctx, &mut list)?,
        "Johnson Cook" => read_johnson_cook(ctx, &mut list)?,
        "Von Mises Stress" => read_von_mises_stress(ctx, &mut list)?,
        _ => unreachable!("choice() returns one of MODELS"),
    };
    // Peridigm does not validate damage-model lists, so a deck may carry the parameters of
    // another model (left over after switching models): a warning, not an error.
    let ignored: Vec<(&str, &str)> = DAMAGE_KEYS
        .iter()
        .map(|key| (*key, "a parameter of other damage models, not of this one"))
        .collect();
    list.finish(ctx, &ignored)?;
    Ok(DamageModel {
        name: field.key().to_string(),
        kind,
    })
}

/// `Critical Stretch`: exactly one of `Critical Stretch` and `Critical Energy Release Rate`.
fn read_critical_stretch(ctx: &mut Ctx, list: &mut ListReader) -> Result<DamageKind, DeckError> {
    let stretch = list.positive_opt(ctx, "Critical Stretch")?;
    let energy = list.positive_opt(ctx, "Critical Energy Release Rate")?;
    let critical_stretch =
        match (stretch, energy) {
            (Some(s), None) => StretchLimit::Stretch(s),
            (None, Some(g)) => StretchLimit::EnergyReleaseRate(g),
            _ => return Err(ctx.error(
                Some(list.line),
                &list.path,
                "give exactly one of \"Critical Stretch\" and \"Critical Energy Release Rate\" \
                 (the second derives s_c = sqrt(5 G0 / (9 K horizon)) for each block)",
            )),
        };
    Ok(DamageKind::CriticalStretch {
        critical_stretch,
        thermal_expansion_coefficient: list.f64_opt(ctx, "Thermal Expansion Coefficient")?,
    })
}

/// `Initial Damage`: at least one `Rectangular_Plane` or `Exodus Mesh` bond filter.
fn read_initial_damage(ctx: &mut Ctx, list: &mut ListReader) -> Result<DamageKind, DeckError> {
    let mut filters = list.list_req(ctx, "Bond Filters")?;
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
    Ok(DamageKind::InitialDamage { bond_filters })
}

/// `Johnson Cook`: three damage parameters, 0 ≤ threshold < critical ≤ 1.
fn read_johnson_cook(ctx: &mut Ctx, list: &mut ListReader) -> Result<DamageKind, DeckError> {
    let damage_parameters = [
        list.f64_req(ctx, "Damage Parameter 1")?,
        list.f64_req(ctx, "Damage Parameter 2")?,
        list.f64_req(ctx, "Damage Parameter 3")?,
    ];
    let critical = list.require(ctx, "Critical Damage", "a number in (0, 1]")?;
    let critical_damage = critical.positive(ctx)?;
    if critical_damage > 1.0 {
        return Err(critical.err(ctx, format!("must not exceed 1, found {critical_damage}")));
    }
    let threshold = list.require(ctx, "Threshold Damage", "a number below Critical Damage")?;
    let threshold_damage = threshold.non_negative(ctx)?;
    if threshold_damage >= critical_damage {
        return Err(threshold.err(
            ctx,
            format!("must be smaller than Critical Damage ({critical_damage})"),
        ));
    }
    Ok(DamageKind::JohnsonCook {
        damage_parameters,
        critical_damage,
        threshold_damage,
        critical_damage_to_neglect: list
            .positive_opt(ctx, "Critical Damage To Neglect Material Point")?
            .unwrap_or(0.95),
    })
}

/// `Von Mises Stress`: the critical stress, and threshold < critical damage (defaults 0.99
/// and 1).
fn read_von_mises_stress(ctx: &mut Ctx, list: &mut ListReader) -> Result<DamageKind, DeckError> {
    let critical_von_mises_stress = list.positive_req(ctx, "Critical Von Mises Stress")?;
    let critical_damage = list.positive_opt(ctx, "Critical Damage")?.unwrap_or(1.0);
    let threshold_damage = list
        .non_negative_opt(ctx, "Threshold Damage")?
        .unwrap_or(0.99);
    if threshold_damage >= critical_damage {
        let line = list
            .get("Threshold Damage")
            .or_else(|| list.get("Critical Damage"))
            .map_or(list.line, |f| f.line());
        return Err(ctx.error(
            Some(line),
            &list.path,
            format!("Threshold Damage ({threshold_damage}) must be smaller than Critical Damage ({critical_damage})"),
        ));
    }
    Ok(DamageKind::VonMisesStress {
        critical_von_mises_stress,
        critical_damage,
        threshold_damage,
        critical_damage_to_neglect: list
            .positive_opt(ctx, "Critical Damage To Neglect Material Point")?
            .unwrap_or(0.95),
    })
}

impl DamageKind {
    /// The `Damage Model` string, as written in decks.
    pub fn deck_name(&self) -> &'static str {
        match self {
            DamageKind::CriticalStretch { .. } => "Critical Stretch",
            DamageKind::TimeDependentCriticalStretch { .. } => "Time Dependent Critical Stretch",
            DamageKind::InterfaceAware { .. } => "Interface Aware",
            DamageKind::InitialDamage { .. } => "Initial Damage",
            DamageKind::JohnsonCook { .. } => "Johnson Cook",
            DamageKind::VonMisesStress { .. } => "Von Mises Stress",
        }
    }

    /// The constant critical stretch limit of the models that have one (`Critical Stretch`,
    /// `Interface Aware`); `None` for the others.
    pub fn critical_stretch(&self) -> Option<StretchLimit> {
        match self {
            DamageKind::CriticalStretch {
                critical_stretch, ..
            } => Some(*critical_stretch),
            DamageKind::InterfaceAware {
                critical_stretch, ..
            } => Some(StretchLimit::Stretch(*critical_stretch)),
            _ => None,
        }
    }

    /// The text of `Time Dependent Critical Stretch` (an expression in `t`), when given.
    pub fn critical_stretch_expression(&self) -> Option<&str> {
        match self {
            DamageKind::TimeDependentCriticalStretch {
                critical_stretch, ..
            } => Some(critical_stretch),
            _ => None,
        }
    }

    /// `Thermal Expansion Coefficient` α of the stretch-based models, when given.
    pub fn thermal_expansion_coefficient(&self) -> Option<f64> {
        match self {
            DamageKind::CriticalStretch {
                thermal_expansion_coefficient,
                ..
            }
            | DamageKind::TimeDependentCriticalStretch {
                thermal_expansion_coefficient,
                ..
            }
            | DamageKind::InterfaceAware {
                thermal_expansion_coefficient,
                ..
            } => *thermal_expansion_coefficient,
            _ => None,
        }
    }
}
