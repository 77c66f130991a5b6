"""The tasks of the standard-tasks benchmark: each a Gymnasium environment with a real margin.

Hyperparameters are the RL Zoo's (rl-baselines3-zoo, ``hyperparams/{td3,sac,ddpg}.yml`` at
v2.8.0-1-g22e3ff2, commit 22e3ff2450fd92033f7f032915e1f64894a09584, 2026-04-23), copied here
key for key so the benchmark does not depend on the Zoo package. Published scores are the Zoo's
``benchmark.md`` at the same commit (mean and standard deviation of the episode return of the
Zoo's own trained agent). Where the Zoo has no entry for a task (MuJoCo's InvertedPendulum and
Reacher for these three algorithms, and the toolkit's nav-walls), the Zoo's MuJoCo defaults
(the ``&mujoco-defaults`` block, HalfCheetah-v4) are used with the budget the Zoo gives its
PyBullet counterparts (``ReacherBulletEnv-v0`` and ``InvertedPendulumSwingupBulletEnv-v0``:
3e5 steps), and the page says so.

>>> [t.name for t in TASKS]
['pendulum', 'mountain-car', 'inverted-pendulum', 'reacher', 'nav-walls']
>>> task("pendulum").budget, task("pendulum").zoo["sac"].n_timesteps
(20000, 20000)
>>> task("mountain-car").zoo["sac"].n_timesteps
50000
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Optional

ZOO_VERSION = "rl-baselines3-zoo v2.8.0-1-g22e3ff2 (22e3ff2450fd92033f7f032915e1f64894a09584)"


@dataclass(frozen=True)
class ZooEntry:
    """One algorithm's settings for one task, as the Zoo writes them.

    ``source`` names the Zoo block they come from; ``score`` is the Zoo's published
    (mean, std) return, ``None`` where the Zoo publishes none for this task.
    """

    n_timesteps: int
    kwargs: dict[str, Any]
    noise: Optional[tuple[str, float]] = None
    source: str = ""
    score: Optional[tuple[float, float]] = None


# The Zoo's MuJoCo defaults (td3.yml / ddpg.yml `HalfCheetah-v4: &mujoco-defaults`): SB3's
# defaults otherwise.
_MUJOCO_TD3 = dict(
    learning_starts=10000,
    train_freq=1,
    gradient_steps=1,
    learning_rate=1e-3,
    batch_size=256,
    policy_kwargs=dict(net_arch=[400, 300]),
)
# sac.yml `HalfCheetah-v4: &mujoco-defaults`: learning_starts only.
_MUJOCO_SAC: dict[str, Any] = dict(learning_starts=10000)


def _mujoco(budget: int, source: str) -> dict[str, ZooEntry]:
    return {
        "td3": ZooEntry(budget, dict(_MUJOCO_TD3), ("normal", 0.1), source),
        "ddpg": ZooEntry(budget, dict(_MUJOCO_TD3), ("normal", 0.1), source),
        "sac": ZooEntry(budget, dict(_MUJOCO_SAC), None, source),
    }


_PENDULUM_TD3 = dict(
    gamma=0.98,
    buffer_size=200000,
    learning_starts=10000,
    gradient_steps=1,
    train_freq=1,
    learning_rate=1e-3,
    policy_kwargs=dict(net_arch=[400, 300]),
)
_MOUNTAIN_CAR_TD3 = dict(
    gradient_steps=1,
    train_freq=1,
    learning_rate=1e-3,
    batch_size=256,
    policy_kwargs=dict(net_arch=[400, 300]),
)


def _td3_and_ddpg(
    n: int, kwargs: dict[str, Any], noise: tuple[str, float], block: str,
    td3_score: tuple[float, float], ddpg_score: tuple[float, float],
) -> dict[str, ZooEntry]:
    """The Zoo's TD3 and DDPG entries of a task: the same settings in td3.yml and ddpg.yml
    (block ``block`` of each), each with its own published score."""
    return {
        "td3": ZooEntry(n, dict(kwargs), noise, f"td3.yml {block}", td3_score),
        "ddpg": ZooEntry(n, dict(kwargs), noise, f"ddpg.yml {block}", ddpg_score),
    }


@dataclass(frozen=True)
class Task:
    """A benchmark task.

    ``budget`` is the environment steps every toolkit agent trains for (the Zoo's TD3 and DDPG
    budget); ``contact`` names the position limit whose contacts are counted (``None`` where
    the only margin is the action bound); ``success_return`` is the return a test episode
    must reach to count as a success in firmware-sim's report (the task's own "solved" line).
    """

    name: str
    env_id: str
    margin: str
    budget: int
    zoo: dict[str, ZooEntry]
    contact: Optional[str] = None
    success_return: float = 0.0
    env_kwargs: dict[str, Any] = field(default_factory=dict)


TASKS: tuple[Task, ...] = (
    Task(
        name="pendulum",
        env_id="Pendulum-v1",
        margin="torque limit |u| <= 2 N m, too weak to lift the pendulum in one swing",
        budget=20000,
        success_return=-200.0,
        zoo={
            **_td3_and_ddpg(20000, _PENDULUM_TD3, ("normal", 0.1), "Pendulum-v1", (-151.855, 90.227), (-152.099, 94.282)),
            "sac": ZooEntry(20000, dict(learning_rate=1e-3), None, "sac.yml Pendulum-v1", (-156.995, 88.714)),
        },
    ),
    Task(
        name="mountain-car",
        env_id="MountainCarContinuous-v0",
        margin="left wall at x = -1.2 (position clipped, velocity zeroed); force limit |u| <= 1",
        budget=300000,
        contact="left wall",
        success_return=90.0,
        zoo={
            **_td3_and_ddpg(
                300000, _MOUNTAIN_CAR_TD3, ("ornstein-uhlenbeck", 0.5), "MountainCarContinuous-v0",
                (93.483, 0.075), (93.512, 0.048),
            ),
            "sac": ZooEntry(
                50000,
                dict(
                    learning_rate=3e-4,
                    buffer_size=50000,
                    batch_size=512,
                    ent_coef=0.1,
                    train_freq=32,
                    gradient_steps=32,
                    gamma=0.9999,
                    tau=0.01,
                    learning_starts=0,
                    use_sde=True,
                    policy_kwargs=dict(log_std_init=-3.67, net_arch=[64, 64]),
                ),
                None,
                "sac.yml MountainCarContinuous-v0",
                (94.679, 1.134),
            ),
        },
    ),
    Task(
        name="inverted-pendulum",
        env_id="InvertedPendulum-v5",
        margin="cart on a rail with hard ends (slider range [-1, 1] m); force limit |u| <= 3",
        budget=300000,
        contact="rail end",
        success_return=950.0,
        zoo=_mujoco(300000, "td3/sac/ddpg.yml &mujoco-defaults, budget of InvertedPendulumSwingupBulletEnv-v0"),
    ),
    Task(
        name="reacher",
        env_id="Reacher-v5",
        margin="elbow joint range [-3, 3] rad; torque limit |u| <= 1",
        budget=300000,
        contact="elbow limit",
        success_return=-5.0,
        zoo=_mujoco(300000, "td3/sac/ddpg.yml &mujoco-defaults, budget of ReacherBulletEnv-v0"),
    ),
    Task(
        name="nav-walls",
        env_id="margin_safe_rl/NavWalls-v0",
        margin="the pinwheel's walls (firmware-sim's nav-walls: motion stops at a wall)",
        budget=300000,
        contact="wall",
        success_return=float("nan"),
        env_kwargs={"reward": "gr"},
        zoo=_mujoco(300000, "td3/sac/ddpg.yml &mujoco-defaults, the toolkit's budget class"),
    ),
)


def task(name: str) -> Task:
    """The task called ``name`` (a :data:`TASKS` name); ``KeyError`` naming the choices."""
    for t in TASKS:
        if t.name == name:
            return t
    raise KeyError(f"no task {name!r}; the tasks are {', '.join(t.name for t in TASKS)}")
