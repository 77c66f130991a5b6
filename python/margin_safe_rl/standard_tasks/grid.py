"""The grid of runs: every task x agent x seed, one folder each, resumable, one writer at a time.

A run's folder is ``OUT/{task}/{agent}/seed{N}/``; it is done when ``result.json`` is in it
(written last, atomically). Running the grid again runs only what is not done, so the grid can
be run in parts (``--tasks``, ``--agents``, ``--seeds``) or after a kill. A toolkit run killed
mid-way continues from its last checkpoint (``host-trainer train --resume``), an SB3 run from its
own (``sb3_agents``: written on a stop and every ten minutes), each ending as a run never stopped
would. A run whose program fails is recorded as failed (``result.json`` with ``failed``) and
counted on the page; ``--retry-failed`` runs it again. A run stopped by Ctrl-C or SIGTERM has
neither failed nor finished: nothing is written for it (:class:`Interrupted`), the trainer has
written its checkpoint, and the next ``run`` continues it.

A run's folder stays on the machine that ran it. What the page needs of each finished run (its
``result.json`` and ``train.jsonl``, each task's ``random.json`` and ``chip.json``, the blob the
chip figures are measured on, and the grid's ``speed.json``) is kept in the repository with
:func:`keep` (``standard_tasks keep``), and
``run --kept DIR`` puts the kept runs back into a new machine's folder first, so the grid goes
on there from where it stopped.

Agents:
- ``sb3-td3``, ``sb3-sac``, ``sb3-ddpg``: SB3 with the Zoo's settings and budget for the task;
- ``dcp``, ``dcp-paper``, ``ddpg``, ``td3``: the toolkit's agents with its defaults (4x48 ReLU),
  trained through ``--plant-cmd`` for the task's budget;
- the same four with ``@zoo-net``: hidden layers 2x400, the blob format's closest shape to the
  Zoo's [400, 300] (the format stores DEPTHxWIDTH; 2x400 has every unit of [400, 300] and more,
  so the speed ratio is measured against the toolkit doing more work, not less).
"""
from __future__ import annotations

import fcntl
import json
import os
import re
import shlex
import signal
import subprocess
import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterable, Optional, Sequence

from .files import write_whole
from .tasks import TASKS, Task, task

TOOLKIT = ("dcp", "dcp-paper", "ddpg", "td3")
SB3 = ("sb3-td3", "sb3-sac", "sb3-ddpg")
AGENTS = SB3 + TOOLKIT + tuple(f"{a}@zoo-net" for a in TOOLKIT)
TEST_EPISODES = 100
ZOO_NET = "2x400"
DEFAULT_NET = "4x48"
# DCP as the paper gives it (host-trainer's `dcp::Config::paper()`): the critic's own score,
# no target smoothing, one-step targets.
PAPER_DCP = '[dcp]\nscoring = "critic"\ntarget_smoothing = false\nn_step = 1\n'


class GridError(Exception):
    """A grid that cannot run as asked (one line)."""


class Interrupted(Exception):
    """A run stopped by a signal before it finished: not a failed run (nothing is written for
    it; the next ``run`` continues it from the trainer's checkpoint)."""


# How a program the grid starts reports a stop by signal: host-trainer and firmware-sim exit
# 130 for SIGINT, SIGTERM and SIGHUP alike (after writing their checkpoint); a Python child
# exits 130 (see ``_one``) or dies by the signal itself (a negative status).
INTERRUPTED_STATUSES = (130, -signal.SIGINT, -signal.SIGTERM, -signal.SIGHUP)

# The programs running now, so that the grid's main thread can pass a Ctrl-C on to them: a
# `kill -INT` of the grid alone reaches no child, and a terminal's Ctrl-C reaches them too
# (host-trainer counts two deliveries within half a second as one press).
_children: set[subprocess.Popen] = set()
_children_lock = threading.Lock()


def interrupt_children() -> None:
    """Sends SIGINT to every program the grid is running now."""
    with _children_lock:
        for child in _children:
            if child.poll() is None:
                child.send_signal(signal.SIGINT)


