#!/usr/bin/env bash
# CI snippet for the Trilinos backend (feature `trilinos`): installs Debian 12's Trilinos 13.2
# and OpenMPI packages, builds with the feature and runs its tests. Sourced or run from the
# repository root by .ci/run; about 40 s of apt, 2-4 minutes of compiling on 2 cores and a minute
# of regression decks.
set -euo pipefail
cd "$(dirname "$0")/.."
export CARGO_TERM_COLOR=never

# The minimal set for the shim (reference: ffi.md §1): kokkos-dev and epetraext-dev are
# needed by the Teuchos and ML headers although the Debian packages do not depend on them.
apt-get update -o DPkg::Lock::Timeout=600 -qq
apt-get install -y -qq -o DPkg::Lock::Timeout=600 \
  libopenmpi-dev openmpi-bin pkg-config cmake g++ libclang-dev \
  libtrilinos-teuchos-dev libtrilinos-epetra-dev libtrilinos-epetraext-dev libtrilinos-kokkos-dev \
  libtrilinos-belos-dev libtrilinos-ifpack-dev libtrilinos-ml-dev libtrilinos-nox-dev
# Only for Trilinos_DIR / PERIDYN_TRILINOS_CMAKE=1 (find_package(Trilinos) includes these
# packages' CMake configs):
#   libtrilinos-{amesos,amesos2,anasazi,galeri,ifpack2,isorropia,kokkos-kernels,rtop,shylu,
#   stratimikos,teko,thyra,tpetra,triutils,xpetra,zoltan,zoltan2}-dev

# MPI is started by peridyn (rsmpi, whose mpi-sys needs libclang); a CI container usually
# runs as root.
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
# One C++ compile at a time: the shim's Belos/ML templates take ~1 GB each.
export NUM_JOBS=1 CMAKE_BUILD_PARALLEL_LEVEL=1

cargo build --release --locked --features trilinos
# Compile first, then run under `timeout`: the limits are for hangs, not for compiling.
cargo test --locked --features trilinos --no-run --test trilinos_backend --test trilinos_nox --lib
timeout 600 cargo test --locked --features trilinos --test trilinos_backend --test trilinos_nox
timeout 300 cargo test --locked --features trilinos --lib -- io::deck::solver solver::linear solver::nox_newton

# Peridigm's regression decks with the Trilinos build: NOXQuasiStatic decks run on NOX itself
# and every other implicit solver list on Belos (--backend trilinos). The README lists the
# decks that pass; fewer is a regression.
if [ -d ../shared/peridigm ]; then
  scripts/peridigm-regression ../shared/peridigm --peridyn target/release/peridyn \
    --backend trilinos --min-pass 33
fi
