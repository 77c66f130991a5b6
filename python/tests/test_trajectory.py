"""Bit for bit: FirmwareSimEnv over the plant link against nav-walls run in process by
firmware-sim's tests (firmware-sim/tests/data/plant-link-trajectory.json, written by its
tests/plant_link_trajectory.rs). The actions head into walls, leave the box, include a NaN,
leave the arena and run to the time limit."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from margin_safe_rl.firmware_sim_env import FirmwareSimEnv
from paths import load_golden

GOLDEN = load_golden("plant-link-trajectory.json")


def bits(values: Any) -> list[int]:
    return np.asarray(values, dtype=np.float32).view(np.uint32).tolist()


def floats(values: list[int]) -> np.ndarray:
    return np.asarray(values, dtype=np.uint32).view(np.float32)


@pytest.fixture(scope="module")
def env(firmware_sim: str) -> Any:
    env = FirmwareSimEnv(GOLDEN["scenario"], binary=firmware_sim)
    yield env
    env.close()


@pytest.mark.parametrize(
    "episode", GOLDEN["episodes"], ids=[f"seed {e['seed']}" for e in GOLDEN["episodes"]]
)
def test_trajectory_is_bit_identical(env: FirmwareSimEnv, episode: dict[str, Any]) -> None:
    observation, _ = env.reset(seed=episode["seed"])
    assert bits(observation) == episode["observation"]
    for i, golden in enumerate(episode["steps"]):
        observation, reward, terminated, truncated, info = env.step(floats(golden["action"]))
        got = {
            "observation": bits(observation),
            "reward": bits([reward])[0],
            "terminated": terminated,
            "truncated": truncated,
            "margin_touched": info["margin_touched"],
            "applied": bits(info["applied"]),
            "success": info.get("success"),
        }
        expected = {k: v for k, v in golden.items() if k != "action"}
        assert got == expected, f"step {i} of seed {episode['seed']}"
