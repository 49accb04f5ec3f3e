"""Numba kernels: one step of N identifiers of one kind at once (N = 1 for a single env).

Memory layout (all float64, C-contiguous; row i is identifier i):

* ``theta`` (N, P): [vec Ŵ (n·n_h) | vec V̂ (n_h·p) | x̂ (n) | z (n) | initialised (1)];
* ``out`` (N, Q): results and scratch, offsets from :func:`out_offsets`; the last entry is
  the row's status (:data:`STATUS_OK` …);
* inputs ``x, u, f, x_next``: flat (N·n,), (N·m,), (N·n,), (N·n,): a single identifier
  passes its 1-D vectors as they are, a batch passes ``a.reshape(-1)``;
* ``hp``: hyper-parameters, indices ``HP_*``;
* ``active`` (N,) int8: 0 = not a transition (row untouched), 1 = frozen (x̂ runs, no
  weight / z / buffer update), 2 = learn.

A row that fails (non-finite input, divergence) is left exactly as it was before the call
(nothing half-written) and gets a non-zero status; the other rows proceed.
"""

from __future__ import annotations

import numpy as np
from numba import float64, int8, int64, njit, types

from simgap.identifiers.laws import (
    INTEGRAL,
    norm2,
    observer_delta,
    observer_error,
    unified_update,
    z_filter_step,
)
from simgap.identifiers.minibatch import DUE, FILLED, buffer_push, sgd_step
from simgap.identifiers.network import forward_flat

HP_DT, HP_AD, HP_ETA1, HP_ETA2, HP_RHO1, HP_RHO2, HP_LAM, HP_MAXN = 0, 1, 2, 3, 4, 5, 6, 7
HP_H, HP_MODE, HP_PERIOD, HP_N, HP_M = 8, 9, 10, 11, 12
HP_SIZE = 13

STATUS_OK = 0
STATUS_BAD_INPUT = 2
STATUS_DIVERGED = 3
STATUS_STATE_DIVERGED = 4
#: Number of counters per minibatch identifier (pos, filled, since, due).
N_COUNTERS = 4


@njit(cache=True, inline="always")
def out_offsets(n, h, p):  # pragma: no cover - compiled
    """Return the offsets in an ``out`` row.

    Order: g, x̄, x̂_{k+1}, x̃_{k+1}, e, x̃_k, δ, σ, z_{k+1}, G_W, G_V, backup of (Ŵ, V̂),
    status, total size.
    """
    o_g = 0
    o_xb = o_g + n
    o_xh = o_xb + p
    o_xt = o_xh + n
    o_e = o_xt + n
    o_xtk = o_e + n
    o_d = o_xtk + n
    o_s = o_d + n
    o_z = o_s + h
    o_gw = o_z + n
    o_gv = o_gw + n * h
    o_bk = o_gv + h * p
    o_st = o_bk + n * h + h * p
    return o_g, o_xb, o_xh, o_xt, o_e, o_xtk, o_d, o_s, o_z, o_gw, o_gv, o_bk, o_st, o_st + 1


def layout_sizes(n: int, h: int, m: int) -> tuple[int, int]:
    """(P, Q): row sizes of ``theta`` and ``out`` for n states, n_h hidden, m inputs."""
    p = n + m
    return n * h + h * p + 2 * n + 1, out_offsets(n, h, p)[-1]


@njit(cache=True, inline="always")
def _all_finite(a):  # pragma: no cover - compiled
    for k in range(a.shape[0]):
        if not np.isfinite(a[k]):
            return False
    return True


@njit(cache=True, inline="always")
def _row_inputs(x, u, f, x_next, i, n, m):  # pragma: no cover - compiled
    """Row i's slices of the flat inputs, and whether they are all finite."""
    xi = x[i * n:(i + 1) * n]
    ui = u[i * m:(i + 1) * m]
    fi = f[i * n:(i + 1) * n]
    xni = x_next[i * n:(i + 1) * n]
    ok = _all_finite(xi) and _all_finite(ui) and _all_finite(fi) and _all_finite(xni)
    return xi, ui, fi, xni, ok


_OBS_SIG = int64(float64[:, ::1], float64[:, ::1], float64[::1], float64[::1], float64[::1],
                 float64[::1], float64[::1], int8[::1])


