"""Gymnasium registration of the simgap envs (idempotent: safe to call repeatedly).

The built-in env ids come from :data:`simgap._envtable.BUILTIN_ENVS` (plain data), so that
``import simgap`` registers them without importing the system registry, the models or numba;
the env of a user system is registered by :func:`simgap.systems.register_system` itself
(with an ``env_id`` and ``env_entry_point``, through :func:`register_env`), and
:func:`register_envs` registers again whatever is missing (e.g. after the Gymnasium registry
was cleared). Entry points are strings, so registering does not import the env modules.
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


def register_env(env_id: str, entry_point: str, max_episode_steps: int | None = None,
                 vector_entry_point: str | None = None, *, replace: bool = False) -> None:
    """Register one env id with Gymnasium, idempotently.

    Args:
        env_id: the Gymnasium id (``"namespace/Name-v0"``).
        entry_point: ``"module:Class"`` (or callable) making the env.
        max_episode_steps: default ``TimeLimit`` of ``gym.make`` (``None``: none).
        vector_entry_point: ``"module:Class"`` of a native vector env, or ``None``.
        replace: replace an id registered with other settings.

    Raises:
        ValueError: the id is registered with another entry point, limit or vector entry
            point, and ``replace`` is false.
    """
    old = gym.registry.get(env_id)
    if old is not None:
        same = (old.entry_point, old.max_episode_steps, old.vector_entry_point) == \
            (entry_point, max_episode_steps, vector_entry_point)
        if same:
            return
        if not replace:
            raise ValueError(f"env id {env_id!r} is already registered for {old.entry_point!r}"
                             f"; pass replace=True to replace it")
        del gym.registry[env_id]
    gym.register(id=env_id, entry_point=entry_point, max_episode_steps=max_episode_steps,
                 order_enforce=False,  # the envs raise EnvError before reset
                 vector_entry_point=vector_entry_point)


def register_envs() -> None:
    """Register every env id that is not registered yet (no warning on repeats).

    The built-in ones and the task envs always; those of user systems when
    :mod:`simgap.systems` is loaded (:func:`simgap.systems.register_system` registers them
    already; this restores any removed from the Gymnasium registry since).
    """
    specs = {**ENV_SPECS, **TASK_SPECS}
    if "simgap.systems" in sys.modules:
        specs.update(env_specs())
    for env_id, (entry_point, max_steps, vector) in specs.items():
        if env_id not in gym.registry:
            register_env(env_id, entry_point, max_steps, vector)
