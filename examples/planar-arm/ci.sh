#!/usr/bin/env bash
# The worked example's CI step, runnable locally from anywhere: `bash examples/planar-arm/ci.sh`.
# Builds the example as a user's crate outside the workspace, runs its tests, trains a tiny
# budget, and checks the exported blob three ways that must agree episode for episode: in
# process (`planar-arm check`), through the plant link (`firmware-sim run --plant-cmd`), and,
# with `--hil` after `bash scripts/cortex-m.sh` built the HIL firmware, on the Cortex-M4F under
# QEMU. Exit 0 or 1 of a check is its verdict on an untrained blob; 2 (bad input) fails CI.
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/../.." && pwd)"
TARGET="${CARGO_TARGET_DIR:-$ROOT/target}"
HIL=0
[ "${1:-}" = "--hil" ] && HIL=1
cd "$ROOT/examples/planar-arm"
cargo fmt -- --check
cargo clippy --locked --all-targets --target-dir "$TARGET" -- -D warnings
cargo test --locked --target-dir "$TARGET"
cargo build --locked --target-dir "$TARGET"
cd "$ROOT"
cargo build --locked -p firmware-sim
ARM="$TARGET/debug/planar-arm"
FS="$TARGET/debug/firmware-sim"
OUT=$(mktemp -d)
trap 'rm -rf "$OUT"' EXIT
verdict() { local status=0; "$@" >/dev/null || status=$?; test "$status" -le 1; }
verdict "$ARM" train --out "$OUT" --episodes 5 --eval-episodes 10
BLOB="$OUT/planar-arm__dcp__0/policy.postcard"
verdict "$ARM" check --blob "$BLOB" --episodes 10 --json "$OUT/in-process.json"
verdict "$FS" run --plant-cmd "$ARM serve" --blob "$BLOB" --episodes 10 --json "$OUT/link.json"
same() {
    python3 -c 'import json, sys
a, b = (json.load(open(p))["episodes"] for p in sys.argv[1:])
sys.exit(0 if a == b else "the episodes differ: " + " vs ".join(sys.argv[1:]))' "$@"
}
same "$OUT/in-process.json" "$OUT/link.json"
if [ "$HIL" = 1 ]; then
    verdict "$ARM" check --blob "$BLOB" --episodes 3 --json "$OUT/in-process-3.json"
    verdict "$FS" run --plant-cmd "$ARM serve" --blob "$BLOB" --episodes 3 --hil qemu-m4f \
        --json "$OUT/hil.json"
    same "$OUT/in-process-3.json" "$OUT/hil.json"
fi
echo "planar-arm: in process, through the plant link$([ "$HIL" = 1 ] && echo ' and on the M4F') agree"
