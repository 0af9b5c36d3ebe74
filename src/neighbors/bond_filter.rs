//! Bond filters: geometric obstacles (pre-cracks) through which no bond is created.
//!
//! Peridigm's `Discretization → Bond Filters → <name>` with `Type: Rectangular_Plane` or
//! `Type: Disk`. A bond i→j is never created when the straight segment X_i→X_j crosses the
//! object. The geometry follows Peridigm's `PdBondFilter` (checked against its source and the
//! `PrecrackedPlate`, `PrecrackedPlateTwoCracks` and `DiskFilter` regression decks):
//!
//! * the segment meets the object's plane at parameter t ∈ [0, 1] — **endpoints included**, so a
//!   bond that merely touches the plane at one of its points is cut (Peridigm's `t >= 0 && t <= 1`);
//! * a segment parallel to the plane (including one lying in it) is never cut;
//! * rectangle: the hit point must lie in the closed rectangle, widened by Peridigm's 1e-15
//!   edge tolerance ([`EDGE_TOLERANCE`]); disk: strictly inside the circle
//!   (Peridigm's `distance² < radius²`).
//!
//! The test is evaluated with the two endpoints put in a canonical (lexicographic) order, so
//! `cuts(a, b) == cuts(b, a)` holds bit for bit and filtered families stay symmetric.

use thiserror::Error;

/// Why a bond filter from the deck cannot be built.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum BondFilterError {
    /// A coordinate, vector component or length is NaN or infinite.
    #[error("bond filter: {what} must be finite numbers, got {value:?}")]
    NotFinite {
        /// Deck key(s) concerned, e.g. `Normal_X/Y/Z`.
        what: &'static str,
        /// The value given.
        value: Vec<f64>,
    },
    /// The normal vector is (numerically) zero, so no plane is defined.
    #[error("bond filter: the normal (Normal_X/Y/Z) is the zero vector {0:?}; give the plane's normal direction")]
    ZeroNormal([f64; 3]),
    /// The rectangle's normal must be a unit vector (Peridigm scales the side length by its length
    /// without telling; we refuse instead of silently differing or silently agreeing).
    #[error("Rectangular_Plane bond filter: the normal (Normal_X/Y/Z) {normal:?} has length {length}, but a unit vector is required (divide it by its length)")]
    NonUnitNormal {
        /// The normal given.
        normal: [f64; 3],
        /// Its Euclidean length.
        length: f64,
    },
    /// The bottom edge direction has no component in the plane.
    #[error("Rectangular_Plane bond filter: Bottom_Unit_Vector_X/Y/Z {bottom:?} is parallel to the normal {normal:?}; it must point along the rectangle's bottom edge, inside the plane")]
    BottomParallelToNormal {
        /// The bottom vector given.
        bottom: [f64; 3],
        /// The normal given.
        normal: [f64; 3],
    },
    /// The in-plane part of the bottom edge direction is not of unit length.
    #[error("Rectangular_Plane bond filter: Bottom_Unit_Vector_X/Y/Z {bottom:?} has in-plane length {in_plane_length} (its part along the normal is ignored, as in Peridigm), but it must be 1; normalise the vector")]
    NonUnitBottom {
        /// The bottom vector given.
        bottom: [f64; 3],
        /// Length of its component perpendicular to the normal.
        in_plane_length: f64,
    },
    /// A length or radius is zero or negative.
    #[error("bond filter: {what} must be positive, got {value}")]
    NonPositive {
        /// Deck key concerned (`Bottom_Length`, `Side_Length`, `Radius`).
        what: &'static str,
        /// The value given.
        value: f64,
    },
}

/// Relative tolerance on vector lengths checked for being 1 (deck values are typed by hand with
/// a few digits, e.g. 0.7071068 for 1/√2, which is off by 1e-8).
const UNIT_LENGTH_TOLERANCE: f64 = 1e-6;

/// A segment counts as parallel to a plane when its normal component is below this fraction of
/// its length. Peridigm uses an absolute 1e-14 (length units); a relative bound behaves the same
/// for bonds of length ~1e-2…1e2 and does not depend on the mesh units.
const PARALLEL_TOLERANCE: f64 = 1e-12;

/// Tolerance of Peridigm's rectangle edge test (absolute below the lower edges, relative to the
/// length at the upper edges).
pub const EDGE_TOLERANCE: f64 = 1e-15;

