"""Shared fixtures: the firmware-sim binary, and a child Python's environment."""

from __future__ import annotations

import os

import pytest

from paths import PYTHON_DIR, find_firmware_sim


@pytest.fixture(scope="session")
def firmware_sim() -> str:
    binary = find_firmware_sim()
    if binary is None:
        pytest.skip(
            "no firmware-sim binary: set FIRMWARE_SIM or run `cargo build -p firmware-sim` "
            "(looked in $CARGO_TARGET_DIR/debug and target/debug)"
        )
    return str(binary)


@pytest.fixture
def python_env() -> dict[str, str]:
    """The environment for a child Python that imports this package from the repository."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(PYTHON_DIR), env.get("PYTHONPATH")]))
    return env
