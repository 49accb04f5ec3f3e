"""The built-in systems' Gymnasium registrations as plain data (imports nothing).

:mod:`simgap.systems` builds the built-in :class:`~simgap.systems.SystemSpec` entries from
this table and :mod:`simgap.envs.registration` registers the env ids from it, so that
``import simgap`` registers the envs without importing the system registry (and with it the
models and numba).
"""

from __future__ import annotations

#: System name → (env id, env entry point, default max_episode_steps, vector entry point).
BUILTIN_ENVS: dict[str, tuple[str, str, int, str | None]] = {
    "manipulator2dof": ("simgap/ManipulatorFriction-v0",
                        "simgap.envs.manipulator:ManipulatorFrictionEnv", 5000,
                        "simgap.envs.manipulator_vector:ManipulatorVectorEnv"),
    "bicycle": ("simgap/BicycleTire-v0", "simgap.envs.bicycle:BicycleTireEnv", 3500,
                "simgap.envs.bicycle_vector:BicycleVectorEnv"),
}
