"""Running input and output scales of the network (the ``auto`` preset).

With ``scale_rate`` > 0 the network works in normalised units:

    ĝ = s · Ŵ tanh(V̂ (x̄ ⊘ r)),

r_c = √⟨x̄_c²⟩ the running RMS of input c (state and input units) and s = √⟨‖ε‖²/n⟩ the
running RMS of a residual sample ε (state units/s, one scalar for all rows): ε = ĝ_k − a_d x̃_k
for the observer laws (the quasi-static balance of the observer error, eq. 3.1: x̃ settles
where g − ĝ = −a_d x̃), ε = (x_{k+1} − x_k)/Δt − f_k for baseline 2 (the one-step residual
its cost J_mb is built from, eq. 4.2). ⟨·⟩ is the exponential mean

    m ← m + β (v² − m),   β = max(1/(k + 1), Δt · scale_rate)

(the plain mean of the first samples, then forgetting with time constant 1/scale_rate s).

Why the inputs: the step sizes of :func:`~simgap.identifiers.laws.normalised_rates` are
scale-free per layer, but inside a layer the raw units still decide who learns. A V̂ step is
b x̄ᵀ: an input of 20 m/s next to a steering angle of 0.02 rad gets a 10⁶ times larger share
of ‖x̄‖², so the small inputs never move the hidden layer, and LeCun-scaled weights on raw
inputs of tens of units saturate tanh, where (1 − σ²) ≈ 0 stops the hidden layer's gradient.
Dividing by r gives every input unit RMS (the LeCun initialisation is then right): a
diagonal preconditioner 1/r_c² on V̂ in raw units.

Why one output scale, not one per row: the normalised steps already move every row of ĝ by
the same fraction of its own error. A per-row s would only reweight the rows inside the
hidden layer's error b = (I − Λ) Ŵᵀ (δ ⊘ s), and rows whose true residual is zero (the arm's
q rows, dq/dt = M⁻¹p exactly) would have their numerical noise blown up to the weight of
the friction rows: measured on thesis Case 1 (seed 0), the last-part error went from 7 % to
29 % of |g|. The scalar s makes Ŵ of order one in any units, so the weight-norm bound
(``max_weight_norm``) means the same thing for every plant.

Output preservation (as "Pop-Art", van Hasselt et al. 2016): when s moves, Ŵ is rescaled by
s / s', so ĝ(x̄) is unchanged. The input scales are not preserved that way: that multiplies
column c of V̂ by r'_c / r_c, and an input that starts at rest (the bicycle's vy, r and
steering before the slalom fades in) has r growing by orders of magnitude, which drove the
hidden weights past the divergence bound on Case 2-2 (measured). Without it x̄ ⊘ r stays of
order one, and ĝ drifts only as fast as r does (time constant 1/scale_rate).

Step cap: a learning step uses s_eff = max(s, RMS of the current residual samples), so one
step never moves the normalised output by more than its normalised error even when s is
still the (small) mean of a plant at rest; otherwise the first excited step after a rest
period gives Ŵ entries of ε/s ≫ 1 (measured: divergence of every kind on Case 2-2).

An input with no data yet (m = 0) enters as 0. The statistics are updated after a step has
succeeded (nothing half-written on failure) and only while learning (frozen: held).

Cost: the square roots r_c = √m_c, s = √m_out and the noise gate's ρ⁺
(:func:`whiteness`) are taken where the statistics change (:func:`update_scales`,
:func:`update_whiteness`, at the end of a step) and stored next to them, so the next step's
forward pass reads them instead of starting with p + 1 square roots and a division: the
same values bit for bit, off the step's critical path (issue 14's cost bar,
``benchmarks/bench_auto_cost_vs_filing.py``).
"""

from __future__ import annotations

import math

from numba import njit
from numba import uint64 as _ix  # unsigned indices: no wrap-around check, loops vectorise


