"""Fixed-step integrators, separate from the physics.

Every dynamics kernel used with these integrators has the signature
``deriv(x, u, theta) -> dx/dt`` where ``theta`` is a flat float64 parameter array built by
the model's parameter dataclass. The integrators are numba-compiled and take the kernel as
an argument (numba specialises them per kernel), so one RK4 serves every model.

They are compiled with ``cache=False``: a specialisation keyed on a dispatcher argument
cannot be cached reliably (each process appended a new on-disk entry, and loading another
process's entry raised ``ReferenceError: underlying object has vanished``).
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, inline="always")
def rk4_stage(x, c, k):  # pragma: no cover - compiled
    """One RK4 stage point x + c·k (c = h/2 or h), the one place of that formula."""
    return x + c * k


@njit(cache=True, inline="always")
def rk4_combine(x, h6, k1, k2, k3, k4):  # pragma: no cover - compiled
    """The RK4 update x + (h/6)·(k1 + 2 k2 + 2 k3 + k4), the one place of that formula."""
    return x + h6 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)


@njit(cache=False)
def rk4_step(deriv, x, u, theta, h):  # pragma: no cover - compiled
    """One classical Runge-Kutta step of length ``h`` seconds with ``u`` held constant."""
    n = x.shape[0]
    tmp = np.empty(n)
    half = 0.5 * h
    k1 = deriv(x, u, theta)
    for i in range(n):
        tmp[i] = rk4_stage(x[i], half, k1[i])
    k2 = deriv(tmp, u, theta)
    for i in range(n):
        tmp[i] = rk4_stage(x[i], half, k2[i])
    k3 = deriv(tmp, u, theta)
    for i in range(n):
        tmp[i] = rk4_stage(x[i], h, k3[i])
    k4 = deriv(tmp, u, theta)
    h6 = h / 6.0
    for i in range(n):
        tmp[i] = rk4_combine(x[i], h6, k1[i], k2[i], k3[i], k4[i])
    return tmp


@njit(cache=False)
def rk4(deriv, x, u, theta, dt, n_sub):  # pragma: no cover - compiled
    """Advance ``x`` by ``dt`` seconds with ``n_sub`` RK4 sub-steps (zero-order-hold input)."""
    h = dt / n_sub
    y = x.copy()
    for _ in range(n_sub):
        y = rk4_step(deriv, y, u, theta, h)
    return y


@njit(cache=False)
def euler(deriv, x, u, theta, dt, n_sub):  # pragma: no cover - compiled
    """Advance ``x`` by ``dt`` seconds with ``n_sub`` explicit Euler sub-steps."""
    h = dt / n_sub
    y = x.copy()
    for _ in range(n_sub):
        y = y + h * deriv(y, u, theta)
    return y


def integrate(deriv, x0: np.ndarray, u: np.ndarray, theta: np.ndarray, dt: float,
              n_sub: int = 1, method: str = "rk4") -> np.ndarray:
    """Python entry point: advance ``x0`` by ``dt`` (s) with a fixed-step method.

    Args:
        deriv: numba-compiled kernel ``deriv(x, u, theta)``.
        x0: state at the start of the step.
        u: input held constant over the step.
        theta: flat float64 parameter array for ``deriv``.
        dt: step length in seconds (> 0).
        n_sub: number of sub-steps (>= 1).
        method: ``"rk4"`` or ``"euler"``.

    Returns:
        The state after ``dt`` seconds.
    """
    if not dt > 0:
        raise ValueError(f"dt must be positive, got {dt!r}")
    if int(n_sub) < 1:
        raise ValueError(f"n_sub must be >= 1, got {n_sub!r}")
    fn = {"rk4": rk4, "euler": euler}.get(method)
    if fn is None:
        raise ValueError(f"unknown integration method {method!r}; use 'rk4' or 'euler'")
    return fn(deriv, np.asarray(x0, dtype=np.float64), np.asarray(u, dtype=np.float64),
              np.asarray(theta, dtype=np.float64), float(dt), int(n_sub))


def rk4_batch_step(deriv, x: np.ndarray, h: float) -> np.ndarray:
    """One classical RK4 step of length ``h`` (s) for a batch of states, in numpy.

    ``deriv(x) -> dx/dt`` evaluates a whole batch (rows = independent states, the input
    held over the step is closed over). The stage formulas are :func:`rk4_stage` and
    :func:`rk4_combine` (their Python bodies), the same operations in the same order as
    :func:`rk4_step`; this is how the diagnosis simulates many recorded windows at once.
    """
    stage, combine = rk4_stage.py_func, rk4_combine.py_func
    half = 0.5 * h
    k1 = deriv(x)
    k2 = deriv(stage(x, half, k1))
    k3 = deriv(stage(x, half, k2))
    k4 = deriv(stage(x, h, k3))
    return combine(x, h / 6.0, k1, k2, k3, k4)
