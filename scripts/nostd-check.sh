#!/usr/bin/env bash
# Proof that policy-core is no_std: build nostd-check/ -- a `#![no_std]`, `#![no_main]`
# binary with its own panic handler and `_start`, linked without the C start-up files -- for the
# host, check that no `std` symbol made it in, then run it. It exits 0 only if the golden blobs
# load and `act`/`refine` give finite, in-bounds, golden results.
set -euo pipefail

repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
if [[ "$(uname -sm)" != "Linux x86_64" ]]; then
    echo "nostd-check: needs an x86_64 Linux host (found $(uname -sm))" >&2
    exit 1
fi
# Its own target directory: nostd-check is a separate workspace with panic = "abort".
target_dir="${CARGO_TARGET_DIR:-$repo/target}/nostd-check"
manifest="$repo/nostd-check/Cargo.toml"

for profile in dev release; do
    CARGO_TARGET_DIR="$target_dir" cargo build --quiet --locked --manifest-path "$manifest" --profile "$profile"
    dir=$([[ $profile == dev ]] && echo debug || echo release)
    bin="$target_dir/$dir/nostd-check"
    if nm --demangle "$bin" | grep -q ' std::'; then
        echo "nostd-check: the $profile binary contains std symbols:" >&2
        nm --demangle "$bin" | grep ' std::' | head -5 >&2
        exit 1
    fi
    "$bin"
done
