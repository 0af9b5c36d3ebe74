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
/// elements become a point at their centroid (24 tetrahedra about the face averages, as Peridigm), TETRA4 (corner nodes of TETRA10) at the
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

/// Volume and centroid of an 8-node hexahedron (Exodus node order) as Peridigm computes them
/// (`hexCentroidAndVolume`): each face is split into four triangles at its corner average,
/// each triangle is joined to the element's centre (the mean of the two end-face averages),
/// and the 24 tetrahedra are summed; the centroid is their volume-weighted mean. This is exact
/// for elements with planar faces (Body_Force.g's trapezoids); for warped faces it is the
/// approximation Peridigm uses, which the gold files of meshed spheres depend on (1e-7 in
/// position for Contact_Perforation's projectile, against a 1e-12 tolerance).
fn hexahedron_volume_and_centroid(c: &[[f64; 3]]) -> (f64, [f64; 3]) {
    // Each face: its four corners in order, and the four (first, second) corner pairs whose
    // triangles with the face average and the centre make the tetrahedra (outward winding).
    type FaceSplit = ([usize; 4], [(usize, usize); 4]);
    const FACES: [FaceSplit; 6] = [
        ([0, 1, 4, 5], [(1, 0), (5, 1), (4, 5), (0, 4)]),
        ([1, 2, 5, 6], [(2, 1), (6, 2), (5, 6), (1, 5)]),
        ([2, 3, 6, 7], [(3, 2), (7, 3), (6, 7), (2, 6)]),
        ([0, 3, 4, 7], [(0, 3), (3, 7), (7, 4), (4, 0)]),
        ([0, 1, 2, 3], [(0, 1), (1, 2), (2, 3), (3, 0)]),
        ([4, 5, 6, 7], [(5, 4), (4, 7), (7, 6), (6, 5)]),
    ];
    let average = |corners: [usize; 4]| {
        [0, 1, 2].map(|a| {
            0.25 * (c[corners[0]][a] + c[corners[1]][a] + c[corners[2]][a] + c[corners[3]][a])
        })
    };
    let face_average: Vec<[f64; 3]> = FACES.iter().map(|(corners, _)| average(*corners)).collect();
    let centre = [0, 1, 2].map(|a| 0.5 * (face_average[4][a] + face_average[5][a]));
    let mut volume = 0.0;
    let mut moment = [0.0; 3];
    for (face, (_, tets)) in FACES.iter().enumerate() {
        for &(first, second) in tets {
            let tet = [c[first], c[second], face_average[face], centre];
            let v = tetrahedron_volume(&tet);
            volume += v;
            for a in 0..3 {
                moment[a] += 0.25 * (tet[0][a] + tet[1][a] + tet[2][a] + tet[3][a]) * v;
            }
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
