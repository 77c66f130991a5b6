"""FirmwareSimEnv: firmware-sim's nav-walls plant as a Gymnasium environment, checked by
Gymnasium's own environment checker (and Stable-Baselines3's where it is installed)."""

from __future__ import annotations

import warnings
from typing import Iterator

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import margin_safe_rl  # noqa: F401 - registers the environments
from margin_safe_rl.firmware_sim_env import FirmwareSimEnv
from margin_safe_rl.plant_link import PlantError


@pytest.fixture
def env(firmware_sim: str) -> Iterator[FirmwareSimEnv]:
    env = FirmwareSimEnv("nav-walls", binary=firmware_sim)
    yield env
    env.close()


def test_gymnasium_check_env_passes(env: FirmwareSimEnv) -> None:
    with warnings.catch_warnings():
        # Any warning of the checker is a convention broken: fail on it.
        warnings.simplefilter("error")
        check_env(env, skip_render_check=True)


# The plant's box is ±0.25 per step, not SB3's preferred [-1, 1] (README: RescaleAction).
@pytest.mark.filterwarnings("ignore:We recommend you to use a symmetric and normalized Box")
def test_stable_baselines3_check_env_passes(env: FirmwareSimEnv) -> None:
    sb3_checker = pytest.importorskip("stable_baselines3.common.env_checker")
    sb3_checker.check_env(env, warn=True)


def test_spaces_are_the_plants_float32_boxes(env: FirmwareSimEnv) -> None:
    assert env.plant_name == "nav-walls"
    # The arena is ±6; the step that leaves it ends up to one step (0.25) past its edge.
    assert env.observation_space == gymnasium.spaces.Box(-6.25, 6.25, (2,), np.float32)
    assert env.action_space == gymnasium.spaces.Box(-0.25, 0.25, (2,), np.float32)


def test_registered_ids_make_the_scenarios(firmware_sim: str) -> None:
    ids = {"margin_safe_rl/NavWalls-v0": "nav-walls", "margin_safe_rl/NavOpen-v0": "nav-open"}
    for env_id, name in ids.items():
        env = gymnasium.make(env_id, binary=firmware_sim)
        try:
            assert isinstance(env.unwrapped, FirmwareSimEnv)
            assert env.unwrapped.plant_name == name
            observation, info = env.reset(seed=1)
            assert observation.dtype == np.float32 and info == {}
        finally:
            env.close()


def test_firmware_sim_from_the_environment_variable(
    firmware_sim: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("FIRMWARE_SIM", firmware_sim)
    env = gymnasium.make("margin_safe_rl/NavOpen-v0")
    env.close()


def test_seeds_follow_gymnasium(env: FirmwareSimEnv) -> None:
    first, _ = env.reset(seed=5)
    again, _ = env.reset(seed=5)
    assert np.array_equal(first, again)
    # Unseeded resets continue the env's stream: reproducible after the same seed.
    env.reset(seed=9)
    stream = [env.reset()[0] for _ in range(3)]
    env.reset(seed=9)
    assert all(np.array_equal(a, env.reset()[0]) for a in stream)


def test_step_reports_the_margin_and_the_motion(env: FirmwareSimEnv) -> None:
    start, _ = env.reset(seed=0)
    inward = -start / np.linalg.norm(start) * 0.25
    touched = False
    for _ in range(40):
        observation, reward, terminated, truncated, info = env.step(inward)
        assert observation.dtype == np.float32 and isinstance(reward, float)
        assert info["applied"].dtype == np.float32 and isinstance(info["success"], bool)
        touched |= info["margin_touched"]
    assert touched, "heading for the centre from seed 0 meets a wall"


def test_an_episode_the_goal_ends_is_a_success(firmware_sim: str) -> None:
    # Straight in on the open arena and hold the centre: the goal (10 steps within 0.1) ends the
    # episode before the settle window (20 steps within 2) fills, and it counts.
    env = FirmwareSimEnv("nav-open", binary=firmware_sim)
    try:
        observation, _ = env.reset(seed=3)
        for step in range(1, 200):
            action = np.clip(-observation, -0.25, 0.25)
            observation, _, terminated, truncated, info = env.step(action)
            if terminated or truncated:
                break
        assert terminated and not truncated and step < 200
        assert info["success"] is True and info["is_success"] is True
    finally:
        env.close()


def test_reward_form_is_passed_to_the_plant(firmware_sim: str) -> None:
    rewards = {}
    for form in ("lr", "gr"):
        env = FirmwareSimEnv("nav-walls", reward=form, binary=firmware_sim)
        try:
            env.reset(seed=0)
            rewards[form] = env.step(np.zeros(2, dtype=np.float32))[1]
        finally:
            env.close()
    assert rewards["lr"] != rewards["gr"]


def test_wrong_action_size_is_a_value_error(env: FirmwareSimEnv) -> None:
    env.reset(seed=0)
    with pytest.raises(ValueError, match="an action of 3 values, expected 2"):
        env.step(np.zeros(3, dtype=np.float32))


def test_close_ends_the_plant(env: FirmwareSimEnv) -> None:
    process = env._client._process  # type: ignore[union-attr]
    env.close()
    assert process.returncode == 0
    env.close()  # a second close is harmless
    with pytest.raises(RuntimeError, match="closed"):
        env.reset(seed=0)


def test_a_missing_binary_is_one_line() -> None:
    with pytest.raises(PlantError, match="cannot start"):
        FirmwareSimEnv(binary="/no/such/firmware-sim")


def test_a_bad_scenario_is_the_plants_exit(firmware_sim: str) -> None:
    with pytest.raises(PlantError, match="exited with status"):
        FirmwareSimEnv("no-such-scenario", binary=firmware_sim)
