#!/usr/bin/env bash
# CI snippet for the PETSc backend (feature `petsc`): installs Debian 12's PETSc 3.18 (with MUMPS,
# hypre, GAMG) and what bindgen needs, builds with the feature, runs the PETSc tests and the
# implicit regression decks with --backend petsc. Run from .ci/run after the Trilinos step;
# about 15 s of apt, a few minutes of compiling on 2 cores, a minute of tests and decks.
set -euo pipefail
cd "$(dirname "$0")/.."
export CARGO_TERM_COLOR=never

apt-get update -o DPkg::Lock::Timeout=600 -qq
apt-get install -y -qq -o DPkg::Lock::Timeout=600 \
  libpetsc-real-dev libopenmpi-dev openmpi-bin pkg-config clang libclang-dev

# PETSc needs MPI even on one process (peridyn starts it); a CI container usually runs as root.
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1

cargo build --release --locked --features petsc
# Compile first, then run under `timeout`: the limits are for hangs, not for compiling.
cargo test --release --locked --features petsc --no-run --test petsc_backend
timeout 600 cargo test --release --locked --features petsc --test petsc_backend

# Peridigm's regression decks with every implicit solver list on PETSc (KSP for QuasiStatic and
# Implicit, SNES for NOXQuasiStatic). 32 pass today (the native 35 less Body_Force_QS_NOX,
# DiskFilter and NOX_QS_MatrixFree_NoPrec, where SNES stalls); fewer is a regression.
if [ -d ../shared/peridigm ]; then
  scripts/peridigm-regression ../shared/peridigm --peridyn target/release/peridyn --backend petsc \
    --min-pass 32
fi
