#!/usr/bin/env bash
# End-to-end check of scripts/reproduce.sbatch on a one-node Slurm (scripts/slurm-local.sh):
# submit exp1's quick grid as a two-task array, wait for both tasks, then build the results page
# with --merge and check that no run is missing. Slurm is stopped at the end, pass or fail.
#
#   bash scripts/slurm-reproduce-check.sh target/release/host-trainer
#
# It builds nothing: the binary is the first argument. SLURM_CHECK_TIMEOUT (seconds, default
# 2400) bounds the wait for the array.
set -euo pipefail

repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
die() {
    echo "slurm-reproduce-check: $*" >&2
    exit 1
}

[[ $# -eq 1 ]] || {
    echo "usage: $0 PATH/TO/host-trainer" >&2
    exit 2
}
[[ -x "$1" && -f "$1" ]] || die "no executable host-trainer at '$1' (build it first: cargo build --release -p host-trainer)"
bin="$(realpath "$1")"
timeout_s="${SLURM_CHECK_TIMEOUT:-2400}"
experiment=exp1
args=(--quick --seeds 2)
tasks=2

# The array's slurm-*.out files land in the folder sbatch is called from: a scratch folder, not
# the repository. The runs go to out/ inside it.
work="$(mktemp -d)"
out="$work/out"
mkdir "$out"
t0=$SECONDS
passed=no

show_outputs() {
    local f
    for f in "$work"/slurm-*.out; do
        [[ -e "$f" ]] || {
            echo "(no slurm-*.out file in $work)"
            break
        }
        echo "--- $f"
        cat "$f"
    done
    echo "--- sinfo"
    sinfo 2>&1 || true
    echo "--- last lines of the slurmd log"
    tail -n 20 "${SLURM_LOCAL_DIR:-/var/spool/slurm-local}/log/slurmd.log" 2>&1 || true
}

finish() {
    local rc=$?
    if [[ $passed != yes ]]; then
        show_outputs >&2
        echo "slurm-reproduce-check: FAILED after $((SECONDS - t0)) s; the runs and outputs are kept in $work" >&2
    fi
    bash "$repo/scripts/slurm-local.sh" stop || true
    [[ $passed == yes ]] && rm -rf "$work"
    exit "$rc"
}
trap finish EXIT

bash "$repo/scripts/slurm-local.sh" start

echo "slurm-reproduce-check: sbatch --wait --array=0-$((tasks - 1)) reproduce.sbatch $experiment OUT ${args[*]}"
cd "$work"
status=0
# --parsable prints the job id alone; --wait exits with the highest exit code of the tasks.
job="$(HOST_TRAINER="$bin" timeout "$timeout_s" \
    sbatch --parsable --wait --array=0-$((tasks - 1)) "$repo/scripts/reproduce.sbatch" \
    "$experiment" "$out" "${args[@]}")" || status=$?
[[ $status -ne 124 ]] || die "the array did not finish within $timeout_s s"
[[ $status -eq 0 ]] || die "an array task failed (sbatch --wait exited $status)"
[[ "$job" =~ ^[0-9]+$ ]] || die "sbatch printed '$job', not a job id"

# No accounting database, so no sacct: the exit status above covers the tasks' codes, and each
# task must have left its output file with the line reproduce.sbatch prints before it starts.
for ((i = 0; i < tasks; i++)); do
    f="$work/slurm-${job}_$i.out"
    [[ -f "$f" ]] || die "array task $i left no $f"
    grep -q "slice $i/$tasks" "$f" || die "array task $i did not run slice $i/$tasks (see $f)"
done

echo "slurm-reproduce-check: host-trainer reproduce $experiment --out OUT ${args[*]} --merge"
"$bin" reproduce "$experiment" --out "$out" "${args[@]}" --merge ||
    die "the merge failed (exit $?)"
[[ -s "$out/$experiment.md" ]] || die "the merge exited 0 but wrote no $out/$experiment.md"

passed=yes
echo "slurm-reproduce-check: $tasks array tasks and the merge passed in $((SECONDS - t0)) s"
