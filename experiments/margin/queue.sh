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
# Every sweep skips finished runs and resumes checkpointed ones, so the queue can be stopped
# (Ctrl-C: the running runs checkpoint) and started again from the top. One queue runs at a
# time: a second one waits on the lock, which the running sweep holds until it ends, so a new
# plan can take over from a stopped queue without two sweeps sharing the machine.
# Runs made beside other work can sit in a low-priority session:
#   (echo 19 > /proc/self/autogroup; exec experiments/margin/queue.sh experiments/margin/plan.txt)
set -euo pipefail

plan="${1:?usage: experiments/margin/queue.sh PLAN_FILE}"
[ -r "$plan" ] || { echo "queue.sh: cannot read the plan $plan" >&2; exit 2; }
cd "$(dirname "$0")/../.."
bin="${HOST_TRAINER:-target/release/host-trainer}"
[ -x "$bin" ] || { echo "queue.sh: no host-trainer at $bin (cargo build --release -p host-trainer, or set HOST_TRAINER)" >&2; exit 2; }

mkdir -p runs/margin
exec 9> runs/margin/queue.lock
flock 9

while read -r step arm layout seeds rest; do
  case "$step" in '' | '#'*) continue ;; esac
  case "$step" in
    screen) layouts=experiments/margin/layouts; suffix=seed11 ;;
    confirm) layouts=experiments/margin/confirm-layouts; suffix=seed12 ;;
    *) echo "queue.sh: unknown step '$step' in $plan" >&2; exit 2 ;;
  esac
  if [ -z "$seeds" ] || [ -n "$rest" ]; then
    echo "queue.sh: a line of $plan is not 'STEP ARM LAYOUT SEEDS': $step $arm $layout $seeds $rest" >&2
    exit 2
  fi
  case "$arm" in
    A0) opts=() ;;
    ddpg | td3 | ppo | dqn) opts=(--algo "$arm") ;;
    *)
      [ -r "experiments/margin/$arm.toml" ] || { echo "queue.sh: no config experiments/margin/$arm.toml" >&2; exit 2; }
      opts=(--config "experiments/margin/$arm.toml")
      ;;
  esac
  if [ "$layout" = pinwheel ]; then
    task=()
  else
    [ -r "$layouts/$layout-$suffix.toml" ] || { echo "queue.sh: no layout $layouts/$layout-$suffix.toml" >&2; exit 2; }
    task=(--task "$layouts/$layout-$suffix.toml")
  fi
  out="runs/margin/$step/$arm"
  mkdir -p "$out"
  echo "$(date -u +%FT%TZ) start $step $arm $layout $seeds"
  rc=0
  "$bin" sweep "${opts[@]}" "${task[@]}" --seeds "$seeds" --out "$out" || rc=$?
  echo "$(date -u +%FT%TZ) end $step $arm $layout $seeds rc=$rc"
  # A sweep stopped by Ctrl-C ends the queue; a failed run is recorded by the sweep and the
  # queue goes on.
  [ "$rc" -eq 130 ] && exit 130
done < "$plan"
