//! Families of points in compressed-sparse-row form.

/// Every point's neighbour list (its family), directed: a bond i→j is stored in i's row and
/// j→i in j's row, as Peridigm's state-based formulas expect.
///
/// Row `i` is `neighbor[offsets[i]..offsets[i + 1]]`; per-bond arrays (`reference_length`, later
/// quadrature weights, influence, damage) are indexed by the same bond index.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct BondList {
    /// Row starts, length `points + 1`, `offsets[0] = 0`.
    pub offsets: Vec<usize>,
    /// Neighbour point index of each directed bond.
    pub neighbor: Vec<u32>,
    /// Reference bond length ζ = |X_j − X_i| of each directed bond (length units), computed as
    /// the square root of the summed squared coordinate differences (x, y, z in that order), so
    /// the bonds i→j and j→i hold bitwise the same number (damage models rely on it).
    pub reference_length: Vec<f64>,
}

impl BondList {
    /// Number of points (rows).
    pub fn num_points(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    /// Number of directed bonds.
    pub fn num_bonds(&self) -> usize {
        self.neighbor.len()
    }

    /// Bond-index range of point `i`'s family.
    pub fn range(&self, i: usize) -> std::ops::Range<usize> {
        self.offsets[i]..self.offsets[i + 1]
    }

    /// Neighbours of point `i`.
    pub fn family(&self, i: usize) -> &[u32] {
        &self.neighbor[self.range(i)]
    }

    /// Number of neighbours of point `i` (Peridigm's `Number_Of_Neighbors`).
    pub fn family_size(&self, i: usize) -> usize {
        self.offsets[i + 1] - self.offsets[i]
    }
}
