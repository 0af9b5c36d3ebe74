//! The layout of a system distributed over the MPI ranks, as PETSc's parallel objects want it,
//! and the `MATMPIAIJ` matrices built on it.
//!
//! PETSc gives each rank a contiguous range of rows, rank 0 the first. peridyn numbers its
//! distributed unknowns otherwise: a rank's unknowns are the free dofs of the points it owns,
//! with global ids `3·(run-wide point) + component`, with holes where dofs are prescribed and
//! the ranks' points interleaved through the model. [`Layout`] renumbers them: rank r's
//! unknowns, in their local order, become the PETSc rows `start_r..start_r + n_r` with
//! `start_r = Σ_{q<r} n_q`, and an `AOMAPPING` application ordering (the kind that allows
//! holes) maps a global id, such as a tangent column that couples to another rank's unknown,
//! to its PETSc row. Matrices whose columns are this rank's own unknowns (the 3×3 block
//! diagonal, the one-hop operator restricted to the rank) need only the shift by `start_r`
//! ([`Columns::Local`]).
//!
//! Every function here is collective over `MPI_COMM_WORLD` unless it says otherwise.

use mpi::collective::{CommunicatorCollectives, SystemOperation};
use mpi::topology::SimpleCommunicator;

use super::runtime::{check, PetscError, Turn};
use super::sys;
use crate::backend::Csr;

/// How the columns of a matrix handed to [`DistributedMatrix::new`] are numbered.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Columns {
    /// Global ids of the unknowns (`3·(run-wide point) + component`), the assembled tangent's.
    Global,
    /// This rank's unknowns `0..n` (the matrix couples no two ranks).
    Local,
}

/// This rank's rows in PETSc's numbering of a distributed system (see the module docs).
pub(super) struct Layout {
    /// First PETSc row of this rank.
    start: usize,
    /// Rows of this rank.
    local: usize,
    /// Rows of all ranks.
    global: usize,
    /// Global id → PETSc row (null when no global ids were given).
    ao: sys::AO,
}

/// `a` as a `PetscInt`, or the error of a system too large for PETSc's indices.
pub(super) fn petsc_int(a: usize) -> Result<sys::PetscInt, PetscError> {
    sys::PetscInt::try_from(a).map_err(|_| PetscError {
        code: -1,
        message: format!(
            "index {a} exceeds PETSc's {}-bit indices",
            8 * std::mem::size_of::<sys::PetscInt>()
        ),
    })
}

/// Σ over the ranks of `local` (collective).
pub(super) fn sum_over_ranks(local: f64) -> f64 {
    let mut total = 0.0;
    SimpleCommunicator::world().all_reduce_into(&local, &mut total, SystemOperation::sum());
    total
}

impl Layout {
    /// The layout of `local` rows on this rank whose global ids are `global_ids` (one per row,
    /// or `None` when only [`Columns::Local`] matrices will be built).
    pub(super) fn new(
        turn: &Turn,
        local: usize,
        global_ids: Option<&[usize]>,
    ) -> Result<Self, PetscError> {
        let world = SimpleCommunicator::world();
        let count = local as u64;
        let mut inclusive = 0u64;
        world.scan_into(&count, &mut inclusive, SystemOperation::sum());
        let mut global = 0u64;
        world.all_reduce_into(&count, &mut global, SystemOperation::sum());
        let mut layout = Self {
            start: (inclusive - count) as usize,
            local,
            global: global as usize,
            ao: std::ptr::null_mut(),
        };
        petsc_int(layout.global)?;
        if let Some(ids) = global_ids {
            let application: Vec<sys::PetscInt> = ids
                .iter()
                .map(|&i| petsc_int(i))
                .collect::<Result<_, _>>()?;
            let petsc: Vec<sys::PetscInt> = (layout.start..layout.start + local)
                .map(petsc_int)
                .collect::<Result<_, _>>()?;
            // SAFETY: arrays of `local` entries that outlive the call (PETSc copies them).
            check(unsafe {
                sys::AOCreateMapping(
                    turn.comm_world(),
                    petsc_int(local)?,
                    application.as_ptr(),
                    petsc.as_ptr(),
                    &mut layout.ao,
                )
            })?;
        }
        Ok(layout)
    }

    /// Rows of this rank.
    pub(super) fn local(&self) -> usize {
        self.local
    }

    /// Rows of all ranks.
    pub(super) fn global(&self) -> usize {
        self.global
    }

    /// The PETSc row of this rank's row `r`.
    pub(super) fn row(&self, r: usize) -> usize {
        self.start + r
    }

    /// `columns` (numbered as `numbering` says) as PETSc rows (not collective).
    fn to_petsc(
        &self,
        columns: &[usize],
        numbering: Columns,
    ) -> Result<Vec<sys::PetscInt>, PetscError> {
        let shift = match numbering {
            Columns::Local => self.start,
            Columns::Global => 0,
        };
        let mut mapped: Vec<sys::PetscInt> = columns
            .iter()
            .map(|&c| petsc_int(shift + c))
            .collect::<Result<_, _>>()?;
        if numbering == Columns::Global {
            if self.ao.is_null() {
                return Err(PetscError {
                    code: -1,
                    message: "a matrix with global column ids on a layout without them".into(),
                });
            }
            // SAFETY: a live AO; the array holds `mapped.len()` entries, mapped in place. An
            // AOMAPPING holds the whole ordering on every rank, so the call is local.
            check(unsafe {
                sys::AOApplicationToPetsc(self.ao, petsc_int(mapped.len())?, mapped.as_mut_ptr())
            })?;
            if let Some(k) = mapped.iter().position(|&c| c < 0) {
                return Err(PetscError {
                    code: -1,
                    message: format!(
                        "the matrix couples to unknown {} that no rank holds",
                        columns[k]
                    ),
                });
            }
        }
        Ok(mapped)
    }

