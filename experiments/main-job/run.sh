#!/usr/bin/env bash
# The main job's study as one queue (docs/results/main-job.md): each line of plan.txt is one
# `host-trainer train`, run into OUT/NAME/ and timed by /usr/bin/time (elapsed and CPU seconds,
# one line per part in OUT/NAME/parts.txt). A finished line (OUT/NAME/done) is skipped, and a
# line stopped part-way (Ctrl-C: the run or race checkpoints) continues with `train --resume`,
# so the queue starts again from the top after any stop:
#
#   experiments/main-job/run.sh runs/main-job
#   HOST_TRAINER=/path/to/host-trainer experiments/main-job/run.sh runs/main-job
#
# A line already in experiments/main-job/record.tsv (finished on this or another machine) is
# skipped too. One queue at a time (a lock on OUT). Keep the finished lines and render the page
# with
#   cargo run --release -p studies --bin main-job -- --runs runs/main-job --save-record \
#       --page docs/results/main-job.md --commit COMMIT --cpu MACHINE
set -uo pipefail

die() { echo "run.sh: $*" >&2; exit 2; }
out="${1:?usage: experiments/main-job/run.sh OUT}"
cd "$(dirname "$0")/../.."
bin="${HOST_TRAINER:-target/release/host-trainer}"
[ -x "$bin" ] || die "no host-trainer at $bin (cargo build --release, or set HOST_TRAINER)"
[ -x /usr/bin/time ] || die "needs /usr/bin/time (Debian package time)"
mkdir -p "$out" || die "cannot make $out"
exec 9> "$out/.queue.lock"
flock -n 9 || die "another queue runs in $out"
stop=0
trap 'stop=1' INT TERM

while read -r name flags; do
  [ -z "$name" ] || [ "${name:0:1}" = "#" ] && continue
  dir="$out/$name"
  [ -f "$dir/done" ] && continue
  cut -f1 experiments/main-job/record.tsv | grep -qx -- "$name" && continue
  mkdir -p "$dir"
  run=$(find "$dir" -mindepth 1 -maxdepth 1 -type d | head -n 1)
  if [ -n "$run" ]; then
    args=(train --resume "$run" --quiet)
  else
    # shellcheck disable=SC2206 # the plan's flags are words
    args=(train $flags --out "$dir" --quiet)
  fi
  part=1
  [ -f "$dir/parts.txt" ] && part=$(($(wc -l < "$dir/parts.txt") + 1))
  echo "$(date -u +%FT%TZ) $name part $part: ${args[*]}"
  /usr/bin/time -f "%e %U %S" -o "$dir/time-$part.txt" "$bin" "${args[@]}" \
    > "$dir/stdout-$part.txt" 2> "$dir/stderr-$part.txt"
  code=$?
  echo "$part $code $(cat "$dir/time-$part.txt" | tail -n 1)" >> "$dir/parts.txt"
  # 0: the gate passes; 1: it fails (a finished run either way); anything else: stopped.
  if [ "$code" -le 1 ]; then
    echo "$code" > "$dir/done"
  else
    echo "$(date -u +%FT%TZ) $name stopped (exit $code): $(tail -n 1 "$dir/stderr-$part.txt")"
    [ "$stop" = 1 ] && exit 130
    [ "$code" = 130 ] && exit 130
  fi
  [ "$stop" = 1 ] && exit 130
done < experiments/main-job/plan.txt
echo "$(date -u +%FT%TZ) every line of the plan is done"
