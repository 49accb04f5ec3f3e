"""Small synthetic recordings for the evaluation tests (no env, milliseconds to build)."""

from __future__ import annotations

import numpy as np
import pytest

from simgap.evaluation.reproducibility import Transitions


def synthetic_transitions(n_steps: int = 600, dt: float = 0.01, seed: int = 0) -> Transitions:
    """A 2-state, 1-input system x' = f + g with a known saturating residual g(x, u).

    f(x, u) = (x2, -x1 + u) (a unit oscillator, state units/s), g = (0, -0.5 tanh(3 x2)),
    u = a sum of two sines; explicit Euler, so x_{k+1} = x_k + dt (f_k + g_k) exactly.
    """
    rng = np.random.default_rng(seed)
    t = np.arange(n_steps) * dt
    u = (0.8 * np.sin(1.3 * t) + 0.4 * np.sin(3.1 * t + rng.uniform(0, 1)))[:, None]
    x = np.zeros((n_steps + 1, 2))
    f = np.zeros((n_steps, 2))
    g = np.zeros((n_steps, 2))
    for k in range(n_steps):
        f[k] = (x[k, 1], -x[k, 0] + u[k, 0])
        g[k] = (0.0, -0.5 * np.tanh(3.0 * x[k, 1]))
        x[k + 1] = x[k] + dt * (f[k] + g[k])
    return Transitions(t=t, x=x[:-1], u=u, f=f, x_next=x[1:], target=g, dt=dt,
                       extra={"obs": x[:-1], "u": u})


@pytest.fixture
def transitions() -> Transitions:
    return synthetic_transitions()