/// A finite rectangle that bonds may not cross (Peridigm `Type: Rectangular_Plane`).
///
/// The rectangle is `lower_left_corner + a·bottom_unit_vector + b·side` for a ∈ [0,
/// `bottom_length`], b ∈ [0, `side_length`], where **side = bottom_unit_vector × normal**
/// (Peridigm's `ua = cross(ub, n)`). Example (`PrecrackedPlate`): normal (0,1,0), corner
/// (−10,0,−10), bottom (1,0,0) gives side (0,0,1): the crack covers x ∈ [−10,0], z ∈ [−10,10].
///
/// Build it with [`RectangularPlane::new`], which validates and normalises the input; the fields
/// are public for inspection, and if set directly they must satisfy the same invariants
/// (`normal`, `bottom_unit_vector` unit and perpendicular, lengths positive).
#[derive(Debug, Clone, PartialEq)]
pub struct RectangularPlane {
    /// Unit normal of the plane (`Normal_X/Y/Z`).
    pub normal: [f64; 3],
    /// Corner where the bottom and side edges start (`Lower_Left_Corner_X/Y/Z`, length units).
    pub lower_left_corner: [f64; 3],
    /// Unit direction of the bottom edge, in the plane (`Bottom_Unit_Vector_X/Y/Z` with any
    /// component along the normal removed).
    pub bottom_unit_vector: [f64; 3],
    /// Length of the bottom edge (`Bottom_Length`, length units).
    pub bottom_length: f64,
    /// Length of the side edge, along `bottom_unit_vector × normal` (`Side_Length`).
    pub side_length: f64,
}

impl RectangularPlane {
    /// Validates the deck values and builds the rectangle.
    ///
    /// The normal must be a unit vector (within 1e-6). The bottom vector's component along the
    /// normal is dropped, as Peridigm effectively does (it only ever projects in-plane offsets on
    /// it; Peridigm's own `PrecrackedPlateTwoCracks` deck gives (1, ±4, 0) with normal (0,1,0),
    /// meaning (1,0,0)); what remains must have unit length (within 1e-6) and is renormalised.
    pub fn new(
        normal: [f64; 3],
        lower_left_corner: [f64; 3],
        bottom_unit_vector: [f64; 3],
        bottom_length: f64,
        side_length: f64,
    ) -> Result<Self, BondFilterError> {
        check_finite("Normal_X/Y/Z", &normal)?;
        check_finite("Lower_Left_Corner_X/Y/Z", &lower_left_corner)?;
        check_finite("Bottom_Unit_Vector_X/Y/Z", &bottom_unit_vector)?;
        check_positive("Bottom_Length", bottom_length)?;
        check_positive("Side_Length", side_length)?;
        let length = norm(normal);
        if length == 0.0 {
            return Err(BondFilterError::ZeroNormal(normal));
        }
        if (length - 1.0).abs() > UNIT_LENGTH_TOLERANCE {
            return Err(BondFilterError::NonUnitNormal { normal, length });
        }
        let unit_normal = scale(normal, 1.0 / length);
        let along_normal = dot(bottom_unit_vector, unit_normal);
        let in_plane = sub(bottom_unit_vector, scale(unit_normal, along_normal));
        let in_plane_length = norm(in_plane);
        if in_plane_length <= UNIT_LENGTH_TOLERANCE * norm(bottom_unit_vector) {
            return Err(BondFilterError::BottomParallelToNormal {
                bottom: bottom_unit_vector,
                normal,
            });
        }
        if (in_plane_length - 1.0).abs() > UNIT_LENGTH_TOLERANCE {
            return Err(BondFilterError::NonUnitBottom {
                bottom: bottom_unit_vector,
                in_plane_length,
            });
        }
        Ok(Self {
            normal: unit_normal,
            lower_left_corner,
            bottom_unit_vector: scale(in_plane, 1.0 / in_plane_length),
            bottom_length,
            side_length,
        })
    }

    /// Direction of the side edge, `bottom_unit_vector × normal`.
    pub fn side_unit_vector(&self) -> [f64; 3] {
        cross(self.bottom_unit_vector, self.normal)
    }

    /// True when the closed segment a→b meets the closed rectangle (see the module doc).
    pub fn cuts(&self, a: [f64; 3], b: [f64; 3]) -> bool {
        let Some(hit) = segment_meets_plane(a, b, self.lower_left_corner, self.normal) else {
            return false;
        };
        let offset = sub(hit, self.lower_left_corner);
        let along_bottom = dot(offset, self.bottom_unit_vector);
        let along_side = dot(offset, self.side_unit_vector());
        // Peridigm's edge test (`FinitePlane::bondIntersect`): −ε < s and s/L < 1 + ε with
        // ε = 1e-15, so a crossing that rounds to just below the lower edge still counts
        // (PrecrackedPlateTwoCracks has one such bond, at −4.4e-16).
        let within = |s: f64, length: f64| -EDGE_TOLERANCE < s && s / length < 1.0 + EDGE_TOLERANCE;
        within(along_bottom, self.bottom_length) && within(along_side, self.side_length)
    }
}

