//! Peridigm's `Exodus` discretization: one point per element.

use super::MeshError;
use crate::io::exodus::ExodusFile;
use crate::model::{BlockInfo, NodeSets, PointCloud};
use std::path::Path;

/// Points from an Exodus mesh, one per element in file order (block by block).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ExodusMesh {
    /// Points; original id = element index in the file.
    pub points: PointCloud,
    /// One block per element block, named `block_<id>`.
    pub blocks: Vec<BlockInfo>,
    /// Exodus node sets mapped to points.
    pub node_sets: NodeSets,
}

/// Reads an Exodus mesh the way Peridigm does: HEX8 (and the corner nodes of HEX20/27)
/// elements become a point at their volume centroid, TETRA4 (corner nodes of TETRA10) at the
/// mean of their corners (the same thing for a tetrahedron), with the element volume; SPHERE elements become a point at their node with the volume in
/// their second attribute. A node set becomes the set of every element that touches one of
/// its nodes (named as in the file, or `nodelist_<id>`).
pub fn read_exodus_mesh(path: &Path) -> Result<ExodusMesh, MeshError> {
    let file = ExodusFile::open(path)?;
    let fail = |message: String| MeshError::Exodus {
        path: path.to_path_buf(),
        message,
    };
    let mut mesh = ExodusMesh::default();
    let mut elements_of_node: Vec<Vec<u32>> = vec![Vec::new(); file.coordinates.len()];
    for (block_index, block) in file.blocks.iter().enumerate() {
        mesh.blocks.push(BlockInfo::from_id(block.id));
        let per = block.nodes_per_element;
        if per == 0 {
            continue;
        }
        let count = block.connectivity.len() / per;
        let kind = block.element_type.to_ascii_uppercase();
        for e in 0..count {
            let nodes = &block.connectivity[e * per..(e + 1) * per];
            let corners = |n: usize| -> Result<Vec<[f64; 3]>, MeshError> {
                if nodes.len() < n {
                    return Err(fail(format!(
                        "block {}: {kind} element with {} nodes (need {n})",
                        block.id,
                        nodes.len()
                    )));
                }
                nodes[..n]
                    .iter()
                    .map(|&node| {
                        file.coordinates.get(node as usize).copied().ok_or_else(|| {
                            fail(format!(
                                "block {}: node {} does not exist",
                                block.id,
                                node + 1
                            ))
                        })
                    })
                    .collect()
            };
            let (position, volume) = if kind.starts_with("HEX") {
                let c = corners(8)?;
                let (volume, centroid) = hexahedron_volume_and_centroid(&c);
                (centroid, volume)
            } else if kind.starts_with("TET") {
                let c = corners(4)?;
                (mean(&c), tetrahedron_volume(&c).abs())
            } else if kind.starts_with("SPHERE") {
                let c = corners(1)?;
                let attributes = &block.attributes;
                let per_attr = block.attributes_per_element;
                if per_attr < 2 {
                    return Err(fail(format!(
                        "block {}: SPHERE elements need 2 attributes (radius, volume); found {per_attr}",
                        block.id
                    )));
                }
                (c[0], attributes[e * per_attr + 1])
            } else {
                return Err(fail(format!(
                    "block {}: element type {kind} is not supported (use HEX8, TETRA4 or SPHERE)",
                    block.id
                )));
            };
            if !(volume > 0.0 && volume.is_finite()) {
                return Err(fail(format!(
                    "block {}, element {}: volume {volume:e} is not positive (inverted or degenerate element?)",
                    block.id,
                    e + 1
                )));
            }
            let point = mesh.points.len() as u32;
            for &node in &nodes[..nodes.len().min(8)] {
                elements_of_node[node as usize].push(point);
            }
            mesh.points.push(position, volume, block_index as u32);
        }
    }
    if mesh.points.is_empty() {
        return Err(MeshError::Empty {
            path: path.to_path_buf(),
        });
    }
    for set in &file.node_sets {
        let mut points: Vec<u32> = set
            .nodes
            .iter()
            .flat_map(|&node| {
                elements_of_node
                    .get(node as usize)
                    .into_iter()
                    .flatten()
                    .copied()
            })
            .collect();
        points.sort_unstable();
        points.dedup();
        mesh.node_sets.insert(set.name.clone(), points);
    }
    Ok(mesh)
}

