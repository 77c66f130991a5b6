#!/usr/bin/env bash
# Side-by-side: RLtools' TD3 Pendulum benchmark and this project running the same schedule at the
# same shapes (studies/src/bin/rltools_schedule.rs), interleaved. RLtools and our one-thread
# run are pinned to one core; our default run takes the threads a user gets (every core).
#
#   scripts/bench-rltools.sh RLTOOLS_BINARY [ROUNDS]
#
# RLTOOLS_BINARY is RLtools' rl_environments_pendulum_td3_blas_benchmark, built outside this
# repository as the README ("Training speed against RLtools") describes; it runs with OpenBLAS on
# one thread. ROUNDS (default 7) rounds alternate RLtools, ours on one thread, ours on every core,
# RLtools, ...; the table gives every run, the medians and the ratios ours / RLtools.
set -euo pipefail
rltools=${1:?usage: scripts/bench-rltools.sh RLTOOLS_BINARY [ROUNDS]}
rounds=${2:-7}
[ -x "$rltools" ] || { echo "bench-rltools: $rltools is not an executable" >&2; exit 2; }
case $rounds in ''|*[!0-9]*|0) echo "bench-rltools: ROUNDS must be a positive integer" >&2; exit 2;; esac
cd "$(dirname "$0")/.."
cargo build --release -q -p studies --bin rltools-schedule
ours=${CARGO_TARGET_DIR:-target}/release/rltools-schedule
pin=()
command -v taskset >/dev/null && pin=(taskset -c 0)

median() { sort -g | awk '{v[NR]=$1} END {print (NR % 2) ? v[(NR+1)/2] : (v[NR/2] + v[NR/2+1]) / 2}'; }

r_times=() o_times=() d_times=()
core=? isa=?
for i in $(seq "$rounds"); do
  out=$(cd "$(dirname "$rltools")" && OPENBLAS_NUM_THREADS=1 OPENBLAS_VERBOSE=2 "${pin[@]}" "$rltools" 2>&1)
  r=$(printf '%s\n' "$out" | sed -n 's/^Time: \([0-9.]*\)s.*/\1/p' | tail -1)
  core=$(printf '%s\n' "$out" | sed -n 's/^Core: *//p' | head -1)
  [ -n "$r" ] || { echo "bench-rltools: no 'Time:' line from RLtools:" >&2; printf '%s\n' "$out" >&2; exit 1; }
  line=$("${pin[@]}" "$ours" --threads 1)
  o=$(printf '%s\n' "$line" | sed -n 's/^schedule: \([0-9.]*\) s.*/\1/p')
  default=$("$ours")
  d=$(printf '%s\n' "$default" | sed -n 's/^schedule: \([0-9.]*\) s.*/\1/p')
  threads=$(printf '%s\n' "$default" | sed -n 's/.*, \([0-9]*\) threads$/\1/p')
  isa=$(printf '%s\n' "$line" | sed -n 's/.*kernels \([^,]*\),.*/\1/p')
  macs=$(printf '%s\n' "$line" | sed -n 's/.* \([0-9.]*\) G multiply-adds.*/\1/p')
  r_times+=("$r") o_times+=("$o") d_times+=("$d")
  echo "round $i: RLtools $r s, ours $o s (1 thread), $d s ($threads threads)" >&2
done
rm=$(printf '%s\n' "${r_times[@]}" | median)
om=$(printf '%s\n' "${o_times[@]}" | median)
dm=$(printf '%s\n' "${d_times[@]}" | median)
echo "| | runs (s) | median (s) | instruction set |"
echo "|---|---|---:|---|"
echo "| RLtools TD3 Pendulum (OpenBLAS, 1 thread) | ${r_times[*]} | $rm | OpenBLAS core $core, -march=native |"
echo "| host-trainer, same schedule ($macs G multiply-adds), 1 thread | ${o_times[*]} | $om | $isa |"
echo "| host-trainer, same schedule, $threads threads (the study's default: every core) | ${d_times[*]} | $dm | $isa |"
awk -v o="$om" -v d="$dm" -v r="$rm" 'BEGIN { printf "ours / RLtools = %.2f on 1 thread, %.2f on every core (median over median)\n", o / r, d / r }'