/// A disk that bonds may not cross (Peridigm `Type: Disk`).
///
/// Points x of the plane through `center` with normal `normal` and |x − center| < `radius`
/// (strict, as Peridigm).
#[derive(Debug, Clone, PartialEq)]
pub struct Disk {
    /// Centre of the disk (`Center_X/Y/Z`, length units).
    pub center: [f64; 3],
    /// Unit normal of the disk's plane (`Normal_X/Y/Z`, normalised by [`Disk::new`]).
    pub normal: [f64; 3],
    /// Radius (`Radius`, length units).
    pub radius: f64,
}

impl Disk {
    /// Validates the deck values and builds the disk. Any non-zero normal is accepted and
    /// normalised: Peridigm's disk test does not depend on the normal's length.
    pub fn new(center: [f64; 3], normal: [f64; 3], radius: f64) -> Result<Self, BondFilterError> {
        check_finite("Center_X/Y/Z", &center)?;
        check_finite("Normal_X/Y/Z", &normal)?;
        check_positive("Radius", radius)?;
        let length = norm(normal);
        if length == 0.0 {
            return Err(BondFilterError::ZeroNormal(normal));
        }
        Ok(Self {
            center,
            normal: scale(normal, 1.0 / length),
            radius,
        })
    }

    /// True when the closed segment a→b meets the open disk (see the module doc).
    pub fn cuts(&self, a: [f64; 3], b: [f64; 3]) -> bool {
        let Some(hit) = segment_meets_plane(a, b, self.center, self.normal) else {
            return false;
        };
        let offset = sub(hit, self.center);
        dot(offset, offset) < self.radius * self.radius
    }
}

/// One bond filter of the discretization (Peridigm `Bond Filters` entry).
#[derive(Debug, Clone, PartialEq)]
pub enum BondFilter {
    /// `Type: Rectangular_Plane`.
    RectangularPlane(RectangularPlane),
    /// `Type: Disk`.
    Disk(Disk),
}

impl BondFilter {
    /// True when the segment a→b crosses the filter, i.e. the bond a→b must not exist.
    /// Symmetric: `cuts(a, b) == cuts(b, a)`.
    pub fn cuts(&self, a: [f64; 3], b: [f64; 3]) -> bool {
        match self {
            BondFilter::RectangularPlane(plane) => plane.cuts(a, b),
            BondFilter::Disk(disk) => disk.cuts(a, b),
        }
    }

    /// Axis-aligned bounding box (min, max corners) of the filter's surface; a bond whose
    /// bounding box misses it cannot be cut.
    pub fn bounding_box(&self) -> ([f64; 3], [f64; 3]) {
        match self {
            BondFilter::RectangularPlane(p) => {
                let bottom = scale(p.bottom_unit_vector, p.bottom_length);
                let side = scale(p.side_unit_vector(), p.side_length);
                let corners = [
                    p.lower_left_corner,
                    add(p.lower_left_corner, bottom),
                    add(p.lower_left_corner, side),
                    add(add(p.lower_left_corner, bottom), side),
                ];
                let mut lo = corners[0];
                let mut hi = corners[0];
                for c in &corners[1..] {
                    for k in 0..3 {
                        lo[k] = lo[k].min(c[k]);
                        hi[k] = hi[k].max(c[k]);
                    }
                }
                (lo, hi)
            }
            BondFilter::Disk(d) => {
                // Half-extent of a disk along axis k is r·sqrt(1 − n_k²).
                let mut lo = d.center;
                let mut hi = d.center;
                for k in 0..3 {
                    let half = d.radius * (1.0 - d.normal[k] * d.normal[k]).max(0.0).sqrt();
                    lo[k] -= half;
                    hi[k] += half;
                }
                (lo, hi)
            }
        }
    }
}

impl From<RectangularPlane> for BondFilter {
    fn from(plane: RectangularPlane) -> Self {
        BondFilter::RectangularPlane(plane)
    }
}

impl From<Disk> for BondFilter {
    fn from(disk: Disk) -> Self {
        BondFilter::Disk(disk)
    }
}

