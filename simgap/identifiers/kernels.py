"""Numba kernels: one step of N identifiers of one kind at once (N = 1 for a single env).

State layout: one float64 C-contiguous array ``S`` of shape (N, row_size); row i is
identifier i and holds, at the offsets returned by :func:`row_layout`:

* ``[0 : HP_SIZE]``: hyper-parameters and flags (``HP_*``): Δt, a_d, η1, η2, ρ1, ρ2, λ,
  max weight norm, n, m, n_h, error-signal code, P_upd, the row's activity (0 = not a
  transition: row untouched; 1 = frozen: x̂ runs, no weight / z / buffer update; 2 = learn)
  the status of its last step (``STATUS_*``), two counters (steps taken, weight updates
  made), ‖Ŵ‖_F², ‖V̂‖_F² (kept up to date for the divergence bound), c_e, the scales' rate,
  and the noise gate's clean-data a_d, η1, η2, c_e (``HP_ADC`` …);
* θ: Ŵ (n × n_h) and V̂ᵀ (p × n_h) (layout of :mod:`~simgap.identifiers.network`), x̂ (n),
  z (n), initialised flag (1);
* results of the last step: ĝ_k (n), x̄_k (p), x̂_{k+1} (n), x̃_{k+1} (n), e_k (n).

Scratch (working copies of the results, committed only when a row's step succeeds; x̃_k,
δ, σ, pre-activations, gradient, update scratch; offsets from :func:`scratch_layout`) is one array
per thread, shared by the rows it processes, so a batch step streams only the ≈ 2 KB of
each row's weights and results through the caches. A single identifier keeps its scratch in
extra columns after its row, which saves an allocation on every call.

Inputs ``x, u, f, x_next`` are flat float64 arrays of N·n, N·m, N·n, N·n values: a single
identifier passes its 1-D vectors as they are, a batch passes ``a.reshape(-1)``.

Where the time of one ≈ 1 µs step goes, and what the code does about it (measured on the
2-core benchmark machine; ``benchmarks/bench_identifiers.py``):

* numba's dispatcher costs ≈ 55 ns per array argument, ≈ 30 ns without numba's runtime:
  the whole state is one array, and :func:`observer_step_single` is compiled without the
  runtime (:func:`_kernel`). The single identifier's hot path skips the dispatcher
  altogether: the optional C extension ``_call`` calls :func:`c_observer_step`, the same
  body compiled as a C function (:mod:`~simgap.identifiers.fastcall`; ≈ 0.65 µs per
  ``Identifier.step`` against ≈ 1.15 µs through the dispatcher). That caller is the
  identifier's ``step`` itself (an instance attribute that falls back on the general path),
  which also saves the Python frame of a method (≈ 0.06-0.13 µs of a ≈ 0.4 µs step);
* numba's atomic reference counting on every array binding took ≈ 25 % of a batched step:
  the runtime-enabled kernels work on owner-less views (:mod:`~simgap.identifiers._raw`);
* loops over the hidden units vectorise only if their indices are unsigned (``_ix``: no
  negative-index wrap-around) and σ = tanh is straight-line arithmetic
  (:mod:`~simgap.identifiers.activation`);
* the divergence bound uses weight norms tracked by an exact identity instead of a backup
  pass over the weights (:func:`~simgap.identifiers.laws.unified_update`);
* the ``auto`` preset's extras (running scales, noise gate, bound-normalised steps; issue 14
  allows 1.3× the thesis preset's step at the commit it was filed on): LLVM does not
  reorder a float sum, so every reduction is a serial chain of ≈ 4-cycle adds. ‖Ŵ D‖_F² is
  taken from Ŵ's column norms (vectorised; n_h serial terms instead of n·n_h, once per
  baseline-2 mini-batch; keeping four columns' sums in registers instead, or fusing the
  two loops, compiled to scalar code and measured slower, as did the same for Ŵᵀv);
  ‖σ‖², ‖x̄‖², ‖δ‖² are summed once and shared with the update; s_eff comes from mean
  squares (one square root, one division) and enters the update as a factor of the step
  sizes, so the hidden error does not wait for ĝ_k (≈ 150 cycles of dependent arithmetic);
  the square roots of the
  running means and the noise gate's ρ⁺ are taken at the end of the step that changes them
  (:mod:`~simgap.identifiers.scales`). Baseline 2 bursts every 10 steps (half the fixed
  cost per burst; :func:`~simgap.identifiers.config.auto_preset`). Measured
  (``benchmarks/bench_auto_cost_vs_filing.py --runs 31 --repeats 8``, pooled medians,
  load 4.6-5.1): ``auto`` over the thesis preset at the filing commit 1.08
  (instantaneous), 1.13 (integral; 1.00-1.19 per worker pair), 0.98 (mini-batch), from
  1.17, 1.26, 1.29 (21 runs, load 2.3) before; over today's thesis preset 1.30, 1.38,
  0.98 (``bench_identifiers.py --scales-only``, 200 runs, load 5.3: 1.33, 1.43 for the
  observer laws; its mini-batch median is bimodal at that load, best runs 1.01): the
  Python frame saved above is a fixed ≈ 0.05-0.1 µs off both, so the ratio to today's
  thesis preset rose (1.22, 1.28, 1.30 before) while ``auto``'s own step fell from
  ≈ 0.46 to ≈ 0.37-0.40 µs.

A row that fails (non-finite input, divergence) is left exactly as it was before the call
(nothing half-written) and gets a non-zero status; the other rows proceed.
"""

