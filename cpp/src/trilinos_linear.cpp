// See cpp/include/peridyn/trilinos_linear.hpp. Errors from Epetra (negative return codes),
// Ifpack and ML become std::runtime_error, which cxx hands to Rust as Err.
#include "peridyn/trilinos_linear.hpp"
#include "peridyn/src/backend/trilinos/ffi.rs.h"

#include <mpi.h>

#include <algorithm>
#include <climits>
#include <stdexcept>
#include <string>
#include <vector>

#include <BelosBlockCGSolMgr.hpp>
#include <BelosBlockGmresSolMgr.hpp>
#include <BelosEpetraAdapter.hpp>
#include <BelosLinearProblem.hpp>
#include <Epetra_CrsGraph.h>
#include <Epetra_FECrsMatrix.h>
#include <Epetra_Map.h>
#include <Epetra_MpiComm.h>
#include <Epetra_Vector.h>
#include <Ifpack.h>
#include <Ifpack_Preconditioner.h>
#include <Teuchos_ParameterList.hpp>
#include <Teuchos_RCP.hpp>
#include <ml_MultiLevelPreconditioner.h>
#include <ml_struct.h>

namespace peridyn {
namespace trilinos {

namespace {

static_assert(sizeof(MPI_Fint) == sizeof(std::int32_t), "MPI_Fint is passed as a 32-bit integer");

void check(int code, const char *what) {
  if (code < 0) {
    throw std::runtime_error(std::string(what) + " failed with Epetra error code " +
                             std::to_string(code));
  }
}

// Ifpack's factory, initialised and computed on the system's matrix.
void set_ifpack(LinearSystem &system, const char *kind, Teuchos::ParameterList &params) {
  Ifpack factory;
  std::unique_ptr<Ifpack_Preconditioner> prec(factory.Create(kind, system.matrix.get(), 0));
  if (!prec) {
    throw std::runtime_error(std::string("Ifpack has no preconditioner \"") + kind + "\"");
  }
  check(prec->SetParameters(params), "Ifpack SetParameters");
  check(prec->Initialize(), "Ifpack Initialize");
  check(prec->Compute(), "Ifpack Compute");
  system.preconditioner = std::move(prec);
}

} // namespace

Teuchos::ParameterList &sublist_at(Teuchos::ParameterList &top,
                                   const rust::Vec<rust::String> &path) {
  Teuchos::ParameterList *list = &top;
  for (const auto &name : path) {
    list = &list->sublist(std::string(name));
  }
  return *list;
}

void fill_parameter_list(Teuchos::ParameterList &top, rust::Slice<const Parameter> parameters) {
  for (const auto &p : parameters) {
    Teuchos::ParameterList &list = sublist_at(top, p.path);
    const std::string name(p.name);
    switch (p.kind) {
    case ParameterKind::Text:
      list.set(name, std::string(p.text));
      break;
    case ParameterKind::Double:
      list.set(name, p.number);
      break;
    case ParameterKind::Int:
      list.set(name, static_cast<int>(p.integer));
      break;
    case ParameterKind::Bool:
      list.set(name, p.flag);
      break;
    }
  }
}

MPI_Comm communicator_from_handle(std::int32_t handle) {
  return MPI_Comm_f2c(static_cast<MPI_Fint>(handle));
}

LinearSystem::LinearSystem() = default;
LinearSystem::~LinearSystem() = default;

namespace {

int narrow(std::size_t value, const char *what) {
  if (value > static_cast<std::size_t>(INT_MAX)) {
    throw std::runtime_error(std::string(what) + " exceed Epetra's 32-bit indices (2^31 - 1)");
  }
  return static_cast<int>(value);
}

// The column ids of CSR row r as Epetra's ints, in `columns`.
void row_columns(rust::Slice<const std::size_t> row_offsets,
                 rust::Slice<const std::size_t> column_gids, std::size_t r,
                 std::vector<int> &columns) {
  columns.clear();
  for (std::size_t k = row_offsets[r]; k < row_offsets[r + 1]; ++k) {
    columns.push_back(narrow(column_gids[k], "the column ids"));
  }
}

// Writes the CSR values into the matrix built on the CSR's graph (entries that share a column
// are summed, as InsertGlobalValues sums them).
void fill_values(LinearSystem &system, rust::Slice<const std::int32_t> row_gids,
                 rust::Slice<const std::size_t> row_offsets,
                 rust::Slice<const std::size_t> column_gids, rust::Slice<const double> values) {
  check(system.matrix->PutScalar(0.0), "Epetra_CrsMatrix::PutScalar");
  std::vector<int> columns;
  for (std::size_t r = 0; r < row_gids.size(); ++r) {
    row_columns(row_offsets, column_gids, r, columns);
    check(system.matrix->SumIntoGlobalValues(row_gids[r], static_cast<int>(columns.size()),
                                             values.data() + row_offsets[r], columns.data()),
          "Epetra_CrsMatrix::SumIntoGlobalValues");
  }
}

} // namespace

std::unique_ptr<LinearSystem>
new_linear_system(std::int32_t communicator, rust::Slice<const std::int32_t> owned_rows,
                  rust::Slice<const std::int32_t> row_gids,
                  rust::Slice<const std::size_t> row_offsets,
                  rust::Slice<const std::size_t> column_gids,
                  rust::Slice<const double> values) {
  narrow(row_offsets[row_gids.size()], "the stored entries");
  auto system = std::make_unique<LinearSystem>();
  system->comm = std::make_unique<Epetra_MpiComm>(communicator_from_handle(communicator));
  system->map = std::make_unique<Epetra_Map>(-1, static_cast<int>(owned_rows.size()),
                                             owned_rows.data(), 0, *system->comm);
  std::vector<int> columns;
  const bool owned = row_gids.size() == owned_rows.size() &&
                     std::equal(row_gids.begin(), row_gids.end(), owned_rows.begin());
  if (owned) {
    // Every row is this rank's: the graph is built first with each row's exact length (one
    // allocation, nothing copied when it is completed), then the matrix on it, so that the
    // values sit in one array the refills write into.
    std::vector<int> lengths(row_gids.size());
    for (std::size_t r = 0; r < row_gids.size(); ++r) {
      lengths[r] = static_cast<int>(row_offsets[r + 1] - row_offsets[r]);
    }
    Epetra_CrsGraph graph(Copy, *system->map, lengths.data(), true);
    for (std::size_t r = 0; r < row_gids.size(); ++r) {
      row_columns(row_offsets, column_gids, r, columns);
      check(graph.InsertGlobalIndices(row_gids[r], static_cast<int>(columns.size()),
                                      columns.data()),
            "Epetra_CrsGraph::InsertGlobalIndices");
    }
    check(graph.FillComplete(), "Epetra_CrsGraph::FillComplete");
    system->matrix = std::make_unique<Epetra_FECrsMatrix>(Copy, graph);
    fill_values(*system, row_gids, row_offsets, column_gids, values);
    check(system->matrix->GlobalAssemble(), "Epetra_FECrsMatrix::GlobalAssemble");
    return system;
  }
  // Rows owned by other ranks are sent to them when the matrix is assembled.
  int longest_row = 0;
  for (std::size_t r = 0; r < row_gids.size(); ++r) {
    longest_row = std::max(longest_row, static_cast<int>(row_offsets[r + 1] - row_offsets[r]));
  }
  system->matrix = std::make_unique<Epetra_FECrsMatrix>(Copy, *system->map, longest_row);
  for (std::size_t r = 0; r < row_gids.size(); ++r) {
    row_columns(row_offsets, column_gids, r, columns);
    check(system->matrix->InsertGlobalValues(row_gids[r], static_cast<int>(columns.size()),
                                             values.data() + row_offsets[r], columns.data()),
          "Epetra_FECrsMatrix::InsertGlobalValues");
  }
  check(system->matrix->GlobalAssemble(), "Epetra_FECrsMatrix::GlobalAssemble");
  return system;
}

void refill_linear_system(LinearSystem &system, rust::Slice<const std::int32_t> row_gids,
                          rust::Slice<const std::size_t> row_offsets,
                          rust::Slice<const std::size_t> column_gids,
                          rust::Slice<const double> values) {
  if (!system.matrix->StaticGraph()) {
    throw std::runtime_error("the Epetra matrix was not built on a fixed graph; it cannot be refilled");
  }
  system.preconditioner.reset();
  fill_values(system, row_gids, row_offsets, column_gids, values);
}

void multiply(const LinearSystem &system, rust::Slice<const double> x, rust::Slice<double> y) {
  Epetra_Vector xv(View, *system.map, const_cast<double *>(x.data()));
  Epetra_Vector yv(View, *system.map, y.data());
  check(system.matrix->Multiply(false, xv, yv), "Epetra_CrsMatrix::Multiply");
}

void set_jacobi_preconditioner(LinearSystem &system, std::int32_t sweeps) {
  Teuchos::ParameterList params;
  params.set("relaxation: type", std::string("Jacobi"));
  params.set("relaxation: sweeps", static_cast<int>(sweeps));
  set_ifpack(system, "point relaxation", params);
}

void set_ilu_preconditioner(LinearSystem &system, std::int32_t fill_level) {
  Teuchos::ParameterList params;
  params.set("fact: level-of-fill", static_cast<int>(fill_level));
  set_ifpack(system, "ILU", params);
}

std::unique_ptr<Epetra_Operator> build_ml(const Epetra_RowMatrix &matrix,
                                          std::int32_t pde_equations,
                                          std::vector<double> &null_space, std::int32_t modes,
                                          MultigridShape *shape) {
  int agreed = pde_equations;
  check(matrix.Comm().MinAll(&pde_equations, &agreed, 1), "Epetra_Comm::MinAll");
  Teuchos::ParameterList params;
  ML_Epetra::SetDefaults("SA", params);
  params.set("ML output", 0);
  params.set("PDE equations", agreed);
  // Chebyshev (degree 2) instead of SA's default symmetric Gauss-Seidel (2 sweeps before and
  // after): on the one-hop operator of the 20,000-point tension block NOX's GMRES needs the
  // same iterations (146 + 94 against 152 + 99 over two load steps) at less than half the
  // time (20.9 s against 46.7 s on one thread); it is built from mat-vecs, so it does not
  // depend on the split over ranks, and it is symmetric, as CG needs.
  params.set("smoother: type", std::string("Chebyshev"));
  if (!null_space.empty()) {
    params.set("null space: type", std::string("pre-computed"));
    params.set("null space: dimension", static_cast<int>(modes));
    params.set("null space: vectors", null_space.data());
  }
  auto ml = std::make_unique<ML_Epetra::MultiLevelPreconditioner>(matrix, params, true);
  if (!ml->IsPreconditionerComputed()) {
    throw std::runtime_error("ML could not build the multigrid hierarchy");
  }
  if (shape != nullptr) {
    double complexity = 0.0;
    double fine_entries = 0.0;
    ml->Complexities(complexity, fine_entries);
    shape->levels = ml->GetML()->ML_num_actual_levels;
    shape->operator_complexity = complexity;
  }
  return ml;
}

MlHierarchy set_ml_preconditioner(LinearSystem &system, std::int32_t pde_equations,
                                  rust::Slice<const double> null_space, std::int32_t modes) {
  system.preconditioner.reset();
  system.null_space.assign(null_space.begin(), null_space.end());
  MultigridShape shape;
  system.preconditioner =
      build_ml(*system.matrix, pde_equations, system.null_space, modes, &shape);
  return MlHierarchy{shape.levels, shape.operator_complexity};
}

BelosOutcome belos_solve(const LinearSystem &system, bool gmres, rust::Slice<const double> rhs,
                         rust::Slice<double> x, rust::Slice<const Parameter> parameters) {
  using MV = Epetra_MultiVector;
  using OP = Epetra_Operator;
  auto b = Teuchos::rcp(new Epetra_Vector(View, *system.map, const_cast<double *>(rhs.data())));
  auto solution = Teuchos::rcp(new Epetra_Vector(View, *system.map, x.data()));
  auto problem = Teuchos::rcp(new Belos::LinearProblem<double, MV, OP>(
      Teuchos::rcp(system.matrix.get(), false), solution, b));
  if (system.preconditioner) {
    auto prec = Teuchos::rcp(new Belos::EpetraPrecOp(Teuchos::rcp(system.preconditioner.get(), false)));
    if (gmres) {
      problem->setRightPrec(prec);
    } else {
      problem->setLeftPrec(prec);
    }
  }
  if (!problem->setProblem()) {
    throw std::runtime_error("Belos::LinearProblem::setProblem rejected the system");
  }
  auto params = Teuchos::rcp(new Teuchos::ParameterList("Belos"));
  fill_parameter_list(*params, parameters);
  std::unique_ptr<Belos::SolverManager<double, MV, OP>> solver;
  if (gmres) {
    solver = std::make_unique<Belos::BlockGmresSolMgr<double, MV, OP>>(problem, params);
  } else {
    solver = std::make_unique<Belos::BlockCGSolMgr<double, MV, OP>>(problem, params);
  }
  const Belos::ReturnType result = solver->solve();
  return BelosOutcome{result == Belos::Converged, solver->getNumIters(), solver->achievedTol()};
}

} // namespace trilinos
} // namespace peridyn