@dataclass(frozen=True)
class Programs:
    """The programs a toolkit run needs: the trainer, the simulator and this Python."""

    host_trainer: str
    firmware_sim: str
    python: str = sys.executable

    def serve(self, task_name: str, record: Optional[Path] = None) -> str:
        argv = [self.python, "-m", "margin_safe_rl.standard_tasks", "serve", task_name]
        if record is not None:
            argv += ["--record", str(record)]
        return shlex.join(argv)


def run_folder(out: Path, task_name: str, agent: str, seed: int) -> Path:
    return out / task_name / agent / f"seed{seed}"


RUN_FILES = ("result.json", "train.jsonl")
# Each task's figures are files of their own, so that a task measured later adds a file and
# never changes one already kept.
TASK_FILES = ("random.json", "chip.json")
GRID_FILES = ("speed.json",)
# The run whose exported blob the chip figures are measured on; its blob is kept too (29 KB at
# 4x48), so that `chip` runs on a machine where the grid was put back from the kept folder.
CHIP_AGENT, CHIP_SEED = "dcp", 0


def chip_blob(out: Path, task_name: str) -> Optional[Path]:
    """The exported blob of ``task_name``'s chip run (``dcp``, seed 0), where it is finished."""
    found = sorted((run_folder(out, task_name, CHIP_AGENT, CHIP_SEED) / "train").glob("*/policy.postcard"))
    return found[0] if found else None


def _kept_files(root: Path) -> list[Path]:
    """Every file of ``root`` that a kept grid holds, relative to it: the grid's files, each
    task's, and each finished run's (a run without ``result.json`` is not finished), with the
    chip run's blob."""
    found = [Path(name) for name in GRID_FILES if (root / name).is_file()]
    for result in sorted(root.glob("*/*/seed*/result.json")):
        run = result.parent.relative_to(root)
        found += [run / name for name in RUN_FILES if (root / run / name).is_file()]
        if run.parts[1:] == (CHIP_AGENT, f"seed{CHIP_SEED}"):
            blob = chip_blob(root, run.parts[0])
            if blob is not None:
                found.append(blob.relative_to(root))
    for t in sorted({p.parts[0] for p in found if len(p.parts) > 1}):
        found += [Path(t) / name for name in TASK_FILES if (root / t / name).is_file()]
    return found


def _copy_through(src_root: Path, dst_root: Path, what: str) -> int:
    """Copies every kept file of ``src_root`` that ``dst_root`` lacks; a file both hold must be
    the same bytes (a finished run is never replaced: a difference is an error naming both, and
    nothing is copied). Returns the number of files copied."""
    todo = []
    for rel in _kept_files(src_root):
        src, dst = src_root / rel, dst_root / rel
        data = src.read_bytes()
        if dst.exists():
            if dst.read_bytes() != data:
                raise GridError(
                    f"{what}: {dst} differs from {src}; a finished run is never replaced "
                    "(move one of them away if the other is the one to keep)"
                )
            continue
        todo.append((dst, data))
    for dst, data in todo:
        dst.parent.mkdir(parents=True, exist_ok=True)
        tmp = dst.with_name(f".{dst.name}.{os.getpid()}.tmp")
        tmp.write_bytes(data)
        os.replace(tmp, dst)
    return len(todo)


def keep(out: Path, kept: Path) -> int:
    """Copies what the page needs of every finished run in ``out`` (failed ones too: the page
    counts them) into ``kept``, the folder committed with the page; returns the files copied."""
    if not out.is_dir():
        raise GridError(f"keep: no grid folder {out}")
    return _copy_through(out, kept, "keep")


def restore(kept: Path, out: Path) -> int:
    """Puts the kept runs back into ``out`` (where it lacks them), so that the plan skips them
    and the page reads them; returns the files copied."""
    if not kept.is_dir():
        raise GridError(f"--kept: no folder {kept}")
    return _copy_through(kept, out, "--kept")


