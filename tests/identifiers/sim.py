"""Record a closed-loop manipulator run once, then replay it through identifiers.

The controller (thesis eq. 4.8-4.9) does not use ĝ, so the trajectory is the same for every
identifier: simulating it once and replaying (x_k, u_k, f_k, x_{k+1}) is exactly what the
wrapper would feed each identifier, at a fraction of the cost.
"""

from __future__ import annotations

from dataclasses import dataclass

import gymnasium as gym
import numpy as np
from numba import njit

import simgap  # noqa: F401 - registers the envs
from simgap.envs.scenarios import FeedbackLinearizationController
from simgap.identifiers import IdentifierConfig, make_identifier
from simgap.models.manipulator import (
    coriolis_matrix,
    gravity_vector,
    mass_matrix,
    nominal_derivative,
    plant_step,
    true_residual,
)


@dataclass
class Recording:
    dt: float
    x: np.ndarray       # (K+1, 4)
    u: np.ndarray       # (K, 2)
    f: np.ndarray       # (K, 4)
    g_true: np.ndarray  # (K, 4)


@njit(cache=False)  # not cacheable: plant_step closes over a kernel (dynamic global)
def _closed_loop(s0, ref, kp, kd, low, high, theta, la, dt, n_sub):  # pragma: no cover
    """The env's step (plant_step, clip) + FeedbackLinearizationController (eq. 4.8-4.9),
    compiled: the same model kernels the env calls."""
    k_max = ref.shape[0] - 1
    x = np.zeros((k_max + 1, 4))
    u = np.zeros((k_max, 2))
    f = np.zeros((k_max, 4))
    g = np.zeros((k_max, 4))
    s = s0.copy()
    for k in range(k_max + 1):
        q, dq = s[:2], s[2:]
        m = mass_matrix(q, la)
        x[k, :2] = q
        x[k, 2:] = m @ dq
        if k == k_max:
            break
        r = ref[k]
        v = r[4:6] + kd * (r[2:4] - dq) + kp * (r[0:2] - q)
        a = m @ v + coriolis_matrix(q, dq, la) @ dq + gravity_vector(q, la)
        for j in range(2):
            u[k, j] = min(max(a[j], low[j]), high[j])
        f[k] = nominal_derivative(x[k], u[k], la)
        g[k] = true_residual(s, u[k], theta, la)
        s = plant_step(s, u[k], theta, dt, n_sub)
    return x, u, f, g


def record_manipulator(seconds: float, friction: str | None) -> Recording:
    """The thesis closed loop on ``simgap/ManipulatorFriction-v0``, compiled (fast)."""
    env = gym.make("simgap/ManipulatorFriction-v0", friction=friction).unwrapped
    ctrl = FeedbackLinearizationController(env.nominal_model, env.reference)
    obs, _ = env.reset(seed=0)
    k_max = int(round(seconds / env.dt))
    ref = np.array([env.reference.sample(k * env.dt) for k in range(k_max + 1)])
    x, u, f, g = _closed_loop(np.asarray(obs, dtype=np.float64), ref,
                              np.asarray(ctrl.Kp, dtype=np.float64),
                              np.asarray(ctrl.Kd, dtype=np.float64),
                              env.action_space.low.astype(np.float64),
                              env.action_space.high.astype(np.float64), env.plant_theta,
                              np.ascontiguousarray(env.nominal_params.array), env.dt,
                              env.n_substeps)
    return Recording(env.dt, x, u, f, g)


def record_manipulator_env(seconds: float, friction: str | None) -> Recording:
    """The same closed loop stepped through the env in Python (slow; for cross-checks)."""
    env = gym.make("simgap/ManipulatorFriction-v0", friction=friction).unwrapped
    model = env.nominal_model
    ctrl = FeedbackLinearizationController(model, env.reference)
    obs, _ = env.reset(seed=0)
    k_max = int(round(seconds / env.dt))
    x = np.zeros((k_max + 1, 4))
    u = np.zeros((k_max, 2))
    f = np.zeros((k_max, 4))
    g = np.zeros((k_max, 4))
    x[0] = model.state(obs)
    low, high = env.action_space.low, env.action_space.high
    for k in range(k_max):
        a = ctrl(obs, k * env.dt)
        obs, _, term, trunc, info = env.step(a)
        assert not (term or trunc)
        u[k] = np.clip(a, low, high)
        x[k + 1] = model.state(obs)
        f[k] = model.f(x[k], u[k])
        g[k] = info["residual_true"]
    return Recording(env.dt, x, u, f, g)


def replay(rec: Recording, kind: str, config: IdentifierConfig, seed: int = 0
           ) -> tuple[np.ndarray, np.ndarray]:
    """(ĝ_k, x̃_{k+1}) for every transition of ``rec``."""
    ident = make_identifier(kind, 4, 2, rec.dt, config=config, seed=seed)
    k_max = rec.u.shape[0]
    g_hat = np.zeros((k_max, 4))
    x_tilde = np.zeros((k_max, 4))
    for k in range(k_max):
        g_hat[k] = ident.step(rec.x[k], rec.u[k], rec.f[k], rec.x[k + 1])
        x_tilde[k] = ident.x_tilde
    return g_hat, x_tilde


def network_off(config: IdentifierConfig) -> IdentifierConfig:
    """The same identifier with the network switched off: ĝ ≡ 0 (W0 = 0, η = 0)."""
    return config.replace(w0_scale=0.0, eta1=0.0, eta2=0.0)


def rms(a: np.ndarray) -> float:
    """Root mean square of the row norms."""
    return float(np.sqrt(np.mean(np.sum(a * a, axis=1))))