from __future__ import annotations

import numpy as np
from numba import carray, cfunc, float64, int64, njit, prange, types
from numba import uint64 as _ix  # unsigned indices: no wrap-around check, loops vectorise

from simgap.identifiers._raw import raw
from simgap.identifiers.laws import (
    INTEGRAL,
    bound_error2,
    column_norms2,
    dot,
    jacobian_norm2,
    normalised_rates,
    observer_delta,
    observer_error,
    scratch_size,
    unified_update,
    z_filter_step,
)
from simgap.identifiers.minibatch import DUE, FILLED, buffer_push, sgd_step
from simgap.identifiers.network import forward, forward_keep
from simgap.identifiers.scales import (
    block_size,
    delta_factor,
    gated,
    mean_square,
    normalise_inputs,
    scale_beta,
    scale_outputs,
    stored_whiteness,
    update_scales,
    update_whiteness,
)
from simgap.models.nbcache import guard_cache

HP_DT, HP_AD, HP_ETA1, HP_ETA2, HP_RHO1, HP_RHO2, HP_LAM, HP_MAXN = 0, 1, 2, 3, 4, 5, 6, 7
HP_N, HP_M, HP_H, HP_MODE, HP_PERIOD, HP_ACT, HP_STATUS = 8, 9, 10, 11, 12, 13, 14
HP_NSTEPS, HP_NUPDATES = 15, 16
#: ‖Ŵ‖_F² and ‖V̂‖_F² (HP_NORM2 + 1), tracked for the divergence bound.
HP_NORM2 = 17
#: c_e, the factor that turns the error signal δ into residual units (state units/s) for
#: bound-normalised gradients; 0 = plain gradients as printed (every thesis preset).
HP_ESCALE = 19
#: Rate of the running input / output scales (1/s, :mod:`~simgap.identifiers.scales`);
#: 0 = raw inputs and outputs (every thesis preset).
HP_SRATE = 20
#: Noise gate (:func:`~simgap.identifiers.scales.whiteness`): a_d, η1, η2 and c_e on clean
#: data; the step uses x + ρ⁺ (x_clean − x). a_d_clean = 0: off (every preset but the
#: ``auto`` integral law's).
HP_ADC, HP_ETA1C, HP_ETA2C, HP_ESCALEC = 21, 22, 23, 24
HP_SIZE = 25
#: ``HP_MODE`` of baseline 2 learning on the observer's x̂ (``minibatch_input="estimate"``).
MB_ESTIMATE = 3

#: Activity codes (``S[i, HP_ACT]``).
SKIP, FROZEN, LEARN = 0.0, 1.0, 2.0

STATUS_OK = 0
STATUS_BAD_INPUT = 2
STATUS_DIVERGED = 3
STATUS_STATE_DIVERGED = 4
#: Number of counters per minibatch identifier (pos, filled, since, due).
N_COUNTERS = 4


#: Kernels declared with :func:`_kernel`: name → (function, signature, runtime, options).
_DECLARED: dict = {}
#: Names of the kernels :func:`ready` has compiled (or loaded from numba's cache).
_READY: set = set()


def _kernel(sig, *, runtime: bool = True, **options):
    """Declare a kernel, compiled for ``sig`` by :func:`ready` on first use, not at import.

    A fresh machine then compiles only the kernels it uses (all of them take ≈ 25 s; one
    identifier kind ≈ 5-10 s), and numba's cache serves them afterwards.

    ``runtime=False`` compiles without numba's runtime (NRT, the private ``_nrt`` option):
    such a function cannot allocate, but its array arguments are passed without the
    reference-counted wrappers (≈ 30 ns each) and nothing inside it counts references; a
    single identifier's kernel call then costs ≈ 0.65 µs instead of ≈ 1.0 µs. If a numba
    version rejects the option, :func:`ready` compiles the plain way.
    """
    def declare(fn):
        _DECLARED[fn.__name__] = (fn, sig, runtime, options)
        if not runtime:
            try:
                return njit(_nrt=False, **options)(fn)
            except Exception:  # noqa: BLE001 - numba without the option: the plain way
                pass
        return njit(**options)(fn)
    return declare