def test_seeds(programs: Programs, episodes: int = TEST_EPISODES) -> list[int]:
    """The test protocol's reset seeds (``firmware-sim test-starts``): every agent is tested
    from these starts, so episode i is the same start for all of them."""
    out = subprocess.run(
        [programs.firmware_sim, "test-starts", "--episodes", str(episodes)],
        check=True, capture_output=True, text=True,
    )
    return [int(line) for line in out.stdout.split()]


def _episodes(path: Path) -> list[dict[str, Any]]:
    with open(path) as f:
        return [json.loads(line) for line in f if line.strip()]


def training_seconds(log: str, metrics: list[str]) -> Optional[float]:
    """The seconds a toolkit run trained, over all its parts: the trainer's own figure for its
    training loop (no export, no test) from the last part's ``trained`` line in ``log``, plus,
    for a run continued from a checkpoint, the earlier parts' episodes by the trainer's clock
    in ``metrics.csv`` (``metrics``: its lines; steps / steps per second, summed), since the
    ``trained`` line times its own part alone. None if the log has no ``trained`` line."""
    trained = re.findall(
        r"\((\d+) episodes, \d+ env steps(?: in all; this part: (\d+) episodes, \d+ env steps)? in ([0-9.]+) s",
        log,
    )
    if not trained:
        return None
    episodes, this_part, seconds = trained[-1]
    earlier = int(episodes) - int(this_part or episodes)
    if earlier == 0:
        return float(seconds)
    header = metrics[0].split(",")
    episode, steps, rate = (header.index(c) for c in ("episode", "steps", "steps_per_s"))
    before = 0.0
    for line in metrics[1:]:
        try:
            cells = line.split(",")
            n, r = float(cells[steps]), float(cells[rate])
            if int(cells[episode]) <= earlier and r > 0:  # as the trainer's reader skips them
                before += n / r
        except (ValueError, IndexError):
            continue  # a row the trainer did not finish writing: its seconds are not known
    return before + float(seconds)


def training_parts(log: str) -> int:
    """The parts a toolkit run trained in: one, and one more after each stop at a checkpoint
    that ``log`` records (``train_seconds`` counts them all)."""
    return log.count("; checkpoint written.") + 1


def training_episodes(path: Path, steps: int) -> list[dict[str, Any]]:
    """The training episodes a plant recorded: those within the run's first ``steps`` steps
    (the trainer's test episodes, recorded after them by the same plant, are left out)."""
    kept, total = [], 0
    for e in _episodes(path):
        if total >= steps:
            break
        total += e["steps"]
        kept.append(e)
    return kept


def test_figures(episodes: list[dict[str, Any]], success_return: float) -> dict[str, Any]:
    """A run's test figures from its test episodes (the recorder's lines)."""
    steps = sum(e["steps"] for e in episodes)
    returns = [e["return"] for e in episodes]
    flags = [e["success"] for e in episodes]
    if all(f is not None for f in flags):
        successes = sum(bool(f) for f in flags)
    else:
        successes = sum(r >= success_return for r in returns)
    return {
        "episodes": len(episodes),
        "mean_return": sum(returns) / max(len(returns), 1),
        "returns": returns,
        "successes": successes,
        "steps": steps,
        "at_bound_share": sum(e["at_bound_steps"] for e in episodes) / max(steps, 1),
        "contact_share": sum(e["contact_steps"] for e in episodes) / max(steps, 1),
        "contact_episodes": sum(e["contact_steps"] > 0 for e in episodes),
    }


def judged(status: int) -> bool:
    """Whether a program that judges a blob (``host-trainer train``, ``firmware-sim run``) did
    its work: 0 when the blob passes its gate, 1 when it fails it. 2 is an error and 130 an
    interrupt: the run did not finish."""
    return status in (0, 1)


