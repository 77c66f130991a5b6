#!/usr/bin/env bash
# The Python package's CI step, runnable locally: `bash python/ci.sh` from anywhere.
# Installs the pinned requirements, builds firmware-sim (the plant the tests drive, a no-op
# when it is fresh), runs the package's tests against it, then the Rust host's test against the
# Python plant server with the skip turned into a failure.
set -euo pipefail
cd "$(dirname "$0")/.."
python3 -m pip install --quiet --disable-pip-version-check -r python/requirements.txt
cargo build --quiet --locked -p firmware-sim
export FIRMWARE_SIM="${CARGO_TARGET_DIR:-$PWD/target}/debug/firmware-sim"
python3 -m pytest python/tests -q
REQUIRE_PYTHON_PLANT=1 cargo test --quiet --locked -p firmware-sim --test integration plant_link_python