def ready(name: str):
    """The kernel ``name``, compiled for its declared signature and locked to it.

    Other argument types then raise ``TypeError`` (the identifiers convert and retry).
    """
    disp = globals()[name]
    if name in _READY:
        return disp
    fn, sig, runtime, options = _DECLARED[name]
    try:
        disp.compile(sig)
    except Exception:  # noqa: BLE001 - only the runtime-free variant gets a second try
        if runtime:
            raise
        disp = njit(**options)(fn)
        disp.compile(sig)
        globals()[name] = disp
    disp.disable_compile()
    _READY.add(name)
    return disp


@njit(cache=True, inline="always")
def row_layout(n, m, h):  # pragma: no cover - compiled (also called as .py_func)
    """Offsets in a state row for n states, m inputs, n_h hidden units.

    Returns (ow, oxh, oz, oini, og, oxb, oxh1, oxt1, oe, size): weights, x̂, z,
    initialised flag, the results ĝ_k, x̄_k, x̂_{k+1}, x̃_{k+1}, e_k, and the row size. The
    running scales (:mod:`~simgap.identifiers.scales`) follow e_k, at :func:`scale_block`.
    """
    p = n + m
    ow = HP_SIZE
    oxh = ow + n * h + h * p
    oz = oxh + n
    oini = oz + n
    og = oini + 1
    oxb = og + n
    oxh1 = oxb + p
    oxt1 = oxh1 + n
    oe = oxt1 + n
    return ow, oxh, oz, oini, og, oxb, oxh1, oxt1, oe, oe + n + block_size(n, p)


@njit(cache=True, inline="always")
def scale_block(n, m, h):  # pragma: no cover - compiled (also called as .py_func)
    """Offset of the row's scale block (count, m_in, m_out; after the results)."""
    return row_layout(n, m, h)[-1] - block_size(n, n + m)


@njit(cache=True, inline="always")
def scratch_layout(n, m, h):  # pragma: no cover - compiled (also called as .py_func)
    """Offsets in the per-call scratch array.

    Returns (tg, txb, txh1, te, txt, td, ts, ta, tgw, tsc, size): working ĝ_k, x̄_k,
    x̂_{k+1}, e_k, then x̃_k, δ, σ, pre-activations, gradient (n·n_h + p·n_h), update
    scratch, and the size. The normalised x̄ and the network output y (running scales) follow
    the update scratch, at :func:`norm_scratch`.
    """
    p = n + m
    tg = 0
    txb = tg + n
    txh1 = txb + p
    te = txh1 + n
    txt = te + n
    td = txt + n
    ts = td + n
    ta = ts + h
    tgw = ta + h
    tsc = tgw + n * h + h * p
    return tg, txb, txh1, te, txt, td, ts, ta, tgw, tsc, tsc + scratch_size(n, h, p) + p + 2 * n


@njit(cache=True, inline="always")
def norm_scratch(n, m, h):  # pragma: no cover - compiled (also called as .py_func)
    """Scratch offsets (txn, ty) of the normalised x̄ (p) and the network output y (n).

    ``ty + n`` holds the residual sample ε_k (n) of the running scales.
    """
    end = scratch_layout(n, m, h)[-1]
    return end - n - m - 2 * n, end - 2 * n


def layout(n: int, m: int, h: int) -> dict[str, int]:
    """:func:`row_layout` as a dict of named offsets (Python side)."""
    names = ("ow", "oxh", "oz", "oini", "og", "oxb", "oxh1", "oxt1", "oe", "size")
    out = dict(zip(names, row_layout.py_func(n, m, h), strict=True))
    t = scratch_layout.py_func(n, m, h)
    assert t[-1] - t[-2] == scratch_size(n, h, n + m) + 3 * n + m
    return out


@njit(cache=True, inline="always")
def _finite(a, o, k):  # pragma: no cover - compiled
    """True if ``a[o : o + k]`` is all finite (branch-free: v·0 is NaN only for inf/NaN)."""
    acc = 0.0
    for j in range(k):
        acc += a[_ix(o + j)] * 0.0
    return acc == 0.0


@njit(cache=True, inline="always")
def _inputs_ok(x, u, f, x_next, i, n, m):  # pragma: no cover - compiled
    """Row i's inputs are all finite."""
    return (_finite(x, i * n, n) and _finite(u, i * m, m) and _finite(f, i * n, n)
            and _finite(x_next, i * n, n))


