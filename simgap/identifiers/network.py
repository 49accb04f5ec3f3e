"""The one network of all identifiers: ĝ = Ŵ tanh(V̂ x̄) (thesis Sec. 3.1).

Sizes: x̄ has p = n + m entries (identifier state or estimate, then input), the hidden
layer n_h units, the output n entries (state units/s). No bias terms. Every evaluation,
inside the update kernels and in :func:`network_forward` / ``Identifier.predict``, goes
through :func:`forward_flat` (with the fast :func:`tanh` of this module), so the online
output and a later re-evaluation of the same weights agree bit for bit.

Weights live flat per identifier (row-major Ŵ, then row-major V̂): ``th[0 : n·n_h]`` is Ŵ
(n × n_h), ``th[n·n_h : n·n_h + n_h·p]`` is V̂ (n_h × p).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from simgap.identifiers.errors import IdentifierError


@njit(cache=True, inline="always")
def tanh(a):  # pragma: no cover - compiled
    """Hyperbolic tangent with max relative error ≈ 1e-14 (vs ``numpy.tanh``), ~3× faster.

    |a| < 0.01: odd Taylor polynomial to a⁷ (truncation < 1e-18 relative); |a| ≤ 20:
    (e − 1)/(e + 1) with e = exp(2a); beyond: ±1 (tanh(20) rounds to 1 in float64).
    """
    if a > 20.0:
        return 1.0
    if a < -20.0:
        return -1.0
    if -0.01 < a < 0.01:
        a2 = a * a
        return a * (1.0 + a2 * (-1.0 / 3.0 + a2 * (2.0 / 15.0 + a2 * (-17.0 / 315.0))))
    e = np.exp(2.0 * a)
    return (e - 1.0) / (e + 1.0)


@njit(cache=True, inline="always")
def forward_flat(th, n, h, p, xbar, s, g):  # pragma: no cover - compiled
    """ĝ = Ŵ tanh(V̂ x̄) from flat weights ``th``; writes σ into ``s`` (h,) and ĝ into ``g`` (n,)."""
    ov = n * h
    for j in range(h):
        a = 0.0
        base = ov + j * p
        for c in range(p):
            a += th[base + c] * xbar[c]
        s[j] = tanh(a)
    for r in range(n):
        acc = 0.0
        base = r * h
        for j in range(h):
            acc += th[base + j] * s[j]
        g[r] = acc


@njit(cache=True)
def _forward_rows(th, n, h, p, xbar, out):  # pragma: no cover - compiled
    s = np.empty(h)
    for k in range(xbar.shape[0]):
        forward_flat(th, n, h, p, xbar[k], s, out[k])


def pack_weights(W: np.ndarray, V: np.ndarray) -> np.ndarray:  # noqa: N803 - thesis names
    """Flat weight vector [vec(Ŵ); vec(V̂)] (row-major) as used by the kernels."""
    return np.concatenate([np.ascontiguousarray(W, dtype=np.float64).ravel(),
                           np.ascontiguousarray(V, dtype=np.float64).ravel()])


def network_forward(W: np.ndarray, V: np.ndarray, x_bar: np.ndarray) -> np.ndarray:  # noqa: N803
    """Evaluate ĝ = Ŵ tanh(V̂ x̄) (thesis Sec. 3.1).

    Args:
        W: output weights Ŵ, shape (n, n_h).
        V: hidden weights V̂, shape (n_h, p).
        x_bar: network input(s), shape (p,) or (K, p); finite.

    Returns:
        ĝ, shape (n,) or (K, n), in the state units per second of the identifier state.

    Raises:
        IdentifierError: on inconsistent shapes or non-finite inputs.
    """
    W = np.asarray(W, dtype=np.float64)
    V = np.asarray(V, dtype=np.float64)
    if W.ndim != 2 or V.ndim != 2 or W.shape[1] != V.shape[0]:
        raise IdentifierError(f"weights need shapes (n, n_h) and (n_h, p), got W {W.shape} "
                              f"and V {V.shape}")
    n, h = W.shape
    p = V.shape[1]
    xb = np.ascontiguousarray(x_bar, dtype=np.float64)
    single = xb.ndim == 1
    xb2 = xb.reshape(1, -1) if single else xb
    if xb2.ndim != 2 or xb2.shape[1] != p:
        raise IdentifierError(f"x_bar must have shape ({p},) or (K, {p}), got {xb.shape}")
    if not np.all(np.isfinite(xb2)):
        raise IdentifierError("x_bar contains non-finite values")
    out = np.empty((xb2.shape[0], n))
    _forward_rows(pack_weights(W, V), n, h, p, xb2, out)
    return out[0] if single else out


def init_weights(seed: int, n_out: int, n_hidden: int, n_in: int, w0_scale: float,
                 v0_scale: float) -> tuple[np.ndarray, np.ndarray]:
    """Random initial weights, the same for every identifier kind given the same seed.

    Entries are uniform: Ŵ_0 in [−w0_scale, w0_scale], V̂_0 in [−v0_scale, v0_scale]
    (Table 4.3 / 4.4 "random initialization" read as a scale), drawn by
    ``numpy.random.default_rng(seed)``: Ŵ first, then V̂.

    Args:
        seed: integer seed.
        n_out: n, the number of identifier states.
        n_hidden: n_h.
        n_in: p = n + m.
        w0_scale: scale of Ŵ_0 (state units/s).
        v0_scale: scale of V̂_0.

    Returns:
        (W0 of shape (n, n_h), V0 of shape (n_h, p)).
    """
    rng = np.random.default_rng(seed)
    w0 = rng.uniform(-w0_scale, w0_scale, size=(n_out, n_hidden))
    v0 = rng.uniform(-v0_scale, v0_scale, size=(n_hidden, n_in))
    return w0, v0
