//! Shell meshes for `Exodus Mesh` bond filters: the faces of an Exodus file as triangles.

use super::MeshError;
use crate::io::exodus::ExodusFile;
use std::path::Path;

/// The faces of the shell mesh `path` as triangles, block by block in file order.
///
/// Triangles (`TRI3`, `TRISHELL3`, `SHELL3`, and the corner nodes of their higher-order
/// variants) are taken as they are; quadrilaterals (`QUAD4`, `SHELL4`, and the corners of
/// `QUAD8/9`, `SHELL8/9`) are split along their first diagonal into (n₁, n₂, n₃) and
/// (n₁, n₃, n₄), which is exact for a planar quadrilateral. Empty blocks are skipped; any other
/// element type is an error naming the block and the type.
pub fn read_shell_faces(path: &Path) -> Result<Vec<[[f64; 3]; 3]>, MeshError> {
    let file = ExodusFile::open(path)?;
    let fail = |message: String| MeshError::Exodus {
        path: path.to_path_buf(),
        message,
    };
    let mut faces = Vec::new();
    for block in &file.blocks {
        let per = block.nodes_per_element;
        if per == 0 || block.connectivity.is_empty() {
            continue;
        }
        let kind = block.element_type.to_ascii_uppercase();
        let corners = if kind.starts_with("TRI") || (kind.starts_with("SHELL") && per == 3) {
            3
        } else if kind.starts_with("QUAD") || kind.starts_with("SHELL") {
            4
        } else {
            return Err(fail(format!(
                "block {}: element type {kind} is not a face; a bond-filter shell mesh holds \
                 TRI3, QUAD4 or SHELL4 elements",
                block.id
            )));
        };
        if per < corners {
            return Err(fail(format!(
                "block {}: {kind} element with {per} nodes (need {corners})",
                block.id
            )));
        }
        for nodes in block.connectivity.chunks_exact(per) {
            let point = |k: usize| file.coordinates[nodes[k] as usize];
            faces.push([point(0), point(1), point(2)]);
            if corners == 4 {
                faces.push([point(0), point(2), point(3)]);
            }
        }
    }
    if faces.is_empty() {
        return Err(fail(
            "the file has no faces; a bond-filter shell mesh holds TRI3, QUAD4 or SHELL4 elements"
                .into(),
        ));
    }
    Ok(faces)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::exodus::write_shell_mesh;

    #[test]
    fn quadrilaterals_split_into_two_triangles_and_triangles_stay() {
        let dir = tempfile::tempdir().unwrap();
        let coordinates = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
        ];
        let quad = dir.path().join("quad.g");
        write_shell_mesh(&quad, &coordinates, "SHELL4", 4, &[0, 1, 2, 3]).unwrap();
        assert_eq!(
            read_shell_faces(&quad).unwrap(),
            vec![
                [coordinates[0], coordinates[1], coordinates[2]],
                [coordinates[0], coordinates[2], coordinates[3]],
            ]
        );
        let tri = dir.path().join("tri.g");
        write_shell_mesh(&tri, &coordinates, "TRI3", 3, &[0, 1, 2, 0, 2, 3]).unwrap();
        assert_eq!(read_shell_faces(&tri).unwrap().len(), 2);
    }

    #[test]
    fn a_volume_mesh_is_refused_with_its_element_type() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("hex.g");
        let coordinates: Vec<[f64; 3]> = (0..8)
            .map(|k| [(k & 1) as f64, ((k >> 1) & 1) as f64, (k >> 2) as f64])
            .collect();
        write_shell_mesh(&path, &coordinates, "HEX8", 8, &[0, 1, 3, 2, 4, 5, 7, 6]).unwrap();
        let message = read_shell_faces(&path).unwrap_err().to_string();
        assert!(
            message.contains("HEX8") && message.contains("hex.g"),
            "{message}"
        );
    }
}
