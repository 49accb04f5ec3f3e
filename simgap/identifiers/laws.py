"""The one update structure (thesis eq. 3.6-3.7) and the error signals that drive it.

All three identifiers move the weights of ĝ = Ŵ σ(V̂ x̄) along the same back-propagated
direction for an output-space error δ (state units/s per unit of cost):

    G_W = δ σᵀ,                 G_V = ((I − Λ) Ŵᵀ δ) x̄ᵀ,   Λ = diag(σ_i²)   (eq. 3.5-3.7)
    Ŵ ← Ŵ − k1 G_W − l1 Ŵ,      V̂ ← V̂ − k2 G_V − l2 V̂

(:func:`unified_update`, fused for the per-step observer laws; :func:`backprop` +
:func:`apply_gradients` for baseline 2, whose gradient is a sum over a mini-batch). They
differ only in δ and in the step sizes:

* observer laws, eq. 3.6-3.7 integrated by Euler (eq. 4.1 / 4.5): δ = A_d⁻ᵀ e with
  ``e`` from :func:`observer_error` (e = x̃ for baseline 1, eq. 3.8; e = z for the proposed
  law, eq. 3.9), k_i = Δt η_i, l_i = Δt ρ_i ‖x̃‖. With A_d = a_d I, A_d⁻ᵀ e = e / a_d.
* baseline 2 (eq. 4.3-4.4): δ_j = Δt r_j / M summed over the mini-batch, with r_j the
  one-step prediction error (:mod:`simgap.identifiers.minibatch`), k_i = η_i, l_i = 0.

The kernels are numba functions on the flat weight layout of
:mod:`simgap.identifiers.network`; they are inlined into :mod:`simgap.identifiers.kernels`.
"""

from __future__ import annotations

import numpy as np
from numba import njit

#: Error-signal codes (``IdentifierConfig`` kinds → kernel codes).
INSTANTANEOUS = 0
INTEGRAL = 1
MINIBATCH = 2


@njit(cache=True, inline="always")
def observer_error(mode, xt, z, e):  # pragma: no cover - compiled
    """Error signal ∂J/∂x̃ᵀ: e = x̃ (eq. 3.8, mode 0) or e = z (eq. 3.9, mode 1)."""
    if mode == INTEGRAL:
        for r in range(e.shape[0]):
            e[r] = z[r]
    else:
        for r in range(e.shape[0]):
            e[r] = xt[r]


@njit(cache=True, inline="always")
def z_filter_step(z_k, xt_k, lam, dt, z_next):  # pragma: no cover - compiled
    """Integral error state (eq. 4.6): z_{k+1} = z_k + Δt(−λ z_k + x̃_k)."""
    for r in range(z_k.shape[0]):
        z_next[r] = z_k[r] + dt * (-lam * z_k[r] + xt_k[r])


@njit(cache=True, inline="always")
def observer_delta(e, a_d, delta):  # pragma: no cover - compiled
    """δ = (eᵀ A_d⁻¹)ᵀ for A_d = a_d·I (the static approximation, eq. 3.5)."""
    inv = 1.0 / a_d
    for r in range(e.shape[0]):
        delta[r] = e[r] * inv


@njit(cache=True, inline="always")
def backprop(th, n, h, p, delta, s, xbar, gw, gv, accumulate):  # pragma: no cover - compiled
    """G_W (+)= δ σᵀ and G_V (+)= ((I − Λ) Ŵᵀ δ) x̄ᵀ (eq. 3.5-3.7), flat row-major."""
    for j in range(h):
        b = 0.0
        for r in range(n):
            b += th[r * h + j] * delta[r]
        b *= 1.0 - s[j] * s[j]
        for c in range(p):
            if accumulate:
                gv[j * p + c] += b * xbar[c]
            else:
                gv[j * p + c] = b * xbar[c]
    for r in range(n):
        dr = delta[r]
        for j in range(h):
            if accumulate:
                gw[r * h + j] += dr * s[j]
            else:
                gw[r * h + j] = dr * s[j]


@njit(cache=True, inline="always")
def _commit_or_restore(th, nwv, backup, nw2, nv2, max_norm):  # pragma: no cover - compiled
    """Keep the new weights if both Frobenius norms are finite and ≤ max_norm.

    Otherwise put the backed-up old weights back (bit-exact). Returns True if kept.
    """
    lim = max_norm * max_norm
    if nw2 <= lim and nv2 <= lim:  # False for NaN
        return True
    for k in range(nwv):
        th[k] = backup[k]
    return False


@njit(cache=True, inline="always")
def unified_update(th, n, h, p, delta, s, xbar, k1, k2, l1, l2, max_norm,
                   backup):  # pragma: no cover - compiled
    """Take one Euler step of the unified law, eq. 3.6-3.7, for the output-space error δ.

        Ŵ ← Ŵ − k1 δ σᵀ − l1 Ŵ,     V̂ ← V̂ − k2 ((I − Λ) Ŵᵀ δ) x̄ᵀ − l2 V̂

    with the old Ŵ inside the V̂ term. Observer laws: δ = A_d⁻ᵀ e, k_i = Δt η_i,
    l_i = Δt ρ_i ‖x̃‖. Writes in place, keeping the old weights in ``backup`` (≥ n·h + h·p)
    so a divergent step is undone exactly. Returns True if the new weights were kept.
    """
    ov = n * h
    nv2 = 0.0
    for j in range(h):
        b = 0.0
        for r in range(n):
            b += th[r * h + j] * delta[r]
        b *= 1.0 - s[j] * s[j]
        base = ov + j * p
        for c in range(p):
            old = th[base + c]
            backup[base + c] = old
            v = old - k2 * b * xbar[c] - l2 * old
            th[base + c] = v
            nv2 += v * v
    nw2 = 0.0
    for r in range(n):
        dr = k1 * delta[r]
        base = r * h
        for j in range(h):
            old = th[base + j]
            backup[base + j] = old
            w = old - dr * s[j] - l1 * old
            th[base + j] = w
            nw2 += w * w
    return _commit_or_restore(th, ov + h * p, backup, nw2, nv2, max_norm)


@njit(cache=True, inline="always")
def apply_gradients(th, n, h, p, gw, gv, k1, k2, max_norm, backup):  # pragma: no cover
    """Ŵ ← Ŵ − k1 G_W, V̂ ← V̂ − k2 G_V (eq. 4.4); undone exactly if it would diverge."""
    ov = n * h
    nw2 = 0.0
    for k in range(ov):
        old = th[k]
        backup[k] = old
        w = old - k1 * gw[k]
        th[k] = w
        nw2 += w * w
    nv2 = 0.0
    for k in range(h * p):
        old = th[ov + k]
        backup[ov + k] = old
        v = old - k2 * gv[k]
        th[ov + k] = v
        nv2 += v * v
    return _commit_or_restore(th, ov + h * p, backup, nw2, nv2, max_norm)


@njit(cache=True, inline="always")
def norm2(v):  # pragma: no cover - compiled
    """Euclidean norm of a 1-D array."""
    acc = 0.0
    for r in range(v.shape[0]):
        acc += v[r] * v[r]
    return np.sqrt(acc)
