// See cpp/include/peridyn/trilinos_nox.hpp. The Rust callbacks return Result; their errors
// arrive here as rust::Error and become a `false` fill, which NOX turns into its own
// exception; nox_solve rethrows every exception as std::runtime_error for cxx to hand to Rust.
#include "peridyn/trilinos_nox.hpp"
#include "peridyn/trilinos_linear.hpp"
#include "peridyn/src/backend/trilinos/nox_ffi.rs.h"

#include <mpi.h>

#include <chrono>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <Epetra_CrsMatrix.h>
#include <Epetra_Map.h>
#include <Epetra_MpiComm.h>
#include <Epetra_Operator.h>
#include <Epetra_Vector.h>
#include <NOX.H>
#include <NOX_Epetra.H>
#include <NOX_Epetra_Interface_Jacobian.H>
#include <NOX_Epetra_Interface_Preconditioner.H>
#include <NOX_Epetra_Interface_Required.H>
#include <NOX_Epetra_LinearSystem_AztecOO.H>
#include <NOX_Epetra_MatrixFree.H>
#include <Teuchos_ParameterList.hpp>
#include <Teuchos_RCP.hpp>

namespace peridyn {
namespace trilinos {

// The kept matrix and ML (a Multigrid, held through its base type so that this struct does not
// name a type of the anonymous namespace).
struct NoxMultigrid::State {
  Teuchos::RCP<Epetra_CrsMatrix> matrix;
  Teuchos::RCP<Epetra_Operator> multigrid;
};

namespace {

using Teuchos::RCP;
using Teuchos::rcp;

void check(int code, const char *what) {
  if (code < 0) {
    throw std::runtime_error(std::string(what) + " failed with Epetra error code " +
                             std::to_string(code));
  }
}

// A matrix with the CSR pattern (global row ids `rows`, `offsets` into `columns`), all zero.
RCP<Epetra_CrsMatrix> pattern_matrix(const Epetra_Map &map, rust::Slice<const std::int32_t> rows,
                                     const rust::Vec<std::int32_t> &offsets,
                                     const rust::Vec<std::int32_t> &columns) {
  int longest_row = 0;
  for (std::size_t r = 0; r + 1 < offsets.size(); ++r) {
    longest_row = std::max(longest_row, offsets[r + 1] - offsets[r]);
  }
  auto matrix = rcp(new Epetra_CrsMatrix(Copy, map, longest_row));
  std::vector<double> zeros(longest_row, 0.0);
  for (std::size_t r = 0; r + 1 < offsets.size(); ++r) {
    check(matrix->InsertGlobalValues(rows[r], offsets[r + 1] - offsets[r], zeros.data(),
                                     columns.data() + offsets[r]),
          "Epetra_CrsMatrix::InsertGlobalValues");
  }
  check(matrix->FillComplete(), "Epetra_CrsMatrix::FillComplete");
  return matrix;
}

// Writes CSR-ordered `values` into the matrix built by pattern_matrix.
void replace_values(Epetra_CrsMatrix &matrix, rust::Slice<const std::int32_t> rows,
                    const rust::Vec<std::int32_t> &offsets, const rust::Vec<std::int32_t> &columns,
                    const std::vector<double> &values) {
  for (std::size_t r = 0; r + 1 < offsets.size(); ++r) {
    check(matrix.ReplaceGlobalValues(rows[r], offsets[r + 1] - offsets[r],
                                     values.data() + offsets[r], columns.data() + offsets[r]),
          "Epetra_CrsMatrix::ReplaceGlobalValues");
  }
}

rust::Slice<const double> view(const Epetra_Vector &v) {
  return rust::Slice<const double>(v.Values(), static_cast<std::size_t>(v.MyLength()));
}

// A matrix that already holds a preconditioner's inverse, applied as AztecOO's "User Defined"
// preconditioner: AztecOO calls ApplyInverse, which here is the product with the matrix.
// AztecOO preconditions in place (x and y view the same array), so the input is copied first.
class InverseByProduct : public Epetra_Operator {
public:
  explicit InverseByProduct(RCP<Epetra_CrsMatrix> inverse) : inverse_(std::move(inverse)) {}
  int SetUseTranspose(bool) override { return -1; }
  int Apply(const Epetra_MultiVector &, Epetra_MultiVector &) const override { return -1; }
  int ApplyInverse(const Epetra_MultiVector &x, Epetra_MultiVector &y) const override {
    const Epetra_MultiVector input(x);
    return inverse_->Multiply(false, input, y);
  }
  double NormInf() const override { return inverse_->NormInf(); }
  const char *Label() const override { return "peridyn preconditioner (inverse by product)"; }
  bool UseTranspose() const override { return false; }
  bool HasNormInf() const override { return true; }
  const Epetra_Comm &Comm() const override { return inverse_->Comm(); }
  const Epetra_Map &OperatorDomainMap() const override { return inverse_->OperatorDomainMap(); }
  const Epetra_Map &OperatorRangeMap() const override { return inverse_->OperatorRangeMap(); }

private:
  RCP<Epetra_CrsMatrix> inverse_;
};

// ML smoothed aggregation on the preconditioner matrix, with the near-null space the layout
// carries, applied as AztecOO's "User Defined" preconditioner. The hierarchy is rebuilt only
// when the matrix was refilled (Rust decides when, see nox_problem.rs), and kept otherwise.
class Multigrid : public Epetra_Operator {
public:
  Multigrid(RCP<Epetra_CrsMatrix> matrix, const NoxLayout &layout)
      : matrix_(std::move(matrix)), null_space_(layout.null_space.begin(), layout.null_space.end()),
        pde_equations_(layout.pde_equations), modes_(layout.null_space_modes) {}

