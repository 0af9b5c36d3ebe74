#!/usr/bin/env bash
# Restart files (feature `hdf5`): install HDF5, build with the feature, run the restart tests
# and Peridigm's restart decks (Contact_Perforation_With_Restart: Run1 then Run2 against the
# uninterrupted run).
set -euo pipefail
cd "$(dirname "$0")/.."

if ! pkg-config --exists hdf5 2>/dev/null && [ ! -e /usr/include/hdf5/serial/hdf5.h ]; then
    apt-get update -o DPkg::Lock::Timeout=600
    apt-get install -y -o DPkg::Lock::Timeout=600 libhdf5-dev pkg-config
fi

cargo build --release --locked --features hdf5
# Compile first, then run under `timeout`: the limit is for hangs, not for compiling.
cargo test --release --locked --features hdf5 --no-run --lib --test restart --test deck_formats
timeout 900 cargo test --release --locked --features hdf5 --lib restart
timeout 900 cargo test --release --locked --features hdf5 --test restart --test deck_formats

if [ -d ../shared/peridigm ]; then
  out=$(scripts/peridigm-regression ../shared/peridigm --peridyn target/release/peridyn \
    --filter With_Restart)
  echo "$out"
  # Both Run decks of the series must pass.
  [ "$(grep -c '^PASS .*_Run[0-9]' <<<"$out")" -ge 2 ]
fi
