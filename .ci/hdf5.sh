#!/usr/bin/env bash
# Debian 12 packages for feature `hdf5` (restart files): HDF5 1.10 and pkg-config.
# .ci/backends.sh runs this, then builds and tests.
set -euo pipefail
packages=(libhdf5-dev pkg-config)
# Nothing to do when they are installed already (apt-get update alone takes seconds).
if ! dpkg -s "${packages[@]}" >/dev/null 2>&1; then
  apt-get update -o DPkg::Lock::Timeout=600 -qq
  apt-get install -y -qq -o DPkg::Lock::Timeout=600 "${packages[@]}"
fi