@njit(cache=True, inline="always")
def _observer_row(R, T, x, u, f, x_next, i, n, m, h):  # pragma: no cover - compiled
    """One Euler step of one observer-based identifier (row ``R``, scratch ``T``).

    Eq. 3.1 (errata sign), 3.6-3.9, 4.1, 4.5, 4.6; the time indexing is in the package
    docstring. Returns the row's status (``STATUS_*``); on failure the row is unchanged.
    """
    act = R[HP_ACT]
    if act == SKIP:
        return STATUS_OK
    if not _inputs_ok(x, u, f, x_next, i, n, m):
        return STATUS_BAD_INPUT
    p = n + m
    ow, oxh, oz, oini, og, oxb, oxh1, oxt1, oe, size = row_layout(n, m, h)
    tg, txb, txh1, te, txt, td, ts, ta, tgw, tsc, tsize = scratch_layout(n, m, h)
    io = i * n
    dt = R[HP_DT]
    a_d = R[HP_AD]
    eta1 = R[HP_ETA1]
    eta2 = R[HP_ETA2]
    ce = R[HP_ESCALE]
    ons = scale_block(n, m, h)
    adc = R[HP_ADC]
    if adc != 0.0:  # noise gate: towards the clean-data endpoint by the smooth share ρ⁺ of x̃
        wg = stored_whiteness(R, ons, p)
        a_d = gated(a_d, adc, wg)
        eta1 = gated(eta1, R[HP_ETA1C], wg)
        eta2 = gated(eta2, R[HP_ETA2C], wg)
        ce = gated(ce, R[HP_ESCALEC], wg)
    fresh = R[oini] == 0.0  # fresh observer: x̂_k = x_k, z_k = 0
    for r in range(n):
        xr = x[_ix(io + r)]
        xh = xr if fresh else R[_ix(oxh + r)]
        T[_ix(txb + r)] = xh
        T[_ix(txt + r)] = xr - xh
    for c in range(m):
        T[_ix(txb + n + c)] = u[_ix(i * m + c)]
    # ĝ_k with the weights before the update (the pre-activations are kept for the update)
    rate = R[HP_SRATE]
    if rate > 0.0:  # running scales: ĝ = s ⊙ Ŵ tanh(V̂ (x̄ ⊘ r))
        txn, ty = norm_scratch(n, m, h)
        normalise_inputs(R, ons, p, T, txb, T, txn)
        forward_keep(R, ow, n, h, p, T, txn, T, ta, T, ts, T, ty)
        scale_outputs(R, ons, n, p, T, ty, T, tg)
    else:
        txn, ty = txb, tg
        forward_keep(R, ow, n, h, p, T, txb, T, ta, T, ts, T, tg)
    mode = int(R[HP_MODE])
    observer_error(mode, T, txt, R, oz, T, te, n)  # eq. 3.8 / 3.9 (e = z_k)
    if fresh and mode == INTEGRAL:
        for r in range(n):
            T[_ix(te + r)] = 0.0
    # x̂_{k+1} = x̂_k + Δt (f_k + ĝ_k − A_d x̃_k)   (eq. 3.1 with the errata's sign)
    for r in range(n):
        T[_ix(txh1 + r)] = T[_ix(txb + r)] + dt * (f[_ix(io + r)] + T[_ix(tg + r)]
                                                   - a_d * T[_ix(txt + r)])
    if not _finite(T, txh1, n):
        return STATUS_STATE_DIVERGED
    eps_ms = 0.0  # mean square of the residual sample ε_k (running scales only)
    if act == LEARN:
        observer_delta(T, te, a_d, td, n)
        inv = 1.0
        if rate > 0.0:  # δ / s_eff with the residual sample ε_k = ĝ_k − a_d x̃_k (scales.py)
            for r in range(n):
                T[_ix(ty + n + r)] = T[_ix(tg + r)] - a_d * T[_ix(txt + r)]
            eps_ms = mean_square(T, ty + n, n)
            inv = delta_factor(R, ons, p, eps_ms)
        # δ stays unscaled: 1/s_eff enters as a factor of the step sizes (the update is
        # linear in δ), so the hidden error Ŵᵀδ and its dot products do not wait for ĝ_k,
        # ε_k and s_eff (a chain of ≈ 150 cycles; 1 without running scales: exact)
        l1 = 0.0
        l2 = 0.0
        if R[HP_RHO1] != 0.0 or R[HP_RHO2] != 0.0:  # leakage Δt ρ_i ‖x̃‖ (none in "auto")
            leak = dt * np.sqrt(dot(T, txt, T, txt, n))
            l1 = leak * R[HP_RHO1]
            l2 = leak * R[HP_RHO2]
        k1 = dt * eta1
        k2 = dt * eta2
        ss = dot(T, ts, T, ts, h)
        xx = dot(T, txn, T, txn, p)
        dd = dot(T, td, T, td, n)  # ‖δ‖² unscaled
        if ce > 0.0:  # bound-normalised gradients (the "auto" preset), for δ / s_eff
            column_norms2(R, ow, n, h, T, tsc + h)  # unified_update's scratch: b only
            k1, k2 = normalised_rates(k1, k2, ss, xx,
                                      bound_error2(mode, dd * inv * inv, T, txt, n,
                                                   inv / (a_d * R[HP_LAM])),
                                      jacobian_norm2(T, tsc + h, ts, h), ce)
        if not unified_update(R, ow, n, h, p, T, td, ts, ta, ty, T, txn, k1 * inv, k2 * inv,
                              l1, l2, R[HP_MAXN], HP_NORM2, tsc, ss, xx, dd):
            return STATUS_DIVERGED
    # nothing can fail from here on: commit the observer state and the results
    if fresh:
        for r in range(n):
            R[_ix(oz + r)] = 0.0
    if act == LEARN and mode == INTEGRAL:
        z_filter_step(R, oz, T, txt, R[HP_LAM], dt, n)  # eq. 4.6
    if act == LEARN and rate > 0.0:
        beta = scale_beta(R, ons, rate, dt)
        if adc != 0.0:
            update_whiteness(R, ons, p, T, txt, x_next, io, T, txh1, n, beta)
        update_scales(R, ow, n, h, p, ons, T, txb, eps_ms, beta, HP_NORM2)
    for r in range(n):
        xh1 = T[_ix(txh1 + r)]
        R[_ix(oxh + r)] = xh1
        R[_ix(oxh1 + r)] = xh1
        R[_ix(oxt1 + r)] = x_next[_ix(io + r)] - xh1
        R[_ix(og + r)] = T[_ix(tg + r)]
        R[_ix(oe + r)] = T[_ix(te + r)]
    for c in range(p):
        R[_ix(oxb + c)] = T[_ix(txb + c)]
    R[oini] = 1.0
    R[HP_NSTEPS] += 1.0
    if act == LEARN:
        R[HP_NUPDATES] += 1.0
    return STATUS_OK


