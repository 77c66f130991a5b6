"""Stable-Baselines3's side: TD3, SAC and DDPG with the RL Zoo's hyperparameters.

Built as the Zoo builds them (``rl_zoo3/exp_manager.py``): the algorithm class with the task's
Zoo keywords, action noise ``NormalActionNoise`` / ``OrnsteinUhlenbeckActionNoise`` with mean 0
and ``sigma = noise_std * ones(n_actions)``, ``MlpPolicy``. Torch runs on the CPU with one
thread, as every toolkit run here does. Tested with the deterministic policy
(``predict(deterministic=True)``) from the test protocol's starts.
"""
from __future__ import annotations

import time
from pathlib import Path
from typing import Any, Optional, Sequence

import numpy as np

from .recorder import make_env
from .tasks import Task

ALGOS = ("td3", "sac", "ddpg")


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
    import torch
    from stable_baselines3.common.noise import NormalActionNoise, OrnsteinUhlenbeckActionNoise

    torch.set_num_threads(1)
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


def quiet_logger(model: Any, folder: Path) -> None:
    """SB3's logger writing nowhere but ``folder``: without one, every ``learn`` makes a folder
    of its own in the system's temporary folder (``/tmp/SB3-<date>``) and leaves it there."""
    from stable_baselines3.common.logger import configure

    model.set_logger(configure(str(folder), []))


def train_and_test(
    task: Task, algo: str, seed: int, folder: Path, test_seeds: Sequence[int], steps: Optional[int] = None
) -> dict[str, Any]:
    """Trains, then tests over ``test_seeds``; writes ``train.jsonl`` (every training episode)
    and ``test.jsonl`` (every test episode) in ``folder`` and returns the run's figures."""
    with open(folder / "train.jsonl", "w") as train_log:
        env = make_env(task, out=train_log)
        model, budget = build(task, algo, seed, env, steps)
        quiet_logger(model, folder / "sb3-log")
        started = time.perf_counter()
        model.learn(total_timesteps=budget)
        seconds = time.perf_counter() - started
        env_seconds = env.env_seconds
        env.close()
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
    return {
        "env_steps": int(model.num_timesteps),
        "train_seconds": seconds,
        "env_seconds": env_seconds,
        "parameters": int(sum(p.numel() for p in model.policy.actor.parameters())),
    }
