//! Comparing two Exodus results files the way SEACAS `exodiff` does, driven by exodiff's
//! command (`.comp`) files as used in Peridigm's regression suite.
//!
//! Semantics (those of exodiff's command files and `Tolerance` class):
//!
//! * A value pair `(a, b)` is equal when `|a| <= floor` and `|b| <= floor`; otherwise
//!   - `relative v`: different if `|a − b| > v · max(|a|, |b|)` (equal if both are 0);
//!   - `absolute v`: different if `|a − b| > v`;
//!   - `combined v`: different if `|a − b| >= v · max(1, |a|, |b|)`;
//!   - `eigen_relative / eigen_absolute / eigen_combined v`: the same on `|a|` and `|b|`;
//!   - `ignore`: never different.
//!
//!   A NaN in either file is always a difference (exodiff reports NaNs unless told not to).
//! * Without a command file ([`ComparisonSpec::default`]) every global, nodal and element
//!   variable is compared with `relative 1e-6 floor 0`, coordinates with `absolute 1e-6`,
//!   times with `relative 1e-6 floor 1e-15`.
//! * With a command file, only the variable types that have a `… VARIABLES` line are compared.
//!   Under such a line, indented names restrict the comparison to exactly those variables
//!   (each with its own tolerance, or the section's); names prefixed with `!` are excluded;
//!   `(all)` compares every variable, listed ones with their own tolerances. A section line
//!   with no names compares every variable of that type.
//! * `DEFAULT TOLERANCE` sets the tolerance that later section lines start from (and that
//!   `TIME STEPS` and, once given, `COORDINATES` start from); values on a section line
//!   override it for that section, values on a variable line for that variable. A variable
//!   line with a type but no value, e.g. `VELX relative floor 1e-10`, keeps the section value.
//! * Keywords are case-insensitive and may be abbreviated to three letters; variable names
//!   are compared case-insensitively (exodiff's default; `CASE SENSITIVE` switches it off).
//! * Lines end at `#` (comment). A blank line ends a variable list, as in exodiff. exodiff
//!   requires variable lines to start with a tab; we accept any leading whitespace.
//!
//! Files are matched by position: nodes by index, element blocks by id (elements by index
//! inside the block), time steps by index, variables by name.

mod report;
mod spec;

use super::{ExodusError, ExodusFile};

pub use report::{ComparisonReport, QuantityKind, WorstDifference};
use spec::names_equal;
pub use spec::{ComparisonSpec, Tolerance, ToleranceKind, VariableSection};

/// Accumulates the worst difference of one quantity.
struct Tracker {
    worst: WorstDifference,
    worst_severity: f64,
}

impl Tracker {
    fn new(kind: QuantityKind, name: &str, block_id: Option<i64>, tolerance: Tolerance) -> Self {
        Tracker {
            worst: WorstDifference {
                kind,
                name: name.to_string(),
                block_id,
                step: None,
                index: 0,
                first: 0.0,
                second: 0.0,
                difference: 0.0,
                tolerance,
                failures: 0,
                compared: 0,
            },
            worst_severity: -1.0,
        }
    }

    /// Adds value pairs; `offset` is the index of the first pair within the quantity.
    fn add(&mut self, step: Option<usize>, offset: usize, first: &[f64], second: &[f64]) {
        let tol = self.worst.tolerance;
        for (i, (&a, &b)) in first.iter().zip(second).enumerate() {
            let index = offset + i;
            let difference = tol.difference(a, b);
            self.worst.compared += 1;
            if tol.exceeded(a, b) {
                self.worst.failures += 1;
            }
            if difference > self.worst_severity {
                self.worst_severity = difference;
                self.worst.step = step;
                self.worst.index = index;
                self.worst.first = a;
                self.worst.second = b;
                self.worst.difference = difference;
            }
        }
    }
}

/// Compares `first` with `second` as exodiff would with `spec` (see the module docs).
///
/// Errors only when reading values fails; differences are reported in the result.
pub fn compare(
    first: &ExodusFile,
    second: &ExodusFile,
    spec: &ComparisonSpec,
) -> Result<ComparisonReport, ExodusError> {
    compare_from(first, second, spec, None)
}

