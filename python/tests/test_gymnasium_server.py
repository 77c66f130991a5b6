"""The Gymnasium server end to end: ``python3 -m margin_safe_rl.plant_link serve
Pendulum-v1`` as a process, driven by the Python client codec (firmware-sim's Rust host is
checked against the same server by its tests/plant_link_python.rs)."""

from __future__ import annotations

import os
import struct
import subprocess
import sys
from pathlib import Path
from typing import Iterator

import pytest

from margin_safe_rl import plant_link as pl

SERVE = [sys.executable, "-m", "margin_safe_rl.plant_link", "serve"]


@pytest.fixture
def pendulum(python_env: dict[str, str]) -> Iterator[pl.PlantClient]:
    client = pl.PlantClient([*SERVE, "Pendulum-v1"], environ=python_env)
    yield client
    client.close()


def test_hello_declares_pendulums_boxes(pendulum: pl.PlantClient) -> None:
    assert pendulum.hello == pl.HelloReply(
        "Pendulum-v1", [pl.Agent("agent", [-1, -1, -8], [1, 1, 8], [-2], [2])]
    )


def test_the_same_seed_gives_the_same_start(pendulum: pl.PlantClient) -> None:
    first = pendulum.reset(11)
    assert len(first) == 3
    assert pendulum.reset(11) == first
    assert pendulum.reset(12) != first


def test_clipping_sets_margin_touched(pendulum: pl.PlantClient) -> None:
    pendulum.reset(0)
    inside = pendulum.step([1.5])
    assert not inside.margin_touched and inside.applied == (1.5,)
    assert inside.reward <= 0 and not inside.terminated and not inside.truncated
    assert inside.success is None  # Pendulum gives no is_success
    clipped = pendulum.step([-9.0])
    assert clipped.margin_touched and clipped.applied == (-2.0,)


def test_time_limit_is_a_truncation(python_env: dict[str, str]) -> None:
    client = pl.PlantClient([*SERVE, "Pendulum-v1", "--max-episode-steps", "3"], environ=python_env)
    try:
        client.reset(0)
        flags = [client.step([0.0]).truncated for _ in range(3)]
        assert flags == [False, False, True]
    finally:
        client.close()


def test_close_exits_zero(pendulum: pl.PlantClient) -> None:
    pendulum.reset(0)
    assert pendulum.close() == 0


def test_end_of_input_exits_zero(python_env: dict[str, str]) -> None:
    done = subprocess.run(
        [*SERVE, "Pendulum-v1"], input=pl.encode(pl.HelloRequest()), capture_output=True,
        env=python_env, timeout=60,
    )
    assert done.returncode == 0
    assert isinstance(pl.decode_reply(done.stdout[:-1]), pl.HelloReply)


def test_bad_requests_get_error_answers_and_the_link_goes_on(
    pendulum: pl.PlantClient,
) -> None:
    stdin = pendulum._process.stdin
    assert stdin is not None

    def answer_to(raw: bytes) -> pl.FromPlant:
        stdin.write(raw)
        frame = pendulum._frames.read(10)
        assert frame is not None
        return pl.decode_reply(frame)

    # Bytes that are no COBS-framed envelope, then a frame of another protocol version.
    garbled = answer_to(b"\x05garbage\x00")
    assert isinstance(garbled, pl.ErrorReply)
    assert garbled.message.startswith("the Python plant could not read the request: a garbled")
    foreign = answer_to(pl.encode(pl.HelloRequest(), version=7))
    assert isinstance(foreign, pl.ErrorReply)
    assert "version 7; this side speaks version 1" in foreign.message
    with pytest.raises(pl.PlantError, match="the plant says: an action of 2 values, expected 1"):
        pendulum.step([0.0, 0.0])
    assert len(pendulum.reset(0)) == 3


def test_a_step_before_any_reset_is_an_error_answer(pendulum: pl.PlantClient) -> None:
    with pytest.raises(pl.PlantError, match="the plant says: ResetNeeded"):
        pendulum.step([0.0])
    assert len(pendulum.reset(0)) == 3


def test_a_chatty_env_keeps_the_link_clean_and_reports_success(
    python_env: dict[str, str],
) -> None:
    tests = str(Path(__file__).resolve().parent)
    environ = {**python_env, "PYTHONPATH": os.pathsep.join([python_env["PYTHONPATH"], tests])}
    client = pl.PlantClient([*SERVE, "chatty_env:Chatty-v0"], environ=environ)
    try:
        # 0.1 as float32 is a little above the environment's float64 bound 0.1.
        tenth = struct.unpack("<f", struct.pack("<f", 0.1))[0]
        assert client.hello.agents[0].action_high == (1.0, tenth)
        assert len(client.reset(3)) == 2
        clipped = client.step([0.25, 0.75])
        assert clipped.margin_touched and clipped.applied == (0.25, tenth)
        assert isinstance(clipped.success, bool)
        at_the_edge = client.step([-1.0, tenth])
        assert not at_the_edge.margin_touched, "an action on the declared edge needs no clipping"
    finally:
        assert client.close() == 0


def test_a_discrete_env_is_refused_with_status_2(python_env: dict[str, str]) -> None:
    done = subprocess.run(
        [*SERVE, "CartPole-v1"], input=b"", capture_output=True, env=python_env, timeout=60
    )
    assert done.returncode == 2
    assert done.stdout == b""
    assert b"action space is Discrete(2); the plant link serves Box spaces only" in done.stderr
    assert b"Traceback" not in done.stderr


def test_an_unknown_env_is_one_line_with_status_2(python_env: dict[str, str]) -> None:
    done = subprocess.run(
        [*SERVE, "NoSuchEnv-v0"], input=b"", capture_output=True, env=python_env, timeout=60
    )
    assert done.returncode == 2
    assert done.stderr.count(b"\n") == 1 and b"cannot make NoSuchEnv-v0" in done.stderr
