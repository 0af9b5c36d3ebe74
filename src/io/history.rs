//! CSV history of global variables (energies, Block_Data, Node_Set_Data, …), one row per
//! output frame, written next to the Exodus file.
//!
//! Format: a header `Time,<name 1>,<name 2>,…` and one line per frame. Numbers are written in
//! Rust's shortest round-trip representation (`{:?}` of `f64`, e.g. `0.1`, `1e-7`, `NaN`),
//! so reading them back gives the identical `f64`. Every row is flushed as soon as it is
//! written, so a run that fails later leaves a complete, parseable file.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use thiserror::Error;

/// Errors of the history writer; each names the file.
#[derive(Debug, Error)]
pub enum HistoryError {
    /// Creating or writing the file failed.
    #[error("{path}: cannot write CSV history: {source}")]
    Io {
        /// The CSV file.
        path: PathBuf,
        /// The operating system error.
        source: std::io::Error,
    },
    /// A row does not have one value per column.
    #[error("{path}: row has {given} values but the header has {expected} variables")]
    RowLength {
        /// The CSV file.
        path: PathBuf,
        /// Values given.
        given: usize,
        /// Variables in the header.
        expected: usize,
    },
    /// A column name cannot be written as a plain CSV field.
    #[error("{path}: variable name {name:?} contains a comma, quote or line break")]
    BadName {
        /// The CSV file.
        path: PathBuf,
        /// The offending name.
        name: String,
    },
}

/// Writes the CSV history row by row.
#[derive(Debug)]
pub struct HistoryWriter {
    path: PathBuf,
    out: BufWriter<File>,
    columns: usize,
    rows: usize,
}

impl HistoryWriter {
    /// Creates (truncating) `path` and writes the header `Time,<names…>`.
    pub fn create(path: &Path, names: &[String]) -> Result<Self, HistoryError> {
        if let Some(name) = names.iter().find(|n| n.contains([',', '"', '\n', '\r'])) {
            return Err(HistoryError::BadName {
                path: path.to_path_buf(),
                name: name.clone(),
            });
        }
        let io = |source| HistoryError::Io {
            path: path.to_path_buf(),
            source,
        };
        let file = File::create(path).map_err(io)?;
        let mut writer = HistoryWriter {
            path: path.to_path_buf(),
            out: BufWriter::new(file),
            columns: names.len(),
            rows: 0,
        };
        let mut line = String::from("Time");
        for name in names {
            line.push(',');
            line.push_str(name);
        }
        writer.write_line(&line)?;
        Ok(writer)
    }

    fn write_line(&mut self, line: &str) -> Result<(), HistoryError> {
        let result = writeln!(self.out, "{line}").and_then(|()| self.out.flush());
        result.map_err(|source| HistoryError::Io {
            path: self.path.clone(),
            source,
        })
    }

    /// Appends one row (`time`, then one value per variable) and flushes it.
    pub fn write_row(&mut self, time: f64, values: &[f64]) -> Result<(), HistoryError> {
        if values.len() != self.columns {
            return Err(HistoryError::RowLength {
                path: self.path.clone(),
                given: values.len(),
                expected: self.columns,
            });
        }
        let mut line = format!("{time:?}");
        for value in values {
            line.push(',');
            line.push_str(&format!("{value:?}"));
        }
        self.write_line(&line)?;
        self.rows += 1;
        Ok(())
    }

    /// Takes over the first `rows` rows of `previous`, a file with this writer's header (the
    /// history of an interrupted run being continued): its lines are copied unchanged.
    pub fn adopt_rows(&mut self, previous: &Path, rows: usize) -> Result<(), HistoryError> {
        let io = |source| HistoryError::Io {
            path: previous.to_path_buf(),
            source,
        };
        let text = std::fs::read_to_string(previous).map_err(io)?;
        let mut lines = text.lines();
        let header = lines.next().unwrap_or_default();
        let columns = header.split(',').count().saturating_sub(1);
        if columns != self.columns {
            return Err(HistoryError::RowLength {
                path: previous.to_path_buf(),
                given: columns,
                expected: self.columns,
            });
        }
        let kept: Vec<&str> = lines.take(rows).collect();
        if kept.len() < rows {
            return Err(io(std::io::Error::new(
                std::io::ErrorKind::UnexpectedEof,
                format!("{rows} rows expected, {} found", kept.len()),
            )));
        }
        for line in kept {
            self.write_line(line)?;
        }
        self.rows = rows;
        Ok(())
    }

    /// Rows written so far (without the header).
    pub fn rows_written(&self) -> usize {
        self.rows
    }

    /// Flushes and syncs the file.
    pub fn finish(mut self) -> Result<(), HistoryError> {
        let path = self.path.clone();
        self.out
            .flush()
            .and_then(|()| self.out.get_ref().sync_all())
            .map_err(|source| HistoryError::Io { path, source })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(list: &[&str]) -> Vec<String> {
        list.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn rows_round_trip_exactly_and_are_on_disk_before_finish() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("history.csv");
        let mut writer =
            HistoryWriter::create(&path, &names(&["Kinetic_Energy", "Max_Damage"])).unwrap();
        // Values chosen to need all 17 significant digits, a tiny and a huge exponent.
        let rows = [
            (0.0, [0.1 + 0.2, 1.0 / 3.0]),
            (1e-7, [f64::MIN_POSITIVE, -1.234_567_890_123_456_7e300]),
        ];
        for (t, v) in rows {
            writer.write_row(t, &v).unwrap();
        }
        // Read while the writer is still alive: every row must already be complete.
        let text = std::fs::read_to_string(&path).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines[0], "Time,Kinetic_Energy,Max_Damage");
        assert_eq!(lines.len(), 3);
        for (line, (t, v)) in lines[1..].iter().zip(rows) {
            let parsed: Vec<f64> = line.split(',').map(|f| f.parse().unwrap()).collect();
            assert_eq!(parsed, vec![t, v[0], v[1]]);
        }
        assert_eq!(writer.rows_written(), 2);
        writer.finish().unwrap();
    }

    #[test]
    fn wrong_row_length_and_bad_names_are_errors_naming_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("h.csv");
        let mut writer = HistoryWriter::create(&path, &names(&["A"])).unwrap();
        let err = writer.write_row(0.0, &[1.0, 2.0]).unwrap_err();
        assert!(err.to_string().contains("h.csv"), "{err}");
        assert!(err.to_string().contains("2 values"), "{err}");
        let err = HistoryWriter::create(&path, &names(&["a,b"])).unwrap_err();
        assert!(matches!(err, HistoryError::BadName { .. }));
    }
}
