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
from numba import uint64 as _ix  # unsigned indices: no wrap-around check, loops vectorise

from simgap.identifiers.laws import (
    apply_gradients,
    backprop,
    column_norms2,
    dot,
    jacobian_norm2,
    normalised_rates,
)
from simgap.identifiers.network import forward
from simgap.identifiers.scales import (
    delta_factor,
    normalise_inputs,
    output_scale,
    scale_outputs,
)
from simgap.models.nbcache import guard_cache

#: Columns of the per-identifier counters array.
POS, FILLED, SINCE, DUE = 0, 1, 2, 3


@njit(cache=True, inline="always")
def buffer_push(buf, cnt, R, oxb, x, f, x_next, io, dt, p, n, period):  # pragma: no cover
    """Store (x̄_k, d_k = x_k + Δt f_k − x_{k+1}) in the ring buffer.

    x̄_k is read from ``R[oxb : oxb + p]``; x_k, f_k, x_{k+1} from the flat inputs at offset
    ``io``. Every ``period`` pushes an update is flagged (``cnt[DUE] = 1``) and True returned.
    """
    size = buf.shape[0]
    row = buf[cnt[POS]]
    for c in range(p):
        row[c] = R[_ix(oxb + c)]
    for r in range(n):
        row[_ix(p + r)] = x[_ix(io + r)] + dt * f[_ix(io + r)] - x_next[_ix(io + r)]
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
def sgd_step(R, ow, n, h, p, buf, idx, dt, eta1, eta2, max_norm, onorm, T, os, og, od, ogw,
             osc, ce, ons, oxn, oy):  # pragma: no cover - compiled
    """Take one SGD step of eq. 4.4 on the mini-batch ``idx`` of ``buf``.

    Weights at ``R[ow:]``, their squared norms at ``R[onorm:onorm + 2]``. The gradient is
    accumulated in ``T[ogw:]`` (G_W then G_Vᵀ) with the weights held fixed, then applied
    once; ``T[os:]``, ``T[og:]``, ``T[od:]`` and ``T[osc:]`` are scratch. With ``ce`` > 0
    the step sizes are bound-normalised (:func:`~simgap.identifiers.laws.normalised_rates`)
    with the batch means of ‖σ‖², ‖x̄‖², ‖Ŵ D_j‖_F² and of M²‖δ_j‖² (δ_j = Δt r_j / M, so that
    c_e M δ_j is sample j's residual error with c_e = 1/Δt²). With ``ons`` ≥ 0 (the row's
    scale block) the network runs on the running scales of :mod:`~simgap.identifiers.scales`:
    the stored x̄_j is normalised into ``T[oxn:]`` (p), the output y goes to ``T[oy:]`` (n),
    ĝ = s ⊙ y, and the gradient is taken for δ_j ⊘ s. Returns True if the new weights were
    kept.
    """
    m = idx.shape[0]
    for k in range(n * h + h * p):
        T[_ix(ogw + k)] = 0.0
    scale = dt / m
    ss = 0.0
    xx = 0.0
    dd = 0.0
    wd = 0.0  # Σ_j ‖Ŵ D_j‖²
    ee = 0.0  # Σ ‖ε_j‖², ε_j = −d_j / Δt the batch's residual samples (running scales)
    inv = 1.0 / output_scale(R, ons, p) if ons >= 0 and output_scale(R, ons, p) > 0.0 \
        else 0.0
    oc = osc + h  # Ŵ's column norms (Ŵ is fixed over the batch; backprop uses T[osc:osc+h])
    if ce > 0.0:
        column_norms2(R, ow, n, h, T, oc)
    for j in range(m):
        row = buf[idx[j]]
        if ons >= 0:
            normalise_inputs(R, ons, p, row, 0, T, oxn)
            forward(R, ow, n, h, p, T, oxn, T, os, T, oy)
            scale_outputs(R, ons, n, p, T, oy, T, og)
            xin, oin = T, oxn
        else:
            forward(R, ow, n, h, p, row, 0, T, os, T, og)
            xin, oin = row, 0
        for r in range(n):
            T[_ix(od + r)] = scale * (row[_ix(p + r)] + dt * T[_ix(og + r)])
        if ons >= 0:  # δ_j / s (capped to δ_j / s_eff after the loop)
            for r in range(n):
                v = row[_ix(p + r)] / dt
                ee += v * v
                T[_ix(od + r)] *= inv
        if ce > 0.0:
            ss += dot(T, os, T, os, h)
            xx += dot(xin, oin, xin, oin, p)
            dd += dot(T, od, T, od, n)
            wd += jacobian_norm2(T, oc, os, h)
        backprop(R, ow, n, h, p, T, od, os, xin, oin, ogw, osc)
    if ons >= 0:  # s → s_eff = max(s, batch RMS of ε): the gradient is linear in δ
        c = delta_factor(R, ons, p, ee / (m * n)) / inv if inv > 0.0 else 0.0
        eta1 *= c
        eta2 *= c
        dd *= c * c
    if ce > 0.0:
        eta1, eta2 = normalised_rates(eta1, eta2, ss / m, xx / m, dd * m, wd / m, ce)
    return apply_gradients(R, ow, n, h, p, T, ogw, eta1, eta2, max_norm, onorm, osc)


guard_cache(globals())  # drop cached kernels when a module they compile in changes