/// Point where the closed segment a→b meets the plane through `origin` with unit `normal`, or
/// `None` when it does not (or runs parallel to it). The endpoints are ordered canonically first
/// so that the answer, including rounding, is the same for a→b and b→a.
fn segment_meets_plane(
    a: [f64; 3],
    b: [f64; 3],
    origin: [f64; 3],
    normal: [f64; 3],
) -> Option<[f64; 3]> {
    let (p0, p1) = if lexicographic_le(a, b) {
        (a, b)
    } else {
        (b, a)
    };
    let direction = sub(p1, p0);
    let numerator = dot(sub(origin, p0), normal);
    let denominator = dot(direction, normal);
    if denominator.abs() <= PARALLEL_TOLERANCE * norm(direction) || denominator == 0.0 {
        return None;
    }
    let t = numerator / denominator;
    if !(0.0..=1.0).contains(&t) {
        return None;
    }
    Some(add(p0, scale(direction, t)))
}

fn lexicographic_le(a: [f64; 3], b: [f64; 3]) -> bool {
    for k in 0..3 {
        if a[k] != b[k] {
            return a[k] < b[k];
        }
    }
    true
}

fn check_finite(what: &'static str, values: &[f64]) -> Result<(), BondFilterError> {
    if values.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(BondFilterError::NotFinite {
            what,
            value: values.to_vec(),
        })
    }
}

