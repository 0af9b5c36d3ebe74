// C++ side of the cxx bridge in src/backend/trilinos/nox_ffi.rs: NOX's Epetra Newton solver
// with the residual, the tangent and the preconditioner supplied by Rust callbacks.
// Adaptation only: what to solve, with which parameters and what the results mean is decided
// in Rust (src/backend/trilinos/nox.rs).
#pragma once

#include <cstdint>
#include <memory>

#include "rust/cxx.h"

namespace peridyn {
namespace trilinos {

struct NoxProblem;
struct NoxLayout;
struct Parameter;
struct NoxOutcome;

// What a multigrid-preconditioned solve keeps for the next one (the preconditioner matrix and
// ML built on it), so that a later solve over the same unknowns and operator reuses the
// hierarchy instead of building it again. Opaque here: the Trilinos types stay in the .cpp.
class NoxMultigrid {
public:
  NoxMultigrid();
  ~NoxMultigrid();
  struct State;
  std::unique_ptr<State> state;
};

// An empty NoxMultigrid.
std::unique_ptr<NoxMultigrid> new_nox_multigrid();

// Builds the NOX group (assembled or matrix-free Jacobian, optional preconditioner matrix),
// the status tests Combo(OR: FiniteValue, NormF(tolerance, unscaled), MaxIters) and the solver
// from `parameters`, then steps it until a status test ends it, reporting each iteration to
// `problem`. The rows are global ids on the communicator whose Fortran handle the layout holds.
// `x` is the initial guess on entry and NOX's solution on return. A failing Rust
// callback makes the fill return false; NOX's exception is rethrown as std::runtime_error.
// With the layout's `multigrid`, ML lives in `kept`: reused from an earlier solve when the
// layout says `reuse_multigrid` and `kept` holds one, built there otherwise.
NoxOutcome nox_solve(NoxProblem &problem, rust::Slice<const std::int32_t> owned_rows,
                     const NoxLayout &layout, rust::Slice<const Parameter> parameters,
                     rust::Slice<double> x, NoxMultigrid &kept);

} // namespace trilinos
} // namespace peridyn