@njit(cache=True, inline="always")
def _sizes_ok(S, x, u, f, x_next, n, m, h):  # pragma: no cover - compiled
    """Input sizes fit the N rows, and the rows are state only or state plus scratch."""
    nn = S.shape[0]
    size = row_layout(n, m, h)[-1]
    return (x.shape[0] == nn * n and u.shape[0] == nn * m and f.shape[0] == nn * n
            and x_next.shape[0] == nn * n
            and (S.shape[1] == size or S.shape[1] == size + scratch_layout(n, m, h)[-1]))


@njit(cache=True, inline="always")
def _scratch_owner(S):  # pragma: no cover - compiled
    """Row 0's scratch columns if the rows have them (one identifier), else a new array.

    The caller passes ``raw()`` of it to the row code and must use it again afterwards, so
    that numba keeps it alive for the whole call.
    """
    n = int(S[0, HP_N])
    m = int(S[0, HP_M])
    h = int(S[0, HP_H])
    size = row_layout(n, m, h)[-1]
    if S.shape[1] > size:
        return S[0, size:]
    return np.empty(scratch_layout(n, m, h)[-1])


@njit(cache=True, inline="always")
def _observer_rows(S, T, x, u, f, x_next, lo, hi):  # pragma: no cover - compiled
    """Rows lo … hi−1 of :func:`observer_step` with scratch ``T``; returns the failures.

    Called with the owner-less views of :func:`~simgap.identifiers._raw.raw`, or, in a
    function compiled without numba's runtime, with the arguments themselves (neither
    counts references).
    """
    n = int(S[0, HP_N])
    m = int(S[0, HP_M])
    h = int(S[0, HP_H])
    nfail = 0
    for i in range(lo, hi):
        R = S[i]
        st = _observer_row(R, T, x, u, f, x_next, i, n, m, h)
        R[HP_STATUS] = st
        if st != STATUS_OK:
            nfail += 1
    return nfail


_OBS_SIG = int64(float64[:, ::1], float64[::1], float64[::1], float64[::1], float64[::1])


@_kernel(_OBS_SIG, cache=True, error_model="numpy")
def observer_step(S, x, u, f, x_next):  # pragma: no cover - compiled
    """Advance every row by one step of the observer-based identifiers (one thread).

    Returns the number of failed rows (their status says why), or −1 if the array sizes do
    not fit.
    """
    nn = S.shape[0]
    if nn == 0:
        return 0
    if not _sizes_ok(S, x, u, f, x_next, int(S[0, HP_N]), int(S[0, HP_M]), int(S[0, HP_H])):
        return -1
    owner = _scratch_owner(S)
    nfail = _observer_rows(raw(S), raw(owner), raw(x), raw(u), raw(f), raw(x_next), 0, nn)
    owner[0] = owner[0]  # keeps the scratch alive until here
    return nfail


