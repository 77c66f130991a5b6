"""``python3 -m margin_safe_rl.standard_tasks``: serve a task, run the grid, show its state.

- ``serve TASK [--record FILE]``: the task's environment as a plant on stdin/stdout (the plant
  link), every episode measured and appended to FILE;
- ``run --out DIR [--tasks ...] [--agents ...] [--seeds 0-4] [--jobs N] [--threads N] [--steps N]``:
  the grid's runs not done yet, ``--jobs`` at a time, each toolkit run on ``--threads`` trainer
  threads (the same bytes at any count: a long run alone on a machine can use every core; SB3
  keeps the protocol's one thread); ``--steps`` overrides every budget (the CI's tiny grid only);
  Ctrl-C or SIGTERM stops it (exit 130): no new run starts, the running toolkit runs stop at a
  checkpoint and the next ``run`` continues them, and no stopped run is counted as failed;
- ``status --out DIR``: runs done, failed and left per task and agent;
- ``chip --out DIR``: each task's DCP blob (seed 0) on the Cortex-M4F under QEMU, into the
  task's ``chip.json`` (exit 1 if a task's measurement failed: it is printed, not written, and
  tried again next time); ``speed --out DIR``: time per environment step against SB3, into
  ``speed.json``;
- ``keep --out DIR --to KEPT``: what the page needs of every finished run, copied into KEPT (the
  repository's ``experiments/standard-tasks/kept``), so the grid and its page outlive the
  machine; ``run --kept KEPT`` puts those runs back into a new folder before it plans.
"""
from __future__ import annotations

import argparse
import concurrent.futures
import os
import shutil
import signal
import sys
from pathlib import Path
from typing import Any, Iterable, Optional, Sequence

from ..plant_link import GymnasiumPlant, StepReply, serve
from . import grid
from .tasks import TASKS, task


def _log(message: str) -> None:
    print(f"margin_safe_rl.standard_tasks: {message}", file=sys.stderr, flush=True)


class TaskPlant(GymnasiumPlant):
    """A task's environment as a plant: the margin it reports is the action clipped or the
    task's position limit touched (the recorder's figure), so firmware-sim's contact and stuck
    rules see the same margin the page counts."""

    def step(self, action: Sequence[float]) -> StepReply:
        reply = super().step(action)
        if self.env.last_contact and not reply.margin_touched:
            reply = StepReply(
                reply.observation, reply.reward, reply.terminated, reply.truncated,
                True, reply.applied, reply.success,
            )
        return reply


def _serve(args: argparse.Namespace) -> int:
    frames_out = os.fdopen(os.dup(sys.stdout.fileno()), "wb", buffering=0)
    os.dup2(sys.stderr.fileno(), sys.stdout.fileno())
    sys.stdout = sys.stderr
    try:
        t = task(args.task)
    except KeyError as e:
        _log(str(e.args[0]))
        return 2
    from .recorder import make_env, recorded_seconds

    # A continued run's plant appends to its record: the environment clock carries on too.
    clock = recorded_seconds(Path(args.record)) if args.record else 0.0
    record = open(args.record, "a") if args.record else None
    try:
        env = make_env(t, out=record, env_seconds=clock)
    except Exception as e:  # noqa: BLE001 - one line, as every CLI error here
        _log(f"cannot make {t.env_id}: {type(e).__name__}: {e}")
        return 2
    try:
        serve(TaskPlant(env, t.env_id), sys.stdin.buffer, frames_out)
    except BrokenPipeError:
        _log("the host closed the link")
        return 1
    finally:
        env.close()
        if record is not None:
            record.close()
    return 0


def _seeds(text: str) -> list[int]:
    if "-" in text:
        lo, hi = text.split("-", 1)
        seeds = list(range(int(lo), int(hi) + 1))
    else:
        seeds = [int(s) for s in text.split(",")]
    if not seeds or min(seeds) < 0:
        raise argparse.ArgumentTypeError(f"expected seeds as 0-4 or 0,3,7, found {text!r}")
    return seeds


