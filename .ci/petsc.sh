#!/usr/bin/env bash
# Debian 12 packages for feature `petsc`: PETSc 3.18 (with MUMPS, hypre and GAMG), OpenMPI, and
# libclang for bindgen. .ci/backends.sh runs this, then builds and tests.
set -euo pipefail
packages=(libpetsc-real-dev libopenmpi-dev openmpi-bin pkg-config clang libclang-dev)
# Nothing to do when they are installed already (apt-get update alone takes seconds).
if ! dpkg -s "${packages[@]}" >/dev/null 2>&1; then
  apt-get update -o DPkg::Lock::Timeout=600 -qq
  apt-get install -y -qq -o DPkg::Lock::Timeout=600 "${packages[@]}"
fi
