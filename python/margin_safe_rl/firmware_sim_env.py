"""firmware-sim's plants as Gymnasium environments, through the plant link.

:class:`FirmwareSimEnv` starts ``firmware-sim serve-plant --scenario NAME`` (or any plant
command) and drives it with :class:`margin_safe_rl.plant_link.PlantClient`: the walls, the
margins and the rewards are firmware-sim's own, bit for bit the ones host-trainer trains on.

>>> import gymnasium, margin_safe_rl
>>> env = gymnasium.make("margin_safe_rl/NavWalls-v0")  # doctest: +SKIP
>>> obs, info = env.reset(seed=3)  # doctest: +SKIP
"""

from __future__ import annotations

import os
import shlex
from typing import Any, Optional, Sequence, SupportsFloat, Union

import gymnasium
import numpy as np
from gymnasium import spaces

from .plant_link import PlantClient

__all__ = ["FirmwareSimEnv", "firmware_sim_binary"]


def firmware_sim_binary(binary: Optional[str] = None) -> str:
    """The firmware-sim program: ``binary`` if given, else ``$FIRMWARE_SIM``, else
    ``firmware-sim`` on ``PATH``."""
    return binary or os.environ.get("FIRMWARE_SIM") or "firmware-sim"


class FirmwareSimEnv(gymnasium.Env[np.ndarray, np.ndarray]):
    """A firmware-sim plant (or any plant command) as a ``gymnasium.Env``.

    Spaces are the ``float32`` boxes of the plant's hello. ``reset(seed=s)`` sends ``s`` to the
    plant, so the same seed gives the start firmware-sim gives; without a seed, one is drawn
    from ``self.np_random``. ``step`` returns Gymnasium's five values with ``info`` holding
    ``margin_touched`` (a wall or limit was touched), ``applied`` (the motion carried out, in
    action units) and ``success`` (the plant's verdict) where the plant gives one, also as
    ``is_success``, the key Stable-Baselines3 reads for its success rate.

    Args:
        scenario: firmware-sim's scenario name or TOML file (``nav-walls``, ``nav-open``, ...).
        reward: the reward form instead of the scenario's (``lr``, ``gr``, ``lr-gr``);
            host-trainer trains with ``gr`` by default.
        binary: the firmware-sim program (default: ``$FIRMWARE_SIM``, else on ``PATH``).
        command: a whole plant command instead (a string split as a shell would, or a list).
        timeout: seconds to wait for each answer.
    """

    metadata: dict[str, Any] = {"render_modes": []}

    def __init__(
        self,
        scenario: str = "nav-walls",
        reward: Optional[str] = None,
        binary: Optional[str] = None,
        command: Union[str, Sequence[str], None] = None,
        timeout: float = 10.0,
        render_mode: Optional[str] = None,
    ) -> None:
        if render_mode is not None:
            raise ValueError(f"render_mode {render_mode!r}: firmware-sim plants do not render")
        if command is None:
            argv = [firmware_sim_binary(binary), "serve-plant", "--scenario", scenario]
            argv += [] if reward is None else ["--reward", reward]
        elif isinstance(command, str):
            argv = shlex.split(command)
        else:
            argv = list(command)
        self.render_mode = render_mode
        self._client: Optional[PlantClient] = None
        self._client = PlantClient(argv, timeout=timeout)
        agent = self._client.hello.agents[0]
        self.plant_name = self._client.hello.name
        self.observation_space = _box(agent.observation_low, agent.observation_high)
        self.action_space = _box(agent.action_low, agent.action_high)

    def reset(
        self, *, seed: Optional[int] = None, options: Optional[dict[str, Any]] = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        if seed is None:
            # Gymnasium's convention: without a seed the episode continues the env's stream.
            seed = int(self.np_random.integers(0, 2**63))
        observation = self._live().reset(seed)
        return np.asarray(observation, dtype=np.float32), {}

    def step(
        self, action: Any
    ) -> tuple[np.ndarray, SupportsFloat, bool, bool, dict[str, Any]]:
        flat = np.asarray(action, dtype=np.float32).ravel()
        expected = len(self._live().hello.agents[0].action_low)
        if flat.size != expected:
            raise ValueError(f"an action of {flat.size} values, expected {expected}")
        reply = self._live().step(flat.tolist())
        info: dict[str, Any] = {
            "margin_touched": reply.margin_touched,
            "applied": np.asarray(reply.applied, dtype=np.float32),
        }
        if reply.success is not None:
            info["success"] = reply.success
            info["is_success"] = reply.success
        observation = np.asarray(reply.observation, dtype=np.float32)
        return observation, reply.reward, reply.terminated, reply.truncated, info

    def close(self) -> None:
        """Asks the plant to exit, then kills it if it has not within a second."""
        if self._client is not None:
            self._client.close()
            self._client = None
        super().close()

    def _live(self) -> PlantClient:
        if self._client is None:
            raise RuntimeError("the environment is closed")
        return self._client


def _box(low: Sequence[float], high: Sequence[float]) -> spaces.Box:
    return spaces.Box(
        low=np.asarray(low, dtype=np.float32),
        high=np.asarray(high, dtype=np.float32),
        dtype=np.float32,
    )
