"""Gymnasium registration of the simgap envs (idempotent: safe to call repeatedly).

The envs are those of the system registry (:data:`simgap.systems.SYSTEMS`) that declare an
``env_id``; entry points are strings, so registering does not import the env modules.
Episode limits (``TimeLimit`` via ``gym.make``; override with ``max_episode_steps=``):
the manipulator 5,000 steps (10 s at 500 Hz), the bicycle 3,500 steps (35 s at 100 Hz, one
default slalom).
Task envs built on a system (:data:`TASK_SPECS`) are registered alongside:
``simgap/YawRateResidualRL-v0`` (residual RL on the bicycle, :mod:`simgap.control.rl`;
its episode limit is inside the env).
"""

from __future__ import annotations

import gymnasium as gym

from simgap.systems import SYSTEMS

MANIPULATOR_ID = SYSTEMS["manipulator2dof"].env_id
BICYCLE_ID = SYSTEMS["bicycle"].env_id
#: The residual-RL yaw-rate task (entry point simgap.control.rl:make_rl_env).
RL_TASK_ID = "simgap/YawRateResidualRL-v0"
#: Task env id -> (entry point, max_episode_steps); registered by :func:`register_envs`.
TASK_SPECS: dict[str, tuple[str, int | None]] = {
    RL_TASK_ID: ("simgap.control.rl:make_rl_env", None)}


def env_specs() -> dict[str, tuple[str, int | None]]:
    """Id -> (entry point, default max_episode_steps) of every registered system's env."""
    return {s.env_id: (s.env_entry_point, s.max_episode_steps) for s in SYSTEMS.values()
            if s.env_id and s.env_entry_point}


#: The built-in envs (see :func:`env_specs` for user systems registered later).
ENV_SPECS: dict[str, tuple[str, int | None]] = env_specs()


def register_envs() -> None:
    """Register every system env id that is not registered yet (no warning on repeats)."""
    for env_id, (entry_point, max_steps) in {**env_specs(), **TASK_SPECS}.items():
        if env_id not in gym.registry:
            gym.register(id=env_id, entry_point=entry_point, max_episode_steps=max_steps,
                         order_enforce=False)  # the envs raise EnvError before reset
