#!/usr/bin/env bash
# The margin study's runs as one queue: the `sweep` commands of the protocol's steps 1 and 3
# (docs/results/margin-study.md), one after another in the order of a plan file.
#
#   experiments/margin/queue.sh experiments/margin/plan.txt
#   HOST_TRAINER=/path/to/host-trainer experiments/margin/queue.sh experiments/margin/plan.txt
#
# Each plan line is `STEP ARM LAYOUT SEEDS`: STEP `screen` or `confirm`; ARM `A0` (DCP's defaults
# as adopted), a candidate with a config in this folder, or a baseline (`ddpg`, `td3`, `ppo`,
# `dqn`); LAYOUT `pinwheel` or a generated layout's name (`rings-3`: the screening's seed-11 file
# in `layouts/`, the confirmation's seed-12 file in `confirm-layouts/`); SEEDS as `sweep` takes
# them. Blank lines and `#` comments are skipped.
#
# The plan is checked whole before the first run. Every sweep skips finished runs and resumes
# checkpointed ones, so the queue can be stopped (Ctrl-C: the running runs checkpoint) and
# started again from the top. One queue runs at a time: a second one waits on the lock, which
# the running sweep holds until it ends, so a new plan can take over from a stopped queue
# without two sweeps sharing the machine.
# Runs made beside other work can sit in a low-priority session:
#   (echo 19 > /proc/self/autogroup; exec experiments/margin/queue.sh experiments/margin/plan.txt)
set -euo pipefail

die() { echo "queue.sh: $*" >&2; exit 2; }
plan="${1:?usage: experiments/margin/queue.sh PLAN_FILE}"
[ -f "$plan" ] && [ -r "$plan" ] || die "cannot read the plan $plan"
plan="$(realpath "$plan")"
cd "$(dirname "$0")/../.."

# One plan line's sweep: sets `sweep_args` and `out`, or stops the queue naming what is wrong.
job() {
  local step=$1 arm=$2 layout=$3 seeds=$4 rest=$5 layouts suffix
  [ -n "$seeds" ] && [ -z "$rest" ] || die "a line of $plan is not 'STEP ARM LAYOUT SEEDS': $*"
  case "$step" in
    screen) layouts=experiments/margin/layouts suffix=seed11 ;;
    confirm) layouts=experiments/margin/confirm-layouts suffix=seed12 ;;
    *) die "unknown step '$step' in $plan" ;;
  esac
  case "$arm" in
    A0) sweep_args=() ;;
    ddpg | td3 | ppo | dqn) sweep_args=(--algo "$arm") ;;
    *)
      [ -r "experiments/margin/$arm.toml" ] || die "no config experiments/margin/$arm.toml ($plan)"
      sweep_args=(--config "experiments/margin/$arm.toml")
      ;;
  esac
  if [ "$layout" != pinwheel ]; then
    [ -r "$layouts/$layout-$suffix.toml" ] || die "no layout $layouts/$layout-$suffix.toml ($plan)"
    sweep_args+=(--task "$layouts/$layout-$suffix.toml")
  fi
  out="runs/margin/$step/$arm"
  sweep_args+=(--seeds "$seeds" --out "$out")
}

# The whole plan is checked before any run, so a mistake on its last line is found now, not
# hours later.
lines=()
while read -r step arm layout seeds rest; do
  case "$step" in '' | '#'*) continue ;; esac
  job "$step" "$arm" "$layout" "$seeds" "$rest"
  lines+=("$step $arm $layout $seeds")
done < "$plan"

bin="${HOST_TRAINER:-target/release/host-trainer}"
[ -x "$bin" ] || die "no host-trainer at $bin (cargo build --release -p host-trainer, or set HOST_TRAINER)"
mkdir -p runs/margin
exec 9> runs/margin/queue.lock
flock 9

for line in "${lines[@]}"; do
  # shellcheck disable=SC2086 # the line's four words, checked above
  job $line ""
  mkdir -p "$out"
  echo "$(date -u +%FT%TZ) start $line"
  rc=0
  "$bin" sweep "${sweep_args[@]}" || rc=$?
  echo "$(date -u +%FT%TZ) end $line rc=$rc"
  # A sweep stopped by Ctrl-C ends the queue. Any other failure (a failed run, which the sweep
  # records; a folder another process writes) is logged and the queue goes on.
  [ "$rc" -ne 130 ] || exit 130
done
