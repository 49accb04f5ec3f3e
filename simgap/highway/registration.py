"""Register ``simgap/PacejkaLaneKeeping-v0`` if highway-env is installed (no import of it)."""

from __future__ import annotations

import importlib.util

import gymnasium as gym

HIGHWAY_LANE_KEEPING_ID = "simgap/PacejkaLaneKeeping-v0"
#: 30 s at the env's default 100 Hz policy frequency.
MAX_EPISODE_STEPS = 3000


def highway_available() -> bool:
    """Whether the ``highway_env`` package can be imported (checked without importing it)."""
    return importlib.util.find_spec("highway_env") is not None


def register_highway_envs() -> bool:
    """Register the highway env ids (idempotent); returns whether highway-env is installed."""
    if not highway_available():
        return False
    if HIGHWAY_LANE_KEEPING_ID not in gym.registry:
        gym.register(id=HIGHWAY_LANE_KEEPING_ID,
                     entry_point="simgap.highway.lane_keeping:PacejkaLaneKeepingEnv",
                     max_episode_steps=MAX_EPISODE_STEPS,
                     order_enforce=False)  # the env raises its own EnvError before reset
    return True