fn check_positive(what: &'static str, value: f64) -> Result<(), BondFilterError> {
    check_finite(what, &[value])?;
    if value > 0.0 {
        Ok(())
    } else {
        Err(BondFilterError::NonPositive { what, value })
    }
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn add(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

fn scale(a: [f64; 3], s: f64) -> [f64; 3] {
    [a[0] * s, a[1] * s, a[2] * s]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn precracked_plate() -> RectangularPlane {
        // Peridigm test/regression/PrecrackedPlate/PrecrackedPlate.xml.
        RectangularPlane::new(
            [0.0, 1.0, 0.0],
            [-10.0, 0.0, -10.0],
            [1.0, 0.0, 0.0],
            10.0,
            20.0,
        )
        .unwrap()
    }

    #[test]
    fn rectangle_orientation_follows_peridigm() {
        let plane = precracked_plate();
        // side = bottom × normal = (1,0,0) × (0,1,0) = (0,0,1) (Peridigm ua = cross(ub, n)).
        assert_eq!(plane.side_unit_vector(), [0.0, 0.0, 1.0]);
        // Crossing y = 0 at (−5, 0, 5): inside x ∈ [−10,0], z ∈ [−10,10] → cut.
        assert!(plane.cuts([-5.0, -0.5, 5.0], [-5.0, 0.5, 5.0]));
        // At z = −15 the hit lies on the side the opposite convention (normal × bottom) would
        // cover, z ∈ [−30,−10] → not cut.
        assert!(!plane.cuts([-5.0, -0.5, -15.0], [-5.0, 0.5, -15.0]));
        // x = +5 is beyond the bottom edge (x ≤ 0).
        assert!(!plane.cuts([5.0, -0.5, 5.0], [5.0, 0.5, 5.0]));
        // Segment not reaching the plane.
        assert!(!plane.cuts([-5.0, 0.1, 5.0], [-5.0, 0.5, 5.0]));
        // Segment in the plane is parallel: never cut.
        assert!(!plane.cuts([-5.0, 0.0, 5.0], [-4.0, 0.0, 5.0]));
    }

    #[test]
    fn endpoint_on_plane_is_cut_both_ways() {
        // Peridigm accepts t = 0 and t = 1, so a bond touching the crack is cut.
        let plane = precracked_plate();
        let on = [-5.0, 0.0, 0.0];
        let off = [-5.0, 1.0, 0.0];
        assert!(plane.cuts(on, off));
        assert!(plane.cuts(off, on));
        // Rectangle edges are closed: hit exactly on the corner x = −10, z = −10.
        assert!(plane.cuts([-10.0, -1.0, -10.0], [-10.0, 1.0, -10.0]));
    }

    #[test]
    fn two_cracks_deck_bottom_vector_is_projected() {
        // Peridigm PrecrackedPlateTwoCracks: Bottom_Unit_Vector (1, 4, 0), normal (0,1,0);
        // in-plane part (1,0,0), unit.
        let plane = RectangularPlane::new(
            [0.0, 1.0, 0.0],
            [0.0, 4.0, -10.0],
            [1.0, 4.0, 0.0],
            10.0,
            20.0,
        )
        .unwrap();
        assert_eq!(plane.bottom_unit_vector, [1.0, 0.0, 0.0]);
        assert!(plane.cuts([5.0, 3.5, 0.0], [5.0, 4.5, 0.0]));
        assert!(!plane.cuts([-5.0, 3.5, 0.0], [-5.0, 4.5, 0.0]));
    }

    #[test]
    fn disk_is_open_and_symmetric() {
        // Peridigm DiskFilter deck: centre 0, normal (0,1,0), radius 2.5.
        let disk = Disk::new([0.0; 3], [0.0, 2.0, 0.0], 2.5).unwrap();
        assert_eq!(disk.normal, [0.0, 1.0, 0.0]);
        assert!(disk.cuts([1.0, -1.0, 1.0], [1.0, 1.0, 1.0]));
        assert!(disk.cuts([1.0, 1.0, 1.0], [1.0, -1.0, 1.0]));
        // Hit at distance exactly 2.5: strict test (Peridigm distance² < radius²) → not cut.
        assert!(!disk.cuts([2.5, -1.0, 0.0], [2.5, 1.0, 0.0]));
        assert!(!disk.cuts([3.0, -1.0, 0.0], [3.0, 1.0, 0.0]));
    }

    #[test]
    fn invalid_input_is_rejected_with_reason() {
        let err = RectangularPlane::new([0.0; 3], [0.0; 3], [1.0, 0.0, 0.0], 1.0, 1.0);
        assert!(matches!(err, Err(BondFilterError::ZeroNormal(_))));
        let err = RectangularPlane::new([0.0, 2.0, 0.0], [0.0; 3], [1.0, 0.0, 0.0], 1.0, 1.0);
        assert!(matches!(err, Err(BondFilterError::NonUnitNormal { .. })));
        let err = RectangularPlane::new([0.0, 1.0, 0.0], [0.0; 3], [0.0, 1.0, 0.0], 1.0, 1.0);
        assert!(matches!(
            err,
            Err(BondFilterError::BottomParallelToNormal { .. })
        ));
        let err = RectangularPlane::new([0.0, 1.0, 0.0], [0.0; 3], [2.0, 0.0, 0.0], 1.0, 1.0);
        assert!(matches!(err, Err(BondFilterError::NonUnitBottom { .. })));
        let err = RectangularPlane::new([0.0, 1.0, 0.0], [0.0; 3], [1.0, 0.0, 0.0], 0.0, 1.0);
        assert!(matches!(
            err,
            Err(BondFilterError::NonPositive {
                what: "Bottom_Length",
                ..
            })
        ));
        let err = RectangularPlane::new([0.0, 1.0, 0.0], [0.0; 3], [1.0, 0.0, 0.0], 1.0, -1.0);
        assert!(matches!(
            err,
            Err(BondFilterError::NonPositive {
                what: "Side_Length",
                ..
            })
        ));
        let err = Disk::new([0.0; 3], [0.0, 1.0, 0.0], 0.0);
        assert!(matches!(
            err,
            Err(BondFilterError::NonPositive { what: "Radius", .. })
        ));
        let err = Disk::new([0.0; 3], [0.0; 3], 1.0);
        assert!(matches!(err, Err(BondFilterError::ZeroNormal(_))));
        let err = Disk::new([f64::NAN, 0.0, 0.0], [0.0, 1.0, 0.0], 1.0);
        assert!(matches!(err, Err(BondFilterError::NotFinite { .. })));
        // Messages name the deck keys.
        let msg = RectangularPlane::new([0.0, 1.0, 0.0], [0.0; 3], [2.0, 0.0, 0.0], 1.0, 1.0)
            .unwrap_err()
            .to_string();
        assert!(msg.contains("Bottom_Unit_Vector"), "{msg}");
    }

    #[test]
    fn bounding_box_contains_filter() {
        let plane = precracked_plate();
        let (lo, hi) = BondFilter::from(plane).bounding_box();
        assert_eq!(lo, [-10.0, 0.0, -10.0]);
        assert_eq!(hi, [0.0, 0.0, 10.0]);
        let disk = Disk::new([1.0, 2.0, 3.0], [0.0, 1.0, 0.0], 2.0).unwrap();
        let (lo, hi) = BondFilter::from(disk).bounding_box();
        assert_eq!(lo, [-1.0, 2.0, 1.0]);
        assert_eq!(hi, [3.0, 2.0, 5.0]);
    }
}
