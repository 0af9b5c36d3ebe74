//! Node-set lists: 1-based point ids, in the deck or in a file.

use super::MeshError;
use std::path::Path;

/// The ids of a node-set file as written, with the line each is on, so that a problem with an
/// id found later (beyond the number of points) names the file and its line.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct NodeSetFile {
    /// The ids as written (1-based).
    pub ids: Vec<u64>,
    /// The 1-based line of each id.
    pub lines: Vec<usize>,
}

/// Reads a node-set file: whitespace-separated 1-based ids, any number per line; lines
/// starting with `#`, `/` or `*` are comments (Peridigm's rule). Returns the ids as written.
pub fn read_node_set_file(path: &Path) -> Result<Vec<u64>, MeshError> {
    read_node_set_file_lines(path).map(|file| file.ids)
}

/// [`read_node_set_file`], with the line of each id.
pub fn read_node_set_file_lines(path: &Path) -> Result<NodeSetFile, MeshError> {
    let text = std::fs::read_to_string(path).map_err(|source| MeshError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let mut file = NodeSetFile::default();
    for (index, raw) in text.lines().enumerate() {
        let content = raw.trim();
        if content.is_empty() || content.starts_with(['#', '/', '*']) {
            continue;
        }
        for token in content.split_whitespace() {
            let id = parse_node_id(token).ok_or_else(|| MeshError::Syntax {
                path: path.to_path_buf(),
                line: index + 1,
                message: format!("node id `{token}` is not a positive integer (ids are 1-based)"),
            })?;
            file.ids.push(id);
            file.lines.push(index + 1);
        }
    }
    Ok(file)
}

/// A 1-based node id; `0`, negatives and non-integers are rejected.
pub fn parse_node_id(token: &str) -> Option<u64> {
    token.parse::<u64>().ok().filter(|&id| id >= 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_ids_and_skips_comments() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("set.txt");
        std::fs::write(&path, "# header\n9 10\n// c\n* c\n11\n").unwrap();
        assert_eq!(read_node_set_file(&path).unwrap(), vec![9, 10, 11]);
        assert_eq!(
            read_node_set_file_lines(&path).unwrap().lines,
            vec![2, 2, 5]
        );
        std::fs::write(&path, "1\n0\n").unwrap();
        let err = read_node_set_file(&path).unwrap_err().to_string();
        assert!(err.contains("set.txt:2"), "{err}");
    }
}