@njit(cache=True, inline="always")
def block_size(n, p):  # pragma: no cover - compiled (callable from Python too)
    """Entries of a row's scale block.

    k, m_in (p), m_out, ⟨‖x̃_k‖²⟩, ⟨x̃_{k+1}·x̃_k⟩, then the values derived from them for the
    next step: r = √m_in (p), s = √m_out and ρ⁺. k is the sample count; the two means after
    m_out are the statistics of :func:`whiteness`.
    """
    return 6 + 2 * p


@njit(cache=True, inline="always")
def _root_in(ons, p):  # pragma: no cover - compiled
    """Offset of r = √m_in (p entries) in the scale block at ``ons``."""
    return ons + 4 + p


@njit(cache=True, inline="always")
def _root_out(ons, p):  # pragma: no cover - compiled
    """Offset of s = √m_out in the scale block at ``ons``."""
    return ons + 4 + 2 * p


@njit(cache=True, inline="always", error_model="numpy")
def normalise_inputs(R, ons, p, xb, oxb, out, oout):  # pragma: no cover - compiled
    """x̄ ⊘ r into ``out[oout:]`` (0 where the input has no data yet, m_c = 0, r_c = 0)."""
    orr = _root_in(ons, p)
    for c in range(p):
        rc = R[_ix(orr + c)]
        out[_ix(oout + c)] = xb[_ix(oxb + c)] / rc if rc > 0.0 else 0.0


@njit(cache=True, inline="always")
def output_scale(R, ons, p):  # pragma: no cover - compiled
    """The output scale s = √m_out (0 before the first nonzero residual sample; stored)."""
    return R[_ix(_root_out(ons, p))]


@njit(cache=True, inline="always")
def scale_outputs(R, ons, n, p, y, oy, g, og):  # pragma: no cover - compiled
    """ĝ = s · y (``g[og:]`` from the network output ``y[oy:]``)."""
    s = output_scale(R, ons, p)
    for r in range(n):
        g[_ix(og + r)] = s * y[_ix(oy + r)]


@njit(cache=True, inline="always")
def mean_square(a, oa, k):  # pragma: no cover - compiled
    """Σ a_i² / k over ``a[oa : oa + k]`` (the squared RMS of a residual sample)."""
    acc = 0.0
    for i in range(k):
        v = a[_ix(oa + i)]
        acc += v * v
    return acc / k


@njit(cache=True, inline="always", error_model="numpy")
def delta_factor(R, ons, p, sample_ms):  # pragma: no cover - compiled
    """1 / s_eff, s_eff = max(s, √``sample_ms``): δ in normalised output units (0 if 0).

    Taken as 1/√max(s², ``sample_ms``): one square root and one division.
    """
    s2 = max(R[_ix(ons + 1 + p)], sample_ms)
    return 1.0 / math.sqrt(s2) if s2 > 0.0 else 0.0


@njit(cache=True, inline="always", error_model="numpy")
def scale_beta(R, ons, rate, dt):  # pragma: no cover - compiled
    """β = max(1/(k + 1), min(1, Δt · scale_rate)) of the running means (k = sample count)."""
    return max(1.0 / (R[ons] + 1.0), min(1.0, rate * dt))


@njit(cache=True, inline="always", error_model="numpy")
def update_scales(R, ow, n, h, p, ons, xb, oxb, e2, beta,
                  onorm):  # pragma: no cover - compiled
    """One step of the running statistics and the output-preserving rescale of Ŵ.

    ``xb[oxb:]`` holds the raw x̄_k (p), ``e2`` is the mean square of the residual sample
    ε_k (:func:`mean_square` over its n rows; the caller has it already for
    :func:`delta_factor`), ``beta`` the step of the means (:func:`scale_beta`). The
    squared norm ‖Ŵ‖² at ``R[onorm]`` follows the rescale (V̂ is not touched). The roots
    r = √m_in and s = √m_out the next step reads are stored too.
    """
    om = ons + 1
    orr = _root_in(ons, p)
    for c in range(p):
        old = R[_ix(om + c)]
        v = xb[_ix(oxb + c)]
        mc = old + beta * (v * v - old)
        R[_ix(om + c)] = mc
        R[_ix(orr + c)] = math.sqrt(mc)
    oo = om + p
    old = R[oo]
    new = old + beta * (e2 - old)
    R[oo] = new
    R[_ix(_root_out(ons, p))] = math.sqrt(new)
    if old > 0.0 and new > 0.0 and old != new:
        f = math.sqrt(old / new)
        for j in range(n * h):
            R[_ix(ow + j)] *= f
        R[onorm] *= f * f
    R[ons] += 1.0


