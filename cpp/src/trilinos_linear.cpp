// See cpp/include/peridyn/trilinos_linear.hpp. Errors from Epetra (negative return codes),
// Ifpack and ML become std::runtime_error, which cxx hands to Rust as Err.
#include "peridyn/trilinos_linear.hpp"
#include "peridyn/src/backend/trilinos/ffi.rs.h"

#include <mpi.h>

#include <algorithm>
#include <stdexcept>
#include <string>

#include <BelosBlockCGSolMgr.hpp>
#include <BelosBlockGmresSolMgr.hpp>
#include <BelosEpetraAdapter.hpp>
#include <BelosLinearProblem.hpp>
#include <Epetra_FECrsMatrix.h>
#include <Epetra_Map.h>
#include <Epetra_MpiComm.h>
#include <Epetra_Vector.h>
#include <Ifpack.h>
#include <Ifpack_Preconditioner.h>
#include <Teuchos_ParameterList.hpp>
#include <Teuchos_RCP.hpp>
#include <ml_MultiLevelPreconditioner.h>

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

std::unique_ptr<LinearSystem>
new_linear_system(std::int32_t communicator, rust::Slice<const std::int32_t> owned_rows,
                  rust::Slice<const std::int32_t> row_gids,
                  rust::Slice<const std::int32_t> row_offsets,
                  rust::Slice<const std::int32_t> column_gids,
                  rust::Slice<const double> values) {
  auto system = std::make_unique<LinearSystem>();
  system->comm = std::make_unique<Epetra_MpiComm>(communicator_from_handle(communicator));
  system->map = std::make_unique<Epetra_Map>(-1, static_cast<int>(owned_rows.size()),
                                             owned_rows.data(), 0, *system->comm);
  int longest_row = 0;
  for (std::size_t r = 0; r < row_gids.size(); ++r) {
    longest_row = std::max(longest_row, row_offsets[r + 1] - row_offsets[r]);
  }
  system->matrix = std::make_unique<Epetra_FECrsMatrix>(Copy, *system->map, longest_row);
  for (std::size_t r = 0; r < row_gids.size(); ++r) {
    const int start = row_offsets[r];
    check(system->matrix->InsertGlobalValues(row_gids[r], row_offsets[r + 1] - start,
                                             values.data() + start,
                                             column_gids.data() + start),
          "Epetra_FECrsMatrix::InsertGlobalValues");
  }
  check(system->matrix->GlobalAssemble(), "Epetra_FECrsMatrix::GlobalAssemble");
  return system;
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

void set_ml_preconditioner(LinearSystem &system, std::int32_t pde_equations) {
  Teuchos::ParameterList params;
  ML_Epetra::SetDefaults("SA", params);
  params.set("ML output", 0);
  params.set("PDE equations", static_cast<int>(pde_equations));
  auto ml = std::make_unique<ML_Epetra::MultiLevelPreconditioner>(*system.matrix, params, true);
  if (!ml->IsPreconditionerComputed()) {
    throw std::runtime_error("ML could not build the multigrid hierarchy");
  }
  system.preconditioner = std::move(ml);
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
