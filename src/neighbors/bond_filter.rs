//! Bond filters: geometric obstacles (pre-cracks) through which no bond is created.
//!
//! Peridigm's `Discretization → Bond Filters → <name>` with `Type: Rectangular_Plane`,
//! `Type: Disk` or `Type: Exodus Mesh` (a surface of triangles, [`TriangleMesh`]). A bond i→j
//! is never created when the straight segment X_i→X_j crosses the object. The `Initial
//! Damage` damage model uses the same geometry to mark bonds broken instead. The geometry follows Peridigm's `PdBondFilter` (checked against its source and the
//! `PrecrackedPlate`, `PrecrackedPlateTwoCracks` and `DiskFilter` regression decks):
//!
//! * the segment meets the object's plane at parameter t ∈ [0, 1] — **endpoints included**, so a
//!   bond that merely touches the plane at one of its points is cut (Peridigm's `t >= 0 && t <= 1`);
//! * a segment parallel to the plane (including one lying in it) is never cut;
//! * rectangle: the hit point must lie in the closed rectangle, widened by Peridigm's 1e-15
//!   edge tolerance ([`EDGE_TOLERANCE`]); disk: strictly inside the circle
//!   (Peridigm's `distance² < radius²`); triangle: the hit point must lie in the closed
//!   triangle, widened by [`TRIANGLE_TOLERANCE`] in barycentric coordinates (see
//!   [`Triangle::cuts`]).
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
    /// A shell mesh has no face with a non-zero area.
    #[error("Exodus Mesh bond filter: the mesh has no triangle or quadrilateral face with a non-zero area")]
    NoFaces,
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

/// Widening of a [`Triangle`] in barycentric coordinates (dimensionless): the hit point counts
/// as inside when each barycentric coordinate is ≥ −1e-12 (Peridigm's `TriangleFilter` widens
/// by its own tolerance in the same way). Two faces that share an edge compute the same edge
/// point from different corners; their rounding differs by a few units in the 16th digit for
/// faces of reasonable shape, so with this margin a segment through a shared edge or vertex is
/// cut by at least one of the faces and never slips between them.
pub const TRIANGLE_TOLERANCE: f64 = 1e-12;

/// One triangular face of a shell mesh (a face of an `Exodus Mesh` bond filter).
///
/// A segment a→b is cut when it meets the face's plane at a parameter t ∈ [0, 1] (endpoints
/// included, segments parallel to the plane never cut — the rule of the other filters, with
/// the same canonical ordering of the endpoints) and the hit point lies in the closed triangle
/// widened by [`TRIANGLE_TOLERANCE`] in barycentric coordinates.
#[derive(Debug, Clone, PartialEq)]
pub struct Triangle {
    /// Corners v0, v1, v2 (length units).
    pub vertices: [[f64; 3]; 3],
    /// Unit normal (v1 − v0) × (v2 − v0), normalised.
    pub normal: [f64; 3],
    /// Gram matrix of the edges e1 = v1 − v0, e2 = v2 − v0: (e1·e1, e1·e2, e2·e2), and its
    /// determinant, for the barycentric coordinates of a hit point.
    gram: [f64; 3],
    determinant: f64,
}

impl Triangle {
    /// The face with corners `vertices`, or `None` when it has no area (collinear corners, as
    /// in the second half of a quadrilateral with a repeated node) or a corner is not finite:
    /// such a face has no interior for a bond to cross.
    pub fn new(vertices: [[f64; 3]; 3]) -> Option<Self> {
        if vertices.iter().flatten().any(|v| !v.is_finite()) {
            return None;
        }
        let e1 = sub(vertices[1], vertices[0]);
        let e2 = sub(vertices[2], vertices[0]);
        let n = cross(e1, e2);
        let area2 = norm(n);
        // Collinear corners up to rounding: |e1 × e2| at the level of rounding of |e1||e2|.
        if area2 <= 1e-12 * norm(e1) * norm(e2) || area2 == 0.0 {
            return None;
        }
        let gram = [dot(e1, e1), dot(e1, e2), dot(e2, e2)];
        Some(Self {
            vertices,
            normal: scale(n, 1.0 / area2),
            gram,
            determinant: gram[0] * gram[2] - gram[1] * gram[1],
        })
    }

