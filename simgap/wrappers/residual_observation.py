"""``ResidualObservation``: append the identifier's ĝ (and optionally x̃) to the observation.

For RL agents that should see the learned residual. Wrap an
:class:`~simgap.wrappers.IdentifierWrapper` (or pass an env and let this wrapper add one):

    env = ResidualObservation(IdentifierWrapper(gym.make("simgap/BicycleTire-v0")))

Observation = [obs; ĝ_k] or [obs; ĝ_k; x̃_{k+1}] (flattened ``Box``, dtype of the inner
observation space). A ``Dict`` observation keeps its keys and gains
``"residual_estimate"`` (and ``"estimation_error"``), each a ``Box`` of the identifier's
state size. Bounds: the inner bounds, then |ĝ_r| ≤ √n_h · max_weight_norm (tanh is
bounded by 1 and ‖Ŵ‖_F ≤ max_weight_norm, else the identifier raises), and (−∞, ∞) for x̃.
After ``reset`` no transition has happened yet: ĝ and x̃ are appended as zeros.
"""

from __future__ import annotations

from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np

from simgap.identifiers import IdentifierError
from simgap.wrappers.identifier_wrapper import IdentifierWrapper

#: Keys a Dict observation gains: ĝ, then x̃ (with ``include_error``).
DICT_KEYS = ("residual_estimate", "estimation_error")


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
        ident = inner.identifier
        n = ident.n_states
        self.include_error = bool(include_error)
        g_bound = float(np.sqrt(ident.n_hidden) * ident.config.max_weight_norm)
        self._n = n
        self._dict = isinstance(base, gym.spaces.Dict)
        if self._dict:
            taken = [k for k in DICT_KEYS[:1 + self.include_error] if k in base.spaces]
            if taken:
                raise IdentifierError(f"ResidualObservation: the Dict observation already has "
                                      f"the key(s) {taken}")
            dtype = np.float64
            extra = {DICT_KEYS[0]: gym.spaces.Box(-g_bound, g_bound, (n,), dtype=dtype)}
            if self.include_error:
                extra[DICT_KEYS[1]] = gym.spaces.Box(-np.inf, np.inf, (n,), dtype=dtype)
            self.observation_space = gym.spaces.Dict({**base.spaces, **extra})
            return
        if not isinstance(base, gym.spaces.Box):
            raise IdentifierError(f"ResidualObservation needs a Box or Dict observation space, "
                                  f"got {base}")
        dtype = base.dtype
        lows = [base.low.reshape(-1), np.full(n, -g_bound)]
        highs = [base.high.reshape(-1), np.full(n, g_bound)]
        if self.include_error:
            lows.append(np.full(n, -np.inf))
            highs.append(np.full(n, np.inf))
        self.observation_space = gym.spaces.Box(np.concatenate(lows).astype(dtype),
                                                np.concatenate(highs).astype(dtype),
                                                dtype=dtype)

    def _augment(self, obs: Any, g: np.ndarray, xt: np.ndarray | None) -> Any:
        if self._dict:
            out = {**obs, DICT_KEYS[0]: np.asarray(g, dtype=np.float64)}
            if self.include_error:
                out[DICT_KEYS[1]] = np.asarray(xt if xt is not None else np.zeros(self._n),
                                               dtype=np.float64)
            return out
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