fn mean(points: &[[f64; 3]]) -> [f64; 3] {
    let n = points.len() as f64;
    [0, 1, 2].map(|k| points.iter().map(|p| p[k]).sum::<f64>() / n)
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn triple(a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> f64 {
    a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
        + a[2] * (b[0] * c[1] - b[1] * c[0])
}

/// Signed volume of a 4-node tetrahedron, `((b−a)·((c−a)×(d−a)))/6`.
fn tetrahedron_volume(c: &[[f64; 3]]) -> f64 {
    triple(sub(c[1], c[0]), sub(c[2], c[0]), sub(c[3], c[0])) / 6.0
}

/// Exact volume and volume centroid of a trilinear 8-node hexahedron (Exodus node order):
/// V = ∫ det J and x̄ = ∫ x det J / V over the reference cube with 2×2×2 Gauss points. Both are
/// exact: det J is at most quadratic and x·det J at most cubic in each reference coordinate.
/// The centroid (not the node average) is what Peridigm places the point at; they differ for
/// non-parallelepiped elements (`Body_Force.g` has trapezoidal ones).
fn hexahedron_volume_and_centroid(c: &[[f64; 3]]) -> (f64, [f64; 3]) {
    const SIGNS: [[f64; 3]; 8] = [
        [-1.0, -1.0, -1.0],
        [1.0, -1.0, -1.0],
        [1.0, 1.0, -1.0],
        [-1.0, 1.0, -1.0],
        [-1.0, -1.0, 1.0],
        [1.0, -1.0, 1.0],
        [1.0, 1.0, 1.0],
        [-1.0, 1.0, 1.0],
    ];
    let g = 1.0 / 3f64.sqrt();
    let mut volume = 0.0;
    let mut moment = [0.0; 3];
    for gauss in SIGNS {
        let xi = gauss.map(|s| s * g);
        let mut jacobian = [[0.0; 3]; 3];
        let mut x = [0.0; 3];
        for (node, s) in SIGNS.iter().enumerate() {
            let factors = [1.0 + s[0] * xi[0], 1.0 + s[1] * xi[1], 1.0 + s[2] * xi[2]];
            let shape = factors[0] * factors[1] * factors[2] / 8.0;
            for axis in 0..3 {
                x[axis] += shape * c[node][axis];
            }
            for d in 0..3 {
                let mut derivative = s[d] / 8.0;
                for (other, f) in factors.iter().enumerate() {
                    if other != d {
                        derivative *= f;
                    }
                }
                for axis in 0..3 {
                    jacobian[d][axis] += derivative * c[node][axis];
                }
            }
        }
        let det = triple(jacobian[0], jacobian[1], jacobian[2]);
        volume += det;
        for axis in 0..3 {
            moment[axis] += x[axis] * det;
        }
    }
    (volume, moment.map(|m| m / volume))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unit_and_sheared_hexahedra_have_exact_volumes() {
        let cube = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
            [1.0, 0.0, 1.0],
            [1.0, 1.0, 1.0],
            [0.0, 1.0, 1.0],
        ];
        let (volume, centroid) = hexahedron_volume_and_centroid(&cube);
        assert!((volume - 1.0).abs() < 1e-14);
        assert!(centroid.iter().all(|x| (x - 0.5).abs() < 1e-15));
        // A shear x += 0.5 z keeps the volume (det of the shear map is 1); a stretch of 2 in
        // y doubles it.
        let sheared: Vec<[f64; 3]> = cube
            .iter()
            .map(|p| [p[0] + 0.5 * p[2], 2.0 * p[1], p[2]])
            .collect();
        assert!((hexahedron_volume_and_centroid(&sheared).0 - 2.0).abs() < 1e-14);
        // Trapezoidal prism (Body_Force.g's shape): parallel faces at x = 0.125 (width
        // a = 0.25) and x = 0.5 (width b = 1/3), height h = 0.375 → centroid x =
        // 0.125 + h(a + 2b)/(3(a + b)) = 0.3214285714…; the node average would be 0.3125.
        let trapezoid = [
            [0.125, 0.125, 0.0],
            [0.125, -0.125, 0.0],
            [0.5, -1.0 / 6.0, 0.0],
            [0.5, 1.0 / 6.0, 0.0],
            [0.125, 0.125, 1.0],
            [0.125, -0.125, 1.0],
            [0.5, -1.0 / 6.0, 1.0],
            [0.5, 1.0 / 6.0, 1.0],
        ];
        let (_, centroid) = hexahedron_volume_and_centroid(&trapezoid);
        let expected = 0.125 + 0.375 * (0.25 + 2.0 / 3.0) / (3.0 * (0.25 + 1.0 / 3.0));
        assert!((centroid[0] - expected).abs() < 1e-15, "{centroid:?}");
        // Tetrahedron (0,0,0),(1,0,0),(0,1,0),(0,0,1): V = 1/6.
        let tet = [[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        assert!((tetrahedron_volume(&tet) - 1.0 / 6.0).abs() < 1e-15);
    }
}