@njit(cache=True, inline="always", error_model="numpy")
def whiteness(R, ons, p):  # pragma: no cover - compiled
    """ρ⁺ = clip(⟨x̃_{k+1}·x̃_k⟩ / ⟨‖x̃_k‖²⟩, 0, 1): the observer error's smooth share.

    The lag-1 autocorrelation of x̃. x̃ = x − x̂ is the sum of a smooth part, the observer's
    response to the residual error (x̃ ≈ (g − ĝ)/|a_d|, eq. 3.5, correlated from step to
    step), and the white sensor noise of the measured x (uncorrelated from step to step).
    With S and N their powers, ⟨x̃_{k+1}·x̃_k⟩ ≈ S and ⟨‖x̃_k‖²⟩ = S + N, so ρ⁺ ≈ S / (S + N),
    the Wiener gain of the error signal: 1 on clean data, 0 where noise dominates x̃.
    Measured (``auto`` integral law, seed 0): 0.985-0.999 on thesis Case 1, the sines,
    Cases 2-1 and 2-2; −0.05 to −0.03 on Case 1 with sensor noise k = 10 and 50. 0 before
    the first sample. Computed from the statistics; the step reads the value
    :func:`update_whiteness` stored (:func:`stored_whiteness`, the same number).
    """
    m0 = R[_ix(ons + 2 + p)]
    m1 = R[_ix(ons + 3 + p)]
    if not m0 > 0.0:
        return 0.0
    return min(max(m1 / m0, 0.0), 1.0)


@njit(cache=True, inline="always")
def stored_whiteness(R, ons, p):  # pragma: no cover - compiled
    """ρ⁺ of :func:`whiteness` as :func:`update_whiteness` stored it (0 before any sample)."""
    return R[_ix(_root_out(ons, p) + 1)]


@njit(cache=True, inline="always")
def gated(v, v_clean, w):  # pragma: no cover - compiled (also called as .py_func)
    """Return v + ρ⁺ (v_clean − v): a gated rate (a_d, η1, η2, c_e) at smooth share ``w`` = ρ⁺."""
    return v + w * (v_clean - v)


@njit(cache=True, inline="always")
def update_whiteness(R, ons, p, xt, oxt, xn, oxn, xh1, oxh1, n,
                     beta):  # pragma: no cover - compiled
    """One step of the statistics of :func:`whiteness` (call before :func:`update_scales`).

    ``xt[oxt:]`` holds x̃_k; x̃_{k+1} = x_{k+1} − x̂_{k+1} from ``xn[oxn:]`` and
    ``xh1[oxh1:]`` (n each); the same exponential mean (``beta``, :func:`scale_beta`) and
    sample count as the scales. Stores the new ρ⁺ (:func:`stored_whiteness`).
    """
    o0 = ons + 2 + p
    a0 = 0.0
    a1 = 0.0
    for r in range(n):
        v = xt[_ix(oxt + r)]
        a0 += v * v
        a1 += v * (xn[_ix(oxn + r)] - xh1[_ix(oxh1 + r)])
    R[_ix(o0)] = R[_ix(o0)] + beta * (a0 - R[_ix(o0)])
    R[_ix(o0 + 1)] = R[_ix(o0 + 1)] + beta * (a1 - R[_ix(o0 + 1)])
    R[_ix(_root_out(ons, p) + 1)] = whiteness(R, ons, p)