def _run(argv: Sequence[str], log: Path, env: Optional[dict] = None) -> int:
    """Runs a program to its end and returns its exit status; raises :class:`Interrupted` if it
    stopped by a signal. A Ctrl-C here is passed on and the program waited for, not killed
    (``subprocess.run`` would kill it after a quarter second, before its checkpoint)."""
    with open(log, "a") as f:
        f.write(f"$ {shlex.join(argv)}\n")
        f.flush()
        child = subprocess.Popen(argv, stdout=f, stderr=subprocess.STDOUT, env=env)
        with _children_lock:
            _children.add(child)
        interrupted = False
        try:
            while True:
                try:
                    status = child.wait()
                    break
                except KeyboardInterrupt:
                    interrupted = True
                    child.send_signal(signal.SIGINT)
        finally:
            with _children_lock:
                _children.discard(child)
    if interrupted or status in INTERRUPTED_STATUSES:
        raise Interrupted(f"{Path(argv[0]).name} stopped by a signal (exit {status})")
    return status


def run_toolkit(
    t: Task, agent: str, seed: int, folder: Path, programs: Programs, steps: Optional[int],
    eval_episodes: int, threads: int = 1,
) -> dict[str, Any]:
    """Trains a toolkit agent through the plant link on ``threads`` worker threads (the trainer
    gives the same bytes at any count, so this changes the wall time only), then tests its
    exported blob in firmware-sim on the same plant, recording every test episode."""
    algo, _, net = agent.partition("@")
    hidden = ZOO_NET if net == "zoo-net" else DEFAULT_NET
    budget = t.budget if steps is None else steps
    train_dir = folder / "train"
    log = folder / "log.txt"
    existing = [p for p in train_dir.glob("*/checkpoint.postcard")] if train_dir.exists() else []
    started = time.perf_counter()
    if existing:
        argv = [programs.host_trainer, "train", "--resume", str(existing[0].parent), "--threads", str(threads), "--quiet"]
    else:
        train_dir.mkdir(parents=True, exist_ok=True)
        argv = [
            programs.host_trainer, "train",
            "--plant-cmd", programs.serve(t.name, record=folder / "train.jsonl"),
            "--algo", "dcp" if algo == "dcp-paper" else algo, "--hidden", hidden,
            "--env-steps", str(budget), "--episodes", str(min(budget, 1_000_000)),
            "--seed", str(seed), "--out", str(train_dir), "--threads", str(threads), "--quiet",
        ]
        # The test protocol's episode count; DCP's paper settings for dcp-paper.
        config = folder / "toolkit.toml"
        # A tiny run (`--steps`) starts updating at half its steps, as its SB3 runs do, so the
        # updates run through the link too.
        warmup = "" if steps is None else f"[agent]\nwarmup_steps = {max(1, steps // 2)}\n"
        config.write_text(
            f"eval_episodes = {eval_episodes}\n" + warmup + (PAPER_DCP if algo == "dcp-paper" else "")
        )
        argv += ["--config", str(config)]
    status = _run(argv, log)
    seconds = time.perf_counter() - started
    if not judged(status):
        return {"failed": f"host-trainer train exited {status} (see log.txt)"}
    run = next(p.parent for p in train_dir.glob("*/policy.postcard"))
    trainer_eval = json.loads((run / "eval.json").read_text())
    test_log = folder / "test.jsonl"
    test_log.unlink(missing_ok=True)
    argv = [
        programs.firmware_sim, "run", "--plant-cmd", programs.serve(t.name, record=test_log),
        "--blob", str(run / "policy.postcard"), "--episodes", str(eval_episodes),
        "--json", str(folder / "blob-report.json"),
    ]
    if t.success_return == t.success_return:  # a return threshold (nav-walls flags success)
        argv += ["--success-return", str(t.success_return)]
    status = _run(argv, log)
    if not judged(status):
        return {"failed": f"firmware-sim run exited {status} (see log.txt)"}
    blob_report = json.loads((folder / "blob-report.json").read_text())
    metrics = (run / "metrics.csv").read_text().splitlines()
    header = metrics[0].split(",")
    last = dict(zip(header, metrics[-1].split(",")))
    steps_trained = int(last["total_steps"])
    # The recorder's clock is cumulative, over every part of a continued run too: the last
    # training episode's is the run's time in the Python environment (the trainer's own test
    # episodes follow in the same file).
    training = training_episodes(folder / "train.jsonl", steps_trained)
    env_seconds = training[-1]["env_seconds"] if training else 0.0
    log_text = log.read_text()
    train_seconds = training_seconds(log_text, metrics)
    return {
        "env_steps": steps_trained,
        "train_seconds": seconds if train_seconds is None else train_seconds,
        "train_parts": training_parts(log_text),
        "hidden": hidden,
        "trainer_threads": threads,
        "blob": {
            "path": str(run / "policy.postcard"),
            "bytes": (run / "policy.postcard").stat().st_size,
            "trainer_mean_return": trainer_eval.get("mean_return"),
            "blob_mean_return": blob_report.get("mean_return"),
        },
        "env_seconds": env_seconds,
    }


