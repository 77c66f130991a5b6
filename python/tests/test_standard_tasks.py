"""The standard-tasks benchmark's machinery: the task table, the recorder's margin figures, the
grid's plan, lock, failure records and Ctrl-C, and the command line's errors. The grid end to end (the
toolkit's agents through host-trainer and firmware-sim) runs in CI's tiny grid (.ci/run)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from margin_safe_rl.standard_tasks import grid
from margin_safe_rl.standard_tasks.recorder import make_env
from margin_safe_rl.standard_tasks.tasks import TASKS, task


def test_every_task_names_its_margin_and_each_sb3_algorithm_its_zoo_block() -> None:
    for t in TASKS:
        assert t.margin and t.budget > 0
        assert set(t.zoo) == {"td3", "sac", "ddpg"}
        for entry in t.zoo.values():
            assert entry.source and entry.n_timesteps > 0
    with pytest.raises(KeyError, match="the tasks are pendulum"):
        task("cartpole")


def _drive(env, seed: int, action) -> dict:
    env.reset(seed=seed)
    done = False
    while not done:
        _, _, terminated, truncated, _ = env.step(np.asarray(action, dtype=np.float32))
        done = terminated or truncated
    return env.episodes[-1]


def test_full_torque_is_at_the_bound_every_step_and_zero_torque_never() -> None:
    env = make_env(task("pendulum"))
    full = _drive(env, 3, [2.0])
    assert full["steps"] == 200 and full["at_bound_steps"] == 200 and full["contact_steps"] == 0
    # Beyond the box counts as at the bound (the plant clips it).
    assert _drive(env, 3, [7.0])["at_bound_steps"] == 200
    assert _drive(env, 3, [0.0])["at_bound_steps"] == 0
    assert full["seed"] == 3 and full["success"] is None


def test_the_mountain_cars_left_wall_is_counted_when_the_car_is_at_it() -> None:
    env = make_env(task("mountain-car"))
    # Moving left near the wall: the environment clips the position to -1.2 and zeroes the speed.
    env.reset(seed=0)
    env.unwrapped.state = np.array([-1.19, -0.05])
    env.step(np.asarray([-1.0], dtype=np.float32))
    assert env.last_contact
    env.step(np.asarray([1.0], dtype=np.float32))
    assert not env.last_contact
    left = _drive(env, 0, [-1.0])
    assert left["contact_steps"] == 0, left  # constant push: the car rocks, far from the wall
    # Pushing right alone never reaches the left wall from the valley's bottom.
    right = _drive(env, 0, [1.0])
    assert right["contact_steps"] == 0, right


def test_the_carts_rail_end_is_mujocos_joint_limit() -> None:
    pytest.importorskip("mujoco")
    env = make_env(task("inverted-pendulum"))
    # Full force one way: the pole falls (the episode terminates) long before the rail's end.
    pushed = _drive(env, 0, [3.0])
    assert pushed["steps"] < 1000 and pushed["at_bound_steps"] == pushed["steps"]
    env.reset(seed=0)
    data = env.unwrapped.data
    data.qpos[0] = 1.05  # past the slider's range: the limit constraint becomes active
    env.step(np.zeros(1, dtype=np.float32))
    assert env.last_contact


def test_test_figures_pool_episodes_and_use_the_success_line_without_a_flag() -> None:
    episodes = [
        {"return": -150.0, "steps": 200, "at_bound_steps": 20, "contact_steps": 0, "success": None},
        {"return": -300.0, "steps": 200, "at_bound_steps": 60, "contact_steps": 5, "success": None},
    ]
    f = grid.test_figures(episodes, -200.0)
    assert f["successes"] == 1 and f["mean_return"] == -225.0
    assert f["at_bound_share"] == 80 / 400 and f["contact_share"] == 5 / 400
    assert f["contact_episodes"] == 1
    flagged = [dict(e, success=i == 1) for i, e in enumerate(episodes)]
    assert grid.test_figures(flagged, -200.0)["successes"] == 1


def test_the_plan_skips_runs_done_and_retries_failed_ones_only_when_asked(tmp_path: Path) -> None:
    done = grid.run_folder(tmp_path, "pendulum", "dcp", 0)
    done.mkdir(parents=True)
    (done / "result.json").write_text(json.dumps({"test": {}}))
    failed = grid.run_folder(tmp_path, "pendulum", "dcp", 1)
    failed.mkdir(parents=True)
    (failed / "result.json").write_text(json.dumps({"failed": "exited 1"}))
    todo = grid.plan(tmp_path, ["pendulum"], ["dcp"], [0, 1, 2], retry_failed=False)
    assert todo == [("pendulum", "dcp", 2)]
    todo = grid.plan(tmp_path, ["pendulum"], ["dcp"], [0, 1, 2], retry_failed=True)
    assert todo == [("pendulum", "dcp", 1), ("pendulum", "dcp", 2)]
    with pytest.raises(grid.GridError, match="no agent 'dqn'"):
        grid.plan(tmp_path, ["pendulum"], ["dqn"], [0], retry_failed=False)


def test_kept_runs_outlive_the_folder_and_are_never_replaced(tmp_path: Path) -> None:
    out, kept, fresh = tmp_path / "out", tmp_path / "kept", tmp_path / "fresh"
    run = grid.run_folder(out, "pendulum", "dcp", 0)
    run.mkdir(parents=True)
    (run / "result.json").write_text(json.dumps({"test": {"mean_return": -140.0}}))
    (run / "train.jsonl").write_text('{"return": -1200.0}\n')
    (run / "checkpoint.bin").write_bytes(b"large, not kept")
    unfinished = grid.run_folder(out, "pendulum", "dcp", 1)
    unfinished.mkdir(parents=True)
    (unfinished / "train.jsonl").write_text('{"return": -1300.0}\n')
    (out / "pendulum" / "random.json").write_text('{"mean_return": -1200.0}')
    assert grid.keep(out, kept) == 3
    assert grid.keep(out, kept) == 0  # the same files: nothing to do
    assert not (kept / "pendulum" / "dcp" / "seed0" / "checkpoint.bin").exists()
    assert not (kept / "pendulum" / "dcp" / "seed1").exists()
    # On another machine: the kept run is put back, and the plan skips it.
    assert grid.restore(kept, fresh) == 3
    todo = grid.plan(fresh, ["pendulum"], ["dcp"], [0, 1], retry_failed=False)
    assert todo == [("pendulum", "dcp", 1)]
    # A finished run that differs from the kept one is refused, and nothing is copied.
    other = grid.run_folder(out, "pendulum", "dcp", 2)
    other.mkdir(parents=True)
    (other / "result.json").write_text("{}")
    (run / "result.json").write_text(json.dumps({"test": {"mean_return": -150.0}}))
    with pytest.raises(grid.GridError, match="a finished run is never replaced"):
        grid.keep(out, kept)
    assert not (kept / "pendulum" / "dcp" / "seed2").exists()
    assert json.loads((kept / "pendulum" / "dcp" / "seed0" / "result.json").read_text())["test"] == {"mean_return": -140.0}


def test_the_chip_runs_blob_is_kept_so_chip_runs_where_the_grid_was_put_back(tmp_path: Path) -> None:
    out, kept, fresh = tmp_path / "out", tmp_path / "kept", tmp_path / "fresh"
    for agent in ("dcp", "ddpg"):
        run = grid.run_folder(out, "pendulum", agent, 0)
        (run / "train" / "Pendulum-v1__x__0").mkdir(parents=True)
        (run / "train" / "Pendulum-v1__x__0" / "policy.postcard").write_bytes(b"blob of " + agent.encode())
        (run / "result.json").write_text("{}")
    assert grid.keep(out, kept) == 3  # two results and the dcp run's blob, not ddpg's
    grid.restore(kept, fresh)
    assert grid.chip_blob(fresh, "pendulum").read_bytes() == b"blob of dcp"
    # A fake scripts/cortex-m.sh: one report, as the real one writes it, for the blob given.
    repo = tmp_path / "repo"
    (repo / "scripts").mkdir(parents=True)
    report = {"variants": [{"instructions": {"act_mean": 21267.0, "per_mac": 2.99},
                            "flash": {"total": 76228}, "check": {"bit_exact": True}}]}
    (repo / "scripts" / "cortex-m.sh").write_text(
        'while [ $# -gt 0 ]; do [ "$1" = --out ] && OUT=$2; shift; done\n'
        f"test \"$VARIANTS\" = m4f-trained && echo '{json.dumps(report)}' > \"$OUT\"\n"
    )
    chip = grid.chip_figures(fresh, repo, ["pendulum", "reacher"])
    assert chip == {"pendulum": {
        "blob": "pendulum/dcp/seed0/train/Pendulum-v1__x__0/policy.postcard",
        "act": "21,267 instructions (2.99 per MAC), bit-exact; flash 76,228 B with the blob",
    }}
    assert json.loads((fresh / "pendulum" / "chip.json").read_text()) == chip["pendulum"]
    assert grid.keep(fresh, kept) == 1  # the task's chip.json, a file of its own
    # A failed measurement is reported and not written, so the next `chip` tries again.
    (fresh / "pendulum" / "chip.json").unlink()
    # What cortex-m.sh prints for a blob with more observations than the firmware holds.
    (repo / "scripts" / "cortex-m.sh").write_text(
        "echo \"host-check: error: observation size 17 beyond the firmware's maximum of 16\"; exit 1\n"
    )
    chip = grid.chip_figures(fresh, repo, ["pendulum"])
    assert chip["pendulum"]["act"] == "not run: the example firmware holds at most 16 observations, the blob has 17"
    assert not (fresh / "pendulum" / "chip.json").exists()


def test_chip_exits_1_when_a_measurement_fails(tmp_path: Path, python_env) -> None:
    out, repo = tmp_path / "out", tmp_path / "repo"
    run = grid.run_folder(out, "pendulum", "dcp", 0)
    (run / "train" / "r").mkdir(parents=True)
    (run / "train" / "r" / "policy.postcard").write_bytes(b"blob")
    (repo / "scripts").mkdir(parents=True)
    (repo / "scripts" / "cortex-m.sh").write_text("exit 3\n")
    done = subprocess.run(
        [sys.executable, "-m", "margin_safe_rl.standard_tasks", "chip", "--out", str(out),
         "--repo", str(repo), "--tasks", "pendulum"],
        capture_output=True, text=True, env=python_env,
    )
    assert done.returncode == 1, done
    assert "pendulum: not run: cortex-m.sh exited 3" in done.stdout
    assert not (out / "pendulum" / "chip.json").exists()


def test_a_second_grid_in_one_folder_is_refused(tmp_path: Path) -> None:
    first = grid.GridLock(tmp_path)
    try:
        with pytest.raises(grid.GridError, match="another grid is running"):
            grid.GridLock(tmp_path)
    finally:
        first.release()
    grid.GridLock(tmp_path).release()


def test_a_run_whose_process_dies_is_recorded_as_failed(tmp_path: Path) -> None:
    programs = grid.Programs("/nonexistent/host-trainer", "/nonexistent/firmware-sim")
    result = grid.run_in_process(tmp_path, ("pendulum", "dcp", 0), programs, 10, 2)
    assert "without a result" in result["failed"]
    saved = json.loads((grid.run_folder(tmp_path, "pendulum", "dcp", 0) / "result.json").read_text())
    assert saved["failed"] == result["failed"]


def _fake_program(path: Path, text: str) -> str:
    path.write_text("#!/usr/bin/env bash\n" + text)
    path.chmod(0o755)
    return str(path)


@pytest.mark.parametrize("stop", [signal.SIGINT, signal.SIGTERM])
def test_a_stopped_grid_stops_its_runs_at_a_checkpoint_and_counts_none_as_failed(
    tmp_path: Path, python_env, stop: int
) -> None:
    # A trainer that answers SIGINT as host-trainer does (a checkpoint, then exit 130), and a
    # simulator that only lists test starts: the grid's own handling of the press is tested.
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    trainer = _fake_program(
        bin_dir / "host-trainer",
        "trap 'echo stopping after this episode and writing a checkpoint; exit 130' INT\n"
        f"touch {tmp_path / 'trainer-started'}\n"
        "while :; do sleep 0.05; done\n",
    )
    sim = _fake_program(bin_dir / "firmware-sim", 'for i in $(seq "$3"); do echo "$i"; done\n')
    out = tmp_path / "grid"
    running = subprocess.Popen(
        [sys.executable, "-m", "margin_safe_rl.standard_tasks", "run", "--out", str(out),
         "--tasks", "pendulum", "--agents", "dcp", "--seeds", "0,1", "--jobs", "1", "--steps", "10",
         "--test-episodes", "2", "--host-trainer", trainer, "--firmware-sim", sim],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=python_env,
        start_new_session=True,  # the signal below reaches the grid alone: it must pass it on
    )
    try:
        deadline = time.monotonic() + 60
        while not (tmp_path / "trainer-started").exists():  # with its trap set
            assert running.poll() is None and time.monotonic() < deadline, running.communicate()
            time.sleep(0.05)
        running.send_signal(stop)
        stdout, stderr = running.communicate(timeout=60)
    finally:  # a grid (or a run of it) that does not stop leaves nothing behind the test
        try:
            os.killpg(running.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        running.wait()
    assert running.returncode == 130, (stdout, stderr)
    assert "2 runs not finished (none counted as failed)" in stdout, stdout
    log = grid.run_folder(out, "pendulum", "dcp", 0) / "log.txt"
    assert "stopping after this episode" in log.read_text()  # the press reached the trainer
    assert not list(out.glob("pendulum/dcp/seed*/result.json"))
    assert grid.plan(out, ["pendulum"], ["dcp"], [0, 1], False) == [("pendulum", "dcp", 0), ("pendulum", "dcp", 1)]


@pytest.mark.parametrize(
    "args, message",
    [
        (["run", "--out", "X", "--agents", "dqn"], "no agent 'dqn'"),
        (["run", "--out", "X", "--tasks", "cartpole"], "no task 'cartpole'"),
        (["run", "--out", "X", "--jobs", "0"], "--jobs, --threads and --test-episodes must be at least 1"),
        (["run", "--out", "X", "--threads", "0"], "--jobs, --threads and --test-episodes must be at least 1"),
        (["serve", "cartpole"], "no task 'cartpole'"),
        (["chip", "--out", "X"], "chip: no grid folder"),
        (["chip", "--out", ".", "--tasks", "cartpole"], "no task 'cartpole'"),
    ],
)
def test_bad_arguments_get_one_line_and_exit_2(tmp_path: Path, python_env, args, message) -> None:
    args = [str(tmp_path / a) if a == "X" else a for a in args]
    out = subprocess.run(
        [sys.executable, "-m", "margin_safe_rl.standard_tasks", *args],
        capture_output=True, text=True, env=python_env, cwd=tmp_path,
    )
    assert out.returncode == 2, out
    assert message in out.stderr and len(out.stderr.strip().splitlines()) == 1, out.stderr


@pytest.mark.parametrize("status, finished", [(0, True), (1, True), (2, False), (130, False), (-9, False)])
def test_a_run_whose_blob_fails_the_gate_has_finished(status: int, finished: bool) -> None:
    # host-trainer and firmware-sim exit 1 on the gate's FAIL: a judged run, not an error.
    assert grid.judged(status) is finished


def _episodes_without_clock(path: Path) -> list[dict]:
    # Every field of every episode but the recorder's clock (wall time differs run to run).
    return [{k: v for k, v in json.loads(line).items() if k != "env_seconds"} for line in path.read_text().splitlines()]


def _sb3_envs_calling(monkeypatch: pytest.MonkeyPatch, before_step) -> None:
    """SB3's runs get environments that call ``before_step(env)`` before each step (to stop a
    run as Ctrl-C does, mid-step, or to change the environment); ``None`` restores the real ones."""
    from margin_safe_rl.standard_tasks import recorder, sb3_agents

    if before_step is None:
        monkeypatch.setattr(sb3_agents, "make_env", recorder.make_env)
        return

    def make_env(*args, **kwargs):
        env = recorder.make_env(*args, **kwargs)
        real_step = env.step

        def step(action):
            before_step(env)
            return real_step(action)

        env.step = step
        return env

    monkeypatch.setattr(sb3_agents, "make_env", make_env)


def _stop_at_step(n: int):
    """A ``before_step`` that raises SIGINT before the ``n``-th step of the run."""
    steps = {"n": 0}

    def before_step(env) -> None:
        steps["n"] += 1
        if steps["n"] == n:
            signal.raise_signal(signal.SIGINT)

    return before_step


@pytest.mark.parametrize(
    "task_name, algo, stop_at",
    [
        ("pendulum", "td3", 350),  # mid-episode, after the updates begin (Gaussian noise)
        ("mountain-car", "td3", 250),  # in the first, seeded, episode (Ornstein-Uhlenbeck noise)
        ("mountain-car", "sac", 250),  # 32 steps an iteration, gSDE's exploration matrix
        ("nav-walls", "ddpg", 350),  # a firmware-sim process: its start seed drawn in Python
    ],
)
def test_an_sb3_run_stopped_and_continued_ends_as_one_never_stopped(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, request: pytest.FixtureRequest,
    task_name: str, algo: str, stop_at: int,
) -> None:
    pytest.importorskip("stable_baselines3")
    from margin_safe_rl.standard_tasks import sb3_agents

    if task_name == "nav-walls":
        monkeypatch.setenv("FIRMWARE_SIM", request.getfixturevalue("firmware_sim"))

    t, test_seeds = task(task_name), [11, 12]
    straight, stopped = tmp_path / "straight", tmp_path / "stopped"
    straight.mkdir()
    stopped.mkdir()
    figures = sb3_agents.train_and_test(t, algo, 3, straight, test_seeds, steps=600)

    # The stop comes as a Ctrl-C does, in the middle of an environment step.
    _sb3_envs_calling(monkeypatch, _stop_at_step(stop_at))
    with pytest.raises(KeyboardInterrupt):
        sb3_agents.train_and_test(t, algo, 3, stopped, test_seeds, steps=600)
    assert (stopped / sb3_agents.CHECKPOINT).exists() and not (stopped / "test.jsonl").exists()
    _sb3_envs_calling(monkeypatch, None)
    continued = sb3_agents.train_and_test(t, algo, 3, stopped, test_seeds, steps=600)

    assert continued["env_steps"] == figures["env_steps"] >= 600  # SAC here collects 32 steps at a time
    assert not (stopped / sb3_agents.CHECKPOINT).exists()
    for name in ("train.jsonl", "test.jsonl"):
        assert _episodes_without_clock(stopped / name) == _episodes_without_clock(straight / name), name


def test_an_unreadable_sb3_checkpoint_is_named_and_left_alone(tmp_path: Path) -> None:
    pytest.importorskip("stable_baselines3")
    from margin_safe_rl.standard_tasks import sb3_agents

    (tmp_path / sb3_agents.CHECKPOINT).write_bytes(b"half a checkpoint")
    (tmp_path / "train.jsonl").write_text('{"return": -1.0}\n')
    with pytest.raises(RuntimeError, match="cannot be read .*remove it to start the run again"):
        sb3_agents.train_and_test(task("pendulum"), "td3", 0, tmp_path, [1], steps=10)
    assert (tmp_path / sb3_agents.CHECKPOINT).read_bytes() == b"half a checkpoint"
    assert (tmp_path / "train.jsonl").read_text() == '{"return": -1.0}\n'


@pytest.mark.parametrize("task_name, algo", [("pendulum", "td3"), ("mountain-car", "sac")])
def test_the_learning_loop_written_out_is_sb3s_learn_to_the_bit(tmp_path: Path, task_name: str, algo: str) -> None:
    # The checkpoints need SB3's `learn` written out; the runs before it used `learn` itself.
    pytest.importorskip("stable_baselines3")
    import io

    import torch
    from margin_safe_rl.standard_tasks import sb3_agents

    t = task(task_name)
    theirs, budget = sb3_agents.build(t, algo, 5, make_env(t, out=io.StringIO()), 600)
    sb3_agents.quiet_logger(theirs, tmp_path / "a")
    theirs.learn(total_timesteps=budget)
    ours, _ = sb3_agents.build(t, algo, 5, sb3_agents.EpisodeReplay(make_env(t, out=io.StringIO())), 600)
    sb3_agents.quiet_logger(ours, tmp_path / "b")
    sb3_agents._learn(ours, budget, sb3_agents._Stop(), lambda: None)
    assert ours.num_timesteps == theirs.num_timesteps
    for a, b in zip(theirs.policy.parameters(), ours.policy.parameters()):
        assert torch.equal(a, b)


def test_a_checkpoint_of_another_budget_is_refused_and_left_alone(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    pytest.importorskip("stable_baselines3")
    from margin_safe_rl.standard_tasks import sb3_agents

    _sb3_envs_calling(monkeypatch, _stop_at_step(1))
    with pytest.raises(KeyboardInterrupt):
        sb3_agents.train_and_test(task("pendulum"), "td3", 0, tmp_path, [1], steps=300)
    _sb3_envs_calling(monkeypatch, None)
    saved = (tmp_path / sb3_agents.CHECKPOINT).read_bytes()
    with pytest.raises(RuntimeError, match="written by a run of 300 steps, not 400: run with the same --steps"):
        sb3_agents.train_and_test(task("pendulum"), "td3", 0, tmp_path, [1], steps=400)
    assert (tmp_path / sb3_agents.CHECKPOINT).read_bytes() == saved


def test_a_run_killed_after_its_checkpoint_continues_from_it_and_refuses_an_environment_that_does_not_replay(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
) -> None:
    pytest.importorskip("stable_baselines3")
    from margin_safe_rl.standard_tasks import sb3_agents

    t, test_seeds = task("pendulum"), [11, 12]
    straight, stopped = tmp_path / "straight", tmp_path / "stopped"
    straight.mkdir()
    stopped.mkdir()
    figures = sb3_agents.train_and_test(t, "td3", 3, straight, test_seeds, steps=600)

    _sb3_envs_calling(monkeypatch, _stop_at_step(350))  # mid-way through the second 200-step episode
    with pytest.raises(KeyboardInterrupt):
        sb3_agents.train_and_test(t, "td3", 3, stopped, test_seeds, steps=600)
    # As if the run had gone on past its last checkpoint and been killed: a later episode on
    # record that the checkpoint knows nothing of.
    with open(stopped / "train.jsonl", "a") as f:
        f.write('{"return": -1.0, "steps": 200}\n')
    checkpoint, record = (stopped / sb3_agents.CHECKPOINT).read_bytes(), (stopped / "train.jsonl").read_bytes()

    # A fresh environment that does not follow the old one (here a pendulum under another
    # gravity, as another version of a task might): refused, and nothing touched.
    def other_gravity(env) -> None:
        env.unwrapped.g = 9.0

    _sb3_envs_calling(monkeypatch, other_gravity)
    with pytest.raises(RuntimeError, match="replayed from .* is not where the run stopped"):
        sb3_agents.train_and_test(t, "td3", 3, stopped, test_seeds, steps=600)
    assert (stopped / sb3_agents.CHECKPOINT).read_bytes() == checkpoint
    assert (stopped / "train.jsonl").read_bytes() == record

    # The right environment continues from the checkpoint: the killed run's later episode is
    # dropped and recorded again as the run goes on, and the run ends as one never stopped.
    _sb3_envs_calling(monkeypatch, None)
    continued = sb3_agents.train_and_test(t, "td3", 3, stopped, test_seeds, steps=600)
    assert continued["env_steps"] == figures["env_steps"]
    for name in ("train.jsonl", "test.jsonl"):
        assert _episodes_without_clock(stopped / name) == _episodes_without_clock(straight / name), name


def test_a_continued_toolkit_runs_time_adds_its_earlier_parts_by_the_trainers_clock() -> None:
    # metrics.csv's rows: episode, steps, steps per second (the trainer's clock per episode).
    metrics = ["episode,return,steps,total_steps,steps_per_s", "1,-5,100,100,50", "2,-4,100,200,25",
               "3,-3,100,300,10"]
    one_part = "trained RUN (3 episodes, 300 env steps in 12.5 s, 24 steps/s incl. updates)\n"
    assert grid.training_seconds(one_part, metrics) == 12.5
    # Stopped after episode 2, continued for episode 3: the last part's own figure (the
    # `trained` line times that part alone) plus episodes 1 and 2 (2 s + 4 s).
    continued = (
        "host-trainer: interrupted after episode 2 of 300; checkpoint written.\n"
        "trained RUN (3 episodes, 300 env steps in all; this part: 1 episodes, 100 env steps in"
        " 10.5 s, 10 steps/s incl. updates)\n"
    )
    assert grid.training_seconds(continued, metrics) == 6.0 + 10.5
    # A row without a rate (or cut short) adds nothing rather than stopping the run's record.
    assert grid.training_seconds(continued, [*metrics[:2], "2,-4,100,200,", *metrics[3:]]) == 2.0 + 10.5
    assert (grid.training_parts(one_part), grid.training_parts(continued)) == (1, 2)
    assert grid.training_seconds("host-trainer: interrupted after episode 2\n", metrics) is None


def test_a_plant_appending_to_a_record_carries_its_environment_clock_on(
    tmp_path: Path, python_env: dict[str, str]
) -> None:
    from margin_safe_rl import plant_link as pl
    from margin_safe_rl.standard_tasks.recorder import recorded_seconds

    record = tmp_path / "train.jsonl"
    assert recorded_seconds(record) == 0.0  # no record yet: the clock starts at 0
    record.write_text('{"steps": 200, "env_seconds": 5.0}\n{"steps": 200, "env_se\n')
    assert recorded_seconds(record) == 5.0  # a line cut short is skipped
    record.write_text('{"steps": 200, "env_seconds": 5.0}\n')
    client = pl.PlantClient(
        [sys.executable, "-m", "margin_safe_rl.standard_tasks", "serve", "pendulum", "--record", str(record)],
        environ=python_env,
    )
    try:
        client.reset(0)
        while not client.step([0.0]).truncated:
            pass
    finally:
        assert client.close() == 0
    lines = [json.loads(line) for line in record.read_text().splitlines()]
    assert len(lines) == 2 and lines[0]["env_seconds"] == 5.0
    assert 5.0 < lines[1]["env_seconds"] < 5.0 + 60  # carried on, not started again at 0
