"""``ResidualObservation``: append the identifier's ĝ (and optionally x̃) to the observation.

For RL agents that should see the learned residual. Wrap an
:class:`~simgap.wrappers.IdentifierWrapper` (or pass an env and let this wrapper add one):

    env = ResidualObservation(IdentifierWrapper(gym.make("simgap/BicycleTire-v0")))

Observation = [obs; ĝ_k] or [obs; ĝ_k; x̃_{k+1}] (flattened ``Box``, dtype of the inner
observation space). Bounds: the inner bounds, then |ĝ_r| ≤ √n_h · max_weight_norm (tanh is
bounded by 1 and ‖Ŵ‖_F ≤ max_weight_norm, else the identifier raises), and (−∞, ∞) for x̃.
After ``reset`` no transition has happened yet: ĝ and x̃ are appended as zeros.
"""

from __future__ import annotations

from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np

from simgap.identifiers import IdentifierError
from simgap.wrappers.identifier_wrapper import IdentifierWrapper


def _find_identifier_wrapper(env: gym.Env) -> IdentifierWrapper | None:
    e: Any = env
    while isinstance(e, gym.Wrapper):
        if isinstance(e, IdentifierWrapper):
            return e
        e = e.env
    return None


class ResidualObservation(gym.Wrapper, gym.utils.RecordConstructorArgs):
    """Observation wrapper appending ĝ (and x̃ if ``include_error``) to a Box observation.

    Args:
        env: an env containing an :class:`IdentifierWrapper`; if there is none, one is added
            with ``identifier_kwargs``.
        include_error: also append x̃_{k+1} (``info["estimation_error"]``).
        **identifier_kwargs: passed to :class:`IdentifierWrapper` when one is added.
    """

    def __init__(self, env: gym.Env, *, include_error: bool = False,
                 **identifier_kwargs: Any) -> None:
        gym.utils.RecordConstructorArgs.__init__(self, include_error=include_error,
                                                 **identifier_kwargs)
        inner = _find_identifier_wrapper(env)
        if inner is None:
            env = IdentifierWrapper(env, **identifier_kwargs)
            inner = env
        elif identifier_kwargs:
            raise IdentifierError("env already contains an IdentifierWrapper; "
                                  f"identifier arguments {sorted(identifier_kwargs)} are unused")
        gym.Wrapper.__init__(self, env)
        self.identifier_wrapper = inner
        base = env.observation_space
        if not isinstance(base, gym.spaces.Box):
            raise IdentifierError(f"ResidualObservation needs a Box observation space, got "
                                  f"{base}")
        ident = inner.identifier
        n = ident.n_states
        self.include_error = bool(include_error)
        g_bound = float(np.sqrt(ident.n_hidden) * ident.config.max_weight_norm)
        dtype = base.dtype
        lows = [base.low.reshape(-1), np.full(n, -g_bound)]
        highs = [base.high.reshape(-1), np.full(n, g_bound)]
        if self.include_error:
            lows.append(np.full(n, -np.inf))
            highs.append(np.full(n, np.inf))
        self.observation_space = gym.spaces.Box(np.concatenate(lows).astype(dtype),
                                                np.concatenate(highs).astype(dtype),
                                                dtype=dtype)
        self._n = n

    def _augment(self, obs: Any, g: np.ndarray, xt: np.ndarray | None) -> np.ndarray:
        parts = [np.asarray(obs).reshape(-1), g]
        if self.include_error:
            parts.append(xt if xt is not None else np.zeros(self._n))
        return np.concatenate(parts).astype(self.observation_space.dtype, copy=False)

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None
              ) -> tuple[np.ndarray, dict[str, Any]]:
        """Reset; ĝ and x̃ are appended as zeros (no transition yet)."""
        obs, info = self.env.reset(seed=seed, options=options)
        z = np.zeros(self._n)
        return self._augment(obs, z, z), info

    def step(self, action: Any) -> tuple[np.ndarray, SupportsFloat, bool, bool, dict[str, Any]]:
        """Step; append ``info["residual_estimate"]`` (and ``estimation_error``)."""
        obs, reward, terminated, truncated, info = self.env.step(action)
        return (self._augment(obs, info["residual_estimate"], info.get("estimation_error")),
                reward, terminated, truncated, info)
