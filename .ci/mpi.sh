#!/usr/bin/env bash
# Distributed explicit runs (feature `mpi`): build with MPI and run the 1-vs-N-ranks tests.
#
# Needs OpenMPI (mpirun, mpicc and headers) and libclang (mpi-sys generates its bindings with
# bindgen); installs them with apt when mpirun is missing. Every mpirun in the tests is wrapped
# in `timeout 300`, so a hang fails instead of blocking CI.
set -euo pipefail
cd "$(dirname "$0")/.."

if ! command -v mpirun >/dev/null 2>&1 || ! command -v mpicc >/dev/null 2>&1 \
    || ! ls /usr/lib/llvm-*/lib/libclang.so* >/dev/null 2>&1; then
    apt-get update -o DPkg::Lock::Timeout=600
    apt-get install -y -o DPkg::Lock::Timeout=600 libopenmpi-dev openmpi-bin libclang-dev
fi

# OpenMPI refuses to run as root without these; -np 3 on a 2-core machine needs oversubscription
# (the tests also pass --oversubscribe).
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_rmaps_base_oversubscribe=1

cargo build --locked --features mpi
# Compile first, then run under `timeout`: the limits are for hangs, not for compiling.
cargo test --locked --features mpi --no-run --lib --test mpi_explicit --test mpi_contact
timeout 600 cargo test --locked --features mpi --lib parallel
timeout 900 cargo test --locked --features mpi --test mpi_explicit --test mpi_contact

# Quasi-static on 1, 2 and 3 ranks through Trilinos NOX (needs the Trilinos packages that
# .ci/trilinos.sh installs).
if [ -d /usr/include/trilinos ]; then
  cargo test --locked --features mpi,trilinos --no-run --test mpi_implicit
  timeout 900 cargo test --locked --features mpi,trilinos --test mpi_implicit
  # Peridigm's regression decks on 2 ranks with that build (target/debug/peridyn now has both
  # features) and the implicit solver lists on Trilinos: every deck that passes on one rank
  # passes on two. Fewer passes is a regression.
  if [ -d ../shared/peridigm ]; then
    cargo build --locked --features mpi,trilinos
    scripts/peridigm-regression ../shared/peridigm --peridyn target/debug/peridyn \
      --ranks 2 --backend trilinos --min-pass 33
  fi
fi
