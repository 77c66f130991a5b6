"""Stable-Baselines3's side: TD3, SAC and DDPG with the RL Zoo's hyperparameters.

Built as the Zoo builds them (``rl_zoo3/exp_manager.py``): the algorithm class with the task's
Zoo keywords, action noise ``NormalActionNoise`` / ``OrnsteinUhlenbeckActionNoise`` with mean 0
and ``sigma = noise_std * ones(n_actions)``, ``MlpPolicy``. Torch runs on the CPU with one
thread, as every toolkit run here does. Tested with the deterministic policy
(``predict(deterministic=True)``) from the test protocol's starts.

**A run stops and continues.** An SB3 run at the Zoo's budgets takes hours here, longer than
a machine is often free, so it stops as a toolkit run does: Ctrl-C or SIGTERM lets the running
iteration (one ``train_freq`` of steps and its gradient steps) finish, writes a checkpoint
(``sb3-checkpoint.pkl``, every ten minutes too) and exits 130; the next run in that folder
continues from it and ends with the same policy, training record and test, bit for bit, as a
run never stopped. The checkpoint is the model itself (networks, optimisers, replay buffer,
action noise, counters), the three random streams (torch's, NumPy's, Python's) and the open
episode as :class:`EpisodeReplay` remembers it: the environment's own state (a MuJoCo
simulation, a firmware-sim process) cannot be saved, but it is deterministic given how the
episode began and the actions since, so a fresh copy is brought to the same state by replaying
them, and checked against the observation the model saved.
"""
from __future__ import annotations

import random
import signal
import threading
import time
from pathlib import Path
from typing import Any, Optional, Sequence

import gymnasium
import numpy as np

from .files import write_whole
from .recorder import make_env
from .tasks import Task

ALGOS = ("td3", "sac", "ddpg")
CHECKPOINT = "sb3-checkpoint.pkl"
CHECKPOINT_SECONDS = 600.0


def _classes() -> dict[str, Any]:
    from stable_baselines3 import DDPG, SAC, TD3

    return {"td3": TD3, "sac": SAC, "ddpg": DDPG}