/// [`compare`] with frame k of `first` against frame k + `offset` of `second` when `offset` is
/// given (exodiff's `-TimeStepOffset`): a run that covers part of another's time span (a
/// restarted run against the uninterrupted one). `second` may then have more frames.
pub fn compare_from(
    first: &ExodusFile,
    second: &ExodusFile,
    spec: &ComparisonSpec,
    offset: Option<usize>,
) -> Result<ComparisonReport, ExodusError> {
    let names = |f: &ExodusFile| format!("{}", f.path.display());
    let mut c = Comparison {
        first,
        second,
        offset,
        ignore_case: spec.ignore_case,
        name_a: names(first),
        name_b: names(second),
        report: ComparisonReport::default(),
    };
    let same_nodes = c.coordinates(spec.coordinates);
    let block_pairs = c.blocks();
    c.node_sets();
    let steps = c.times(spec.time_steps);
    let global = c.select(
        QuantityKind::Global,
        &spec.global,
        &first.global_variable_names,
        &second.global_variable_names,
    );
    let nodal = c.select(
        QuantityKind::Nodal,
        &spec.nodal,
        &first.nodal_variable_names,
        &second.nodal_variable_names,
    );
    let element = c.select(
        QuantityKind::Element,
        &spec.element,
        &first.element_variable_names,
        &second.element_variable_names,
    );
    c.global_variables(&global, steps)?;
    if same_nodes {
        c.nodal_variables(&nodal, steps)?;
    }
    c.element_variables(&element, &block_pairs, steps)?;
    Ok(c.report)
}

/// A variable to compare: its index in the first file, in the second, and its tolerance.
type VariablePair = (usize, usize, Tolerance);

/// One comparison under way: the two files and the report so far.
struct Comparison<'a> {
    first: &'a ExodusFile,
    second: &'a ExodusFile,
    /// Frame k of `first` is compared with frame k + offset of `second` (see [`compare_from`]).
    offset: Option<usize>,
    ignore_case: bool,
    /// The files' paths, for messages.
    name_a: String,
    name_b: String,
    report: ComparisonReport,
}

