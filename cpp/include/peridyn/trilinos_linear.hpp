// C++ side of the cxx bridge in src/backend/trilinos/ffi.rs: an Epetra matrix built from a
// Rust CSR, an Ifpack/ML preconditioner and a Belos solve. Adaptation only: every choice
// (which method, which preconditioner, tolerances, validation of the input) is made in Rust.
// Only forward declarations of Trilinos types appear here, so the cxx-generated translation
// unit does not parse the Trilinos headers.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include <mpi.h>

#include "rust/cxx.h"

class Epetra_Comm;
class Epetra_Map;
class Epetra_FECrsMatrix;
class Epetra_Operator;
class Epetra_RowMatrix;
namespace Teuchos {
class ParameterList;
}

namespace peridyn {
namespace trilinos {

struct BelosOutcome;
struct MlHierarchy;
struct Parameter;

// The shape of an ML hierarchy.
struct MultigridShape {
  // Levels, the finest and the coarsest included.
  int levels = 0;
  // ML's operator complexity, the sum of the levels' entries over the finest level's.
  double operator_complexity = 0.0;
};

// One distributed matrix with its communicator, row map and (optional) preconditioner. Member
// order is destruction order in reverse: the preconditioner goes before the matrix and the
// near-null space it references, the map before the communicator.
class LinearSystem {
public:
  LinearSystem();
  ~LinearSystem();
  std::unique_ptr<Epetra_Comm> comm;
  std::unique_ptr<Epetra_Map> map;
  std::unique_ptr<Epetra_FECrsMatrix> matrix;
  // ML's near-null space (column-major, one vector after the other over the owned rows):
  // ML reads it through a raw pointer, so it lives as long as the preconditioner.
  std::vector<double> null_space;
  std::unique_ptr<Epetra_Operator> preconditioner;
};

// ML smoothed aggregation (ML_Epetra::SetDefaults("SA"), output off) on `matrix` with
// `pde_equations` unknowns per node (the smallest value over the matrix's ranks is used, so
// one rank with split points makes every rank aggregate single unknowns) and, when
// `null_space` is not empty, the pre-computed near-null space of `modes` column-major vectors
// in it (`null space: type` = `pre-computed`). `null_space` must outlive the preconditioner.
// `shape`, if given, receives the hierarchy's levels and operator complexity.
std::unique_ptr<Epetra_Operator> build_ml(const Epetra_RowMatrix &matrix,
                                          std::int32_t pde_equations,
                                          std::vector<double> &null_space, std::int32_t modes,
                                          MultigridShape *shape);

// The sublist of `top` reached through the sublist names `path` (created as needed).
Teuchos::ParameterList &sublist_at(Teuchos::ParameterList &top,
                                   const rust::Vec<rust::String> &path);
// Sets every entry of `parameters` (typed, each in its sublist) in `top`.
void fill_parameter_list(Teuchos::ParameterList &top, rust::Slice<const Parameter> parameters);

// The communicator whose Fortran handle (MPI_Comm_c2f) Rust passed. MPI is started and
// finalised by Rust (src/mpi_session.rs); Epetra_MpiComm borrows the communicator.
MPI_Comm communicator_from_handle(std::int32_t handle);

// Builds the row map from `owned_rows` (global ids this process owns) on the communicator
// with the Fortran handle `communicator`, then fills an Epetra_FECrsMatrix with the CSR rows `row_gids`
// (row_offsets / column_gids / values; rows owned by another process are sent to it by
// GlobalAssemble).
// The matrix is allocated with each row's exact length (static profile), so that filling it
// completes without copying the rows into new storage. Offsets and column ids above Epetra's
// `int` range are an error.
std::unique_ptr<LinearSystem>
new_linear_system(std::int32_t communicator, rust::Slice<const std::int32_t> owned_rows,
                  rust::Slice<const std::int32_t> row_gids,
                  rust::Slice<const std::size_t> row_offsets,
                  rust::Slice<const std::size_t> column_gids,
                  rust::Slice<const double> values);

// Writes new values into the matrix of `system`, whose pattern is the CSR (row_gids,
// row_offsets, column_gids) it was built from: the storage is reused, not rebuilt. The
// preconditioner, built on the old values, is dropped.
void refill_linear_system(LinearSystem &system, rust::Slice<const std::int32_t> row_gids,
                          rust::Slice<const std::size_t> row_offsets,
                          rust::Slice<const std::size_t> column_gids,
                          rust::Slice<const double> values);

// y = A x over the owned rows (the Epetra mat-vec, for checks from Rust).
void multiply(const LinearSystem &system, rust::Slice<const double> x,
              rust::Slice<double> y);

// Ifpack point relaxation (Jacobi, `sweeps` sweeps).
void set_jacobi_preconditioner(LinearSystem &system, std::int32_t sweeps);
// Ifpack incomplete LU with `fill_level` levels of fill.
void set_ilu_preconditioner(LinearSystem &system, std::int32_t fill_level);
// ML smoothed aggregation (build_ml) with `pde_equations` unknowns per node and, when
// `null_space` (column-major, `modes` vectors over the owned rows) is not empty, that
// near-null space, kept in the system for ML's lifetime; returns the hierarchy's shape.
MlHierarchy set_ml_preconditioner(LinearSystem &system, std::int32_t pde_equations,
                                  rust::Slice<const double> null_space, std::int32_t modes);

// Belos BlockCGSolMgr (left preconditioner) or BlockGmresSolMgr (right preconditioner) with
// the parameter list built from `parameters` (block size, tolerance, limits and residual
// scaling are all chosen in Rust). `x` is the initial guess on entry and the solution on
// return.
BelosOutcome belos_solve(const LinearSystem &system, bool gmres,
                         rust::Slice<const double> rhs, rust::Slice<double> x,
                         rust::Slice<const Parameter> parameters);

} // namespace trilinos
} // namespace peridyn
