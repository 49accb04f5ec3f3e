"""Sampling MPC (MPPI) for bicycle yaw-rate tracking, nominal model ± a frozen residual network.

Prediction model, Euler with sub-step dt_pred / n_sub:

    dx/dt = A x + B u                      (nominal alone, thesis eq. 2.7)
    dx/dt = A x + B u + Ŵ tanh(V̂ [x; u])   (nominal + the identifier's frozen network)

with x = (vy, r) (m/s, rad/s) and u = (δ_f, 0) (rad, front steering only). Cost of a candidate
steering sequence δ_0 … δ_{H−1}:

    J = Σ_h w_r (r_h − r_ref(t + (h+1)·dt_pred))² + w_du (δ_h − δ_{h−1})² + w_u δ_h²,

with δ_{−1} the last applied angle. The small effort weight w_u matters beyond the tire peak:
there the predicted force is flat in δ, and without it the sampler can park the plan at full
lock (observed with the exact-plant model before w_u was added). Each iteration also keeps the
current mean and the all-zero sequence among the candidates.

Why sampling MPC (model-predictive path integral, Williams et al. 2017) and not a gradient
solver such as ``scipy.optimize.minimize``: the residual network makes the prediction model
nonconvex and, near the tire limit, flat or falling in δ (past the Magic Formula peak), where
gradient steps stall or run to the wrong side of the peak; MPPI needs no derivatives, takes the
steering bound by clipping, and its cost per control step is fixed (n_samples × horizon model
evaluations in one numba kernel, :func:`rollout_costs`), which is what a real-time loop needs.
The random perturbations come from a seeded ``numpy.random.Generator``; the same seed gives
bit-identical steering sequences.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numba import njit

from simgap.control.compensation import ResidualNetwork
from simgap.identifiers.activation import tanh_scalar as fast_tanh
from simgap.models import bicycle as bic
from simgap.models.bicycle import BicycleNominal, plant_derivative
from simgap.models.effects import Plant
from simgap.models.nbcache import guard_cache


@njit(cache=True)
def rollout_costs(x0, U, A, b, W, V, use_residual, dt, n_sub, r_ref, w_r, w_du, w_u, u_prev
                  ):  # pragma: no cover - compiled
    """Cost of each steering sequence U[i] (rad), shape (N, H), from state x0 = (vy, r).

    Pure function: A (2, 2), b (2,) the front-steer column of B, W (2, n_h), V (n_h, 4),
    ``use_residual`` adds Ŵ tanh(V̂ [x; δ; 0]); dt (s) per horizon step with n_sub Euler
    sub-steps; r_ref (H,) rad/s; weights w_r (s²/rad²), w_du and w_u (1/rad²); u_prev (rad).
    """
    n, hor = U.shape
    nh = W.shape[1]
    h_sub = dt / n_sub
    costs = np.empty(n)
    for i in range(n):
        vy = x0[0]
        r = x0[1]
        c = 0.0
        last = u_prev
        for k in range(hor):
            d = U[i, k]
            for _ in range(n_sub):
                dvy = A[0, 0] * vy + A[0, 1] * r + b[0] * d
                dr = A[1, 0] * vy + A[1, 1] * r + b[1] * d
                if use_residual:
                    g0 = 0.0
                    g1 = 0.0
                    for j in range(nh):
                        sj = fast_tanh(V[j, 0] * vy + V[j, 1] * r + V[j, 2] * d)
                        g0 += W[0, j] * sj
                        g1 += W[1, j] * sj
                    dvy += g0
                    dr += g1
                vy += h_sub * dvy
                r += h_sub * dr
            e = r - r_ref[k]
            du = d - last
            c += w_r * e * e + w_du * du * du + w_u * d * d
            last = d
        costs[i] = c
    return costs


@njit(cache=True)
def rollout_costs_plant(x0, U, theta, dt, n_sub, r_ref, w_r, w_du, w_u, u_prev
                        ):  # pragma: no cover - compiled
    """Cost of each steering sequence, predicted with the env's exact plant.

    Like :func:`rollout_costs`, with ``theta`` = :func:`simgap.models.bicycle.plant_array`
    (no relaxation or steering lag): the perfect-model bound, available in simulation only.
    """
    n, hor = U.shape
    h_sub = dt / n_sub
    costs = np.empty(n)
    s = np.zeros(6)
    u = np.zeros(2)
    for i in range(n):
        s[:] = 0.0
        s[0] = x0[0]
        s[1] = x0[1]
        c = 0.0
        last = u_prev
        for k in range(hor):
            u[0] = U[i, k]
            for _ in range(n_sub):
                d = plant_derivative(s, u, theta)
                s[0] += h_sub * d[0]
                s[1] += h_sub * d[1]
            e = s[1] - r_ref[k]
            du = u[0] - last
            c += w_r * e * e + w_du * du * du + w_u * u[0] * u[0]
            last = u[0]
        costs[i] = c
    return costs


@dataclass(frozen=True, kw_only=True)
class MPCConfig:
    """MPPI settings.

    Attributes:
        horizon: prediction steps H.
        dt_pred: prediction step (s).
        n_sub: Euler sub-steps per prediction step.
        n_samples: candidate sequences per iteration.
        n_iter: MPPI iterations per control step.
        sigma: std of the steering perturbations (rad).
        temperature: MPPI temperature relative to the median cost spread (-), > 0.
        w_r: yaw-rate error weight (s²/rad²).
        w_du: steering-rate weight (1/rad²).
        w_u: steering effort weight (1/rad²).
        steer_limit: |δ_f| bound (rad).
        replan_period: time between re-plans (s); between them the plan is applied open loop
            (its step k at t − t_plan in [k·dt_pred, (k+1)·dt_pred)). 0 = re-plan every call.
    """

    horizon: int = 20
    dt_pred: float = 0.02
    n_sub: int = 2
    n_samples: int = 512
    n_iter: int = 3
    sigma: float = 0.02
    temperature: float = 0.05
    w_r: float = 100.0
    w_du: float = 10.0
    w_u: float = 0.5
    steer_limit: float = 0.5
    replan_period: float = 0.0

    def __post_init__(self) -> None:
        for name in ("horizon", "n_sub", "n_samples", "n_iter"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < 1:
                raise ValueError(f"MPCConfig.{name} must be a positive integer, got {v!r}")
        for name in ("dt_pred", "sigma", "temperature", "steer_limit"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"MPCConfig.{name} must be a positive number, got {v!r}")
        for name in ("w_r", "w_du", "w_u", "replan_period"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0):
                raise ValueError(f"MPCConfig.{name} must be a non-negative number, got {v!r}")


class SamplingMPC:
    """MPPI yaw-rate tracking controller on the nominal bicycle, optionally + frozen ĝ.

    Call it as a policy ``mpc(obs, t) -> (δ_f, 0)`` (rad). Keeps a warm-started mean sequence
    between calls; :meth:`reset` clears it.

    Args:
        model: nominal bicycle (A, B at the env's speed).
        reference: callable t (s) → r_ref (rad/s).
        residual: a :class:`~simgap.control.compensation.ResidualNetwork`; ``None`` predicts
            with the nominal model alone. An online (live) network is copied at every call.
        config: :class:`MPCConfig`.
        seed: seed of the perturbation Generator.
        exact_plant: a bicycle :class:`~simgap.models.effects.Plant` (``env.plant``; a plant
            kernel array is accepted too) to predict with the exact truth instead
            (simulation-only upper bound; ``residual`` must be ``None``).
    """

    def __init__(self, model: BicycleNominal, reference: Callable[[float], float],
                 residual: ResidualNetwork | None = None, *, config: MPCConfig | None = None,
                 seed: int = 0, exact_plant: Plant | np.ndarray | None = None) -> None:
        if not isinstance(model, BicycleNominal):
            raise TypeError(f"model must be a BicycleNominal, got {model!r}")
        if not callable(reference):
            raise TypeError(f"reference must be a callable t -> r_ref (rad/s), got "
                            f"{reference!r}")
        if residual is not None and (residual.n_states, residual.n_inputs) != (2, 2):
            raise ValueError("the bicycle residual must have 2 states and 2 inputs")
        if exact_plant is not None:
            if residual is not None:
                raise ValueError("give either a residual network or exact_plant, not both")
            if isinstance(exact_plant, Plant):
                exact_plant = exact_plant.array
            exact_plant = np.ascontiguousarray(exact_plant, dtype=np.float64)
            if exact_plant.shape != (bic.PLANT.size,) or bic.has_lag_states(exact_plant):
                raise ValueError(f"exact_plant must be a {bic.PLANT.size}-entry bicycle plant "
                                 "array without relaxation or steering lag")
        self.exact_plant = exact_plant
        self.model = model
        self.reference = reference
        self.residual = residual
        self.config = config if config is not None else MPCConfig()
        self.seed = int(seed)
        self._A = np.ascontiguousarray(model.A)
        self._b = np.ascontiguousarray(model.B[:, 0])
        self.reset()

    def reset(self) -> None:
        """Clear the warm start and re-seed the Generator."""
        self._rng = np.random.default_rng(self.seed)
        self._mean = np.zeros(self.config.horizon)
        self._u_prev = 0.0
        self._plan: np.ndarray | None = None
        self._t_plan = -np.inf

    def _weights(self) -> tuple[np.ndarray, np.ndarray, bool]:
        if self.residual is None:
            return np.zeros((2, 1)), np.zeros((1, 4)), False
        w, v = self.residual.weights
        return np.ascontiguousarray(w), np.ascontiguousarray(v), True

    def plan(self, x: np.ndarray, t: float) -> np.ndarray:
        """Optimised steering sequence (H,) in rad from state x = (vy, r) at time t (s)."""
        cfg = self.config
        x = np.asarray(x, dtype=np.float64)
        if x.shape != (2,) or not np.all(np.isfinite(x)):
            raise ValueError(f"state must be 2 finite values (vy m/s, r rad/s), got {x!r}")
        w, v, use = self._weights()
        r_ref = np.array([float(self.reference(t + (k + 1) * cfg.dt_pred))
                          for k in range(cfg.horizon)])
        mean = self._mean
        for _ in range(cfg.n_iter):
            eps = self._rng.normal(0.0, cfg.sigma, size=(cfg.n_samples, cfg.horizon))
            eps[0] = 0.0  # keep the current mean as a candidate
            eps[1] = -mean  # and the all-zero sequence
            cand = np.clip(mean + eps, -cfg.steer_limit, cfg.steer_limit)
            if self.exact_plant is not None:
                costs = rollout_costs_plant(x, cand, self.exact_plant, cfg.dt_pred, cfg.n_sub,
                                            r_ref, cfg.w_r, cfg.w_du, cfg.w_u, self._u_prev)
            else:
                costs = rollout_costs(x, cand, self._A, self._b, w, v, use, cfg.dt_pred,
                                      cfg.n_sub, r_ref, cfg.w_r, cfg.w_du, cfg.w_u,
                                      self._u_prev)
            c_min = costs.min()
            spread = max(float(np.median(costs) - c_min), 1e-12)
            wts = np.exp(-(costs - c_min) / (cfg.temperature * spread))
            mean = (wts / wts.sum()) @ cand
        return mean

    def __call__(self, obs: np.ndarray, t: float) -> np.ndarray:
        """Steering (δ_f, δ_r = 0) in rad for observation (vy, r) at time t (s)."""
        cfg = self.config
        age = t - self._t_plan
        if self._plan is not None and cfg.replan_period > 0 and age < cfg.replan_period - 1e-9:
            k = min(int(age / cfg.dt_pred + 1e-9), cfg.horizon - 1)
            return np.array([float(self._plan[k]), 0.0])
        seq = self.plan(obs, t)
        self._plan, self._t_plan = seq, float(t)
        delta = float(seq[0])
        shift = max(1, int(round(cfg.replan_period / cfg.dt_pred)))
        self._mean = np.concatenate([seq[shift:], np.repeat(seq[-1:], min(shift, seq.size))])
        self._u_prev = float(seq[min(shift, seq.size) - 1])
        return np.array([delta, 0.0])


guard_cache(globals())  # drop cached kernels when a module they compile in changes
