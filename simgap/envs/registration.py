"""Gymnasium registration of the simgap envs (idempotent: safe to call repeatedly).

The envs are those of the system registry (:data:`simgap.systems.SYSTEMS`) that declare an
``env_id``; entry points are strings, so registering does not import the env modules.
Episode limits (``TimeLimit`` via ``gym.make``; override with ``max_episode_steps=``):
the manipulator 5,000 steps (10 s at 500 Hz), the bicycle 3,500 steps (35 s at 100 Hz, one
default slalom).
"""

from __future__ import annotations

import gymnasium as gym

from simgap.systems import SYSTEMS

MANIPULATOR_ID = SYSTEMS["manipulator2dof"].env_id
BICYCLE_ID = SYSTEMS["bicycle"].env_id


def env_specs() -> dict[str, tuple[str, int | None, str | None]]:
    """Id -> (entry point, default max_episode_steps, vector entry point or None)."""
    return {s.env_id: (s.env_entry_point, s.max_episode_steps, s.vector_entry_point)
            for s in SYSTEMS.values() if s.env_id and s.env_entry_point}


#: The built-in envs (see :func:`env_specs` for user systems registered later).
ENV_SPECS: dict[str, tuple[str, int | None, str | None]] = env_specs()


def register_envs() -> None:
    """Register every system env id that is not registered yet (no warning on repeats).

    A system with a ``vector_entry_point`` gets it registered: ``gym.make_vec(id, N)`` then
    builds the native vector env (``vectorization_mode="sync"`` the sync one).
    """
    for env_id, (entry_point, max_steps, vector) in env_specs().items():
        if env_id not in gym.registry:
            gym.register(id=env_id, entry_point=entry_point, max_episode_steps=max_steps,
                         order_enforce=False,  # the envs raise EnvError before reset
                         vector_entry_point=vector)
