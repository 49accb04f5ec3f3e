"""Gymnasium registration of the simgap envs (idempotent: safe to call repeatedly).

Entry points are strings, so registering does not import the env modules (or numba).
Episode limits (``TimeLimit`` via ``gym.make``; override with ``max_episode_steps=``):
the manipulator 5,000 steps (10 s at 500 Hz), the bicycle 3,500 steps (35 s at 100 Hz, one
default slalom).
"""

from __future__ import annotations

import gymnasium as gym

MANIPULATOR_ID = "simgap/ManipulatorFriction-v0"
BICYCLE_ID = "simgap/BicycleTire-v0"

#: id -> (entry point, default max_episode_steps)
ENV_SPECS: dict[str, tuple[str, int]] = {
    MANIPULATOR_ID: ("simgap.envs.manipulator:ManipulatorFrictionEnv", 5000),
    BICYCLE_ID: ("simgap.envs.bicycle:BicycleTireEnv", 3500),
}


def register_envs() -> None:
    """Register every simgap env id that is not registered yet (no warning on repeats)."""
    for env_id, (entry_point, max_steps) in ENV_SPECS.items():
        if env_id not in gym.registry:
            gym.register(id=env_id, entry_point=entry_point, max_episode_steps=max_steps,
                         order_enforce=False)  # the envs raise EnvError before reset
