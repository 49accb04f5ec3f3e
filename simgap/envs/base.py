"""What the simgap envs share: time keeping, the plant state, the Box spaces, the renderer.

Subclasses set ``dt``, ``render_mode``, call :meth:`PlantEnv._init_plant` at the end of
their constructor, and implement ``reset``, ``step``, :meth:`_make_renderer` and
:meth:`_draw`. Physics stays in :mod:`simgap.models`.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from simgap.envs._common import check_reset, prepare_action
from simgap.errors import EnvError
from simgap.models.effects import Plant, PlantSchema


class PlantEnv(gym.Env):
    """Base of the simgap envs (not registered itself)."""

    dt: float
    render_mode: str | None
    plant_schema: PlantSchema
    _plant: Plant
    _theta: np.ndarray
    _theta_params: tuple[float, ...]

    # ------------------------------------------------------------------ the one plant
    @property
    def plant(self) -> Plant:
        """The truth: nominal parameters + named effects (:class:`~simgap.models.effects.Plant`).

        Assigning a new plant (``env.plant = env.plant.with_effect(...)``) rebuilds the kernel
        array; every plant quantity of the env (``plant_theta``, ``true_params``, …) is derived
        from it, so none can go stale. The new plant acts from the next step on.
        """
        return self._plant

    @plant.setter
    def plant(self, plant: Plant) -> None:
        if not isinstance(plant, Plant) or plant.schema is not self.plant_schema:
            raise EnvError(f"{type(self).__name__}.plant needs a {self.plant_schema.system} "
                           f"Plant, got {plant!r}")
        self._check_plant(plant)
        self._plant = plant
        self._theta = plant.array
        # the same parameters as a tuple of floats for the step kernels: numba then holds
        # them as values instead of reloading them from an array (1.2-1.5x faster, same bits)
        self._theta_params = tuple(self._theta.tolist())

    def _check_plant(self, plant: Plant) -> None:
        """Subclasses reject plants the env cannot run (e.g. another speed)."""

    @property
    def plant_theta(self) -> np.ndarray:
        """Copy of the plant kernel array (read-only view of :attr:`plant`)."""
        return self._theta.copy()

    @property
    def true_params(self) -> Any:
        """The plant's effective rigid-body parameters (read-only view of :attr:`plant`)."""
        return self._plant.true_params

    def _init_plant(self, n_obs: int, n_plant: int, low: np.ndarray, high: np.ndarray) -> None:
        """Set the spaces (unbounded float64 observation, float32 action box) and the state.

        Args:
            n_obs: observation size.
            n_plant: size of the plant state integrated by the kernels.
            low: action lower bounds (float64, physical units).
            high: action upper bounds.
        """
        self._low = low
        self._high = high
        self.observation_space = spaces.Box(-np.inf, np.inf, shape=(n_obs,), dtype=np.float64)
        self.action_space = spaces.Box(low.astype(np.float32), high.astype(np.float32),
                                       dtype=np.float32)
        self._zero_u = np.zeros(low.shape[0])
        self._s = np.zeros(n_plant)
        self._k = 0
        self._last_u = np.zeros(low.shape[0])
        self._renderer: Any = None
        self._was_reset = False

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> Any:
        """Seed ``np_random`` (gymnasium) and allow ``step``; subclasses extend it."""
        super().reset(seed=seed, options=options)
        self._was_reset = True

    def _action(self, action: object, what: str) -> np.ndarray:
        """The validated, clipped action of a ``step`` (one :class:`EnvError` line if bad)."""
        check_reset(self._was_reset, type(self).__name__)
        return prepare_action(action, self._low, self._high, what)

    @property
    def t(self) -> float:
        """Current time (s): number of steps since reset × dt."""
        return self._k * self.dt

    @property
    def plant_state(self) -> np.ndarray:
        """Copy of the plant state (layout in the subclass docstring)."""
        return self._s.copy()

    def _make_renderer(self) -> Any:
        """Create the renderer (subclasses)."""
        raise NotImplementedError

    def _draw(self) -> np.ndarray:
        """Draw the current state with ``self._renderer`` (subclasses)."""
        raise NotImplementedError

    def render(self) -> np.ndarray | None:
        """``rgb_array``: an HxWx3 uint8 picture of the current state (see the subclass)."""
        if self.render_mode is None:
            gym.logger.warn("render() called without render_mode; use render_mode='rgb_array'")
            return None
        if self._renderer is None:
            self._renderer = self._make_renderer()
        return self._draw()

    def close(self) -> None:
        """Release the renderer."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