    /// A vector of this layout without storage, for `VecPlaceArray`.
    pub(super) fn vector_without_array(&self, turn: &Turn) -> Result<sys::PetscVec, PetscError> {
        let mut v: sys::PetscVec = std::ptr::null_mut();
        // SAFETY: a vector of this rank's rows whose array is placed before use.
        check(unsafe {
            sys::VecCreateMPIWithArray(
                turn.comm_world(),
                1,
                petsc_int(self.local)?,
                petsc_int(self.global)?,
                std::ptr::null(),
                &mut v,
            )
        })?;
        Ok(v)
    }

    /// A vector of this layout with its own storage.
    pub(super) fn vector(&self, turn: &Turn) -> Result<sys::PetscVec, PetscError> {
        let mut v: sys::PetscVec = std::ptr::null_mut();
        // SAFETY: a new vector of this rank's rows.
        check(unsafe {
            sys::VecCreateMPI(
                turn.comm_world(),
                petsc_int(self.local)?,
                petsc_int(self.global)?,
                &mut v,
            )
        })?;
        Ok(v)
    }
}

impl Drop for Layout {
    fn drop(&mut self) {
        if !self.ao.is_null() && super::runtime::alive() {
            // SAFETY: created by `new`, destroyed once (PETSc nulls the handle).
            unsafe { sys::AODestroy(&mut self.ao) };
        }
    }
}

/// A `MATMPIAIJ` holding this rank's rows of a [`Csr`], whose values are refilled through its
/// fixed pattern ([`DistributedMatrix::set_values`]).
pub(super) struct DistributedMatrix {
    /// The matrix; its owner (the solver's objects) destroys it.
    pub matrix: sys::Mat,
    /// PETSc row of every local row.
    rows: Vec<sys::PetscInt>,
    /// The source's row offsets.
    offsets: Vec<usize>,
    /// PETSc column of every entry, in the source's order.
    columns: Vec<sys::PetscInt>,
}

impl DistributedMatrix {
    /// The matrix of `matrix`'s rows (this rank's rows of `layout`, columns numbered as
    /// `numbering` says) with its values.
    pub(super) fn new(
        turn: &Turn,
        layout: &Layout,
        matrix: &Csr,
        numbering: Columns,
    ) -> Result<Self, PetscError> {
        if matrix.nrows != layout.local() {
            return Err(PetscError {
                code: -1,
                message: format!(
                    "a matrix of {} rows for {} unknowns on this rank",
                    matrix.nrows,
                    layout.local()
                ),
            });
        }
        let columns = layout.to_petsc(&matrix.columns, numbering)?;
        // MatCreateMPIAIJWithArrays wants the columns of each row sorted.
        let mut sorted_columns = Vec::with_capacity(columns.len());
        let mut sorted_values = Vec::with_capacity(columns.len());
        for r in 0..matrix.nrows {
            let mut row: Vec<usize> = (matrix.offsets[r]..matrix.offsets[r + 1]).collect();
            row.sort_by_key(|&k| columns[k]);
            sorted_columns.extend(row.iter().map(|&k| columns[k]));
            sorted_values.extend(row.iter().map(|&k| matrix.values[k]));
        }
        let offsets: Vec<sys::PetscInt> = matrix
            .offsets
            .iter()
            .map(|&o| petsc_int(o))
            .collect::<Result<_, _>>()?;
        let local = petsc_int(layout.local())?;
        let mut out = Self {
            matrix: std::ptr::null_mut(),
            rows: (0..matrix.nrows)
                .map(|r| petsc_int(layout.row(r)))
                .collect::<Result<_, _>>()?,
            offsets: matrix.offsets.clone(),
            columns,
        };
        // SAFETY: PETSc copies the arrays, which outlive the call.
        check(unsafe {
            sys::MatCreateMPIAIJWithArrays(
                turn.comm_world(),
                local,
                local,
                petsc_int(layout.global())?,
                petsc_int(layout.global())?,
                offsets.as_ptr(),
                sorted_columns.as_ptr(),
                sorted_values.as_ptr(),
                &mut out.matrix,
            )
        })?;
        Ok(out)
    }

    /// Writes `values` (in the order of the source [`Csr`]'s entries) into the matrix; the
    /// caller assembles it (`MatAssemblyBegin/End`, collective) before use. Not collective.
    pub(super) fn set_values(&self, values: &[f64]) -> Result<(), PetscError> {
        if values.len() != self.columns.len() {
            return Err(PetscError {
                code: -1,
                message: format!(
                    "{} values for a pattern of {} entries",
                    values.len(),
                    self.columns.len()
                ),
            });
        }
        for (r, &row) in self.rows.iter().enumerate() {
            let range = self.offsets[r]..self.offsets[r + 1];
            // SAFETY: a live matrix; row, columns and values of one row of its own pattern
            // (this rank's rows only, so nothing is sent at assembly).
            check(unsafe {
                sys::MatSetValues(
                    self.matrix,
                    1,
                    &row,
                    petsc_int(range.len())?,
                    self.columns[range.clone()].as_ptr(),
                    values[range].as_ptr(),
                    sys::InsertMode_INSERT_VALUES,
                )
            })?;
        }
        Ok(())
    }
}
