#!/usr/bin/env bash
# Debian 12 packages for feature `mpi`: OpenMPI (mpirun, mpicc and headers) and libclang (rsmpi's
# mpi-sys generates its bindings with bindgen). .ci/backends.sh runs this, then builds and tests.
set -euo pipefail
packages=(libopenmpi-dev openmpi-bin libclang-dev)
# Nothing to do when they are installed already (apt-get update alone takes seconds).
if ! dpkg -s "${packages[@]}" >/dev/null 2>&1; then
  apt-get update -o DPkg::Lock::Timeout=600 -qq
  apt-get install -y -qq -o DPkg::Lock::Timeout=600 "${packages[@]}"
fi
