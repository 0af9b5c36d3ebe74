#!/usr/bin/env bash
# Debian 12 packages for feature `trilinos` (Trilinos 13.2 and OpenMPI): the minimal set for the
# C++ shim. kokkos-dev and epetraext-dev are needed by the Teuchos and ML headers although the
# Debian packages do not depend on them. .ci/backends.sh runs this, then builds and tests.
#
# Only for Trilinos_DIR / PERIDYN_TRILINOS_CMAKE=1 (find_package(Trilinos) includes these
# packages' CMake configs):
#   libtrilinos-{amesos,amesos2,anasazi,galeri,ifpack2,isorropia,kokkos-kernels,rtop,shylu,
#   stratimikos,teko,thyra,tpetra,triutils,xpetra,zoltan,zoltan2}-dev
set -euo pipefail
packages=(libopenmpi-dev openmpi-bin pkg-config cmake g++ libclang-dev libtrilinos-teuchos-dev libtrilinos-epetra-dev libtrilinos-epetraext-dev libtrilinos-kokkos-dev libtrilinos-belos-dev libtrilinos-ifpack-dev libtrilinos-ml-dev libtrilinos-nox-dev)
# Nothing to do when they are installed already (apt-get update alone takes seconds).
if ! dpkg -s "${packages[@]}" >/dev/null 2>&1; then
  apt-get update -o DPkg::Lock::Timeout=600 -qq
  apt-get install -y -qq -o DPkg::Lock::Timeout=600 "${packages[@]}"
fi