@njit(_OBS_SIG, cache=True)
def observer_step(theta, out, x, u, f, x_next, hp, active):  # pragma: no cover - compiled
    """Advance every row by one Euler step of the observer-based identifiers.

    Eq. 3.1 (errata sign), 3.6-3.9, 4.1, 4.5, 4.6; the time indexing is in the package
    docstring.

    Returns the number of failed rows, or −1 if the array sizes do not fit.
    """
    nn = active.shape[0]
    n = int(hp[HP_N])
    m = int(hp[HP_M])
    h = int(hp[HP_H])
    p = n + m
    mode = int(hp[HP_MODE])
    dt = hp[HP_DT]
    a_d = hp[HP_AD]
    o_g, o_xb, o_xh, o_xt, o_e, o_xtk, o_d, o_s, o_z, o_gw, o_gv, o_bk, o_st, q = out_offsets(
        n, h, p)
    ow = n * h
    oxh = ow + h * p
    oz = oxh + n
    oini = oz + n
    if (x.shape[0] != nn * n or u.shape[0] != nn * m or f.shape[0] != nn * n
            or x_next.shape[0] != nn * n or theta.shape[0] != nn or out.shape[0] != nn
            or theta.shape[1] != oini + 1 or out.shape[1] != q):
        return -1
    nfail = 0
    # backup space of the weight update, reused row after row: only row 0's copy is touched,
    # which keeps the memory traffic of large batches down
    scratch = out[0, o_bk:o_st]
    for i in range(nn):
        act = active[i]
        if act == 0:
            continue
        th = theta[i]
        o = out[i]
        xi, ui, fi, xni, ok = _row_inputs(x, u, f, x_next, i, n, m)
        if not ok:
            o[o_st] = STATUS_BAD_INPUT
            nfail += 1
            continue
        init = th[oini] != 0.0
        xb = o[o_xb:o_xb + p]
        xtk = o[o_xtk:o_xtk + n]
        zn = o[o_z:o_z + n]
        for r in range(n):
            xh = th[oxh + r] if init else xi[r]
            xb[r] = xh
            xtk[r] = xi[r] - xh
            zn[r] = th[oz + r] if init else 0.0  # z_k for now
        for c in range(m):
            xb[n + c] = ui[c]
        g = o[o_g:o_g + n]
        s = o[o_s:o_s + h]
        forward_flat(th, n, h, p, xb, s, g)  # ĝ_k with the weights before the update
        e = o[o_e:o_e + n]
        observer_error(mode, xtk, zn, e)  # eq. 3.8 / 3.9 (e = z_k)
        # x̂_{k+1} = x̂_k + Δt (f_k + ĝ_k − A_d x̃_k)   (eq. 3.1 with the errata's sign)
        xh1 = o[o_xh:o_xh + n]
        ok = True
        for r in range(n):
            xh1[r] = xb[r] + dt * (fi[r] + g[r] - a_d * xtk[r])
            if not np.isfinite(xh1[r]):
                ok = False
        if not ok:
            o[o_st] = STATUS_STATE_DIVERGED
            nfail += 1
            continue
        if act == 2:
            d = o[o_d:o_d + n]
            observer_delta(e, a_d, d)
            leak = dt * norm2(xtk)
            if not unified_update(th, n, h, p, d, s, xb, dt * hp[HP_ETA1], dt * hp[HP_ETA2],
                                  leak * hp[HP_RHO1], leak * hp[HP_RHO2], hp[HP_MAXN],
                                  scratch):
                o[o_st] = STATUS_DIVERGED
                nfail += 1
                continue
            if mode == INTEGRAL:
                z_filter_step(zn, xtk, hp[HP_LAM], dt, zn)  # eq. 4.6 (in place)
        # commit the observer state
        xtn = o[o_xt:o_xt + n]
        for r in range(n):
            th[oxh + r] = xh1[r]
            th[oz + r] = zn[r]
            xtn[r] = xni[r] - xh1[r]
        th[oini] = 1.0
        o[o_st] = STATUS_OK
    return nfail


_MB_SIG = types.UniTuple(int64, 2)(float64[:, ::1], float64[:, ::1], float64[::1], float64[::1],
                                   float64[::1], float64[::1], float64[::1], int8[::1],
                                   float64[:, :, ::1], int64[:, ::1])