def build(
    task: Task, algo: str, seed: int, env: Any, steps: Optional[int] = None,
    net_arch: Optional[list[int]] = None,
) -> tuple[Any, int]:
    """The SB3 model for ``task`` and ``algo`` and its budget in steps (``steps`` overrides the
    Zoo's, and then caps ``learning_starts`` at half of it, for the tiny runs CI makes;
    ``net_arch`` the Zoo's network, for the speed measurement's second size)."""
    from stable_baselines3.common.noise import NormalActionNoise, OrnsteinUhlenbeckActionNoise

    _one_thread()
    entry = task.zoo[algo]
    kwargs = dict(entry.kwargs)
    budget = entry.n_timesteps if steps is None else steps
    if steps is not None and "learning_starts" in kwargs:
        kwargs["learning_starts"] = min(kwargs["learning_starts"], steps // 2)
    elif steps is not None:
        kwargs["learning_starts"] = min(100, steps // 2)  # SB3's default, capped alike
    if net_arch is not None:
        kwargs["policy_kwargs"] = dict(kwargs.get("policy_kwargs", {}), net_arch=net_arch)
    if entry.noise is not None:
        kind, std = entry.noise
        n = env.action_space.shape[0]
        noise_class = NormalActionNoise if kind == "normal" else OrnsteinUhlenbeckActionNoise
        kwargs["action_noise"] = noise_class(mean=np.zeros(n), sigma=std * np.ones(n))
    model = _classes()[algo]("MlpPolicy", env, seed=seed, device="cpu", verbose=0, **kwargs)
    return model, budget


def _one_thread() -> None:
    import torch

    torch.set_num_threads(1)


def quiet_logger(model: Any, folder: Path) -> None:
    """SB3's logger writing nowhere but ``folder``: without one, every ``learn`` makes a folder
    of its own in the system's temporary folder (``/tmp/SB3-<date>``) and leaves it there."""
    from stable_baselines3.common.logger import configure

    model.set_logger(configure(str(folder), []))


class EpisodeReplay(gymnasium.Wrapper):
    """Remembers how the open episode began (the reset's arguments and the environment's random
    state just before it) and every action since, so that :func:`replay` can bring a fresh copy
    of the environment to the same state."""

    def __init__(self, env: Any) -> None:
        super().__init__(env)
        self.began: tuple[dict[str, Any], Optional[dict[str, Any]]] = ({}, None)
        self.actions: list[np.ndarray] = []

    def reset(self, **kwargs: Any) -> Any:
        rng = self.unwrapped._np_random  # None until the first seeded reset makes it
        self.began = (dict(kwargs), None if rng is None else rng.bit_generator.state)
        self.actions = []
        return self.env.reset(**kwargs)

    def step(self, action: Any) -> Any:
        self.actions.append(np.array(action, copy=True))
        return self.env.step(action)


def replay(env: Any, began: tuple[dict[str, Any], Optional[dict[str, Any]]], actions: Sequence[Any]) -> Any:
    """Resets ``env`` as the episode began and steps it through ``actions``; returns the last
    observation."""
    kwargs, rng_state = began
    if rng_state is not None:
        bit_generator = getattr(np.random, rng_state["bit_generator"])()
        bit_generator.state = rng_state
        env.unwrapped.np_random = np.random.Generator(bit_generator)
    observation, _ = env.reset(**kwargs)
    for action in actions:
        observation = env.step(action)[0]
    return observation


class _Stop:
    """Ctrl-C and SIGTERM during training: remembered, so the iteration running finishes and
    the run stops at a checkpoint (the toolkit's trainer stops the same way)."""

    def __init__(self) -> None:
        self.asked = threading.Event()
        self._previous: dict[int, Any] = {}

    def __enter__(self) -> "_Stop":
        for sig in (signal.SIGINT, signal.SIGTERM):
            self._previous[sig] = signal.signal(sig, lambda *_: self.asked.set())
        return self

    def __exit__(self, *_: Any) -> None:
        for sig, handler in self._previous.items():
            signal.signal(sig, handler)


def _save(path: Path, model: Any, budget: int, wrapper: EpisodeReplay, train_log: Any,
          train_seconds: float, env_seconds: float) -> None:
    import cloudpickle
    import torch

    train_log.flush()
    env, model.env = model.env, None  # the environment is rebuilt and replayed, not saved
    try:
        data = cloudpickle.dumps({
            "model": model,
            "budget": budget,
            "random": (torch.get_rng_state(), np.random.get_state(), random.getstate()),
            "began": wrapper.began,
            "actions": wrapper.actions,
            "train_bytes": train_log.tell(),
            "train_seconds": train_seconds,
            "env_seconds": env_seconds,
        })
    finally:
        model.env = env
    write_whole(path, data)


def _learn(model: Any, budget: int, stop: _Stop, save: Any) -> None:
    """SB3's ``OffPolicyAlgorithm.learn`` (2.7.1) written out, so that a checkpoint falls
    between two iterations, where the model's state is whole: ``learn``'s own callbacks come
    mid-iteration (before the step's transition is stored, before its gradient steps)."""
    resuming = model._last_obs is not None
    noise = model.action_noise
    if resuming:
        model.action_noise = None  # `_setup_learn` would reset the noise mid-episode
    total, callback = model._setup_learn(budget - model.num_timesteps, None, not resuming, "run", False)
    model.action_noise = noise
    callback.on_training_start(locals(), globals())
    last_save = time.monotonic()
    while model.num_timesteps < total:
        rollout = model.collect_rollouts(
            model.env, train_freq=model.train_freq, action_noise=model.action_noise, callback=callback,
            learning_starts=model.learning_starts, replay_buffer=model.replay_buffer, log_interval=4,
        )
        if not rollout.continue_training:
            break
        if model.num_timesteps > 0 and model.num_timesteps > model.learning_starts:
            gradient_steps = model.gradient_steps if model.gradient_steps >= 0 else rollout.episode_timesteps
            if gradient_steps > 0:
                model.train(batch_size=model.batch_size, gradient_steps=gradient_steps)
        if stop.asked.is_set() or time.monotonic() - last_save >= CHECKPOINT_SECONDS:
            save()
            last_save = time.monotonic()
            if stop.asked.is_set():
                raise KeyboardInterrupt
    callback.on_training_end()


def _continue(saved: dict[str, Any], path: Path, model_env: EpisodeReplay, steps_budget: int) -> Any:
    """The model of checkpoint ``saved`` (read from ``path``) in ``model_env``, replayed to the
    state the run stopped in, with the random streams as they were."""
    import torch

    if saved["budget"] != steps_budget:
        raise RuntimeError(
            f"{path} was written by a run of {saved['budget']} steps, not {steps_budget}: "
            "run with the same --steps, or remove it to start the run again"
        )
    model = saved["model"]
    _one_thread()
    model.set_env(model_env, force_reset=False)
    observation = replay(model.env.envs[0], saved["began"], saved["actions"])
    if not np.array_equal(observation, model._last_obs[0]):
        raise RuntimeError(f"the environment replayed from {path} is not where the run stopped")
    torch_state, numpy_state, python_state = saved["random"]
    torch.set_rng_state(torch_state)
    np.random.set_state(numpy_state)
    random.setstate(python_state)
    return model


def train_and_test(
    task: Task, algo: str, seed: int, folder: Path, test_seeds: Sequence[int], steps: Optional[int] = None
) -> dict[str, Any]:
    """Trains (continuing from ``folder``'s checkpoint if it has one), then tests over
    ``test_seeds``; writes ``train.jsonl`` (every training episode) and ``test.jsonl`` (every
    test episode) in ``folder`` and returns the run's figures. A stop by signal while training
    writes the checkpoint and raises ``KeyboardInterrupt``."""
    checkpoint = folder / CHECKPOINT
    train_path = folder / "train.jsonl"
    budget = task.zoo[algo].n_timesteps if steps is None else steps
    saved = _read(checkpoint) if checkpoint.exists() else None
    with open(train_path, "w" if saved is None else "a") as train_log, _Stop() as stop:
        recorder = make_env(task, out=train_log)
        wrapper = EpisodeReplay(recorder)
        if saved is not None:
            model = _continue(saved, checkpoint, wrapper, budget)
            # Episodes recorded after the checkpoint are recorded again as the run continues;
            # cut only now, so a checkpoint refused above leaves the record as it was.
            train_log.truncate(saved["train_bytes"])
            train_log.seek(saved["train_bytes"])  # truncate leaves the position where it was
            saved["model"] = None  # the replay buffer is large: one copy of it, not two
            recorder.env_seconds = saved["env_seconds"]
            seconds_before = saved["train_seconds"]
        else:
            model, budget = build(task, algo, seed, wrapper, steps)
            seconds_before = 0.0
        quiet_logger(model, folder / "sb3-log")
        started = time.perf_counter()

        def save() -> None:
            _save(checkpoint, model, budget, wrapper, train_log,
                  seconds_before + time.perf_counter() - started, recorder.env_seconds)

        _learn(model, budget, stop, save)
        seconds = seconds_before + time.perf_counter() - started
        env_seconds = recorder.env_seconds
        save()  # trained: a stop during the test continues from here
        wrapper.close()
    if stop.asked.is_set():
        raise KeyboardInterrupt
    with open(folder / "test.jsonl", "w") as test_log:
        test_env = make_env(task, out=test_log)
        for s in test_seeds:
            observation, _ = test_env.reset(seed=int(s))
            done = False
            while not done:
                action, _ = model.predict(observation, deterministic=True)
                observation, _, terminated, truncated, _ = test_env.step(action)
                done = terminated or truncated
        test_env.close()
    checkpoint.unlink()
    return {
        "env_steps": int(model.num_timesteps),
        "train_seconds": seconds,
        "env_seconds": env_seconds,
        "parameters": int(sum(p.numel() for p in model.policy.actor.parameters())),
    }


def _read(path: Path) -> dict[str, Any]:
    import cloudpickle

    try:
        return cloudpickle.loads(path.read_bytes())
    except Exception as e:  # noqa: BLE001 - any unreadable checkpoint gets the same answer
        raise RuntimeError(f"{path} cannot be read ({type(e).__name__}: {e}); remove it to start the run again") from e