_OBS1_SIG = int64(float64[:, ::1], float64[::1], float64[::1], float64[::1], float64[::1],
                  float64[::1])


@njit(cache=True, inline="always", error_model="numpy")
def _observer_single(S, x, u, f, x_next, g_out):  # pragma: no cover - compiled
    """Body of :func:`observer_step_single` and of its C-ABI twin (:func:`c_observer_step`)."""
    if S.shape[0] != 1 or S.shape[1] <= HP_SIZE:
        return -1
    n = int(S[0, HP_N])
    m = int(S[0, HP_M])
    h = int(S[0, HP_H])
    size = row_layout(n, m, h)[-1]
    if (S.shape[1] == size or g_out.shape[0] != n
            or not _sizes_ok(S, x, u, f, x_next, n, m, h)):
        return -1
    r = _observer_rows(S, S[0, size:], x, u, f, x_next, 0, 1)
    if r == 0:
        og = row_layout(n, m, h)[4]
        for k in range(n):
            g_out[k] = S[0, og + k]
    return r


@_kernel(_OBS1_SIG, runtime=False, cache=True, error_model="numpy")
def observer_step_single(S, x, u, f, x_next, g_out):  # pragma: no cover - compiled
    """:func:`observer_step` for one identifier whose row carries its scratch columns.

    The hot path of ``Identifier.step`` when the C caller is not built (same row code); also
    copies ĝ_k into ``g_out`` (n), the array the step returns. Returns 0, 1 (failed; the
    status says why; ``g_out`` untouched) or −1 (sizes do not fit, or no scratch columns).
    """
    return _observer_single(S, x, u, f, x_next, g_out)


_F8P = types.CPointer(float64)
#: C ABI of :func:`c_observer_step` (the C caller ``_call.c`` declares the same).
C_OBS1_SIG = int64(_F8P, int64, int64, _F8P, int64, _F8P, int64, _F8P, int64, _F8P, int64,
                   _F8P, int64)
_C_KERNELS: dict = {}


def _c_observer_step(sp, rows, cols, xp, nx, up, nu, fp, nf, xnp, nxn, gp,
                     ng):  # pragma: no cover - compiled by c_observer_step
    return _observer_single(carray(sp, (rows, cols)), carray(xp, nx), carray(up, nu),
                            carray(fp, nf), carray(xnp, nxn), carray(gp, ng))


def c_observer_step():
    """:func:`observer_step_single` as a C function (a numba ``cfunc``), built on first use.

    Signature :data:`C_OBS1_SIG`: (S, rows, cols, x, len, u, len, f, len, x_next, len, ĝ,
    len) with data pointers and lengths; same body, same result codes. Called by the C
    caller ``simgap.identifiers._call`` (see :mod:`~simgap.identifiers.fastcall`), which
    skips numba's dispatcher. Returns the numba ``CFunc`` (keep it alive while its
    ``address`` is in use; this module keeps it).
    """
    if "observer" not in _C_KERNELS:
        _C_KERNELS["observer"] = cfunc(C_OBS1_SIG, cache=True,
                                       error_model="numpy")(_c_observer_step)
    return _C_KERNELS["observer"]


#: Rows per thread task of :func:`observer_step_parallel`.
CHUNK = 64

#: The same row loop as a called (not inlined) function: keeps the threaded kernel's
#: compilation short.
_observer_rows_called = njit(cache=True, error_model="numpy")(_observer_rows.py_func)


@_kernel(_OBS_SIG, cache=True, error_model="numpy", parallel=True)
def observer_step_parallel(S, x, u, f, x_next):  # pragma: no cover - compiled
    """:func:`observer_step` with the rows split over numba's threads (same row code).

    Chunks of :data:`CHUNK` rows, each with its own scratch. Rows are independent, so the
    result is bit-identical to :func:`observer_step`.
    """
    nn = S.shape[0]
    if nn == 0:
        return 0
    if not _sizes_ok(S, x, u, f, x_next, int(S[0, HP_N]), int(S[0, HP_M]), int(S[0, HP_H])):
        return -1
    Sr, xr, ur, fr, xnr = raw(S), raw(x), raw(u), raw(f), raw(x_next)
    nchunk = (nn + CHUNK - 1) // CHUNK
    nfail = 0
    tsize = scratch_layout(int(S[0, HP_N]), int(S[0, HP_M]), int(S[0, HP_H]))[-1]
    for c in prange(nchunk):
        owner = np.empty(tsize)
        nfail += _observer_rows_called(Sr, raw(owner), xr, ur, fr, xnr, c * CHUNK,
                                       min(nn, (c + 1) * CHUNK))
        owner[0] = 0.0  # keeps the scratch alive until here
    return nfail


