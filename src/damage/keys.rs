//! The deck keys several damage models share, documented once.

use crate::model::KeyDoc;

/// `Critical Stretch`.
pub const CRITICAL_STRETCH: KeyDoc = KeyDoc {
    key: "Critical Stretch",
    meaning: "s_c: a bond breaks for good once its stretch (|Y| − ζ)/ζ exceeds it",
    unit: "—",
    default: "required",
};

/// `Thermal Expansion Coefficient` of the stretch-based damage models.
pub const THERMAL_EXPANSION: KeyDoc = KeyDoc {
    key: "Thermal Expansion Coefficient",
    meaning: "α: a bond of point i is tested with s − α ΔT_i, ΔT_i the point's temperature \
              change",
    unit: "1/temperature",
    default: "none",
};