    /// True when the closed segment a→b meets the widened closed triangle (see the type doc).
    /// Symmetric: `cuts(a, b) == cuts(b, a)`.
    pub fn cuts(&self, a: [f64; 3], b: [f64; 3]) -> bool {
        let Some(hit) = segment_meets_plane(a, b, self.vertices[0], self.normal) else {
            return false;
        };
        let [v0, v1, v2] = self.vertices;
        let c = sub(hit, v0);
        let (c1, c2) = (dot(c, sub(v1, v0)), dot(c, sub(v2, v0)));
        let [g11, g12, g22] = self.gram;
        // Weights of v1 and v2 in hit = v0 + s·e1 + r·e2 (least squares on the plane).
        let s = (g22 * c1 - g12 * c2) / self.determinant;
        let r = (g11 * c2 - g12 * c1) / self.determinant;
        s >= -TRIANGLE_TOLERANCE && r >= -TRIANGLE_TOLERANCE && s + r <= 1.0 + TRIANGLE_TOLERANCE
    }

    /// Axis-aligned bounding box (min, max corners).
    pub fn bounding_box(&self) -> ([f64; 3], [f64; 3]) {
        let mut lo = self.vertices[0];
        let mut hi = self.vertices[0];
        for v in &self.vertices[1..] {
            for k in 0..3 {
                lo[k] = lo[k].min(v[k]);
                hi[k] = hi[k].max(v[k]);
            }
        }
        (lo, hi)
    }
}

/// A surface of triangles that bonds may not cross (Peridigm `Type: Exodus Mesh`: the faces
/// of a shell mesh, quadrilaterals split into two triangles). A segment is cut when it cuts
/// any face ([`Triangle::cuts`]).
///
/// The faces are bucketed in a uniform grid of cells about the size of a face, so a bond
/// (shorter than a horizon) is tested against the few faces near it, not all of them.
#[derive(Debug, Clone, PartialEq)]
pub struct TriangleMesh {
    triangles: Vec<Triangle>,
    lo: [f64; 3],
    hi: [f64; 3],
    grid: FaceGrid,
}

/// Faces bucketed by the grid cells their (padded) bounding boxes overlap.
#[derive(Debug, Clone, PartialEq)]
struct FaceGrid {
    origin: [f64; 3],
    cell: f64,
    dims: [usize; 3],
    /// `start[c]..start[c + 1]` index `faces` for cell c (x fastest).
    start: Vec<u32>,
    faces: Vec<u32>,
    /// Padded bounding box of every face.
    boxes: Vec<([f64; 3], [f64; 3])>,
}

impl FaceGrid {
    fn new(triangles: &[Triangle], lo: [f64; 3], hi: [f64; 3]) -> Self {
        let extent = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
        let scale_of = |a: [f64; 3], b: [f64; 3]| {
            (0..3)
                .map(|k| a[k].abs().max(b[k].abs()))
                .fold(0.0, f64::max)
        };
        // Rounding margin: far above the error of a hit point, far below any face size.
        let pad = 1e-9 * (extent + scale_of(lo, hi));
        let boxes: Vec<([f64; 3], [f64; 3])> = triangles
            .iter()
            .map(|t| {
                let (l, h) = t.bounding_box();
                (l.map(|v| v - pad), h.map(|v| v + pad))
            })
            .collect();
        let mut sizes: Vec<f64> = boxes
            .iter()
            .map(|(l, h)| (0..3).map(|k| h[k] - l[k]).fold(0.0, f64::max))
            .collect();
        sizes.sort_by(f64::total_cmp);
        let median = sizes[sizes.len() / 2].max(pad);
        // Cells of about one face, but never more than a few per face in all.
        let budget = 8 * triangles.len() + 64;
        let mut cell = median;
        let dims_for = |cell: f64| -> [usize; 3] {
            std::array::from_fn(|k| (((hi[k] - lo[k] + 2.0 * pad) / cell).ceil() as usize).max(1))
        };
        let mut dims = dims_for(cell);
        while dims.iter().product::<usize>() > budget {
            cell *= 2.0;
            dims = dims_for(cell);
        }
        let origin = lo.map(|v| v - pad);
        let mut grid = FaceGrid {
            origin,
            cell,
            dims,
            start: Vec::new(),
            faces: Vec::new(),
            boxes,
        };
        let cells = dims.iter().product::<usize>();
        let mut lists: Vec<Vec<u32>> = vec![Vec::new(); cells];
        for (f, (l, h)) in grid.boxes.iter().enumerate() {
            grid.for_each_cell(*l, *h, |c| lists[c].push(f as u32));
        }
        grid.start.push(0);
        for list in lists {
            grid.faces.extend(list);
            grid.start.push(grid.faces.len() as u32);
        }
        grid
    }