def _names(text: str) -> list[str]:
    return [s for s in text.split(",") if s]


def _programs(args: argparse.Namespace) -> grid.Programs:
    found = {}
    for name, given in (("host-trainer", args.host_trainer), ("firmware-sim", args.firmware_sim)):
        path = given or shutil.which(name)
        if path is None or not os.access(path, os.X_OK):
            raise grid.GridError(
                f"cannot find {name}: give --{name} PATH (cargo build --release puts it in target/release/)"
            )
        found[name] = os.path.abspath(path)
    return grid.Programs(found["host-trainer"], found["firmware-sim"])


def _stop_on_signals() -> None:
    # Ctrl-C and SIGTERM (a job scheduler's stop) alike stop a grid or a run at a checkpoint, as
    # they stop host-trainer; SIGINT too where it came in ignored (a job started with `&` from a
    # script), so that the grid's press passed on to a run is never lost.
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, signal.default_int_handler)


def _run(args: argparse.Namespace) -> int:
    out = Path(args.out)
    lock = grid.GridLock(out)
    try:
        if args.kept:
            restored = grid.restore(Path(args.kept), out)
            if restored:
                print(f"{restored} kept files put back into {out} from {args.kept}", flush=True)
        todo = grid.plan(out, args.tasks, args.agents, args.seeds, args.retry_failed)
        programs = _programs(args)
        os.environ["FIRMWARE_SIM"] = programs.firmware_sim  # nav-walls's plant (see `_one`)
        if not todo:
            print(f"nothing to run: every asked run in {out} is done")
            return 0
        seeds = grid.test_seeds(programs, args.test_episodes)
        print(f"{len(todo)} runs to do in {out}, {args.jobs} at a time", flush=True)

        for task_name in sorted({item[0] for item in todo}):
            grid.random_baseline(out, task(task_name), seeds)

        def one(item: tuple[str, str, int]) -> dict[str, Any]:
            # Each run in a process of its own: SB3's torch and the GIL stay out of each
            # other's way, and a run that crashes Python is a failed run, not a failed grid.
            return grid.run_in_process(out, item, programs, args.steps, args.test_episodes, args.threads)

        pool = concurrent.futures.ThreadPoolExecutor(max_workers=args.jobs)
        futures = {pool.submit(one, item): item for item in todo}
        counts = {"failed": 0, "stopped": 0}
        reported: set[concurrent.futures.Future] = set()

        def report(done: Iterable[concurrent.futures.Future]) -> None:
            # Each run's line as it ends, so a long grid shows its progress.
            for future in done:
                reported.add(future)
                task_name, agent, seed = futures[future]
                name = f"{task_name}/{agent}/seed{seed}"
                if isinstance(future.exception(), grid.Interrupted):
                    counts["stopped"] += 1
                    continue
                result = future.result()
                if "failed" in result:
                    counts["failed"] += 1
                    print(f"{name}: FAILED: {result['failed']}", flush=True)
                else:
                    t = result["test"]
                    print(f"{name}: mean return {t['mean_return']:.2f}, {result['train_seconds']:.0f} s", flush=True)

        # Ctrl-C: no new run starts; the running ones stop at their checkpoint (the trainer
        # writes one) and are neither failed nor finished. A second Ctrl-C is passed on too:
        # host-trainer then stops at once, keeping its last checkpoint.
        left, stopping = list(futures), False
        while left:
            try:
                report(concurrent.futures.as_completed(left))
                left = []
            except KeyboardInterrupt:
                if not stopping:
                    stopping = True
                    print("interrupted: no new run starts; the running ones stop at a checkpoint", flush=True)
                    pool.shutdown(wait=False, cancel_futures=True)
                grid.interrupt_children()
                # The started runs not reported yet (a run cancelled in the queue never completes).
                left = [f for f in futures if not f.cancelled() and f not in reported]
        counts["stopped"] += sum(f.cancelled() for f in futures)
        pool.shutdown()
        if counts["stopped"]:
            print(f"interrupted: {counts['stopped']} runs not finished (none counted as failed); run again to continue them")
            return 130
        return 1 if counts["failed"] else 0
    finally:
        lock.release()