@njit(cache=True, inline="always")
def _minibatch_rows(S, T, x, u, f, x_next, buf, cnt, nn):  # pragma: no cover - compiled
    """Rows 0 … nn−1 of :func:`minibatch_step` with scratch ``T``: (failures, rows due)."""
    n = int(S[0, HP_N])
    m = int(S[0, HP_M])
    h = int(S[0, HP_H])
    p = n + m
    ow, oxh, oz, oini, og, oxb, oxh1, oxt1, oe, size = row_layout(n, m, h)
    ts = scratch_layout(n, m, h)[6]
    txn, ty = norm_scratch(n, m, h)
    ons = scale_block(n, m, h)
    nfail = 0
    ndue = 0
    for i in range(nn):
        R = S[i]
        act = R[HP_ACT]
        if act == SKIP:
            continue
        if not _inputs_ok(x, u, f, x_next, i, n, m):
            R[HP_STATUS] = STATUS_BAD_INPUT
            nfail += 1
            continue
        io = i * n
        dt = R[HP_DT]
        observe = R[HP_MODE] == MB_ESTIMATE
        fresh = R[oini] == 0.0
        for r in range(n):  # x̄_k = [x_k; u_k], or [x̂_k; u_k] on the observer's estimate
            R[_ix(oxb + r)] = R[_ix(oxh + r)] if observe and not fresh else x[_ix(io + r)]
        for c in range(m):
            R[_ix(oxb + n + c)] = u[_ix(i * m + c)]
        rate = R[HP_SRATE]
        if rate > 0.0:
            normalise_inputs(R, ons, p, R, oxb, T, txn)
            forward(R, ow, n, h, p, T, txn, T, ts, T, ty)
            scale_outputs(R, ons, n, p, T, ty, R, og)
        else:
            forward(R, ow, n, h, p, R, oxb, T, ts, R, og)
        if observe:  # x̂_{k+1} = x̂_k + Δt (f_k + ĝ_k − a_d (x_k − x̂_k))   (eq. 3.1)
            a_d = R[HP_AD]
            for r in range(n):
                xh = R[_ix(oxb + r)]
                T[_ix(ty + r)] = xh + dt * (f[_ix(io + r)] + R[_ix(og + r)]
                                            - a_d * (x[_ix(io + r)] - xh))
            if not _finite(T, ty, n):
                R[HP_STATUS] = STATUS_STATE_DIVERGED
                nfail += 1
                continue
            for r in range(n):
                R[_ix(oxh + r)] = T[_ix(ty + r)]
            R[oini] = 1.0
        for r in range(n):
            pred = x[_ix(io + r)] + dt * (f[_ix(io + r)] + R[_ix(og + r)])  # eq. 4.2
            R[_ix(oxh1 + r)] = pred
            R[_ix(oxt1 + r)] = x_next[_ix(io + r)] - pred
            R[_ix(oe + r)] = x_next[_ix(io + r)] - pred
        R[HP_STATUS] = STATUS_OK
        R[HP_NSTEPS] += 1.0
        if act == LEARN:
            if buffer_push(buf[i], cnt[i], R, oxb, x, f, x_next, io, dt, p, n,
                           int(R[HP_PERIOD])):
                ndue += 1
            if rate > 0.0:
                # residual sample ε_k = (x_{k+1} − x_k)/Δt − f_k (eq. 4.2's one-step residual)
                for r in range(n):
                    T[_ix(ty + r)] = ((x_next[_ix(io + r)] - x[_ix(io + r)]) / dt
                                      - f[_ix(io + r)])
                update_scales(R, ow, n, h, p, ons, R, oxb, mean_square(T, ty, n),
                              scale_beta(R, ons, rate, dt), HP_NORM2)
    return nfail, ndue


@njit(cache=True, inline="always")
def _minibatch_sizes_ok(S, x, u, f, x_next, buf, cnt):  # pragma: no cover - compiled
    n = int(S[0, HP_N])
    nn = S.shape[0]
    return (_sizes_ok(S, x, u, f, x_next, n, int(S[0, HP_M]), int(S[0, HP_H]))
            and buf.shape[0] == nn and buf.shape[2] == int(S[0, HP_M]) + 2 * n
            and cnt.shape[0] == nn)


