"""One measurement of every episode, whoever acts: the benchmark's margin figures.

:class:`Recorder` wraps a task's environment. It is used twice with the same code: inside the
plant server that ``host-trainer`` and ``firmware-sim`` drive (so a blob's test episodes are
measured), and around the environment SB3's policies are tested on. Per episode it writes one
JSON line: the reset seed, the return, the steps, the steps with an action component at the
action bound, the steps in contact with the task's position limit, the success flag where
the plant gives one, and the seconds spent in the environment's ``reset`` and ``step`` so far
(``env_seconds``). That clock runs over the whole record: a plant that appends to a record
(a run continued from its checkpoint) carries it on from the record's last line
(:func:`recorded_seconds`), so the last line holds the time of every part.

- **At the action bound**: a component of the (clipped) action within 1 % of the box's width
  of either edge. A tanh-squashed actor never reaches its edge exactly, so "equal to the bound"
  would count nothing; 1 % is far smaller than any exploration noise used here.
- **Position-limit contact**: MountainCarContinuous's left wall (position at its minimum, where
  the environment zeroes the velocity); a MuJoCo joint whose limit constraint is active after
  the step (the cart's slider at a rail end, the reacher's elbow at +-3 rad): MuJoCo's own
  record of the limit, ``data.efc_type == mjCNSTR_LIMIT_JOINT`` for that joint; firmware-sim's
  ``margin_touched`` for nav-walls (a wall stopped the motion).
"""
from __future__ import annotations

import json
import time
from pathlib import Path
from typing import IO, Any, Callable, Optional

import gymnasium
import numpy as np

BOUND_SHARE = 0.01


def _joint_limit_contact(env: Any, joint: str) -> Callable[[Any], bool]:
    import mujoco

    model = env.unwrapped.model
    joint_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, joint)
    if joint_id < 0:
        raise ValueError(f"{env.spec.id} has no joint {joint!r}")
    limit = int(mujoco.mjtConstraint.mjCNSTR_LIMIT_JOINT)

    def touching(_info: Any) -> bool:
        data = env.unwrapped.data
        n = int(data.nefc)
        return bool(np.any((data.efc_type[:n] == limit) & (data.efc_id[:n] == joint_id)))

    return touching


def contact_detector(env: Any, contact: Optional[str]) -> Optional[Callable[[Any], bool]]:
    """The position-limit test of ``env`` for a task's ``contact`` (``None``: none)."""
    if contact is None:
        return None
    if contact == "left wall":
        car = env.unwrapped
        return lambda _info: bool(car.state[0] <= car.min_position)
    if contact == "rail end":
        return _joint_limit_contact(env, "slider")
    if contact == "elbow limit":
        return _joint_limit_contact(env, "joint1")
    if contact == "wall":
        return lambda info: bool(info.get("margin_touched", False))
    raise ValueError(f"no contact detector called {contact!r}")


class Recorder(gymnasium.Wrapper):
    """Writes one JSON line per finished episode to ``out`` (see the module docs)."""

    def __init__(
        self, env: Any, contact: Optional[str], out: Optional[IO[str]], env_seconds: float = 0.0
    ) -> None:
        super().__init__(env)
        self._touching = contact_detector(env, contact)
        self._out = out
        low = np.asarray(env.action_space.low, dtype=np.float64)
        high = np.asarray(env.action_space.high, dtype=np.float64)
        self._low, self._high = low, high
        self._edge = BOUND_SHARE * (high - low)
        self.episodes: list[dict[str, Any]] = []
        self.env_seconds = env_seconds
        self._open: Optional[dict[str, Any]] = None
        self.last_contact = False

    def reset(self, *, seed: Optional[int] = None, options: Optional[dict] = None) -> Any:
        started = time.perf_counter()
        result = self.env.reset(seed=seed, options=options)
        self.env_seconds += time.perf_counter() - started
        self._open = {
            "seed": seed,
            "return": 0.0,
            "steps": 0,
            "at_bound_steps": 0,
            "contact_steps": 0,
            "success": None,
        }
        return result

    def step(self, action: Any) -> Any:
        a = np.clip(np.asarray(action, dtype=np.float64).ravel(), self._low.ravel(), self._high.ravel())
        started = time.perf_counter()
        observation, reward, terminated, truncated, info = self.env.step(action)
        self.env_seconds += time.perf_counter() - started
        e = self._open
        if e is not None:
            e["return"] += float(reward)
            e["steps"] += 1
            edge = self._edge.ravel()
            if np.any((a - self._low.ravel() <= edge) | (self._high.ravel() - a <= edge)):
                e["at_bound_steps"] += 1
            self.last_contact = self._touching is not None and self._touching(info)
            if self.last_contact:
                e["contact_steps"] += 1
            success = info.get("success", info.get("is_success")) if isinstance(info, dict) else None
            if success is not None:
                e["success"] = bool(success)
            if terminated or truncated:
                self._finish()
        return observation, reward, terminated, truncated, info

    def _finish(self) -> None:
        e, self._open = self._open, None
        if e is None:
            return
        e["env_seconds"] = round(self.env_seconds, 6)
        self.episodes.append(e)
        if self._out is not None:
            self._out.write(json.dumps(e) + "\n")
            self._out.flush()


def recorded_seconds(path: Path) -> float:
    """The environment clock a record ends on: its last readable line's ``env_seconds``, or 0
    for a record that is missing, empty or has no such line (a line cut short by a killed
    plant is skipped: the clock then misses that open episode's time alone)."""
    try:
        lines = path.read_text().splitlines()
    except FileNotFoundError:
        return 0.0
    for line in reversed(lines):
        try:
            seconds = json.loads(line).get("env_seconds")
        except (ValueError, AttributeError):
            continue
        if isinstance(seconds, (int, float)):
            return float(seconds)
    return 0.0


def make_env(
    task: Any, contact: bool = True, out: Optional[IO[str]] = None, env_seconds: float = 0.0
) -> Recorder:
    """The task's environment, wrapped in a :class:`Recorder` writing to ``out``, its clock
    starting at ``env_seconds``."""
    if task.env_id.startswith("margin_safe_rl/"):
        import margin_safe_rl.firmware_sim_env  # noqa: F401 - registers the environments
    env = gymnasium.make(task.env_id, **task.env_kwargs)
    return Recorder(env, task.contact if contact else None, out, env_seconds)
