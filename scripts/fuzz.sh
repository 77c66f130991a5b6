#!/usr/bin/env bash
# Coverage-guided fuzzing of the parsers that read outside input (cargo-fuzz, libFuzzer).
#
#   scripts/fuzz.sh blob 600        # fuzz the blob loader and boot path for 600 s
#   scripts/fuzz.sh scenario 600    # the scenario TOML parser
#   scripts/fuzz.sh faults 600      # the --faults parser
#   scripts/fuzz.sh badminton 600   # the badminton scenario parser, playing what it accepts
#   scripts/fuzz.sh train_config 600 # host-trainer's config files, training what they accept
#   scripts/fuzz.sh plant_link 600  # the plant link's frames, both sides' messages
#   scripts/fuzz.sh all 20          # each target in turn (what CI runs)
#   scripts/fuzz.sh blob 60 -jobs=2 # extra arguments go to libFuzzer
#
# Works on the stable toolchain: with `--sanitizer none` cargo-fuzz passes only stable codegen
# flags (-Cpasses=sancov-module ...). Rust code is memory-safe here (no `unsafe` in a host build:
# the workspace forbids it, and policy-core's one `asm!`, its SMLAD kernel, is Armv7E-M only),
# so AddressSanitizer, which needs nightly, adds little; set FUZZ_TOOLCHAIN=nightly and
# FUZZ_SANITIZER=address to use it anyway. Builds are optimised with debug assertions and
# overflow checks on (cargo-fuzz's default without -O): an integer overflow is a finding.
#
# The run corpus (fuzz/corpus/<target>, not committed) starts from fuzz/seeds/<target> plus the
# golden blobs (policy-core/tests/golden) or the built-in scenarios (firmware-sim/scenarios).
# Crashes land in fuzz/artifacts/<target>/; minimise one with
#   cargo fuzz tmin -s none <target> <crash file>
# and keep the reproducer in fuzz/regressions/<target>/: `cargo test` replays every file there
# (tests/tests/fuzz_regressions.rs).
set -euo pipefail

root="$(cd "$(dirname "$0")/.." && pwd)"
fuzz="$root/fuzz"
toolchain="${FUZZ_TOOLCHAIN:-stable}"
sanitizer="${FUZZ_SANITIZER:-none}"
targets=(blob scenario faults badminton train_config plant_link)

usage() {
    echo "usage: scripts/fuzz.sh {blob|scenario|faults|badminton|train_config|plant_link|all} [SECONDS] [LIBFUZZER_ARGS...]" >&2
    exit 2
}

ensure_cargo_fuzz() {
    if ! cargo fuzz --version >/dev/null 2>&1; then
        echo "installing cargo-fuzz from crates.io" >&2
        cargo install cargo-fuzz --version 0.13.2 --locked
    fi
}

# The run corpus: committed seeds, plus the golden blobs or the built-in scenarios.
seed_corpus() {
    local target="$1" corpus="$fuzz/corpus/$1"
    mkdir -p "$corpus"
    cp "$fuzz/seeds/$target"/* "$corpus/"
    case "$target" in
        blob) cp "$root"/policy-core/tests/golden/*.postcard "$corpus/" ;;
        scenario) cp "$root"/firmware-sim/scenarios/*.toml "$corpus/" ;;
    esac
}

cargo_fuzz() {
    (cd "$fuzz" && cargo "+$toolchain" fuzz "$@")
}

run() {
    local target="$1" seconds="$2"
    shift 2
    seed_corpus "$target"
    local log="$fuzz/artifacts/$target.log"
    mkdir -p "$fuzz/artifacts/$target"
    cargo_fuzz run -s "$sanitizer" "$target" "corpus/$target" -- \
        -max_total_time="$seconds" -dict="dict/$target.dict" -print_final_stats=1 \
        "$@" 2>&1 | tee "$log" |
        grep -v -e '^#[0-9].*\(NEW\|REDUCE\|pulse\)' -e '^stat::' -e '# Uses: ' -e 'NEW_FUNC' || true
    summary "$target" "$log"
}

# The last status line and the final stats: executions, exec/s, coverage, corpus size.
summary() {
    local target="$1" log="$2" last
    last="$(grep -E '^#[0-9]+' "$log" | tail -1 || true)"
    echo "== $target: ${last:-no status line}"
    grep -E '^stat::(number_of_executed_units|average_exec_per_sec|new_units_added|peak_rss_mb)' "$log" || true
    echo "corpus files: $(find "$fuzz/corpus/$target" -type f | wc -l)"
    if grep -qE '^(==[0-9]+== ERROR|thread .* panicked|SUMMARY: libFuzzer)' "$log"; then
        echo "== $target: FOUND A CRASH, see $log and $fuzz/artifacts/$target/" >&2
        return 1
    fi
    if ! grep -qE '^#[0-9]+[[:space:]]+DONE' "$log"; then
        echo "== $target: the fuzzer did not finish its run, see $log" >&2
        return 1
    fi
}

[ $# -ge 1 ] || usage
ensure_cargo_fuzz
case "$1" in
    all)
        seconds="${2:-60}"
        status=0
        for t in "${targets[@]}"; do run "$t" "$seconds" "${@:3}" || status=1; done
        exit "$status"
        ;;
    blob | scenario | faults | badminton | train_config | plant_link) run "$1" "${2:-60}" "${@:3}" ;;
    *) usage ;;
esac
