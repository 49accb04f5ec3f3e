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
:mod:`simgap.identifiers.network`, addressed by offsets into one float64 row ``R`` per
identifier; they are inlined into :mod:`simgap.identifiers.kernels`.
"""

from __future__ import annotations

from dataclasses import dataclass

from numba import njit
from numba import uint64 as _ix  # unsigned indices: no wrap-around check, loops vectorise

from simgap.identifiers.network import mat_t_vec
from simgap.models.nbcache import guard_cache


@dataclass(frozen=True, kw_only=True)
class Law:
    """Declaration of one error signal (one identifier kind).

    Attributes:
        code: integer code of the error signal inside the numba kernels (``HP_MODE``).
        uses_observer: True if the law runs the observer x̂ (eq. 3.1) and learns per step
            (baseline 2 runs x̂ too when it learns on it, ``minibatch_input="estimate"``,
            with the ``a_d`` of the observer laws).
        uses_buffer: True if the law keeps a sliding-window buffer (baseline 2).
        hyper: the :class:`~simgap.identifiers.IdentifierConfig` fields only this law (or
            this family of laws) reads, besides the shared network sizes, η1, η2 and the
            divergence bound.
        column: position in the thesis' tables (Table 4.1: baseline 1, baseline 2,
            proposed), the order every evaluation table uses.
        label: the name in tables and figures.
        short: the short name in table headers.
        equation: the thesis equations that define the error signal.
    """

    code: int
    uses_observer: bool
    uses_buffer: bool
    hyper: tuple[str, ...]
    column: int
    label: str
    short: str
    equation: str


#: The one table of error signals: kind name → :class:`Law` (in kernel-code order). Every
#: other list of kinds (``KINDS``, ``KIND_CODES``, the evaluation tables' ``METHODS``) is
#: derived from it.
LAWS: dict[str, Law] = {
    "instantaneous": Law(code=0, uses_observer=True, uses_buffer=False,
                         hyper=("a_d", "rho1", "rho2", "a_d_clean", "eta1_clean",
                                "eta2_clean"), column=0,
                         label="Baseline 1 (instantaneous)", short="B1", equation="3.8"),
    "integral": Law(code=1, uses_observer=True, uses_buffer=False,
                    hyper=("a_d", "rho1", "rho2", "lam", "a_d_clean", "eta1_clean",
                           "eta2_clean"), column=2,
                    label="Proposed (integral)", short="Proposed", equation="3.9, 4.6"),
    "minibatch": Law(code=2, uses_observer=False, uses_buffer=True,
                     hyper=("buffer_size", "batch_size", "update_period", "minibatch_input"),
                     column=1,
                     label="Baseline 2 (mini-batch)", short="B2", equation="4.2-4.4"),
}

#: Error-signal codes as compile-time constants of the kernels.
INSTANTANEOUS = LAWS["instantaneous"].code
INTEGRAL = LAWS["integral"].code
MINIBATCH = LAWS["minibatch"].code


@njit(cache=True, inline="always")
def scratch_size(n, h, p):  # pragma: no cover - compiled (callable from Python too)
    """Entries of the update scratch block: b and two accumulators (n_h each), a backup."""
    return 3 * h + n * h + h * p


@njit(cache=True, inline="always")
def observer_error(mode, xt, oxt, z, oz, e, oe, n):  # pragma: no cover - compiled
    """Error signal ∂J/∂x̃ᵀ: e = x̃ (eq. 3.8, mode 0) or e = z (eq. 3.9, mode 1)."""
    if mode == INTEGRAL:
        for r in range(n):
            e[_ix(oe + r)] = z[_ix(oz + r)]
    else:
        for r in range(n):
            e[_ix(oe + r)] = xt[_ix(oxt + r)]


@njit(cache=True, inline="always")
def z_filter_step(z, oz, xt, oxt, lam, dt, n):  # pragma: no cover - compiled
    """Integral error state (eq. 4.6), in place: z_{k+1} = z_k + Δt(−λ z_k + x̃_k)."""
    for r in range(n):
        zr = z[_ix(oz + r)]
        z[_ix(oz + r)] = zr + dt * (-lam * zr + xt[_ix(oxt + r)])


@njit(cache=True, inline="always", error_model="numpy")
def observer_delta(T, oe, a_d, od, n):  # pragma: no cover - compiled
    """δ = (eᵀ A_d⁻¹)ᵀ for A_d = a_d·I (the static approximation, eq. 3.5)."""
    inv = 1.0 / a_d
    for r in range(n):
        T[_ix(od + r)] = T[_ix(oe + r)] * inv


@njit(cache=True, inline="always")
def _hidden_error(R, ow, n, h, T, od, os, ob):  # pragma: no cover - compiled
    """Hidden-layer error b = (I − Λ) Ŵᵀ δ into ``T[ob : ob + n_h]``.

    Ŵ at ``R[ow:]``, δ at ``T[od:]``, σ at ``T[os:]``; vectorised over the hidden units.
    """
    mat_t_vec(R, ow, n, h, T, od, T, ob)  # Ŵᵀ δ
    for j in range(h):
        sj = T[_ix(os + j)]
        T[_ix(ob + j)] *= 1.0 - sj * sj


@njit(cache=True, inline="always")
def dot(a, oa, b, ob, k):  # pragma: no cover - compiled
    """Σ_i a[oa + i] · b[ob + i] over k entries."""
    acc = 0.0
    for i in range(k):
        acc += a[_ix(oa + i)] * b[_ix(ob + i)]
    return acc


@njit(cache=True, inline="always")
def column_norms2(R, ow, n, h, T, oc):  # pragma: no cover - compiled
    """c_j = Σ_r Ŵ_rj² (the squared column norms of Ŵ) into ``T[oc : oc + n_h]``.

    Ŵ at ``R[ow:]`` (row-major n × n_h); summed over r in order, vectorised over j. Ŵ is
    fixed during a baseline-2 mini-batch, so it is computed once per batch there.
    """
    for j in range(h):
        T[_ix(oc + j)] = 0.0
    for r in range(n):
        base = ow + r * h
        for j in range(h):
            w = R[_ix(base + j)]
            T[_ix(oc + j)] += w * w


@njit(cache=True, inline="always")
def jacobian_norm2(T, oc, os, h):  # pragma: no cover - compiled
    """‖Ŵ D‖_F² = Σ_j (1 − σ_j²)² c_j, D = I − Λ: the hidden layer's gain.

    c_j = Σ_r Ŵ_rj² at ``T[oc:]`` (:func:`column_norms2`), σ at ``T[os:]``. ‖Ŵ D‖_F² ‖x̄‖²
    bounds the largest eigenvalue of J_V J_Vᵀ = ‖x̄‖² Ŵ D² Ŵᵀ (J_V = ∂ĝ/∂V̂), the output
    move of a unit V̂ step. Column norms first: the n·n_h products vectorise, and the serial
    sum has n_h terms instead of n·n_h (one ≈ 4-cycle add each; measured ≈ 0.1 µs per step
    saved on the arm, ``benchmarks/bench_identifiers.py --scales-only``).
    """
    acc = 0.0
    for j in range(h):
        sj = T[_ix(os + j)]
        d = 1.0 - sj * sj
        acc += d * d * T[_ix(oc + j)]
    return acc


@njit(cache=True, inline="always")
def bound_error2(mode, dd, T, oxt, n, f):  # pragma: no cover - compiled
    """‖δ‖² for the step bound of :func:`normalised_rates`, observer laws.

    Baseline 1: ``dd`` = ‖δ‖². Integral law: max(‖δ‖², f² ‖x̃‖²) with x̃ at
    ``T[oxt:]`` and f = 1/(a_d λ) (times 1/s_eff with running scales), so that
    c_e² f² ‖x̃‖² = a_d² ‖x̃‖²: the size of the instantaneous error, in the units of
    c_e²‖δ‖² = λ² a_d² ‖z‖² (which z ≈ x̃/λ makes equal to it on a smooth error).

    Why: the integral law's δ = z/a_d averages x̃ over 1/λ, so sensor noise, which sits in
    x̃ (x̃ = x̂ − x, the measured x), leaves δ small and the bound ‖δ‖² alone would let the
    hidden layer take full steps along noise-driven directions. Bounding by the larger of the
    averaged and the instantaneous error slows V̂ exactly on the samples whose error
    disagrees with its own short-time average (noise), and changes nothing where x̃ is
    smooth. Measured (``auto`` preset, seeds 0-2): Case 1 with noise k = 50 consistency
    0.134/0.148/0.172 → 0.102/0.126/0.120 N·m; clean sines and Case 1 unchanged to the
    third digit.
    """
    if mode == INTEGRAL:
        return max(dd, dot(T, oxt, T, oxt, n) * f * f)
    return dd


@njit(cache=True, inline="always")
def normalised_rates(k1, k2, ss, xx, dd, ww, ce):  # pragma: no cover - compiled
    """Bound-normalised step sizes of the unified law (the ``auto`` preset).

        k1' = k1 / (1 + ‖σ‖²),    k2' = k2 / (‖x̄‖² (‖Ŵ D‖_F² + c_e² ‖δ‖²)),   D = I − Λ

    Why: one Ŵ step moves ĝ by −k1' ‖σ‖² δ and one V̂ step by −k2' Ŵ D² Ŵᵀ δ ‖x̄‖², whose
    norm is at most k2' ‖x̄‖² ‖Ŵ D‖_F² ‖δ‖ (:func:`jacobian_norm2`). With δ = ε / c_e, ε
    the residual error in state units/s (c_e = a_d² for baseline 1, λ a_d² for the integral
    law, 1/Δt² for baseline 2), both moves are then at most k_i / c_e of ε per step,
    whatever the scales of x̄ (input units) and ĝ (state units/s): the normalised LMS step
    in each layer. The bound uses ‖Ŵ D‖_F², not ‖Ŵ‖_F²: saturated units (D ≈ 0) already
    carry no gradient, and a bound that ignored D would shrink the hidden layer's step a
    second time. ‖Ŵ D‖² + c_e²‖δ‖² > 0 whenever there is an error to learn from, so the V̂
    step stays bounded while Ŵ is still ≈ 0 (its weight change is at most
    k2 / (2 c_e ‖x̄‖) however small ‖Ŵ D‖ is). Returns (k1', k2'); k2' = 0 when x̄ = 0 and
    δ = 0 (nothing to learn).

    Args:
        k1: plain step size of Ŵ (Δt η1 for the observer laws, η1 for baseline 2).
        k2: plain step size of V̂ (Δt η2, η2).
        ss: ‖σ‖².
        xx: ‖x̄‖².
        dd: ‖δ‖².
        ww: ‖Ŵ D‖_F² (:func:`jacobian_norm2`; baseline 2: its batch mean).
        ce: c_e (> 0).
    """
    den = xx * (ww + ce * ce * dd)
    k2n = k2 / den if den > 0.0 else 0.0
    return k1 / (1.0 + ss), k2n


@njit(cache=True, inline="always")
def unified_update(R, ow, n, h, p, T, od, os, oa, og, xb, oxb, k1, k2, l1, l2, max_norm, onorm,
                   osc, ss, xx, dd):  # pragma: no cover - compiled
    """Take one Euler step of the unified law, eq. 3.6-3.7, for the output-space error δ.

        Ŵ ← (1 − l1) Ŵ − k1 δ σᵀ,     V̂ ← (1 − l2) V̂ − k2 ((I − Λ) Ŵᵀ δ) x̄ᵀ

    with the old Ŵ inside the V̂ term. Observer laws: δ = A_d⁻ᵀ e, k_i = Δt η_i,
    l_i = Δt ρ_i ‖x̃‖. Weights at ``R[ow:]`` (layout in :mod:`~simgap.identifiers.network`),
    their squared Frobenius norms ‖Ŵ‖², ‖V̂‖² at ``R[onorm]``, ``R[onorm + 1]``; in ``T``: δ
    at ``od``, σ at ``os``, the pre-activations a = V̂ x̄ at ``oa``, ĝ = Ŵ σ at ``og``, and
    ``scratch_size`` entries of scratch at ``osc``; x̄ at ``xb[oxb:]``; ``ss`` = ‖σ‖²,
    ``xx`` = ‖x̄‖², ``dd`` = ‖δ‖² (:func:`dot` of each, computed once by the caller, which
    needs them for :func:`normalised_rates` too).

    The divergence check needs the norms after the step before anything is written. They
    follow from the rank-one form of the step without a pass over the weights:

        ‖Ŵ'‖² = (1 − l1)² ‖Ŵ‖² − 2 (1 − l1) k1 δᵀĝ + k1² ‖δ‖² ‖σ‖²
        ‖V̂'‖² = (1 − l2)² ‖V̂‖² − 2 (1 − l2) k2 bᵀa + k2² ‖b‖² ‖x̄‖²,   b = (I − Λ) Ŵᵀ δ.

    If √(‖Ŵ'‖² + ‖V̂'‖²) is finite and ≤ ``max_norm`` the weights and norms are updated and
    True returned; otherwise nothing is written. (The tracked norms drift from the exact ones
    by rounding only, ~1e-16 relative per step; they serve this bound and nothing else, and
    are recomputed exactly at every baseline-2 step and at reset.)
    """
    ob = osc
    _hidden_error(R, ow, n, h, T, od, os, ob)
    c1 = 1.0 - l1
    c2 = 1.0 - l2
    wn2 = (c1 * c1 * R[onorm] - 2.0 * c1 * k1 * dot(T, od, T, og, n)
           + k1 * k1 * dd * ss)
    vn2 = (c2 * c2 * R[onorm + 1] - 2.0 * c2 * k2 * dot(T, ob, T, oa, h)
           + k2 * k2 * dot(T, ob, T, ob, h) * xx)
    if not wn2 + vn2 <= max_norm * max_norm:  # also catches NaN and inf
        return False
    nw = n * h
    ov = ow + nw
    for c in range(p):  # V̂ᵀ row c: hidden units contiguous
        kx = k2 * xb[_ix(oxb + c)]
        base = ov + c * h
        for j in range(h):
            R[_ix(base + j)] = c2 * R[_ix(base + j)] - kx * T[_ix(ob + j)]
    for r in range(n):
        kd = k1 * T[_ix(od + r)]
        base = ow + r * h
        for j in range(h):
            R[_ix(base + j)] = c1 * R[_ix(base + j)] - kd * T[_ix(os + j)]
    R[onorm] = max(wn2, 0.0)
    R[onorm + 1] = max(vn2, 0.0)
    return True


@njit(cache=True, inline="always")
def backprop(R, ow, n, h, p, T, od, os, xb, oxb, ogw, osc):  # pragma: no cover - compiled
    """G_W += δ σᵀ and G_V += ((I − Λ) Ŵᵀ δ) x̄ᵀ (eq. 3.5-3.7), in the weights' layout.

    ``T[ogw:]`` accumulates G_W (n × n_h) then G_Vᵀ (p × n_h); ``T[osc:]`` is scratch
    (b uses its first n_h entries).
    """
    _hidden_error(R, ow, n, h, T, od, os, osc)
    _add_outer(T, ogw + n * h, p, h, xb, oxb, T, osc)  # G_Vᵀ += x̄ bᵀ
    _add_outer(T, ogw, n, h, T, od, T, os)  # G_W += δ σᵀ


@njit(cache=True, inline="always")
def _add_outer(G, og, rows, h, v, ov, w, ow):  # pragma: no cover - compiled
    """G += v wᵀ for the row-major (rows × h) block ``G[og:]`` (vectorised over h)."""
    for r in range(rows):
        vr = v[_ix(ov + r)]
        base = og + r * h
        for j in range(h):
            G[_ix(base + j)] += vr * w[_ix(ow + j)]


@njit(cache=True, inline="always")
def apply_gradients(R, ow, n, h, p, T, ogw, k1, k2, max_norm, onorm,
                    osc):  # pragma: no cover - compiled
    """Ŵ ← Ŵ − k1 G_W, V̂ ← V̂ − k2 G_V (eq. 4.4); undone exactly if it would diverge.

    ``T[ogw:]`` holds G_W then G_Vᵀ (same layout as the weights); ``T[osc:]`` is scratch
    of :func:`scratch_size` entries. On success the exact squared norms ‖Ŵ‖², ‖V̂‖² are
    stored at ``R[onorm]``, ``R[onorm + 1]``. Returns True if the new weights were kept.
    """
    accw = osc + h
    accv = accw + h
    obk = accv + h
    for j in range(h):
        T[_ix(accw + j)] = 0.0
        T[_ix(accv + j)] = 0.0
    for r in range(n + p):
        k = k1 if r < n else k2
        acc = accw if r < n else accv
        base = ow + r * h
        gb = ogw + r * h
        bb = obk + r * h
        for j in range(h):
            old = R[_ix(base + j)]
            T[_ix(bb + j)] = old
            w = old - k * T[_ix(gb + j)]
            R[_ix(base + j)] = w
            T[_ix(acc + j)] += w * w
    wn2 = 0.0
    vn2 = 0.0
    for j in range(h):
        wn2 += T[_ix(accw + j)]
        vn2 += T[_ix(accv + j)]
    if wn2 + vn2 <= max_norm * max_norm:  # False for NaN
        R[onorm] = wn2
        R[onorm + 1] = vn2
        return True
    for k in range((n + p) * h):
        R[_ix(ow + k)] = T[_ix(obk + k)]
    return False


guard_cache(globals())  # drop cached kernels when a module they compile in changes