def run_one(
    out: Path, t: Task, agent: str, seed: int, programs: Programs, seeds: Sequence[int],
    steps: Optional[int] = None, threads: int = 1,
) -> dict[str, Any]:
    """Runs one cell's seed and writes its ``result.json``; returns the result."""
    folder = run_folder(out, t.name, agent, seed)
    folder.mkdir(parents=True, exist_ok=True)
    result: dict[str, Any] = {"task": t.name, "agent": agent, "seed": seed, "steps_override": steps}
    try:
        if agent.startswith("sb3-"):
            from .sb3_agents import train_and_test

            result["library"] = "sb3"
            result.update(train_and_test(t, agent[4:], seed, folder, seeds, steps))
            result["budget"] = t.zoo[agent[4:]].n_timesteps if steps is None else steps
        else:
            result["library"] = "toolkit"
            result.update(run_toolkit(t, agent, seed, folder, programs, steps, len(seeds), threads))
            result["budget"] = t.budget if steps is None else steps
    except Interrupted:
        raise  # neither failed nor finished: nothing is written
    except Exception as e:  # noqa: BLE001 - a run's failure is a result, counted on the page
        result["failed"] = f"{type(e).__name__}: {e}"
    if "failed" not in result:
        result["test"] = test_figures(_episodes(folder / "test.jsonl"), t.success_return)
    write_whole(folder / "result.json", json.dumps(result, indent=1) + "\n")
    return result


def run_in_process(
    out: Path, item: tuple[str, str, int], programs: Programs, steps: Optional[int], test_episodes: int,
    threads: int = 1,
) -> dict[str, Any]:
    """:func:`run_one` in a child Python (``... standard_tasks one``); a child that dies
    without a result is a failed run, one stopped by a signal :class:`Interrupted`."""
    task_name, agent, seed = item
    folder = run_folder(out, task_name, agent, seed)
    folder.mkdir(parents=True, exist_ok=True)
    argv = [
        programs.python, "-m", "margin_safe_rl.standard_tasks", "one", task_name, agent, str(seed),
        "--out", str(out), "--test-episodes", str(test_episodes), "--threads", str(threads),
        "--host-trainer", programs.host_trainer, "--firmware-sim", programs.firmware_sim,
    ]
    if steps is not None:
        argv += ["--steps", str(steps)]
    done = folder / "result.json"
    try:
        status = _run(argv, folder / "log.txt")
    except Interrupted:
        if done.exists():  # stopped after its result was written: finished
            return json.loads(done.read_text())
        raise
    if done.exists():
        return json.loads(done.read_text())
    result = {"task": task_name, "agent": agent, "seed": seed, "steps_override": steps,
              "failed": f"the run's process exited {status} without a result (see log.txt)"}
    write_whole(done, json.dumps(result, indent=1) + "\n")
    return result


def random_baseline(out: Path, t: Task, seeds: Sequence[int]) -> dict[str, Any]:
    """A uniformly random policy's test figures on the task (``OUT/{task}/random.json``): the 0
    of the page's normalised returns. Its actions come from a generator seeded with 0."""
    import numpy as np

    from .recorder import make_env

    path = out / t.name / "random.json"
    if path.exists():
        return json.loads(path.read_text())
    path.parent.mkdir(parents=True, exist_ok=True)
    env = make_env(t)
    rng = np.random.default_rng(0)
    low, high = env.action_space.low, env.action_space.high
    for s in seeds:
        env.reset(seed=int(s))
        done = False
        while not done:
            _, _, terminated, truncated, _ = env.step(rng.uniform(low, high).astype(np.float32))
            done = terminated or truncated
    env.close()
    result = test_figures(env.episodes, t.success_return)
    write_whole(path, json.dumps(result, indent=1) + "\n")
    return result


