"""What the native vector envs share: spaces, per-row seeding, action checks, info arrays.

A native vector env advances all N sub-envs in one numba call over structure-of-arrays state
(``(N, n)`` arrays), with Gymnasium 1.x ``NEXT_STEP`` autoreset (the default of
``gym.make_vec``): the step after a sub-env terminated or was truncated only resets it
(reward 0, not terminated, not truncated, its info the reset info) and ignores its action.
Its results equal ``gym.make_vec(id, N, vectorization_mode="sync")`` bit for bit, including
the per-row ``np_random`` streams (seed ``s`` → rows ``s, s + 1, …``), the ``TimeLimit``
truncation and the info arrays with their ``_key`` masks.

The sub-env's constructor checks the keyword arguments and provides the plant (read
through :class:`~simgap.models.effects.Plant`), the nominal model and the spaces; the
kernels are the models' own physics functions.

Threads: the kernels run on one core. A vector step at N = 256 takes ≈ 0.7 ms (arm) or
≈ 0.2 ms (bicycle), so numba's thread start and join (tens of µs) would pay only on an idle
machine; on the shared 2-core machine they lost (issue 17), hence none.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode
from gymnasium.vector.utils import batch_space

from simgap.envs._common import check_count, check_reset, state_option
from simgap.errors import EnvError


class NativeVectorEnv(gym.vector.VectorEnv):
    """Base of the native vector envs: ``reset`` and ``step`` over the subclass's kernel.

    A subclass provides ``_run(actions, rows)`` (one kernel call; ``rows`` are reset
    instead of stepped), ``_run_state(state)`` (every row at ``options["state"]``), a
    ``_zeros`` action array, the class attributes below, and optionally the hooks
    :meth:`_on_reset` and :meth:`_fresh_rows`.

    Args:
        single: one sub-env built with the user's keyword arguments (template: spaces,
            plant, nominal model).
        num_envs: N.
        max_episode_steps: ``TimeLimit`` of each row (``None``: never truncate).
    """

    metadata = {"autoreset_mode": AutoresetMode.NEXT_STEP, "render_modes": []}
    #: length of ``options["state"]`` and what its entries are (for the error line)
    state_size: int
    state_doc: str
    #: what an action row is, with units (for the error lines)
    action_doc: str

    def __init__(self, single: gym.Env, num_envs: int,
                 max_episode_steps: int | None) -> None:
        self.num_envs = check_count("num_envs", num_envs)
        if max_episode_steps is not None:
            check_count("max_episode_steps", max_episode_steps)
        self.max_episode_steps = max_episode_steps
        self.single_env = single
        self.single_observation_space = single.observation_space
        self.single_action_space = single.action_space
        self.observation_space = batch_space(single.observation_space, self.num_envs)
        self.action_space = batch_space(single.action_space, self.num_envs)
        self.nominal_model = single.nominal_model
        self._low = np.ascontiguousarray(single._low)
        self._high = np.ascontiguousarray(single._high)
        self._rngs: list[np.random.Generator | None] = [None] * self.num_envs
        self._autoreset = np.zeros(self.num_envs, dtype=bool)
        self._all_true = np.ones(self.num_envs, dtype=bool)  # template of the info masks
        self._was_reset = False

    @staticmethod
    def _make_single(env_cls: type, reference_cls: type, kwargs: dict[str, Any]) -> Any:
        """The sub-env every row copies, refused where the kernel cannot follow it.

        Raises:
            EnvError: a render mode, or a reference the kernel does not implement.
        """
        if kwargs.get("render_mode") is not None:
            raise EnvError("the native vector env does not render; use "
                           "gym.make_vec(..., vectorization_mode='sync')")
        single = env_cls(**kwargs)
        if type(single.reference) is not reference_cls:
            raise EnvError(f"the native vector env runs the {reference_cls.__name__} only, got "
                           f"{single.reference!r}; use gym.make_vec(..., "
                           f"vectorization_mode='sync') for other references")
        return single

    @staticmethod
    def _check_reset_options(options: dict[str, Any] | None) -> None:
        """Refuse ``reset_mask``: the native envs reset all rows at once."""
        if options is not None and "reset_mask" in options:
            raise EnvError("the native vector env resets all rows; use "
                           "gym.make_vec(..., vectorization_mode='sync') for reset_mask")

    # ------------------------------------------------------------------ plant
    @property
    def plant(self) -> Any:
        """The truth shared by every row (see the sub-env's ``plant``)."""
        return self.single_env.plant

    @plant.setter
    def plant(self, plant: Any) -> None:
        self.single_env.plant = plant  # checked there; rows read it from the next step on

    @property
    def unwrapped(self) -> NativeVectorEnv:
        """The env itself (no wrappers inside)."""
        return self

    def get_attr(self, name: str) -> tuple[Any, ...]:
        """``name`` of every row (the rows share one sub-env template)."""
        return (getattr(self.single_env, name),) * self.num_envs

    def _plant_params(self) -> tuple[float, ...]:
        """The plant kernel array as a tuple of floats (the sub-env's, rebuilt with the plant).

        The kernels take the parameters as a tuple: numba then holds them as values rather
        than loading them from an array it cannot prove unchanged by the state writes, which
        made the arm's vector step 1.5x faster (same arithmetic, same bits).
        """
        return self.single_env._theta_params

    # ------------------------------------------------------------------ seeding
    def _rng(self, i: int) -> np.random.Generator:
        rng = self._rngs[i]
        if rng is None:  # as gymnasium's Env.np_random: unseeded → fresh entropy
            rng, _ = seeding.np_random()
            self._rngs[i] = rng
        return rng

    def _seed(self, seed: int | list[int | None] | None) -> None:
        if seed is None:
            return
        seeds = [seed + i for i in range(self.num_envs)] if isinstance(seed, int) \
            else list(seed)
        if len(seeds) != self.num_envs:
            raise ValueError(f"If seeds are passed as a list the length must match "
                             f"num_envs={self.num_envs} but got length={len(seeds)}.")
        for i, s in enumerate(seeds):
            if s is not None:
                self._rngs[i], _ = seeding.np_random(s)

    # ------------------------------------------------------------------ reset and step
    def reset(self, *, seed: int | list[int | None] | None = None,
              options: dict[str, Any] | None = None) -> tuple[np.ndarray, dict[str, Any]]:
        """Reset every row (``seed``: int s → rows s, s + 1, …; ``options["state"]``: all)."""
        self._check_reset_options(options)
        self._seed(seed)  # the rows' np_random streams, as the sync env's
        self._on_reset()
        state = state_option(options, self.state_size, self.state_doc)
        if state is None:
            rows = np.ones(self.num_envs, dtype=bool)
            self._fresh_rows(rows)
            obs, _, _, _, info = self._run(self._zeros, rows)
        else:  # as the sub-env: every row starts there
            obs, info = self._run_state(state)
        self._autoreset[:] = False
        self._was_reset = True
        return obs, info

    def step(self, actions: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                                          dict[str, Any]]:
        """Step every row (rows that finished last step are reset instead)."""
        a = self._actions(actions, self.action_doc)
        rows = self._autoreset
        if rows.any():
            self._fresh_rows(rows)
        return self._run(a, rows)

    def _on_reset(self) -> None:
        """Called by :meth:`reset` after seeding (e.g. to read the sub-env's reference)."""

    def _fresh_rows(self, rows: np.ndarray) -> None:
        """Draw what ``rows`` need from their ``np_random`` before they start an episode."""

    # ------------------------------------------------------------------ actions
    def _actions(self, actions: Any, what: str) -> np.ndarray:
        """The (N, m) float64 actions, checked as the sub-env checks one (one error line)."""
        check_reset(self._was_reset, type(self).__name__)
        a = np.asarray(actions)
        shape = (self.num_envs, *self.single_action_space.shape)
        if a.dtype.kind != "f":
            raise EnvError(f"actions have dtype {a.dtype}; expected real floating-point {what} "
                           f"of shape {shape}")
        if a.shape != shape:
            raise EnvError(f"actions must have shape {shape} ({what}), got shape {a.shape}")
        a = np.ascontiguousarray(a, dtype=np.float64)
        if np.isfinite(a).all():  # the usual case: one pass, no per-row masks
            return a
        bad = ~np.isfinite(a).all(axis=1) & ~self._autoreset  # reset rows ignore theirs
        if bad.any():
            rows = np.flatnonzero(bad)
            raise EnvError(f"actions of rows {rows.tolist()} contain NaN or inf ({what}); the "
                           f"step was not taken")
        return a

    def _masks(self, info: dict[str, Any]) -> dict[str, Any]:
        """Add gymnasium's ``_key`` masks (all True; one array per key) to the info arrays."""
        true = self._all_true
        out: dict[str, Any] = {}
        for key, value in info.items():
            out[key] = value
            out[f"_{key}"] = true.copy()  # a copy is cheaper than np.ones (Python-level)
        return out

    def close_extras(self, **kwargs: Any) -> None:
        """Nothing to release."""
