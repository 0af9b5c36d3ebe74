//! Material points as a structure of arrays.

/// One block of points as the discretization names it (Peridigm: `block_<id>`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BlockInfo {
    /// Numeric block id from the mesh (Exodus element-block id, text-file column 4, 1 for QuickGrid).
    pub id: i64,
    /// Block name used by the deck's `Block Names`, `block_<id>`.
    pub name: String,
}

impl BlockInfo {
    /// The block with mesh id `id`, named as Peridigm names it (`block_<id>`).
    pub fn from_id(id: i64) -> Self {
        Self {
            id,
            name: format!("block_{id}"),
        }
    }
}

/// Material points in the reference configuration.
///
/// Points are stored in the order the run uses (owned points first; after setup sorted along a
/// space-filling curve for cache locality). `original_id` keeps each point's 0-based position
/// in the input (mesh element order, text-file line order, QuickGrid x-fastest order), which is
/// what node sets, output files and users refer to (1-based there).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PointCloud {
    /// Reference coordinates X (length units).
    pub position: Vec<[f64; 3]>,
    /// Cell volume V (length³).
    pub volume: Vec<f64>,
    /// Index into the discretization's block list (not the mesh block id).
    pub block: Vec<u32>,
    /// 0-based index of the point in the input ordering.
    pub original_id: Vec<u32>,
}

impl PointCloud {
    /// Number of points.
    pub fn len(&self) -> usize {
        self.position.len()
    }

    /// True when there are no points.
    pub fn is_empty(&self) -> bool {
        self.position.is_empty()
    }

    /// Appends one point; its original id is its input position.
    pub fn push(&mut self, position: [f64; 3], volume: f64, block: u32) {
        self.original_id.push(self.position.len() as u32);
        self.position.push(position);
        self.volume.push(volume);
        self.block.push(block);
    }

    /// Reorders the points so that new point `k` is old point `order[k]`.
    ///
    /// `order` must be a permutation of `0..len()`.
    pub fn permute(&mut self, order: &[u32]) {
        debug_assert_eq!(order.len(), self.len());
        let gather = |k: usize| order[k] as usize;
        self.position = (0..order.len()).map(|k| self.position[gather(k)]).collect();
        self.volume = (0..order.len()).map(|k| self.volume[gather(k)]).collect();
        self.block = (0..order.len()).map(|k| self.block[gather(k)]).collect();
        self.original_id = (0..order.len())
            .map(|k| self.original_id[gather(k)])
            .collect();
    }

    /// Radius of the sphere with the point's volume, `(3V/4π)^(1/3)` (Peridigm's element radius).
    pub fn radius(&self, point: usize) -> f64 {
        (3.0 * self.volume[point] / (4.0 * std::f64::consts::PI)).cbrt()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn permute_keeps_original_ids_with_their_points() {
        let mut cloud = PointCloud::default();
        for k in 0..4 {
            cloud.push([k as f64, 0.0, 0.0], 1.0 + k as f64, 0);
        }
        cloud.permute(&[2, 0, 3, 1]);
        assert_eq!(cloud.original_id, vec![2, 0, 3, 1]);
        assert_eq!(cloud.volume, vec![3.0, 1.0, 4.0, 2.0]);
        assert_eq!(cloud.position[0], [2.0, 0.0, 0.0]);
    }

    #[test]
    fn radius_of_unit_sphere_volume_is_one() {
        let mut cloud = PointCloud::default();
        // V = 4π/3 r³ with r = 1
        cloud.push([0.0; 3], 4.0 * std::f64::consts::PI / 3.0, 0);
        assert!((cloud.radius(0) - 1.0).abs() < 1e-14);
    }
}