SPEED_BATCH = 256
SPEED_WARMUP = 1000


SPEED_SIZES = ((ZOO_NET, [400, 300]), (DEFAULT_NET, [48, 48, 48, 48]))


def _cpu_name() -> str:
    import platform

    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "?"


def _speed_row(out: Path, programs: Programs, steps: int, hidden: str, net_arch: list[int]) -> dict[str, Any]:
    import resource

    from .recorder import make_env
    from .sb3_agents import build, quiet_logger

    t = task("pendulum")
    folder = out / "speed" / hidden
    folder.mkdir(parents=True)
    config = folder / "toolkit.toml"
    config.write_text(f"eval_episodes = 1\n[agent]\nbatch = {SPEED_BATCH}\nwarmup_steps = {SPEED_WARMUP}\n")
    record = folder / "train.jsonl"
    argv = [
        programs.host_trainer, "train", "--plant-cmd", programs.serve(t.name, record=record),
        "--algo", "td3", "--hidden", hidden, "--env-steps", str(steps), "--episodes", str(steps),
        "--seed", "0", "--out", str(folder), "--threads", "1", "--quiet", "--config", str(config),
    ]
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    status = _run(argv, folder / "log.txt")
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    # The trainer's and its Python plant's processor time: on a machine shared with other work
    # processor time is the steadier figure; wall time is recorded beside it.
    toolkit_cpu = (after.ru_utime + after.ru_stime) - (children.ru_utime + children.ru_stime)
    # Its one test episode is judged too: a speed run whose blob fails the gate has finished.
    if not judged(status):
        raise GridError(f"the toolkit's speed run exited {status} (see {folder / 'log.txt'})")
    trained = re.search(r"([0-9]+) env steps in ([0-9.]+) s", (folder / "log.txt").read_text())
    if trained is None:
        raise GridError(f"no timing line in {folder / 'log.txt'}")
    toolkit_steps, toolkit_seconds = int(trained.group(1)), float(trained.group(2))
    training = training_episodes(record, toolkit_steps)
    python_seconds = training[-1]["env_seconds"] if training else 0.0

    env = make_env(t)
    model, _ = build(t, "td3", 0, env, net_arch=net_arch)
    model.learning_starts = SPEED_WARMUP
    model.batch_size = SPEED_BATCH
    quiet_logger(model, folder / "sb3-log")
    started, cpu_started = time.perf_counter(), time.process_time()
    model.learn(total_timesteps=toolkit_steps)
    sb3_seconds = time.perf_counter() - started
    sb3_cpu = time.process_time() - cpu_started
    env.close()
    return {
        "toolkit": hidden,
        "sb3": str(net_arch),
        "steps": toolkit_steps,
        "toolkit_seconds_per_step": toolkit_seconds / toolkit_steps,
        "sb3_seconds_per_step": sb3_seconds / toolkit_steps,
        "ratio": sb3_seconds / toolkit_seconds,
        "toolkit_cpu_seconds_per_step": toolkit_cpu / toolkit_steps,
        "sb3_cpu_seconds_per_step": sb3_cpu / toolkit_steps,
        "cpu_ratio": sb3_cpu / toolkit_cpu,
        "python_share": python_seconds / toolkit_seconds,
    }


def measure_speed(out: Path, programs: Programs, steps: int) -> dict[str, Any]:
    """Time per environment step on pendulum, one run after the other on one core: the
    toolkit's TD3 through the plant link against SB3's TD3, at the Zoo's size (2x400 against
    [400, 300]) and at the toolkit's (4x48 against [48, 48, 48, 48]); both with batch 256, the
    first update after 1,000 steps, one update per step and the actor every second (TD3's
    delay); ``OUT/speed.json``."""
    import shutil

    if (out / "speed").exists():
        shutil.rmtree(out / "speed")
    rows = [_speed_row(out, programs, steps, hidden, arch) for hidden, arch in SPEED_SIZES]
    result = {
        "what": f"pendulum, {steps} steps, batch {SPEED_BATCH}, first update after {SPEED_WARMUP}, one core",
        "cpu": _cpu_name(),
        "rows": rows,
    }
    write_whole(out / "speed.json", json.dumps(result, indent=1) + "\n")
    return result


