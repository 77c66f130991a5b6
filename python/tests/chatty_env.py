"""A Gymnasium environment that writes on standard output, from Python and straight to file
descriptor 1, and reports ``is_success``: the server must keep its frames clean of both and
pass the flag on. Served as ``chatty_env:Chatty-v0`` (Gymnasium imports the module first)."""

from __future__ import annotations

import os
from typing import Any, Optional

import gymnasium
import numpy as np
from gymnasium import spaces


class ChattyEnv(gymnasium.Env[np.ndarray, np.ndarray]):
    def __init__(self) -> None:
        # float64 spaces and an uneven action box: the server must send float32 and clip per
        # dimension.
        self.observation_space = spaces.Box(-1.0, 1.0, (2,), np.float64)
        low, high = np.array([-1.0, -0.1]), np.array([1.0, 0.1])
        self.action_space = spaces.Box(low, high, (2,), np.float64)
        self.x = np.zeros(2)

    def reset(
        self, *, seed: Optional[int] = None, options: Optional[dict[str, Any]] = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        print("chatty: reset")
        os.write(1, b"chatty: straight to fd 1\n")
        self.x = self.np_random.uniform(-1.0, 1.0, 2)
        return self.x, {}

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        print("chatty: step", action)
        self.x = np.clip(self.x + action, -1.0, 1.0)
        return self.x, 0.1, False, False, {"is_success": bool(abs(self.x[0]) < 0.5)}


gymnasium.register("Chatty-v0", entry_point="chatty_env:ChattyEnv")