def _one(args: argparse.Namespace) -> int:
    programs = grid.Programs(args.host_trainer, args.firmware_sim)
    # nav-walls is firmware-sim's plant: its Gymnasium environment (and the plant the trainer
    # starts) find the simulator here.
    os.environ["FIRMWARE_SIM"] = args.firmware_sim
    seeds = grid.test_seeds(programs, args.test_episodes)
    grid.run_one(Path(args.out), task(args.task), args.agent, args.seed, programs, seeds, args.steps, args.threads)
    return 0


def _speed(args: argparse.Namespace) -> int:
    out = Path(args.out)
    lock = grid.GridLock(out, ".speed.lock")
    try:
        result = grid.measure_speed(out, _programs(args), args.steps)
    finally:
        lock.release()
    for row in result["rows"]:
        print(
            f"{result['what']}: toolkit {row['toolkit']} {1e3 * row['toolkit_cpu_seconds_per_step']:.3f} ms/step, "
            f"SB3 {row['sb3']} {1e3 * row['sb3_cpu_seconds_per_step']:.3f} ms/step (processor time), "
            f"SB3/toolkit {row['cpu_ratio']:.1f} (wall {row['ratio']:.1f}); "
            f"toolkit time in the Python environment {100 * row['python_share']:.1f} %"
        )
    return 0


def _chip(args: argparse.Namespace) -> int:
    out = Path(args.out)
    if not out.is_dir():
        raise grid.GridError(f"chip: no grid folder {out}")
    for name in args.tasks:
        task(name)
    lock = grid.GridLock(out, ".chip.lock")
    try:
        chip = grid.chip_figures(out, Path(args.repo), args.tasks)
    finally:
        lock.release()
    if not chip:
        raise grid.GridError(f"chip: no task in {out} has its dcp seed-0 blob yet")
    for name, figures in chip.items():
        print(f"{name}: {figures['act']}")
    return 1 if any(figures["act"].startswith("not run") for figures in chip.values()) else 0


def _keep(args: argparse.Namespace) -> int:
    out, kept = Path(args.out), Path(args.to)
    # The grid's writer stays out while its folder is read; one keeper at a time in KEPT.
    lock = grid.GridLock(out)
    try:
        keeper = grid.GridLock(kept, ".keep.lock")
        try:
            copied = grid.keep(out, kept)
        finally:
            keeper.release()
    finally:
        lock.release()
    print(f"{copied} files kept in {kept}")
    return 0


def _status(args: argparse.Namespace) -> int:
    import json

    out = Path(args.out)
    for t in TASKS:
        for agent in grid.AGENTS:
            done = failed = 0
            for seed in args.seeds:
                path = grid.run_folder(out, t.name, agent, seed) / "result.json"
                if path.exists():
                    if "failed" in json.loads(path.read_text()):
                        failed += 1
                    else:
                        done += 1
            if done or failed:
                print(f"{t.name:18} {agent:18} done {done}  failed {failed}  left {len(args.seeds) - done - failed}")
    return 0


