//! What a comparison found: the worst difference of every quantity compared.

use std::cmp::Ordering;
use std::fmt;

use super::Tolerance;

/// Which kind of quantity a difference is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum QuantityKind {
    /// A node coordinate.
    Coordinate,
    /// The time value of a step.
    Time,
    /// A global variable.
    Global,
    /// A nodal variable.
    Nodal,
    /// An element variable.
    Element,
}

impl fmt::Display for QuantityKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            QuantityKind::Coordinate => "coordinate",
            QuantityKind::Time => "time",
            QuantityKind::Global => "global",
            QuantityKind::Nodal => "nodal",
            QuantityKind::Element => "element",
        })
    }
}

/// The largest difference found for one quantity.
#[derive(Debug, Clone, PartialEq)]
pub struct WorstDifference {
    /// Kind of quantity.
    pub kind: QuantityKind,
    /// Variable name (`X`/`Y`/`Z` for coordinates, `time` for times).
    pub name: String,
    /// Block id for element variables.
    pub block_id: Option<i64>,
    /// 0-based time step, where applicable.
    pub step: Option<usize>,
    /// 0-based node / element-in-block / global-variable index.
    pub index: usize,
    /// Value in the first file.
    pub first: f64,
    /// Value in the second file.
    pub second: f64,
    /// Difference in the tolerance's measure.
    pub difference: f64,
    /// The tolerance applied.
    pub tolerance: Tolerance,
    /// Number of values outside the tolerance.
    pub failures: usize,
    /// Number of values compared.
    pub compared: usize,
}

impl WorstDifference {
    /// Whether any value was outside the tolerance.
    pub fn failed(&self) -> bool {
        self.failures > 0
    }

    /// Difference relative to the tolerance (for ranking; ∞ for any difference at tolerance 0).
    pub fn severity(&self) -> f64 {
        if self.tolerance.value > 0.0 {
            self.difference / self.tolerance.value
        } else if self.difference > 0.0 {
            f64::INFINITY
        } else {
            0.0
        }
    }
}

impl fmt::Display for WorstDifference {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} {}", self.kind, self.name)?;
        if let Some(id) = self.block_id {
            write!(f, " (block {id})")?;
        }
        write!(
            f,
            ": worst difference {:.3e} ({}) at",
            self.difference, self.tolerance
        )?;
        if let Some(step) = self.step {
            write!(f, " step {step},")?;
        }
        write!(
            f,
            " index {}: {:e} vs {:e}",
            self.index, self.first, self.second
        )?;
        if self.failed() {
            write!(f, "; {} of {} values differ", self.failures, self.compared)?;
        }
        Ok(())
    }
}

/// The outcome of [`compare`].
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ComparisonReport {
    /// Worst difference of every compared quantity (coordinate axis, time, variable).
    pub quantities: Vec<WorstDifference>,
    /// Structural mismatches (counts, missing blocks or variables); any one fails.
    pub structural: Vec<String>,
    /// Notes that do not fail the comparison (e.g. variables only in the second file).
    pub warnings: Vec<String>,
}

impl ComparisonReport {
    /// True when there is no structural mismatch and every value is within tolerance.
    pub fn passed(&self) -> bool {
        self.structural.is_empty() && self.quantities.iter().all(|q| !q.failed())
    }

    /// Quantities with values outside tolerance, worst (by difference / tolerance) first.
    pub fn failures(&self) -> Vec<&WorstDifference> {
        let mut failed: Vec<&WorstDifference> =
            self.quantities.iter().filter(|q| q.failed()).collect();
        failed.sort_by(|a, b| {
            b.severity()
                .partial_cmp(&a.severity())
                .unwrap_or(Ordering::Equal)
        });
        failed
    }

    /// The worst difference recorded for `name` (case-insensitive), if compared.
    pub fn quantity(&self, kind: QuantityKind, name: &str) -> Option<&WorstDifference> {
        self.quantities
            .iter()
            .filter(|q| q.kind == kind && q.name.eq_ignore_ascii_case(name))
            .max_by(|a, b| {
                a.severity()
                    .partial_cmp(&b.severity())
                    .unwrap_or(Ordering::Equal)
            })
    }
}

impl fmt::Display for ComparisonReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let failures = self.failures();
        if self.passed() {
            writeln!(
                f,
                "PASSED: {} quantities compared, all within tolerance",
                self.quantities.len()
            )?;
        } else {
            writeln!(
                f,
                "FAILED: {} structural mismatch(es), {} of {} quantities outside tolerance",
                self.structural.len(),
                failures.len(),
                self.quantities.len()
            )?;
        }
        for s in &self.structural {
            writeln!(f, "  mismatch: {s}")?;
        }
        const SHOWN: usize = 10;
        for q in failures.iter().take(SHOWN) {
            writeln!(f, "  DIFF {q}")?;
        }
        if failures.len() > SHOWN {
            writeln!(f, "  … and {} more", failures.len() - SHOWN)?;
        }
        if failures.is_empty() {
            // Closest calls, so a pass can be judged too.
            let mut closest: Vec<&WorstDifference> = self.quantities.iter().collect();
            closest.sort_by(|a, b| {
                b.severity()
                    .partial_cmp(&a.severity())
                    .unwrap_or(Ordering::Equal)
            });
            for q in closest.iter().take(3).filter(|q| q.difference > 0.0) {
                writeln!(f, "  closest: {q}")?;
            }
        }
        for w in &self.warnings {
            writeln!(f, "  warning: {w}")?;
        }
        Ok(())
    }
}