    /// Calls `visit` with every cell the box lo..hi overlaps (clamped to the grid).
    fn for_each_cell(&self, lo: [f64; 3], hi: [f64; 3], mut visit: impl FnMut(usize)) {
        let index = |v: f64, k: usize| -> usize {
            let i = ((v - self.origin[k]) / self.cell).floor();
            if i <= 0.0 {
                0
            } else {
                (i as usize).min(self.dims[k] - 1)
            }
        };
        let first: [usize; 3] = std::array::from_fn(|k| index(lo[k], k));
        let last: [usize; 3] = std::array::from_fn(|k| index(hi[k], k));
        for z in first[2]..=last[2] {
            for y in first[1]..=last[1] {
                for x in first[0]..=last[0] {
                    visit(x + self.dims[0] * (y + self.dims[1] * z));
                }
            }
        }
    }
}

impl TriangleMesh {
    /// The surface of `faces` (triangles, or quadrilaterals given as their two triangles).
    /// Faces without area are dropped; a surface with none left is an error.
    pub fn new(faces: &[[[f64; 3]; 3]]) -> Result<Self, BondFilterError> {
        let triangles: Vec<Triangle> = faces.iter().filter_map(|f| Triangle::new(*f)).collect();
        let Some(first) = triangles.first() else {
            return Err(BondFilterError::NoFaces);
        };
        let (mut lo, mut hi) = first.bounding_box();
        for t in &triangles[1..] {
            let (l, h) = t.bounding_box();
            for k in 0..3 {
                lo[k] = lo[k].min(l[k]);
                hi[k] = hi[k].max(h[k]);
            }
        }
        let grid = FaceGrid::new(&triangles, lo, hi);
        Ok(Self {
            triangles,
            lo,
            hi,
            grid,
        })
    }

    /// The faces (triangles) of the surface.
    pub fn triangles(&self) -> &[Triangle] {
        &self.triangles
    }

    /// True when the segment a→b cuts some face. Symmetric: `cuts(a, b) == cuts(b, a)`.
    pub fn cuts(&self, a: [f64; 3], b: [f64; 3]) -> bool {
        let lo: [f64; 3] = std::array::from_fn(|k| a[k].min(b[k]));
        let hi: [f64; 3] = std::array::from_fn(|k| a[k].max(b[k]));
        let grid = &self.grid;
        let mut cut = false;
        grid.for_each_cell(lo, hi, |c| {
            if cut {
                return;
            }
            for &f in &grid.faces[grid.start[c] as usize..grid.start[c + 1] as usize] {
                let (l, h) = grid.boxes[f as usize];
                let overlaps = (0..3).all(|k| lo[k] <= h[k] && hi[k] >= l[k]);
                if overlaps && self.triangles[f as usize].cuts(a, b) {
                    cut = true;
                    return;
                }
            }
        });
        cut
    }
}

/// One bond filter of the discretization (Peridigm `Bond Filters` entry).
#[derive(Debug, Clone, PartialEq)]
pub enum BondFilter {
    /// `Type: Rectangular_Plane`.
    RectangularPlane(RectangularPlane),
    /// `Type: Disk`.
    Disk(Disk),
    /// `Type: Exodus Mesh`: the faces of a shell mesh.
    TriangleMesh(TriangleMesh),
}

impl BondFilter {
    /// True when the segment a→b crosses the filter, i.e. the bond a→b must not exist.
    /// Symmetric: `cuts(a, b) == cuts(b, a)`.
    pub fn cuts(&self, a: [f64; 3], b: [f64; 3]) -> bool {
        match self {
            BondFilter::RectangularPlane(plane) => plane.cuts(a, b),
            BondFilter::Disk(disk) => disk.cuts(a, b),
            BondFilter::TriangleMesh(mesh) => mesh.cuts(a, b),
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
            BondFilter::TriangleMesh(mesh) => (mesh.lo, mesh.hi),
        }
    }
}

impl From<TriangleMesh> for BondFilter {
    fn from(mesh: TriangleMesh) -> Self {
        BondFilter::TriangleMesh(mesh)
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

    /// The unit square in the plane y = 0 (x, z ∈ [0, 1]) as two triangles along its
    /// diagonal (0,0,0)–(1,0,1), as a quadrilateral shell face is split.
    fn unit_square_mesh() -> TriangleMesh {
        let (a, b, c, d) = (
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 0.0, 1.0],
            [0.0, 0.0, 1.0],
        );
        TriangleMesh::new(&[[a, b, c], [a, c, d]]).unwrap()
    }