def chip_figures(out: Path, repo: Path, tasks: Iterable[str]) -> dict[str, Any]:
    """Each task's chip blob on the Cortex-M4F under QEMU (``scripts/cortex-m.sh``, its
    ``m4f-trained`` variant: built, bit-exact with the host, instructions per ``act``, flash),
    written to ``OUT/{task}/chip.json`` once per task; a task whose blob the example firmware
    cannot hold (more than 16 observations or 8 actions) says so. Returns the figures of every
    task measured, now or before."""
    chip: dict[str, Any] = {}
    for task_name in tasks:
        path = out / task_name / "chip.json"
        if path.exists():
            chip[task_name] = json.loads(path.read_text())
            continue
        blob = chip_blob(out, task_name)
        if blob is None:
            continue
        report = out / task_name / "chip-report.json"
        log = out / task_name / "chip.log"
        argv = ["bash", str(repo / "scripts" / "cortex-m.sh"), "--blob", str(blob),
                "--no-slot-cases", "--no-hil", "--out", str(report)]
        status = _run(argv, log, dict(os.environ, VARIANTS="m4f-trained"))
        text = log.read_text()
        if status != 0 or not report.exists():
            # policy-core's SizeBeyondMaximum, as host-check prints it.
            beyond = re.search(r"(observation|action) size (\d+) beyond the firmware's maximum of (\d+)", text)
            if beyond:
                what, found, most = beyond.groups()
                reason = f"the example firmware holds at most {most} {what}s, the blob has {found}"
            else:
                reason = f"cortex-m.sh exited {status} (see {log})"
            # Not written: a failed measurement is tried again by the next `chip`.
            chip[task_name] = {"act": f"not run: {reason}"}
            continue
        variant = json.loads(report.read_text())["variants"][0]
        ins, flash = variant["instructions"], variant["flash"]
        exact = "bit-exact" if variant["check"]["bit_exact"] else "NOT bit-exact"
        chip[task_name] = {
            "blob": str(blob.relative_to(out)),
            "act": f"{ins['act_mean']:,.0f} instructions ({ins['per_mac']:.2f} per MAC), {exact}; "
            f"flash {flash['total']:,} B with the blob",
        }
        write_whole(path, json.dumps(chip[task_name], indent=1) + "\n")
    return chip


def plan(
    out: Path, tasks: Iterable[str], agents: Iterable[str], seeds: Iterable[int], retry_failed: bool
) -> list[tuple[str, str, int]]:
    """The runs not done yet, in task, agent, seed order."""
    todo = []
    for task_name in tasks:
        task(task_name)
        for agent in agents:
            if agent not in AGENTS:
                raise GridError(f"no agent {agent!r}; the agents are {', '.join(AGENTS)}")
            for seed in seeds:
                done = run_folder(out, task_name, agent, seed) / "result.json"
                if done.exists():
                    failed = "failed" in json.loads(done.read_text())
                    if not (failed and retry_failed):
                        continue
                todo.append((task_name, agent, seed))
    return todo


class GridLock:
    """One writer of each kind per folder (the grid's runs; the chip figures; the speed
    measurement, each its own ``name``): a second is refused at once, naming the folder."""

    def __init__(self, out: Path, name: str = ".grid.lock") -> None:
        out.mkdir(parents=True, exist_ok=True)
        self._file = open(out / name, "w")
        try:
            fcntl.flock(self._file, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            self._file.close()
            raise GridError(f"another grid is running in {out} (it holds {out / name})") from None

    def release(self) -> None:
        self._file.close()


def all_tasks() -> list[str]:
    return [t.name for t in TASKS]
