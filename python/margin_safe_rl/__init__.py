"""margin-safe-rl in Python: the plant link and firmware-sim's plants as Gymnasium environments.

- :mod:`margin_safe_rl.plant_link`: the plant link's reference implementation (standard library
  only): serve any Gymnasium environment to host-trainer, or drive a plant process.
- :mod:`margin_safe_rl.firmware_sim_env`: :class:`FirmwareSimEnv`, a firmware-sim plant as a
  ``gymnasium.Env``, registered as ``margin_safe_rl/NavWalls-v0`` and ``margin_safe_rl/NavOpen-v0``.
"""

__version__ = "0.1.0"

try:
    import gymnasium as _gymnasium
except ImportError:
    # The plant link alone needs nothing but the standard library; the environments need
    # Gymnasium and are only registered where it is installed.
    pass
else:
    for _id, _scenario in (("NavWalls-v0", "nav-walls"), ("NavOpen-v0", "nav-open")):
        _gymnasium.register(
            id=f"margin_safe_rl/{_id}",
            entry_point="margin_safe_rl.firmware_sim_env:FirmwareSimEnv",
            kwargs={"scenario": _scenario},
            # The plant ends its episodes itself (200 steps): no TimeLimit wrapper on top.
            max_episode_steps=None,
        )
