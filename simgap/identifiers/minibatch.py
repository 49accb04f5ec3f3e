"""Baseline 2: buffer-based mini-batch online learning (thesis eq. 4.2-4.4).

The sliding-window buffer holds, per transition k, the network input x̄_k = [x_k; u_k]
(p entries) and the part of the one-step prediction error that does not depend on the
weights, d_k = x_k + Δt f_k − x_{k+1} (n entries). This is the thesis' tuple
{x̄_k, x_k, x_{k+1}, f_k} folded into the only combination J_mb uses, so the prediction
error of eq. 4.2-4.3 is r_k = x̂_{k+1} − x_{k+1} = d_k + Δt ĝ(x̄_k).

Every P_upd-th stored transition the identifier draws M indices uniformly, with
replacement, from the filled part of the buffer (seeded ``numpy.random.Generator``) and
takes one SGD step (eq. 4.4) on

    J_mb = 1/(2M) Σ_j ‖r_j‖²,   ∂J_mb/∂ĝ_j = Δt r_j / M,

through the shared back-propagation of :mod:`simgap.identifiers.laws` with k_i = η_i
(the printed η on the exact gradient of the printed cost; see
:mod:`simgap.identifiers.config`).
"""

from __future__ import annotations

from numba import njit

from simgap.identifiers.laws import apply_gradients, backprop
from simgap.identifiers.network import forward_flat

#: Columns of the per-identifier counters array.
POS, FILLED, SINCE, DUE = 0, 1, 2, 3


@njit(cache=True, inline="always")
def buffer_push(buf, cnt, xbar, x, f, x_next, dt, p, n, period):  # pragma: no cover - compiled
    """Store (x̄_k, d_k = x_k + Δt f_k − x_{k+1}) in the ring buffer.

    Every ``period`` pushes an update is flagged (``cnt[DUE] = 1``) and True returned.
    """
    size = buf.shape[0]
    row = buf[cnt[POS]]
    for c in range(p):
        row[c] = xbar[c]
    for r in range(n):
        row[p + r] = x[r] + dt * f[r] - x_next[r]
    cnt[POS] = (cnt[POS] + 1) % size
    if cnt[FILLED] < size:
        cnt[FILLED] += 1
    cnt[SINCE] += 1
    if cnt[SINCE] >= period:
        cnt[SINCE] = 0
        cnt[DUE] = 1
        return True
    return False


@njit(cache=True, inline="always")
def sgd_step(th, n, h, p, buf, idx, dt, eta1, eta2, max_norm, s, g, delta, gw,
             gv, backup):  # pragma: no cover - compiled
    """Take one SGD step of eq. 4.4 on the mini-batch ``idx`` of ``buf``.

    The gradient is accumulated with the weights held fixed, then applied once. Returns
    True if the new weights were kept.
    """
    m = idx.shape[0]
    for k in range(n * h):
        gw[k] = 0.0
    for k in range(h * p):
        gv[k] = 0.0
    scale = dt / m
    for j in range(m):
        row = buf[idx[j]]
        xbar = row[:p]
        forward_flat(th, n, h, p, xbar, s, g)
        for r in range(n):
            delta[r] = scale * (row[p + r] + dt * g[r])
        backprop(th, n, h, p, delta, s, xbar, gw, gv, True)
    return apply_gradients(th, n, h, p, gw, gv, eta1, eta2, max_norm, backup)
