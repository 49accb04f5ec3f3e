"""``ResidualObservation``: append the identifier's ĝ (and optionally x̃) to the observation.

For RL agents that should see the learned residual. Wrap an
:class:`~simgap.wrappers.IdentifierWrapper` (or pass an env and let this wrapper add one):

    env = ResidualObservation(IdentifierWrapper(gym.make("simgap/BicycleTire-v0")))

Observation = [obs; ĝ_k / s] or [obs; ĝ_k / s; x̃_{k+1} / s_x] (flattened ``Box``, dtype of
the inner observation space). A ``Dict`` observation keeps its keys and gains
``"residual_estimate"`` (and ``"estimation_error"``), each a ``Box`` of the identifier's
state size. After ``reset`` no transition has happened yet: ĝ and x̃ are appended as zeros.

Scale (``scale=``; the raw ĝ is always in ``info["residual_estimate"]``):

* ``"running"`` (default): per component, s = the RMS of ĝ over every step seen so far
  (a cumulative mean of ĝ², as stable-baselines3's ``VecNormalize`` keeps for observations,
  without the mean shift: ĝ = 0 means "the nominal model is right" and stays 0), and the
  result is clipped to ±``clip`` (default 10). ĝ's units (the state derivatives') and size
  differ by env and component by orders of magnitude; an agent's network wants inputs of
  order one. Components that have only been 0 stay 0. x̃ is scaled by its own running RMS.
  The statistics carry over episodes like the identifier's weights; a seeded reset that
  restores the identifier (``reset_identifier_on_seed=True``, the default) restores them
  too, so seeded runs are reproducible. :meth:`ResidualObservation.scale_state` /
  :meth:`~ResidualObservation.load_scale_state` copy them (e.g. to an evaluation env).
* a positive number or an array of the state size: a declared residual scale in state
  units/s (e.g. the RMS of the nominal model's f, or a known bound); ĝ / s and
  x̃·|a_d| / s (the observer's quasi-static error x̃ ≈ (g − ĝ)/|a_d|, eq. 3.5, in residual
  units; a_d is the gain the observer runs with, ``Identifier.observer_gain``: the integral
  law's noise gate moves it between ``a_d`` and ``a_d_clean``), clipped to ±``clip``.
* ``None``: the raw ĝ and x̃ (the behaviour before issue 14). Bounds: |ĝ_r| ≤ √n_h ·
  max_weight_norm (tanh is bounded by 1 and ‖Ŵ‖_F ≤ max_weight_norm, else the identifier
  raises), and (−∞, ∞) for x̃.
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


def _declared_scale(scale: Any, n: int) -> np.ndarray:
    """A declared residual scale as a positive (n,) array, or IdentifierError naming it."""
    try:
        s = np.broadcast_to(np.asarray(scale, dtype=np.float64), (n,)).copy()
    except (TypeError, ValueError):
        raise IdentifierError(f"ResidualObservation: scale must be 'running', None, a positive "
                              f"number or {n} positive numbers, got {scale!r}") from None
    if not np.all(np.isfinite(s) & (s > 0)):
        raise IdentifierError(f"ResidualObservation: scale must be finite and positive, "
                              f"got {scale!r}")
    return s


class RunningRMS:
    """Per-component RMS of every vector seen: s = √(Σ v²/k), the cumulative mean of v².

    ``normalise(v)`` is v / s (0 where s = 0), clipped to ±``clip``. Pure numpy; the state
    is (count, Σ v²), so it is bit-for-bit reproducible and copies exactly.
    """

    def __init__(self, n: int, clip: float) -> None:
        self.clip = float(clip)
        self.count = 0
        self.sum_sq = np.zeros(n)

    def update(self, v: np.ndarray) -> None:
        """Add one vector."""
        self.count += 1
        self.sum_sq += v * v

    @property
    def scale(self) -> np.ndarray:
        """The current RMS per component (0 before any non-zero value)."""
        return np.sqrt(self.sum_sq / max(self.count, 1))

    def normalise(self, v: np.ndarray) -> np.ndarray:
        """The vector divided by the scale, clipped to ±clip; 0 where the scale is 0."""
        s = self.scale
        out = np.divide(v, s, out=np.zeros_like(v), where=s > 0)
        return np.clip(out, -self.clip, self.clip)

    def state(self) -> dict[str, Any]:
        """Copy of the statistics."""
        return {"count": self.count, "sum_sq": self.sum_sq.copy()}

    def load(self, state: dict[str, Any]) -> None:
        """Restore :meth:`state`."""
        self.count = int(state["count"])
        self.sum_sq = np.array(state["sum_sq"], dtype=np.float64)


class ResidualObservation(gym.Wrapper, gym.utils.RecordConstructorArgs):
    """Observation wrapper appending a scaled ĝ (and x̃ if ``include_error``).

    Args:
        env: an env containing an :class:`IdentifierWrapper`; if there is none, one is added
            with ``identifier_kwargs``.
        include_error: also append x̃_{k+1} (``info["estimation_error"]``), scaled likewise.
        scale: ``"running"`` (default), a declared residual scale (state units/s; a number
            or one per state), or ``None`` for the raw values; see the module docstring.
        clip: bound of the scaled values (ignored with ``scale=None``).
        **identifier_kwargs: passed to :class:`IdentifierWrapper` when one is added.

    Raises:
        IdentifierError: a bad ``scale``/``clip``, an observation space that is neither
            ``Box`` nor ``Dict``, a ``Dict`` that already has the keys, or identifier
            arguments for an env that already has an identifier.
    """

    def __init__(self, env: gym.Env, *, include_error: bool = False,
                 scale: str | float | np.ndarray | None = "running", clip: float = 10.0,
                 **identifier_kwargs: Any) -> None:
        gym.utils.RecordConstructorArgs.__init__(self, include_error=include_error,
                                                 scale=scale, clip=clip, **identifier_kwargs)
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
        if not (isinstance(clip, int | float) and not isinstance(clip, bool)
                and np.isfinite(clip) and clip > 0):
            raise IdentifierError(f"ResidualObservation: clip must be a finite positive "
                                  f"number, got {clip!r}")
        self.clip = float(clip)
        self.scale_mode = "raw" if scale is None else (
            "running" if isinstance(scale, str) and scale == "running" else "declared")
        if isinstance(scale, str) and scale != "running":
            raise IdentifierError(f"ResidualObservation: scale must be 'running', None, a "
                                  f"positive number or {n} positive numbers, got {scale!r}")
        self._declared = _declared_scale(scale, n) if self.scale_mode == "declared" else None
        self._g_rms = RunningRMS(n, self.clip)
        self._x_rms = RunningRMS(n, self.clip)
        self._scale_reset_point = self.scale_state()
        if self.scale_mode == "raw":
            g_bound = float(np.sqrt(ident.n_hidden) * ident.config.max_weight_norm)
            x_bound = np.inf
        else:
            g_bound = x_bound = self.clip
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
                extra[DICT_KEYS[1]] = gym.spaces.Box(-x_bound, x_bound, (n,), dtype=dtype)
            self.observation_space = gym.spaces.Dict({**base.spaces, **extra})
            return
        if not isinstance(base, gym.spaces.Box):
            raise IdentifierError(f"ResidualObservation needs a Box or Dict observation space, "
                                  f"got {base}")
        dtype = base.dtype
        lows = [base.low.reshape(-1), np.full(n, -g_bound)]
        highs = [base.high.reshape(-1), np.full(n, g_bound)]
        if self.include_error:
            lows.append(np.full(n, -x_bound))
            highs.append(np.full(n, x_bound))
        self.observation_space = gym.spaces.Box(np.concatenate(lows).astype(dtype),
                                                np.concatenate(highs).astype(dtype),
                                                dtype=dtype)

    # ---------------------------------------------------------------- scaling
    def scale_state(self) -> dict[str, Any]:
        """The running statistics of ĝ and x̃ (copies), for :meth:`load_scale_state`."""
        return {"g": self._g_rms.state(), "x": self._x_rms.state()}

    def load_scale_state(self, state: dict[str, Any]) -> None:
        """Restore :meth:`scale_state` (e.g. copy a training env's scales to an eval env)."""
        self._g_rms.load(state["g"])
        self._x_rms.load(state["x"])

    def mark_reset_point(self) -> None:
        """Make the current identifier state and scales what a seeded reset restores."""
        self.identifier_wrapper.mark_reset_point()
        self._scale_reset_point = self.scale_state()

    @property
    def residual_scale(self) -> np.ndarray | None:
        """The scale s that ĝ is divided by now (state units/s); ``None`` with ``scale=None``."""
        if self.scale_mode == "raw":
            return None
        return self._declared.copy() if self._declared is not None else self._g_rms.scale

    def _scaled(self, g: np.ndarray, xt: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        g = np.asarray(g, dtype=np.float64)
        xt = np.zeros(self._n) if xt is None else np.asarray(xt, dtype=np.float64)
        if self.scale_mode == "raw":
            return g, xt
        if self._declared is not None:
            c = self.clip
            gain = abs(self.identifier_wrapper.identifier.observer_gain)
            return (np.clip(g / self._declared, -c, c),
                    np.clip(xt * gain / self._declared, -c, c))
        self._g_rms.update(g)
        self._x_rms.update(xt)
        return self._g_rms.normalise(g), self._x_rms.normalise(xt)

    def _augment(self, obs: Any, g: np.ndarray, xt: np.ndarray) -> Any:
        if self._dict:
            out = {**obs, DICT_KEYS[0]: np.asarray(g, dtype=np.float64)}
            if self.include_error:
                out[DICT_KEYS[1]] = np.asarray(xt, dtype=np.float64)
            return out
        parts = [np.asarray(obs).reshape(-1), g]
        if self.include_error:
            parts.append(xt)
        return np.concatenate(parts).astype(self.observation_space.dtype, copy=False)

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None
              ) -> tuple[np.ndarray, dict[str, Any]]:
        """Reset; ĝ and x̃ are appended as zeros (no transition yet).

        A seeded reset that restores the identifier also restores the running scales.
        """
        obs, info = self.env.reset(seed=seed, options=options)
        if seed is not None and self.identifier_wrapper.reset_identifier_on_seed:
            self.load_scale_state(self._scale_reset_point)
        z = np.zeros(self._n)
        return self._augment(obs, z, z), info

    def step(self, action: Any) -> tuple[np.ndarray, SupportsFloat, bool, bool, dict[str, Any]]:
        """Step; append the scaled ``info["residual_estimate"]`` (and ``estimation_error``).

        ``info["residual_observation_scale"]`` is the scale s used (absent with
        ``scale=None``).
        """
        obs, reward, terminated, truncated, info = self.env.step(action)
        g, xt = self._scaled(info["residual_estimate"], info.get("estimation_error"))
        if self.scale_mode != "raw":
            info["residual_observation_scale"] = self.residual_scale
        return self._augment(obs, g, xt), reward, terminated, truncated, info