    #[test]
    fn triangle_cuts_follow_the_rule_of_the_other_filters() {
        let t = Triangle::new([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]).unwrap();
        assert_eq!(t.normal, [0.0, -1.0, 0.0]);
        // Through the interior, both directions.
        assert!(t.cuts([0.2, -1.0, 0.2], [0.2, 1.0, 0.2]));
        assert!(t.cuts([0.2, 1.0, 0.2], [0.2, -1.0, 0.2]));
        // Beyond the hypotenuse x + z = 1.
        assert!(!t.cuts([0.6, -1.0, 0.6], [0.6, 1.0, 0.6]));
        // On an edge, on the hypotenuse and at a corner: closed.
        assert!(t.cuts([0.5, -1.0, 0.0], [0.5, 1.0, 0.0]));
        assert!(t.cuts([0.5, -1.0, 0.5], [0.5, 1.0, 0.5]));
        assert!(t.cuts([1.0, -1.0, 0.0], [1.0, 1.0, 0.0]));
        // An end point on the face counts; a segment short of it does not.
        assert!(t.cuts([0.2, 0.0, 0.2], [0.2, 1.0, 0.2]));
        assert!(!t.cuts([0.2, 0.1, 0.2], [0.2, 1.0, 0.2]));
        // Parallel to the face, even inside its plane: never cut.
        assert!(!t.cuts([0.1, 0.0, 0.1], [0.3, 0.0, 0.2]));
        // No area: no face.
        assert!(Triangle::new([[0.0; 3], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]]).is_none());
        assert!(Triangle::new([[0.0; 3], [f64::NAN, 0.0, 0.0], [0.0, 0.0, 1.0]]).is_none());
    }

    #[test]
    fn a_segment_through_a_shared_edge_or_the_diagonal_never_slips_through() {
        // Crossings at many points of the diagonal x = z and of the outer edges, including
        // values that are not binary fractions: each must be cut by at least one triangle.
        let mesh = unit_square_mesh();
        let mut rng = crate::model::test_support::Rng::new(11);
        for _ in 0..2000 {
            let s = rng.uniform();
            let tilt = [0.3 * (rng.uniform() - 0.5), 0.3 * (rng.uniform() - 0.5)];
            for hit in [[s, 0.0, s], [s, 0.0, 0.0], [1.0, 0.0, s], [0.0, 0.0, s]] {
                // A tilted segment from a through the hit point, as far beyond the plane.
                let a = [hit[0] - tilt[0], -0.7, hit[2] - tilt[1]];
                let b = [2.0 * hit[0] - a[0], 0.7, 2.0 * hit[2] - a[2]];
                assert!(mesh.cuts(a, b), "hit {hit:?}");
                assert!(mesh.cuts(b, a), "hit {hit:?}");
            }
        }
    }

    #[test]
    fn a_planar_mesh_cuts_what_the_equivalent_rectangle_cuts() {
        // The rectangle of the unit square: normal (0,1,0), corner at the origin, bottom
        // (1,0,0) and side bottom × normal = (0,0,1).
        let plane =
            RectangularPlane::new([0.0, 1.0, 0.0], [0.0; 3], [1.0, 0.0, 0.0], 1.0, 1.0).unwrap();
        let mesh = unit_square_mesh();
        let mut rng = crate::model::test_support::Rng::new(5);
        let mut cut = 0;
        for _ in 0..20000 {
            let a = [
                3.0 * rng.uniform() - 1.0,
                rng.uniform() - 0.5,
                3.0 * rng.uniform() - 1.0,
            ];
            let b = [
                3.0 * rng.uniform() - 1.0,
                rng.uniform() - 0.5,
                3.0 * rng.uniform() - 1.0,
            ];
            assert_eq!(mesh.cuts(a, b), plane.cuts(a, b), "{a:?} → {b:?}");
            cut += usize::from(plane.cuts(a, b));
        }
        assert!(cut > 1000, "the sample exercises the filter: {cut}");
    }

    #[test]
    fn the_face_grid_finds_faces_far_apart() {
        // 400 small triangles on a 20 × 20 grid in the plane y = 0 (x, z ∈ [0, 20]), each the
        // lower-left half of a unit cell: a segment through a cell's lower-left half is cut, one
        // through its upper-right half is not, wherever the cell is.
        let mut faces = Vec::new();
        for i in 0..20 {
            for k in 0..20 {
                let (x, z) = (i as f64, k as f64);
                faces.push([[x, 0.0, z], [x + 1.0, 0.0, z], [x, 0.0, z + 1.0]]);
            }
        }
        let mesh = TriangleMesh::new(&faces).unwrap();
        assert_eq!(mesh.triangles().len(), 400);
        for i in 0..20 {
            for k in 0..20 {
                let (x, z) = (i as f64, k as f64);
                assert!(mesh.cuts([x + 0.2, -0.5, z + 0.2], [x + 0.2, 0.5, z + 0.2]));
                assert!(!mesh.cuts([x + 0.8, -0.5, z + 0.8], [x + 0.8, 0.5, z + 0.8]));
            }
        }
        assert_eq!(
            TriangleMesh::new(&[[[0.0; 3], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]]]),
            Err(BondFilterError::NoFaces)
        );
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
