//! Reading the global-output CSV a run writes (`<Output Filename>.csv`: a header
//! `Time,<name>,…` and one row per output frame, see `peridyn::io::history`).

use std::path::{Path, PathBuf};

use super::ModulusError;

/// The columns of a global-output CSV, by name.
#[derive(Debug, Clone, PartialEq)]
pub struct History {
    /// The file read (for messages).
    pub path: PathBuf,
    /// Column names, `Time` first.
    pub names: Vec<String>,
    /// One row per output frame, one value per column.
    pub rows: Vec<Vec<f64>>,
}

impl History {
    /// Reads and parses `path`.
    pub fn read(path: &Path) -> Result<Self, ModulusError> {
        let text = std::fs::read_to_string(path).map_err(|source| ModulusError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Self::parse(&text, path)
    }

    /// Parses CSV text; `path` names the file in errors. Every row must have one number per
    /// header name, and there must be at least one row.
    pub fn parse(text: &str, path: &Path) -> Result<Self, ModulusError> {
        let bad = |line: usize, message: String| ModulusError::Syntax {
            path: path.to_path_buf(),
            line,
            message,
        };
        let mut lines = text
            .lines()
            .enumerate()
            .filter(|(_, line)| !line.trim().is_empty());
        let (_, header) = lines
            .next()
            .ok_or_else(|| bad(1, "the file is empty; expected a header `Time,…`".into()))?;
        let names: Vec<String> = header.split(',').map(|n| n.trim().to_string()).collect();
        let mut rows = Vec::new();
        for (index, line) in lines {
            let fields: Vec<&str> = line.split(',').map(str::trim).collect();
            if fields.len() != names.len() {
                return Err(bad(
                    index + 1,
                    format!(
                        "{} values, but the header names {} columns",
                        fields.len(),
                        names.len()
                    ),
                ));
            }
            let row = fields
                .iter()
                .zip(&names)
                .map(|(field, name)| {
                    field
                        .parse::<f64>()
                        .map_err(|_| bad(index + 1, format!("{name}: `{field}` is not a number")))
                })
                .collect::<Result<Vec<f64>, _>>()?;
            rows.push(row);
        }
        if rows.is_empty() {
            return Err(bad(2, "no data rows after the header".into()));
        }
        Ok(Self {
            path: path.to_path_buf(),
            names,
            rows,
        })
    }

    /// The index of the column `label` followed by `component` (`Gage_Top_Displacement` +
    /// `Y`), or of `label` itself when the file has it as a scalar column.
    pub fn column(&self, label: &str, component: &str) -> Result<usize, ModulusError> {
        let wanted = format!("{label}{component}");
        self.names
            .iter()
            .position(|n| *n == wanted)
            .or_else(|| self.names.iter().position(|n| n == label))
            .ok_or_else(|| ModulusError::MissingColumn {
                path: self.path.clone(),
                label: wanted,
                available: self.names.join(", "),
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_header_and_rows() {
        let history =
            History::parse("Time,AX,AY\n0.0,1,2\n\n0.5,3,4e-1\n", Path::new("h.csv")).unwrap();
        assert_eq!(history.names, ["Time", "AX", "AY"]);
        assert_eq!(history.rows, vec![vec![0.0, 1.0, 2.0], vec![0.5, 3.0, 0.4]]);
        assert_eq!(history.column("A", "Y").unwrap(), 2);
        assert_eq!(history.column("Time", "Y").unwrap(), 0);
    }

    #[test]
    fn errors_name_the_file_line_and_label() {
        let path = Path::new("run.csv");
        let short = History::parse("Time,A\n0.0\n", path)
            .unwrap_err()
            .to_string();
        assert!(short.contains("run.csv:2"), "{short}");
        let word = History::parse("Time,A\n0.0,x\n", path)
            .unwrap_err()
            .to_string();
        assert!(word.contains("run.csv:2") && word.contains("`x`"), "{word}");
        let empty = History::parse("", path).unwrap_err().to_string();
        assert!(empty.contains("run.csv:1"), "{empty}");
        let no_rows = History::parse("Time,A\n", path).unwrap_err().to_string();
        assert!(no_rows.contains("no data rows"), "{no_rows}");
        let history = History::parse("Time,AX\n0.0,1\n", path).unwrap();
        let missing = history.column("B", "Y").unwrap_err().to_string();
        assert!(
            missing.contains("run.csv") && missing.contains("BY") && missing.contains("AX"),
            "{missing}"
        );
    }
}