@njit(_MB_SIG, cache=True)
def minibatch_step(theta, out, x, u, f, x_next, hp, active, buf, cnt):  # pragma: no cover
    """Baseline 2, per-step part (eq. 4.2): ĝ_k = ĝ(x_k, u_k), x̂^pred_{k+1}, buffer push.

    Returns (failed rows or −1, rows whose SGD update is due).
    """
    nn = active.shape[0]
    n = int(hp[HP_N])
    m = int(hp[HP_M])
    h = int(hp[HP_H])
    p = n + m
    dt = hp[HP_DT]
    period = int(hp[HP_PERIOD])
    o_g, o_xb, o_xh, o_xt, o_e, o_xtk, o_d, o_s, o_z, o_gw, o_gv, o_bk, o_st, q = out_offsets(
        n, h, p)
    if (x.shape[0] != nn * n or u.shape[0] != nn * m or f.shape[0] != nn * n
            or x_next.shape[0] != nn * n or theta.shape[0] != nn or out.shape[0] != nn
            or out.shape[1] != q or buf.shape[0] != nn or buf.shape[2] != p + n
            or cnt.shape[0] != nn):
        return -1, 0
    nfail = 0
    ndue = 0
    for i in range(nn):
        act = active[i]
        if act == 0:
            continue
        th = theta[i]
        o = out[i]
        xi, ui, fi, xni, ok = _row_inputs(x, u, f, x_next, i, n, m)
        if not ok:
            o[o_st] = STATUS_BAD_INPUT
            nfail += 1
            continue
        xb = o[o_xb:o_xb + p]
        for r in range(n):
            xb[r] = xi[r]
        for c in range(m):
            xb[n + c] = ui[c]
        g = o[o_g:o_g + n]
        forward_flat(th, n, h, p, xb, o[o_s:o_s + h], g)
        for r in range(n):
            pred = xi[r] + dt * (fi[r] + g[r])  # x̂^pred_{k+1}, eq. 4.2
            o[o_xh + r] = pred
            o[o_xt + r] = xni[r] - pred
            o[o_e + r] = xni[r] - pred
            o[o_xtk + r] = 0.0
        o[o_st] = STATUS_OK
        if act == 2:
            if buffer_push(buf[i], cnt[i], xb, xi, fi, xni, dt, p, n, period):
                ndue += 1
    return nfail, ndue


_SGD_SIG = int64(float64[:, ::1], float64[:, ::1], float64[::1], float64[:, :, ::1],
                 int64[:, ::1], int64[:, ::1], int64[::1])


@njit(_SGD_SIG, cache=True)
def minibatch_sgd(theta, out, hp, buf, cnt, idx, rows):  # pragma: no cover - compiled
    """Baseline 2, burst part (eq. 4.3-4.4): one SGD step for each row in ``rows``.

    Row j of ``idx`` holds the buffer entries of ``rows[j]``. Clears the due flag.

    Returns the number of rows whose update would diverge (those keep their weights).
    """
    n = int(hp[HP_N])
    m = int(hp[HP_M])
    h = int(hp[HP_H])
    p = n + m
    dt = hp[HP_DT]
    o_g, o_xb, o_xh, o_xt, o_e, o_xtk, o_d, o_s, o_z, o_gw, o_gv, o_bk, o_st, q = out_offsets(
        n, h, p)
    nfail = 0
    o0 = out[0]  # scratch of row 0 serves every row (see observer_step)
    for j in range(rows.shape[0]):
        i = rows[j]
        o = out[i]
        cnt[i, DUE] = 0
        if cnt[i, FILLED] == 0:
            continue
        ok = sgd_step(theta[i], n, h, p, buf[i], idx[j], dt, hp[HP_ETA1], hp[HP_ETA2],
                      hp[HP_MAXN], o0[o_s:o_s + h], o0[o_d:o_d + n], o0[o_xtk:o_xtk + n],
                      o0[o_gw:o_gw + n * h], o0[o_gv:o_gv + h * p], o0[o_bk:o_st])
        if not ok:
            o[o_st] = STATUS_DIVERGED
            nfail += 1
    return nfail


_PRED_SIG = types.void(float64[::1], int64, int64, int64, float64[:, ::1], float64[:, ::1])


@njit(_PRED_SIG, cache=True)
def predict_rows(th, n, h, p, xbar, res):  # pragma: no cover - compiled
    """ĝ for each row of ``xbar`` (K, p) with the flat weights ``th`` (same code as a step)."""
    s = np.empty(h)
    for k in range(xbar.shape[0]):
        forward_flat(th, n, h, p, xbar[k], s, res[k])