def main(argv: Optional[Sequence[str]] = None) -> int:
    parser = argparse.ArgumentParser(prog="python3 -m margin_safe_rl.standard_tasks", description=__doc__.split("\n")[0])
    commands = parser.add_subparsers(dest="command", required=True)
    s = commands.add_parser("serve", help="serve a task's environment over the plant link")
    s.add_argument("task", help=", ".join(t.name for t in TASKS))
    s.add_argument("--record", help="append one JSON line per episode to this file")
    r = commands.add_parser("run", help="run the grid's runs not done yet")
    r.add_argument("--out", required=True, help="the grid's folder (created if missing)")
    r.add_argument("--tasks", type=_names, default=grid.all_tasks())
    r.add_argument("--agents", type=_names, default=list(grid.AGENTS))
    r.add_argument("--seeds", type=_seeds, default=list(range(5)))
    r.add_argument("--jobs", type=int, default=1, help="runs at a time")
    r.add_argument("--threads", type=int, default=1, help="trainer threads of each toolkit run (same bytes at any count)")
    r.add_argument("--steps", type=int, default=None, help="override every budget (tiny grids)")
    r.add_argument("--test-episodes", type=int, default=grid.TEST_EPISODES)
    r.add_argument("--retry-failed", action="store_true")
    r.add_argument("--kept", help="put the runs kept in this folder back into --out first")
    r.add_argument("--host-trainer", help="the host-trainer program (default: on PATH)")
    r.add_argument("--firmware-sim", help="the firmware-sim program (default: on PATH)")
    o = commands.add_parser("one", help="one run of the grid (what `run` starts per run)")
    o.add_argument("task")
    o.add_argument("agent")
    o.add_argument("seed", type=int)
    o.add_argument("--out", required=True)
    o.add_argument("--steps", type=int, default=None)
    o.add_argument("--test-episodes", type=int, default=grid.TEST_EPISODES)
    o.add_argument("--threads", type=int, default=1)
    o.add_argument("--host-trainer", required=True)
    o.add_argument("--firmware-sim", required=True)
    sp = commands.add_parser("speed", help="time per environment step: the toolkit's TD3 against SB3's")
    sp.add_argument("--out", required=True, help="the grid's folder (speed.json is written there)")
    sp.add_argument("--steps", type=int, default=5000)
    sp.add_argument("--host-trainer", help="the host-trainer program (default: on PATH)")
    sp.add_argument("--firmware-sim", help="the firmware-sim program (default: on PATH)")
    c = commands.add_parser("chip", help="each task's DCP blob (seed 0) on the Cortex-M4F under QEMU")
    c.add_argument("--out", required=True, help="the grid's folder (each task's chip.json is written there)")
    c.add_argument("--repo", default=".", help="the repository (for scripts/cortex-m.sh)")
    c.add_argument("--tasks", type=_names, default=grid.all_tasks())
    k = commands.add_parser("keep", help="copy what the page needs of the finished runs into a kept folder")
    k.add_argument("--out", required=True, help="the grid's folder")
    k.add_argument("--to", required=True, help="the kept folder (experiments/standard-tasks/kept)")
    st = commands.add_parser("status", help="what is done in a grid's folder")
    st.add_argument("--out", required=True)
    st.add_argument("--seeds", type=_seeds, default=list(range(5)))
    args = parser.parse_args(argv)
    try:
        if args.command == "serve":
            return _serve(args)
        if args.command == "one":
            _stop_on_signals()
            return _one(args)
        if args.command == "chip":
            return _chip(args)
        if args.command == "keep":
            return _keep(args)
        if args.command == "speed":
            if args.steps < 2000:
                raise grid.GridError("--steps must be at least 2000 (1000 of them before the first update)")
            return _speed(args)
        if args.command == "run":
            if args.jobs < 1 or args.threads < 1 or (args.steps is not None and args.steps < 2) or args.test_episodes < 1:
                raise grid.GridError("--jobs, --threads and --test-episodes must be at least 1, --steps at least 2")
            _stop_on_signals()
            return _run(args)
        return _status(args)
    except (grid.GridError, KeyError) as e:
        _log(str(e.args[0]) if e.args else str(e))
        return 2
    except (grid.Interrupted, KeyboardInterrupt):
        # Stopped by a signal: not an error, and nothing half-written (every file the grid
        # writes is written whole, and a stopped run writes no result).
        _log("interrupted")
        return 130


if __name__ == "__main__":
    sys.exit(main())
