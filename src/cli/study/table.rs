//! The study's table: one row per variant with its values of the variations, its status,
//! cost and measured errors, printed aligned on the terminal and written as CSV.

/// One cell: the terminal shows `short`, the CSV `full` (a failure's whole reason).
#[derive(Debug, Clone, PartialEq)]
pub struct Cell {
    /// Text on the terminal.
    pub short: String,
    /// Text in the CSV.
    pub full: String,
}

impl Cell {
    /// The same text in both.
    pub fn new(text: impl Into<String>) -> Cell {
        let text = text.into();
        Cell {
            short: text.clone(),
            full: text,
        }
    }
}

/// Column names and rows.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Table {
    /// Column names.
    pub header: Vec<String>,
    /// Rows, one cell per column.
    pub rows: Vec<Vec<Cell>>,
    /// Columns the terminal leaves out (long texts such as the folder).
    pub csv_only: Vec<usize>,
}

/// A number in a table cell: empty when unknown, else 4 significant digits.
pub fn number(value: Option<f64>) -> String {
    match value {
        None => String::new(),
        Some(0.0) => "0".to_string(),
        Some(v) if v.is_nan() => "NaN".to_string(),
        Some(v) if (1e-3..1e5).contains(&v.abs()) => format!("{}", round_significant(v, 4)),
        Some(v) => format!("{v:.3e}"),
    }
}

fn round_significant(v: f64, digits: i32) -> f64 {
    let scale = 10f64.powi(digits - 1 - v.abs().log10().floor() as i32);
    let rounded = (v * scale).round() / scale;
    // Through text, so 0.1 + noise prints as 0.1.
    format!("{rounded:.12}").parse().unwrap_or(rounded)
}

impl Table {
    /// The table aligned in columns (the terminal's `short` texts; every column but the
    /// CSV-only ones).
    pub fn render(&self) -> String {
        let shown: Vec<usize> = (0..self.header.len())
            .filter(|c| !self.csv_only.contains(c))
            .collect();
        let width = |c: usize| {
            self.rows
                .iter()
                .map(|r| r[c].short.chars().count())
                .chain([self.header[c].chars().count()])
                .max()
                .unwrap_or(0)
        };
        let widths: Vec<usize> = shown.iter().map(|&c| width(c)).collect();
        let line = |cells: Vec<&str>| {
            cells
                .iter()
                .zip(&widths)
                .map(|(text, w)| format!("{text:<w$}"))
                .collect::<Vec<_>>()
                .join("  ")
                .trim_end()
                .to_string()
        };
        let mut out = line(shown.iter().map(|&c| self.header[c].as_str()).collect());
        out.push('\n');
        out.push_str(
            &"-".repeat(widths.iter().sum::<usize>() + 2 * widths.len().saturating_sub(1)),
        );
        out.push('\n');
        for row in &self.rows {
            out.push_str(&line(
                shown.iter().map(|&c| row[c].short.as_str()).collect(),
            ));
            out.push('\n');
        }
        out
    }

    /// The table as CSV (RFC 4180 quoting; the `full` texts, every column).
    pub fn csv(&self) -> String {
        let quote = |text: &str| {
            if text.contains([',', '"', '\n']) {
                format!("\"{}\"", text.replace('"', "\"\""))
            } else {
                text.to_string()
            }
        };
        let mut out = self
            .header
            .iter()
            .map(|h| quote(h))
            .collect::<Vec<_>>()
            .join(",");
        out.push('\n');
        for row in &self.rows {
            out.push_str(
                &row.iter()
                    .map(|c| quote(&c.full))
                    .collect::<Vec<_>>()
                    .join(","),
            );
            out.push('\n');
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_keep_four_significant_digits() {
        assert_eq!(number(None), "");
        assert_eq!(number(Some(0.0)), "0");
        assert_eq!(number(Some(1.234567)), "1.235");
        assert_eq!(number(Some(12345.6)), "12350");
        assert_eq!(number(Some(2.5e-7)), "2.500e-7");
    }

    #[test]
    fn the_terminal_aligns_and_the_csv_quotes() {
        let table = Table {
            header: vec!["variant".into(), "status".into(), "folder".into()],
            rows: vec![vec![
                Cell::new("0"),
                Cell {
                    short: "failed".into(),
                    full: "failed: a, \"b\"".into(),
                },
                Cell::new("out/variant_000"),
            ]],
            csv_only: vec![2],
        };
        let shown = table.render();
        assert_eq!(shown.lines().next().unwrap(), "variant  status");
        assert_eq!(shown.lines().nth(2).unwrap(), "0        failed");
        assert_eq!(
            table.csv(),
            "variant,status,folder\n0,\"failed: a, \"\"b\"\"\",out/variant_000\n"
        );
    }
}
