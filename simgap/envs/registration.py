"""Gymnasium registration of the simgap envs (idempotent: safe to call repeatedly).

The built-in env ids come from :data:`simgap._envtable.BUILTIN_ENVS` (plain data), so that
``import simgap`` registers them without importing the system registry, the models or numba;
the envs of user systems (:func:`simgap.systems.register_system` with an ``env_id``) are
registered by :func:`register_envs` once :mod:`simgap.systems` is imported. Entry points are
strings, so registering does not import the env modules.
Episode limits (``TimeLimit`` via ``gym.make``; override with ``max_episode_steps=``):
the manipulator 5,000 steps (10 s at 500 Hz), the bicycle 3,500 steps (35 s at 100 Hz, one
default slalom). A ``vector_entry_point`` makes ``gym.make_vec(id, N)`` build the native
vector env (``vectorization_mode="sync"`` still builds the sync one).
Task envs built on a system (:data:`TASK_SPECS`) are registered alongside:
``simgap/YawRateResidualRL-v0`` (residual RL on the bicycle, :mod:`simgap.control.rl`;
its episode limit is inside the env).
"""

from __future__ import annotations

import sys

import gymnasium as gym

from simgap._envtable import BUILTIN_ENVS

MANIPULATOR_ID = BUILTIN_ENVS["manipulator2dof"][0]
BICYCLE_ID = BUILTIN_ENVS["bicycle"][0]
#: The residual-RL yaw-rate task (entry point simgap.control.rl:make_rl_env).
RL_TASK_ID = "simgap/YawRateResidualRL-v0"

#: The built-in envs: id -> (entry point, default max_episode_steps, vector entry point).
ENV_SPECS: dict[str, tuple[str, int | None, str | None]] = {
    env_id: (entry, steps, vector) for env_id, entry, steps, vector in BUILTIN_ENVS.values()}
#: Task env id -> (entry point, max_episode_steps, vector entry point); registered by
#: :func:`register_envs`.
TASK_SPECS: dict[str, tuple[str, int | None, str | None]] = {
    RL_TASK_ID: ("simgap.control.rl:make_rl_env", None, None)}


def env_specs() -> dict[str, tuple[str, int | None, str | None]]:
    """Id -> (entry point, default max_episode_steps, vector entry point) of every system env.

    Imports the system registry (:data:`simgap.systems.SYSTEMS`).
    """
    from simgap.systems import SYSTEMS

    return {s.env_id: (s.env_entry_point, s.max_episode_steps, s.vector_entry_point)
            for s in SYSTEMS.values() if s.env_id and s.env_entry_point}


def register_envs() -> None:
    """Register every env id that is not registered yet (no warning on repeats).

    The built-in ones and the task envs always; those of user systems when
    :mod:`simgap.systems` is loaded (registering a system imports it).
    """
    specs = {**ENV_SPECS, **TASK_SPECS}
    if "simgap.systems" in sys.modules:
        specs.update(env_specs())
    for env_id, (entry_point, max_steps, vector) in specs.items():
        if env_id not in gym.registry:
            gym.register(id=env_id, entry_point=entry_point, max_episode_steps=max_steps,
                         order_enforce=False,  # the envs raise EnvError before reset
                         vector_entry_point=vector)