  // Builds the hierarchy on the matrix's current values (the old one is released first).
  void rebuild() {
    ml_.reset();
    const auto start = std::chrono::steady_clock::now();
    ml_ = build_ml(*matrix_, pde_equations_, null_space_, modes_, &shape_);
    seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    ++setups_;
  }

  int setups() const { return setups_; }
  double seconds() const { return seconds_; }
  const MultigridShape &shape() const { return shape_; }

  int SetUseTranspose(bool) override { return -1; }
  int Apply(const Epetra_MultiVector &, Epetra_MultiVector &) const override { return -1; }
  // AztecOO preconditions in place (x and y view the same array): the input is copied first.
  int ApplyInverse(const Epetra_MultiVector &x, Epetra_MultiVector &y) const override {
    if (!ml_) {
      return -1;
    }
    const Epetra_MultiVector input(x);
    return ml_->ApplyInverse(input, y);
  }
  double NormInf() const override { return 0.0; }
  const char *Label() const override { return "peridyn ML on the one-hop operator"; }
  bool UseTranspose() const override { return false; }
  bool HasNormInf() const override { return false; }
  const Epetra_Comm &Comm() const override { return matrix_->Comm(); }
  const Epetra_Map &OperatorDomainMap() const override { return matrix_->OperatorDomainMap(); }
  const Epetra_Map &OperatorRangeMap() const override { return matrix_->OperatorRangeMap(); }

private:
  RCP<Epetra_CrsMatrix> matrix_;
  std::vector<double> null_space_;
  std::int32_t pde_equations_;
  std::int32_t modes_;
  std::unique_ptr<Epetra_Operator> ml_;
  MultigridShape shape_;
  int setups_ = 0;
  double seconds_ = 0.0;
};

// The NOX interfaces, each forwarding to the Rust problem.
class Callbacks : public NOX::Epetra::Interface::Required,
                  public NOX::Epetra::Interface::Jacobian,
                  public NOX::Epetra::Interface::Preconditioner {
public:
  Callbacks(NoxProblem &problem, rust::Slice<const std::int32_t> rows, const NoxLayout &layout)
      : problem_(problem), rows_(rows), layout_(layout) {}

  RCP<Epetra_CrsMatrix> jacobian;
  RCP<Epetra_CrsMatrix> preconditioner;
  // Set when ML is built on the preconditioner matrix (rebuilt after each refill).
  RCP<Multigrid> multigrid;

  bool computeF(const Epetra_Vector &x, Epetra_Vector &f, FillType fill) override {
    try {
      problem_.residual(view(x),
                        rust::Slice<double>(f.Values(), static_cast<std::size_t>(f.MyLength())),
                        fill != NOX::Epetra::Interface::Required::Residual);
      return true;
    } catch (const rust::Error &) {
      return false;
    }
  }

  bool computeJacobian(const Epetra_Vector &x, Epetra_Operator &) override {
    return refill(x, *jacobian, layout_.jacobian_offsets, layout_.jacobian_columns, false);
  }

  bool computePreconditioner(const Epetra_Vector &x, Epetra_Operator &,
                             Teuchos::ParameterList *) override {
    return refill(x, *preconditioner, layout_.preconditioner_offsets,
                  layout_.preconditioner_columns, true);
  }

private:
  bool refill(const Epetra_Vector &x, Epetra_CrsMatrix &matrix,
              const rust::Vec<std::int32_t> &offsets, const rust::Vec<std::int32_t> &columns,
              bool is_preconditioner) {
    values_.resize(columns.size());
    rust::Slice<double> out(values_.data(), values_.size());
    try {
      const bool fresh = is_preconditioner ? problem_.preconditioner(view(x), out)
                                           : problem_.jacobian(view(x), out);
      if (fresh) {
        replace_values(matrix, rows_, offsets, columns, values_);
        if (is_preconditioner && !multigrid.is_null()) {
          multigrid->rebuild();
        }
      }
      return true;
    } catch (const rust::Error &) {
      return false;
    }
  }

  NoxProblem &problem_;
  rust::Slice<const std::int32_t> rows_;
  const NoxLayout &layout_;
  std::vector<double> values_;
};

int total_linear_iterations(const Teuchos::ParameterList &linear_solver) {
  if (!linear_solver.isSublist("Output")) {
    return 0;
  }
  const Teuchos::ParameterList &output = linear_solver.sublist("Output");
  const char *key = "Total Number of Linear Iterations";
  return output.isParameter(key) ? output.get<int>(key) : 0;
}

// The AztecOO linear system NOX solves with: the assembled Jacobian, or NOX's matrix-free
// operator with an optional preconditioner matrix (applied as an inverse by product, or
// factored by the library the linear-solver list names).
RCP<NOX::Epetra::LinearSystemAztecOO>
linear_system(const RCP<Callbacks> &callbacks, const Epetra_Map &map,
              rust::Slice<const std::int32_t> rows, const NoxLayout &layout,
              Teuchos::ParameterList &printing, Teuchos::ParameterList &linear_solver,
              const NOX::Epetra::Vector &clone, NoxMultigrid &kept) {
  // Typed handles: the LinearSystemAztecOO constructors overload on the interface type.
  RCP<NOX::Epetra::Interface::Required> required = callbacks;
  if (!layout.matrix_free) {
    callbacks->jacobian =
        pattern_matrix(map, rows, layout.jacobian_offsets, layout.jacobian_columns);
    RCP<NOX::Epetra::Interface::Jacobian> jacobian_fill = callbacks;
    RCP<Epetra_Operator> jacobian = callbacks->jacobian;
    return rcp(new NOX::Epetra::LinearSystemAztecOO(printing, linear_solver, required,
                                                    jacobian_fill, jacobian, clone));
  }
  auto matrix_free = rcp(new NOX::Epetra::MatrixFree(printing, required, clone));
  RCP<NOX::Epetra::Interface::Jacobian> directional = matrix_free;
  RCP<Epetra_Operator> jacobian = matrix_free;
  if (layout.preconditioner_offsets.empty()) {
    return rcp(new NOX::Epetra::LinearSystemAztecOO(printing, linear_solver, required,
                                                    directional, jacobian, clone));
  }
  if (layout.multigrid && layout.reuse_multigrid && kept.state) {
    callbacks->preconditioner = kept.state->matrix;
    callbacks->multigrid = Teuchos::rcp_dynamic_cast<Multigrid>(kept.state->multigrid, true);
  } else {
    callbacks->preconditioner =
        pattern_matrix(map, rows, layout.preconditioner_offsets, layout.preconditioner_columns);
  }
  RCP<NOX::Epetra::Interface::Preconditioner> preconditioner_fill = callbacks;
  RCP<Epetra_Operator> preconditioner = callbacks->preconditioner;
  if (layout.multigrid) {
    if (callbacks->multigrid.is_null()) {
      callbacks->multigrid = rcp(new Multigrid(callbacks->preconditioner, layout));
      kept.state = std::make_unique<NoxMultigrid::State>();
      kept.state->matrix = callbacks->preconditioner;
      kept.state->multigrid = callbacks->multigrid;
    }
    preconditioner = callbacks->multigrid;
  } else if (layout.preconditioner_is_inverse) {
    preconditioner = rcp(new InverseByProduct(callbacks->preconditioner));
  }
  return rcp(new NOX::Epetra::LinearSystemAztecOO(printing, linear_solver, directional, jacobian,
                                                  preconditioner_fill, preconditioner, clone));
}

// Peridigm's status tests: finite values, ‖F‖₂ ≤ tolerance (absolute, unscaled), MaxIters.
RCP<NOX::StatusTest::Combo> status_tests(const NoxLayout &layout) {
  auto tests = rcp(new NOX::StatusTest::Combo(NOX::StatusTest::Combo::OR));
  tests->addStatusTest(rcp(new NOX::StatusTest::FiniteValue));
  tests->addStatusTest(
      rcp(new NOX::StatusTest::NormF(layout.tolerance, NOX::StatusTest::NormF::Unscaled)));
  tests->addStatusTest(rcp(new NOX::StatusTest::MaxIters(layout.max_iterations)));
  return tests;
}

NoxOutcome solve(NoxProblem &problem, rust::Slice<const std::int32_t> owned_rows,
                 const NoxLayout &layout, rust::Slice<const Parameter> parameters,
                 rust::Slice<double> x, NoxMultigrid &kept) {
  Epetra_MpiComm comm(communicator_from_handle(layout.communicator));
  Epetra_Map map(-1, static_cast<int>(owned_rows.size()), owned_rows.data(), 0, comm);
  auto params = rcp(new Teuchos::ParameterList("NOX"));
  fill_parameter_list(*params, parameters);
  Teuchos::ParameterList &printing = params->sublist("Printing");
  Teuchos::ParameterList &linear_solver = sublist_at(*params, layout.linear_solver_path);
  auto callbacks = rcp(new Callbacks(problem, owned_rows, layout));
  auto guess = rcp(new Epetra_Vector(Copy, map, x.data()));
  NOX::Epetra::Vector clone(guess, NOX::Epetra::Vector::CreateView);
  auto linear =
      linear_system(callbacks, map, owned_rows, layout, printing, linear_solver, clone, kept);
  // ML's setups before this solve (a kept hierarchy counts those of earlier solves).
  const int setups_before = callbacks->multigrid.is_null() ? 0 : callbacks->multigrid->setups();
  const double seconds_before =
      callbacks->multigrid.is_null() ? 0.0 : callbacks->multigrid->seconds();
  RCP<NOX::Epetra::Interface::Required> required = callbacks;
  auto group = rcp(new NOX::Epetra::Group(printing, required, clone, linear));
  RCP<NOX::Solver::Generic> solver = NOX::Solver::buildSolver(group, status_tests(layout), params);

  NOX::StatusTest::StatusType status = NOX::StatusTest::Unevaluated;
  int iterations = 0;
  while (status != NOX::StatusTest::Converged && status != NOX::StatusTest::Failed) {
    status = solver->step();
    ++iterations;
    problem.iteration_done(iterations, solver->getSolutionGroup().getF().norm());
  }
  const auto &solution =
      dynamic_cast<const NOX::Epetra::Vector &>(solver->getSolutionGroup().getX()).getEpetraVector();
  std::copy(solution.Values(), solution.Values() + solution.MyLength(), x.data());
  NoxOutcome outcome{status == NOX::StatusTest::Converged, iterations,
                     total_linear_iterations(linear_solver),
                     solver->getSolutionGroup().getF().norm(), 0, 0.0, 0, 0.0};
  if (!callbacks->multigrid.is_null()) {
    outcome.preconditioner_setups = callbacks->multigrid->setups() - setups_before;
    outcome.preconditioner_seconds = callbacks->multigrid->seconds() - seconds_before;
    outcome.multigrid_levels = callbacks->multigrid->shape().levels;
    outcome.operator_complexity = callbacks->multigrid->shape().operator_complexity;
  }
  return outcome;
}

} // namespace

NoxMultigrid::NoxMultigrid() = default;
NoxMultigrid::~NoxMultigrid() = default;

std::unique_ptr<NoxMultigrid> new_nox_multigrid() { return std::make_unique<NoxMultigrid>(); }

NoxOutcome nox_solve(NoxProblem &problem, rust::Slice<const std::int32_t> owned_rows,
                     const NoxLayout &layout, rust::Slice<const Parameter> parameters,
                     rust::Slice<double> x, NoxMultigrid &kept) {
  try {
    return solve(problem, owned_rows, layout, parameters, x, kept);
  } catch (const std::exception &e) {
    throw std::runtime_error(e.what());
  } catch (const char *message) {
    throw std::runtime_error(message);
  } catch (const std::string &message) {
    throw std::runtime_error(message);
  } catch (...) {
    throw std::runtime_error("NOX stopped with an exception of unknown type");
  }
}

} // namespace trilinos
} // namespace peridyn