impl Comparison<'_> {
    /// Compares the dimension and the coordinates; returns whether the node counts match (the
    /// nodal variables are compared only then).
    fn coordinates(&mut self, tolerance: Tolerance) -> bool {
        let (first, second) = (self.first, self.second);
        let (name_a, name_b) = (&self.name_a, &self.name_b);
        let report = &mut self.report;
        if first.dimension != second.dimension {
            report.structural.push(format!(
                "spatial dimension {} in {name_a} but {} in {name_b}",
                first.dimension, second.dimension
            ));
        }
        let same_nodes = first.coordinates.len() == second.coordinates.len();
        if !same_nodes {
            report.structural.push(format!(
                "{} nodes in {name_a} but {} in {name_b}",
                first.coordinates.len(),
                second.coordinates.len()
            ));
        } else {
            for (axis, label) in ["X", "Y", "Z"]
                .iter()
                .enumerate()
                .take(first.dimension.max(1))
            {
                let mut t = Tracker::new(QuantityKind::Coordinate, label, None, tolerance);
                let a: Vec<f64> = first.coordinates.iter().map(|c| c[axis]).collect();
                let b: Vec<f64> = second.coordinates.iter().map(|c| c[axis]).collect();
                t.add(None, 0, &a, &b);
                report.quantities.push(t.worst);
            }
        }
        same_nodes
    }

    /// Matches the element blocks by id and compares their sizes, types and connectivity;
    /// returns the (first, second) index pairs of the blocks whose element variables can be
    /// compared.
    fn blocks(&mut self) -> Vec<(usize, usize)> {
        let (first, second) = (self.first, self.second);
        let (name_a, name_b) = (&self.name_a, &self.name_b);
        let report = &mut self.report;
        let mut block_pairs = Vec::new();
        for (ia, block) in first.blocks.iter().enumerate() {
            match second.blocks.iter().position(|b| b.id == block.id) {
                None => report.structural.push(format!(
                    "element block {} of {name_a} is missing in {name_b}",
                    block.id
                )),
                Some(ib) => {
                    let other = &second.blocks[ib];
                    if block.num_elements() != other.num_elements() {
                        report.structural.push(format!(
                            "element block {} has {} elements in {name_a} but {} in {name_b}",
                            block.id,
                            block.num_elements(),
                            other.num_elements()
                        ));
                        continue;
                    }
                    // exodiff's default "short" type check: compare up to the shorter name.
                    let n = block.element_type.len().min(other.element_type.len());
                    if !block.element_type[..n].eq_ignore_ascii_case(&other.element_type[..n]) {
                        report.structural.push(format!(
                            "element block {} is {} in {name_a} but {} in {name_b}",
                            block.id, block.element_type, other.element_type
                        ));
                    }
                    if block.connectivity != other.connectivity {
                        report.structural.push(format!(
                            "element block {} has different connectivity",
                            block.id
                        ));
                    }
                    block_pairs.push((ia, ib));
                }
            }
        }
        for block in &second.blocks {
            if !first.blocks.iter().any(|b| b.id == block.id) {
                report.structural.push(format!(
                    "element block {} of {name_b} is missing in {name_a}",
                    block.id
                ));
            }
        }
        block_pairs
    }

    /// Node sets are compared where both files have them. A set present in only one file is
    /// a warning: Peridigm does not write deck-defined node sets to its results (its gold
    /// files have none) while peridyn does, and the sets carry no results to compare.
    fn node_sets(&mut self) {
        let (name_a, name_b) = (&self.name_a, &self.name_b);
        let report = &mut self.report;
        for set in &self.first.node_sets {
            match self.second.node_sets.iter().find(|s| s.id == set.id) {
                None => report.warnings.push(format!(
                    "node set {} ({}) of {name_a} is not in {name_b}",
                    set.id, set.name
                )),
                Some(other) => {
                    let mut a = set.nodes.clone();
                    let mut b = other.nodes.clone();
                    a.sort_unstable();
                    b.sort_unstable();
                    if a != b {
                        report.structural.push(format!(
                            "node set {} ({}) has different nodes ({} vs {})",
                            set.id,
                            set.name,
                            set.nodes.len(),
                            other.nodes.len()
                        ));
                    }
                }
            }
        }
    }

    /// Compares the step counts and the times of the common steps; returns their number.
    fn times(&mut self, tolerance: Tolerance) -> usize {
        let (first, second) = (self.first, self.second);
        let offset = self.offset.unwrap_or(0);
        let available = second.times.len().saturating_sub(offset);
        let steps = first.times.len().min(available);
        let mismatch = match self.offset {
            None => first.times.len() != second.times.len(),
            Some(_) => first.times.len() > available,
        };
        if mismatch {
            self.report.structural.push(format!(
                "{} time steps in {} but {} in {}",
                first.times.len(),
                self.name_a,
                second.times.len(),
                self.name_b
            ));
        }
        if steps > 0 {
            let mut t = Tracker::new(QuantityKind::Time, "time", None, tolerance);
            for step in 0..steps {
                t.add(
                    Some(step),
                    0,
                    &first.times[step..=step],
                    &second.times[step + offset..=step + offset],
                );
            }
            self.report.quantities.push(t.worst);
        }
        steps
    }

    /// The variables of one kind to compare under `section`, matched by name; listed
    /// variables missing from the first file are mismatches, variables only in the second
    /// file warnings.
    fn select(
        &mut self,
        kind: QuantityKind,
        section: &Option<VariableSection>,
        names_a: &[String],
        names_b: &[String],
    ) -> Vec<VariablePair> {
        let Some(section) = section else {
            return Vec::new();
        };
        let ignore_case = self.ignore_case;
        let (name_a, name_b) = (&self.name_a, &self.name_b);
        let report = &mut self.report;
        for (listed, _) in &section.listed {
            let in_a = names_a.iter().any(|n| names_equal(n, listed, ignore_case));
            let in_b = names_b.iter().any(|n| names_equal(n, listed, ignore_case));
            if !in_a && in_b {
                report.structural.push(format!(
                    "{kind} variable '{listed}' (from the command file) is not in {name_a}"
                ));
            } else if !in_a {
                // Listed but in neither file (e.g. a command file shared by decks that write
                // different variables): there is nothing to compare.
                report.warnings.push(format!(
                    "{kind} variable '{listed}' (from the command file) is in neither file"
                ));
            }
        }
        let mut pairs = Vec::new();
        for (ia, name) in names_a.iter().enumerate() {
            let Some(tol) = section.tolerance_for(name, ignore_case) else {
                continue;
            };
            match names_b
                .iter()
                .position(|n| names_equal(n, name, ignore_case))
            {
                Some(ib) => pairs.push((ia, ib, tol)),
                None => report
                    .structural
                    .push(format!("{kind} variable '{name}' is missing in {name_b}")),
            }
        }
        for name in names_b {
            if section.tolerance_for(name, ignore_case).is_some()
                && !names_a.iter().any(|n| names_equal(n, name, ignore_case))
            {
                report
                    .warnings
                    .push(format!("{kind} variable '{name}' is only in {name_b}"));
            }
        }
        pairs
    }

    /// Compares the selected global variables over the common steps.
    fn global_variables(
        &mut self,
        global: &[VariablePair],
        steps: usize,
    ) -> Result<(), ExodusError> {
        if global.is_empty() {
            return Ok(());
        }
        let (first, second) = (self.first, self.second);
        let mut trackers: Vec<Tracker> = global
            .iter()
            .map(|&(ia, _, tol)| {
                Tracker::new(
                    QuantityKind::Global,
                    &first.global_variable_names[ia],
                    None,
                    tol,
                )
            })
            .collect();
        for step in 0..steps {
            let a = first.global_values(step)?;
            let b = second.global_values(step + self.offset.unwrap_or(0))?;
            for (t, &(ia, ib, _)) in trackers.iter_mut().zip(global) {
                t.add(Some(step), ia, &a[ia..=ia], &b[ib..=ib]);
            }
        }
        self.report
            .quantities
            .extend(trackers.into_iter().map(|t| t.worst));
        Ok(())
    }

    /// Compares the selected nodal variables over the common steps.
    fn nodal_variables(&mut self, nodal: &[VariablePair], steps: usize) -> Result<(), ExodusError> {
        let (first, second) = (self.first, self.second);
        for &(ia, ib, tol) in nodal {
            let mut t = Tracker::new(
                QuantityKind::Nodal,
                &first.nodal_variable_names[ia],
                None,
                tol,
            );
            for step in 0..steps {
                t.add(
                    Some(step),
                    0,
                    &first.nodal_values(step, ia)?,
                    &second.nodal_values(step + self.offset.unwrap_or(0), ib)?,
                );
            }
            self.report.quantities.push(t.worst);
        }
        Ok(())
    }

    /// Compares the selected element variables block by block over the common steps.
    fn element_variables(
        &mut self,
        element: &[VariablePair],
        block_pairs: &[(usize, usize)],
        steps: usize,
    ) -> Result<(), ExodusError> {
        let (first, second) = (self.first, self.second);
        for &(ia, ib, tol) in element {
            let name = &first.element_variable_names[ia];
            for &(ba, bb) in block_pairs {
                let block_id = first.blocks[ba].id;
                let defined_a = first.element_variable_defined[ba][ia];
                let defined_b = second.element_variable_defined[bb][ib];
                if defined_a != defined_b {
                    self.report.structural.push(format!(
                        "element variable '{name}' is defined on block {block_id} in only one file"
                    ));
                    continue;
                }
                if !defined_a {
                    continue;
                }
                let mut t = Tracker::new(QuantityKind::Element, name, Some(block_id), tol);
                for step in 0..steps {
                    let a = first.element_values(step, ia, ba)?.unwrap_or_default();
                    let b = second
                        .element_values(step + self.offset.unwrap_or(0), ib, bb)?
                        .unwrap_or_default();
                    t.add(Some(step), 0, &a, &b);
                }
                self.report.quantities.push(t.worst);
            }
        }
        Ok(())
    }
}