_MB_SIG = types.UniTuple(int64, 2)(float64[:, ::1], float64[::1], float64[::1], float64[::1],
                                   float64[::1], float64[:, :, ::1], int64[:, ::1])


@_kernel(_MB_SIG, cache=True, error_model="numpy")
def minibatch_step(S, x, u, f, x_next, buf, cnt):  # pragma: no cover - compiled
    """Baseline 2, per-step part (eq. 4.2): ĝ_k = ĝ(x_k, u_k), x̂^pred_{k+1}, buffer push.

    Returns (failed rows or −1, rows whose SGD update is due).
    """
    nn = S.shape[0]
    if nn == 0:
        return 0, 0
    if not _minibatch_sizes_ok(S, x, u, f, x_next, buf, cnt):
        return -1, 0
    owner = _scratch_owner(S)
    res = _minibatch_rows(raw(S), raw(owner), raw(x), raw(u), raw(f), raw(x_next), raw(buf),
                          raw(cnt), nn)
    owner[0] = owner[0]  # keeps the scratch alive until here
    return res


@_kernel(_MB_SIG, runtime=False, cache=True, error_model="numpy")
def minibatch_step_single(S, x, u, f, x_next, buf, cnt):  # pragma: no cover - compiled
    """:func:`minibatch_step` for one identifier whose row carries its scratch columns."""
    size = row_layout(int(S[0, HP_N]), int(S[0, HP_M]), int(S[0, HP_H]))[-1]
    if (S.shape[0] != 1 or S.shape[1] == size
            or not _minibatch_sizes_ok(S, x, u, f, x_next, buf, cnt)):
        return -1, 0
    return _minibatch_rows(S, S[0, size:], x, u, f, x_next, buf, cnt, 1)


_SGD_SIG = int64(float64[:, ::1], float64[:, :, ::1], int64[:, ::1], int64[:, ::1],
                 int64[::1])


@_kernel(_SGD_SIG, cache=True, error_model="numpy")
def minibatch_sgd(S, buf, cnt, idx, rows):  # pragma: no cover - compiled
    """Baseline 2, burst part (eq. 4.3-4.4): one SGD step for each row in ``rows``.

    Row j of ``idx`` holds the buffer entries of ``rows[j]``. Clears the due flag.

    Returns the number of rows whose update would diverge (those keep their weights).
    """
    if S.shape[0] == 0:
        return 0
    n = int(S[0, HP_N])
    m = int(S[0, HP_M])
    h = int(S[0, HP_H])
    p = n + m
    ow = HP_SIZE
    tg, txb, txh1, te, txt, td, ts, ta, tgw, tsc, tsize = scratch_layout(n, m, h)
    txn, ty = norm_scratch(n, m, h)
    ons = scale_block(n, m, h)
    owner = _scratch_owner(S)
    T = raw(owner)
    S, buf, cnt, idx, rows = raw(S), raw(buf), raw(cnt), raw(idx), raw(rows)
    nfail = 0
    for j in range(rows.shape[0]):
        i = rows[j]
        R = S[i]
        cnt[i, DUE] = 0
        if cnt[i, FILLED] == 0:
            continue
        ok = sgd_step(R, ow, n, h, p, buf[i], idx[j], R[HP_DT], R[HP_ETA1], R[HP_ETA2],
                      R[HP_MAXN], HP_NORM2, T, ts, tg, td, tgw, tsc, R[HP_ESCALE],
                      ons if R[HP_SRATE] > 0.0 else -1, txn, ty)
        if ok:
            R[HP_NUPDATES] += 1.0
        else:
            R[HP_STATUS] = STATUS_DIVERGED
            nfail += 1
    owner[0] = owner[0]  # keeps the scratch alive until here
    return nfail


_PRED_SIG = types.void(float64[::1], int64, int64, int64, float64[:, ::1], float64[:, ::1])


@_kernel(_PRED_SIG, cache=True, error_model="numpy")
def predict_rows(R, n, m, h, xbar, res):  # pragma: no cover - compiled
    """ĝ for each row of ``xbar`` (K, p) with the weights of state row ``R`` (step's code)."""
    p = n + m
    s = np.empty(h)
    if R[HP_SRATE] > 0.0:
        ons = scale_block(n, m, h)
        t = np.empty(p + n)
        for k in range(xbar.shape[0]):
            normalise_inputs(R, ons, p, xbar[k], 0, t, 0)
            forward(R, HP_SIZE, n, h, p, t, 0, s, 0, t, p)
            scale_outputs(R, ons, n, p, t, p, res[k], 0)
        return
    for k in range(xbar.shape[0]):
        forward(R, HP_SIZE, n, h, p, xbar[k], 0, s, 0, res[k], 0)


guard_cache(globals())  # drop cached kernels when a module they compile in changes
