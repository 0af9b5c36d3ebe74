//! Peridigm's `Text File` discretization: one point per line, `x y z block_id volume`.

use super::MeshError;
use crate::model::{BlockInfo, PointCloud};
use std::collections::BTreeMap;
use std::path::Path;

/// Points read from a text file, with the blocks they name.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TextMesh {
    /// Points in file order (original id = 0-based data-line index).
    pub points: PointCloud,
    /// Blocks sorted by id; `points.block` indexes this list.
    pub blocks: Vec<BlockInfo>,
}

/// Reads `x y z block_id volume` lines (the column order Peridigm's reader uses; its prose
/// documentation says otherwise). Lines that are empty or start with `#` are skipped.
/// Block ids must be positive integers and volumes positive finite numbers.
pub fn read_text_mesh(path: &Path) -> Result<TextMesh, MeshError> {
    let text = std::fs::read_to_string(path).map_err(|source| MeshError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    parse_text_mesh(&text, path)
}

/// Parses the contents of a text mesh; `path` only names the file in errors.
pub fn parse_text_mesh(text: &str, path: &Path) -> Result<TextMesh, MeshError> {
    let bad = |line: usize, message: String| MeshError::Syntax {
        path: path.to_path_buf(),
        line,
        message,
    };
    let mut rows = Vec::new();
    for (index, raw) in text.lines().enumerate() {
        let line = index + 1;
        let content = raw.trim();
        if content.is_empty() || content.starts_with('#') {
            continue;
        }
        let fields: Vec<&str> = content.split_whitespace().collect();
        if fields.len() != 5 {
            return Err(bad(
                line,
                format!(
                    "expected 5 columns `x y z block_id volume`, found {}",
                    fields.len()
                ),
            ));
        }
        let number = |column: usize, name: &str| -> Result<f64, MeshError> {
            let value: f64 = fields[column]
                .parse()
                .map_err(|_| bad(line, format!("{name} `{}` is not a number", fields[column])))?;
            if !value.is_finite() {
                return Err(bad(line, format!("{name} is not finite")));
            }
            Ok(value)
        };
        let position = [number(0, "x")?, number(1, "y")?, number(2, "z")?];
        let block_id = parse_block_id(fields[3]).ok_or_else(|| {
            bad(
                line,
                format!(
                    "block_id `{}` must be a positive integer (column 4)",
                    fields[3]
                ),
            )
        })?;
        let volume = number(4, "volume")?;
        if volume <= 0.0 {
            return Err(bad(
                line,
                format!("volume {volume} must be positive (column 5)"),
            ));
        }
        rows.push((position, block_id, volume));
    }
    if rows.is_empty() {
        return Err(MeshError::Empty {
            path: path.to_path_buf(),
        });
    }
    let mut block_index = BTreeMap::new();
    for &(_, id, _) in &rows {
        block_index.insert(id, 0u32);
    }
    for (k, slot) in block_index.values_mut().enumerate() {
        *slot = k as u32;
    }
    let mut mesh = TextMesh {
        blocks: block_index
            .keys()
            .map(|&id| BlockInfo::from_id(id))
            .collect(),
        ..TextMesh::default()
    };
    for (position, id, volume) in rows {
        mesh.points.push(position, volume, block_index[&id]);
    }
    Ok(mesh)
}

/// Block ids are integers; Peridigm's reader also accepts them written as `1.0`.
fn parse_block_id(field: &str) -> Option<i64> {
    if let Ok(id) = field.parse::<i64>() {
        return (id > 0).then_some(id);
    }
    let value: f64 = field.parse().ok()?;
    (value.fract() == 0.0 && value >= 1.0 && value < i64::MAX as f64).then_some(value as i64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_columns_in_peridigm_order() {
        let text = "# x y z block volume\n0 0 0 2 0.5\n\n1.0 0 0 1 0.25\n";
        let mesh = parse_text_mesh(text, Path::new("m.txt")).unwrap();
        assert_eq!(mesh.points.len(), 2);
        assert_eq!(
            mesh.blocks,
            vec![BlockInfo::from_id(1), BlockInfo::from_id(2)]
        );
        // first point: block id 2 → index 1 in the sorted block list, volume 0.5
        assert_eq!(mesh.points.block, vec![1, 0]);
        assert_eq!(mesh.points.volume, vec![0.5, 0.25]);
    }

    #[test]
    fn errors_name_file_and_line() {
        let err = parse_text_mesh("0 0 0 1 1\n0 0 0 1 -1\n", Path::new("m.txt")).unwrap_err();
        let message = err.to_string();
        assert!(message.contains("m.txt:2"), "{message}");
        assert!(message.contains("volume"), "{message}");
        let err = parse_text_mesh("0 0 0 1\n", Path::new("m.txt")).unwrap_err();
        assert!(err.to_string().contains("5 columns"));
        let err = parse_text_mesh("0 0 0 0 1\n", Path::new("m.txt")).unwrap_err();
        assert!(err.to_string().contains("block_id"));
        let err = parse_text_mesh("# only a comment\n", Path::new("m.txt")).unwrap_err();
        assert!(matches!(err, MeshError::Empty { .. }));
    }
}
