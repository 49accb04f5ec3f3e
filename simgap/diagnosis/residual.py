"""Step 1 of the diagnosis: grid, error model, filters, the residual's noise floor.

The residual of a recording against a nominal model is computed in physical units by the
system adapter (:mod:`simgap.diagnosis.systems`): joint torque (N·m) for mechanical models,
axle lateral force (N) by Delta = K⁻¹(dx/dt − f) for the bicycle. This module supplies what
every adapter shares:

* **gaps and grid**: a time step longer than ``GAP_STEPS`` median steps is a gap (a logger
  pause). The recording is split there into segments (:func:`segmented_grid`); nothing is
  interpolated across a gap. Inside a segment, time stamps that vary by more than 1 % are
  linearly interpolated onto a grid at the median step, unless the data say the samples
  were taken at a fixed rate and only the stamps jitter (each sample is then better
  predicted from its neighbours at the regular instants than at the stamps): then the
  samples are kept and put on those instants (:func:`regular_slots`). Every
  filter runs per segment; rows less than a window from a segment's end are not fitted
  (``valid``), and the per-row segment id is exposed so that selection and validation can
  split per segment.
* **error model per column** (:mod:`simgap.diagnosis.errormodel`): white noise from the
  least signal-biased k-th difference (robust at 100 Hz, where the third difference of a
  smooth signal leaks signal into the estimate), quantisation (floor q/√12, so a staircase
  never has zero noise), heavy tails (a velocity column denoised upstream or a finite
  difference of a quantised angle is flagged; the mechanical adapter then differentiates the
  angle instead and says so in one line). A column with no measurable noise is reported.
* **two filters** (why two, see below): a short cubic Savitzky–Golay filter
  (:class:`Smoother`, scipy.signal.savgol_filter) and one smooth kernel with its exact
  derivatives (:class:`KernelFilter`). Each window is the shortest whose output noise (the
  column's error std times the filter's gain, :func:`choose_window`) stays below 2 % of the
  estimated quantity's RMS, between 5 samples and 0.15 s. The column noise comes from
  k-th differences, which see only the white part of a coloured error; the mechanical
  adapter then compares the residual's upper pass band with the propagated floor's and,
  when it holds more than twice the error, re-chooses the equation's window for the error
  it shows (up to 0.25 s; :meth:`MechanicalSystem._error_excess`).
* the residual's **noise floor** per channel, by propagation: the residual is recomputed with
  an extra white noise of each column's error std (quantisation included) and the RMS of the
  change is the floor (a seeded generator makes it reproducible); and the residual's
  **effective sample count** per channel (N/τ, τ the integrated autocorrelation time).

**No unmodelled smoothing bias (issue 13).** Filtering signals and then evaluating a
nonlinear model on them, M(S q)·S''q + bias(S q, S'q), is not the filtered equation: the
difference (a few % of the inertial and gravity torque with a 0.15 s window) is a smoothing
bias that the fit then names as a gravity mismatch or a spring. The mechanical adapter
instead filters the *whole equation* with one kernel K, in a form without a second
derivative (the modulating-function method of system identification): with momentum
p = M(q) q̇, M(q) q̈ = ṗ − Ṁq̇, and K*ṗ = K'*p for a kernel that vanishes with its first
derivatives at the window's ends, so

    K*[τ − M q̈ − bias] = K*[τ − bias(q, q̇) + Ṁ(q, q̇) q̇] − K'*[M(q) q̇],

exactly, with q, q̇ evaluated sample by sample. The kernel is k(τ) ∝ (1 + b·s²)(1 − s²)^6, s = τ/T, a
fourth-order kernel with a flat passband like the cubic Savitzky–Golay filter's
(:func:`kernel_weights`); the fit filters every effect regressor with the same K
(``system.smoother``), so the residual and the regressors are the same linear functional of
the same equation. q and q̇ inside the nonlinear terms come from the short Savitzky–Golay
filter (a smoothing, not a second derivative: its window keeps the *velocity* noise below
2 %, a few samples, and its bias (ω·T)⁴ is negligible); q̇ is the recorded velocity when it
is trustworthy, else the filter's derivative of q. This was chosen over an output-error
(simulation) fit because it keeps the linear-in-parameters fit and every effect as it is,
and costs one more mass-matrix evaluation per sample (Ṁq̇ by a central difference of M
along q̇). Remaining inconsistency: mass-type effects (payload) are filtered as
K*[ΔM]·(K'*q̇) rather than K*[ΔM q̈], a second-order term. When the mass matrix is constant
along the recording (a prismatic axis such as EMPS), M·q̈ is linear in q and the
Savitzky–Golay signals are used as before (the kernel there changed nothing physical but
tipped the EMPS selection between an offset and an aliased spring, a gate of the selection).
**Interval form (exact for a held input).** A logged command is held over each sample
interval (zero-order hold), so q̇ has a kink at every sample and the point form above
(K' on the sampled momentum, the input as the mean of the two samples around an instant)
is off by (ω·Δt)²/6 of the input at frequency ω: 2.6e-4 N·m on a noise-free arm log, named
as extra inertia at both joints at low noise and as spurious delays and a Stribeck term on a
3600 s log. The arm's equation is therefore integrated over the two sample intervals around
each sample first (``KernelFilter(interval=True)``): the momentum's exact mean rate
(p_{k+1} − p_{k−1})/(2Δt), the held input's exact mean (u_{k−1} + u_k)/2, and the state
terms' trapezoid mean (¼, ½, ¼) (exact where they are linear on each interval, their kinks
at the samples included), then K. Every effect regressor goes through the same mean and
K; an input delay, a change of the held input, through K alone.
The bicycle's equation has only first derivatives and stays on the Savitzky–Golay filter.
For now only the built-in two-link arm uses the momentum form: on MuJoCo models it named
the armature as an inertia mismatch (the model's M(q) and its inverse dynamics disagree
there), so user and MuJoCo models keep the Savitzky–Golay route and main's third-difference
noise estimate (gaps are split for them too) until they are re-validated.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.ndimage import convolve1d
from scipy.signal import savgol_coeffs, savgol_filter

from simgap.diagnosis.errormodel import ColumnErrorModel, column_error_model, effective_samples

POLYORDER = 3
MIN_WINDOW = 5
MAX_WINDOW_S = 0.15
NOISE_RATIO = 0.02
UNIFORM_TOL = 0.01
#: A time step longer than this many median steps is a gap (a logger pause), not jitter.
GAP_STEPS = 3.0
#: Power P of the smoothing kernel (1 − (τ/T)²)^P: k and its first P − 1 derivatives vanish
#: at the window's ends, so K*ẋ = K'*x holds to the sampling's quadrature accuracy.
KERNEL_POWER = 6
#: Segments (between gaps) with fewer samples than this are too short to filter.
MIN_SEGMENT = 40


def noise_std(x: np.ndarray) -> float:
    """Robust white-noise std of a sampled signal from its third differences (signal units)."""
    d3 = np.diff(np.asarray(x, dtype=np.float64), n=3)
    if d3.size == 0:
        return 0.0
    mad = np.median(np.abs(d3 - np.median(d3)))
    return float(1.4826 * mad / np.sqrt(20.0))


def find_gaps(t: np.ndarray) -> np.ndarray:
    """Indices i where ``t[i+1] - t[i]`` is a gap: more than ``GAP_STEPS`` median steps.

    A logger pause is a time step many times the usual one; timestamp jitter (steps within
    a few tens of % of the median) is not a gap.
    """
    dt = np.diff(np.asarray(t, dtype=np.float64))
    if dt.size == 0:
        return np.zeros(0, dtype=int)
    return np.flatnonzero(dt > GAP_STEPS * float(np.median(dt)))


def uniform_grid(t: np.ndarray, columns: Mapping[str, np.ndarray]
                 ) -> tuple[np.ndarray, dict[str, np.ndarray], bool]:
    """Put columns on a uniform time grid (s) if ``t`` is not uniform within 1 %.

    For one gap-free stretch of samples; :func:`segmented_grid` splits at gaps first.

    Returns:
        (t_uniform, columns_uniform, resampled?). Interpolation is linear (numpy.interp).
    """
    dt = np.diff(t)
    step = float(np.median(dt))
    return _uniform(t, columns, step)[:3]


def _uniform(t: np.ndarray, columns: Mapping[str, np.ndarray], step: float
             ) -> tuple[np.ndarray, dict[str, np.ndarray], bool, float | None]:
    """One gap-free stretch on a uniform grid.

    Returns:
        (times, columns, resampled?, step of the regular slots when the stamps were
        replaced by them (:func:`regular_slots`), else None).
    """
    dt = np.diff(t)
    if dt.size == 0 or np.max(np.abs(dt - step)) <= UNIFORM_TOL * step:
        return t, dict(columns), False, None
    slots = regular_slots(t, step)
    if slots is not None and _stamps_jitter(t, slots, columns):
        return slots, dict(columns), True, float(slots[1] - slots[0])
    n = int(np.floor((t[-1] - t[0]) / step + 1e-9)) + 1
    tu = t[0] + step * np.arange(n)
    return tu, {k: np.interp(tu, t, v) for k, v in columns.items()}, True, None


def regular_slots(t: np.ndarray, step: float) -> np.ndarray | None:
    """The uniform instants t₀ + k·h the stamps jitter around, or None.

    t₀ and h are the least-squares line through the stamps (the median step ``step`` is not
    precise enough: over 10⁴ samples its error adds up to many steps); None when h is off
    ``step`` by more than :data:`UNIFORM_TOL` or some stamp is half a step or more from its
    own slot (samples are missing or the rate drifts: the stamps are then the only timing
    there is). Each sample keeps its row, only its time changes.
    """
    k = np.arange(t.size, dtype=np.float64)
    h, t0 = np.polyfit(k, t, 1)
    slots = t0 + h * k
    if abs(h - step) > UNIFORM_TOL * step or np.max(np.abs(t - slots)) >= 0.5 * h:
        return None
    return slots


def _prediction_error(tau: np.ndarray, x: np.ndarray) -> float:
    """RMS error of predicting each sample from two neighbours on each side (column units).

    Cubic Lagrange interpolation at the sample's own time ``tau`` (s).
    """
    n = x.size
    if n < 9:
        return 0.0
    centre = tau[2:n - 2]
    idx = np.arange(2, n - 2)[:, None] + np.array([-2, -1, 1, 2])[None, :]
    nodes = tau[idx]
    w = np.ones_like(nodes)
    for i in range(4):
        for j in range(4):
            if i != j:
                w[:, i] *= (centre - nodes[:, j]) / (nodes[:, i] - nodes[:, j])
    e = x[2:n - 2] - np.sum(w * x[idx], axis=1)
    return float(np.sqrt(np.mean(e**2)))


def _stamps_jitter(t: np.ndarray, slots: np.ndarray, columns: Mapping[str, np.ndarray]
                   ) -> bool:
    """Whether the samples were taken on the regular slots and only their stamps jitter.

    Irregular time stamps mean one of two things. Either the samples were taken at those
    instants (event-driven logging, dropped samples) and interpolating at the stamps is
    right; or they were taken at a fixed rate and only the stamps jitter (a logger stamping
    on receipt), and then interpolating at the stamps *adds* an error ẋ·δt to every column:
    white, heavy-tailed, growing with the signal's rate (measured: every clean arm and car
    log with a 20 % jitter flagged as a mismatch). Whichever timing is wrong adds that error
    and the right one does not, so the data decide: each sample is predicted from its two
    neighbours on each side by cubic interpolation in time, once at the stamps and once at
    the slots (same values, no resampling, so the noise is treated alike), and the slots are
    taken when the sum over columns of the log RMS-error ratios says they predict better.
    """
    rel_t, rel_s = t - t[0], slots - t[0]
    score, used = 0.0, 0
    for v in columns.values():
        x = np.asarray(v, dtype=np.float64)
        a, b = _prediction_error(rel_s, x), _prediction_error(rel_t, x)
        if a > 0 and b > 0:
            score += float(np.log(a / b))
            used += 1
    return used > 0 and score < 0.0


@dataclass(frozen=True)
class Grid:
    """A recording on per-segment uniform grids (no interpolation across gaps).

    Attributes:
        t: time of each row (s); uniform with step ``dt`` inside a segment, jumping at gaps.
        columns: the columns on those rows.
        segment: segment id of each row (0, 1, …), shape (N,).
        dt: the common sample period (s): the median step of the recording.
        resampled: whether any segment's time stamps were non-uniform and were resampled.
        dropped: (start s, end s) of stretches left out because they were too short to
            filter (fewer than ``MIN_SEGMENT`` samples).
        gaps: (end of the segment before s, start of the one after s) of each gap.
        retimed: whether some segment's jittered stamps were replaced by the regular
            instants they jitter around (values kept, not interpolated; ``resampled`` is
            True then too).
    """

    t: np.ndarray
    columns: dict[str, np.ndarray]
    segment: np.ndarray
    dt: float
    resampled: bool
    dropped: tuple[tuple[float, float], ...]
    gaps: tuple[tuple[float, float], ...]
    retimed: bool = False

    @property
    def bounds(self) -> tuple[tuple[int, int], ...]:
        """(first row, end row) of each segment on the grid."""
        return segment_bounds(self.segment)


def segment_bounds(segment: np.ndarray) -> tuple[tuple[int, int], ...]:
    """(first row, one past the last row) of each run of equal segment ids."""
    segment = np.asarray(segment)
    if segment.size == 0:
        return ()
    cuts = np.flatnonzero(np.diff(segment) != 0) + 1
    starts = np.concatenate([[0], cuts])
    ends = np.concatenate([cuts, [segment.size]])
    return tuple((int(a), int(b)) for a, b in zip(starts, ends, strict=True))


def segmented_grid(t: np.ndarray, columns: Mapping[str, np.ndarray]) -> Grid:
    """Split a recording at gaps and put each segment on a uniform grid of the median step.

    Gaps are never interpolated across: a stretch without samples stays without rows, and
    each segment is filtered on its own. Irregular stamps without gaps are resampled (or, when
    only the stamps jitter around a fixed rate, replaced by it: :func:`_stamps_jitter`).
    Segments too short to filter are left out (reported in ``dropped``).
    """
    t = np.asarray(t, dtype=np.float64)
    step = float(np.median(np.diff(t)))
    cuts = find_gaps(t)
    starts = np.concatenate([[0], cuts + 1])
    ends = np.concatenate([cuts + 1, [t.size]])
    ts, cols, segs, dropped, kept = [], {k: [] for k in columns}, [], [], []
    resampled, retimed = False, []
    for a, b in zip(starts, ends, strict=True):
        if b - a < MIN_SEGMENT:
            dropped.append((float(t[a]), float(t[b - 1])))
            continue
        tu, cu, rs, slot = _uniform(t[a:b], {k: np.asarray(v)[a:b] for k, v in columns.items()},
                                    step)
        resampled |= rs
        if slot is not None:
            retimed.append((b - a, slot))
        ts.append(tu)
        for k in columns:
            cols[k].append(cu[k])
        segs.append(np.full(tu.size, len(kept), dtype=int))
        kept.append((float(tu[0]), float(tu[-1])))
    if not ts:
        raise ValueError(f"no stretch of at least {MIN_SEGMENT} samples without a gap "
                         f"(gaps: {cuts.size})")
    gaps = tuple((kept[i][1], kept[i + 1][0]) for i in range(len(kept) - 1))
    if retimed:   # the slots' own step (the rows' spacing), from the longest such segment
        step = max(retimed)[1]
    return Grid(t=np.concatenate(ts), columns={k: np.concatenate(v) for k, v in cols.items()},
                segment=np.concatenate(segs), dt=step, resampled=resampled,
                dropped=tuple(dropped), gaps=gaps, retimed=bool(retimed))


def derivative_gain(window: int, deriv: int, dt: float) -> float:
    """Noise gain of the Savitzky–Golay derivative filter: output std per unit input std."""
    c = savgol_coeffs(window, POLYORDER, deriv=deriv, delta=dt, use="dot")
    return float(np.sqrt(np.sum(c**2)))


def kernel_weights(window: int, deriv: int, dt: float) -> np.ndarray:
    """Weights of the smoothing kernel k(τ) = c·(1 + b·s²)·(1 − s²)^P or of its derivatives.

    s = τ/T. ``window`` = 2h + 1 samples; T = (h + 1)·dt, so that k and its first P − 1 derivatives
    vanish just outside the window. b makes the discrete second moment zero (a fourth-order
    kernel: like the cubic Savitzky–Golay filter it passes cubics unchanged, so its passband
    is flat and its bias O(T⁴)); c makes the deriv-0 weights sum to 1. The deriv-1 and
    deriv-2 weights are the same c times the exact derivatives k'(i·dt), k''(i·dt) (units
    1/s, 1/s²). Applied with ``scipy.ndimage.convolve1d``: y[n] = Σ_i w[i + h]·x[n − i].
    """
    h = window // 2
    big_t = (h + 1) * dt
    s = np.arange(-h, h + 1) / (h + 1)
    p = KERNEL_POWER
    u = 1.0 - s**2
    base = u**p
    b = -float(np.sum(base * s**2)) / float(np.sum(base * s**4))
    poly = 1.0 + b * s**2
    c = 1.0 / float(np.sum(poly * base))
    d1 = -2.0 * p * s * u ** (p - 1)                                     # dB/ds
    if deriv == 0:
        w = poly * base
    elif deriv == 1:
        w = (2.0 * b * s * base + poly * d1) / big_t
    elif deriv == 2:
        d2 = -2.0 * p * u ** (p - 1) + 4.0 * p * (p - 1) * s**2 * u ** (p - 2)
        w = (2.0 * b * base + 4.0 * b * s * d1 + poly * d2) / big_t**2
    else:
        raise ValueError(f"kernel derivative order {deriv} not supported (0, 1, 2)")
    return c * w


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.asarray(x, dtype=np.float64) ** 2))) if np.size(x) else 0.0


def choose_window(signals: list[np.ndarray], dt: float, deriv: int = 1,
                  noise: Sequence[float] | None = None, kind: str = "savgol",
                  pre: np.ndarray | None = None, length: int | None = None,
                  max_seconds: float = MAX_WINDOW_S) -> int:
    """Shortest odd window keeping each signal's derivative noise below 2 % of its RMS.

    Args:
        signals: raw signals that will be differentiated ``deriv`` times.
        dt: sample period (s).
        deriv: derivative order needed (1 or 2).
        noise: error std of each signal (its units); default: the white-noise estimate of
            :func:`noise_std`. A zero noise (exact data) gives the shortest window; the
            callers report that (issue 13: it must never happen silently).
        kind: ``"savgol"`` (cubic Savitzky–Golay) or ``"kernel"`` (:func:`kernel_weights`).
        pre: for ``kind="kernel"``: weights of a filter applied before the kernel's first
            derivative (the short inner smoother or differentiator); the noise gain is then
            that of the composition, and ``deriv`` only names the total order.
        length: shortest segment (samples); bounds the window.
        max_seconds: longest window (s).

    Returns:
        Window length in samples (odd, at least 5, at most 0.15 s or the data length).
    """
    n = length or min(len(s) for s in signals)
    w_max = max(MIN_WINDOW, int(max_seconds / dt) | 1)
    w_max = min(w_max, (n - 1) | 1 if (n - 1) % 2 else n - 2)
    w_max = max(w_max, MIN_WINDOW)

    def weights(w: int) -> np.ndarray:
        if kind == "savgol":
            return savgol_coeffs(w, POLYORDER, deriv=deriv, delta=dt, use="dot")
        if pre is None:
            return kernel_weights(w, deriv, dt)
        return np.convolve(kernel_weights(w, 1, dt), pre)

    def estimate(s: np.ndarray, w: int) -> np.ndarray:
        if kind == "savgol":
            return savgol_filter(s, w, POLYORDER, deriv=deriv, delta=dt)
        return convolve1d(np.asarray(s, dtype=np.float64), weights(w), mode="nearest")

    best = MIN_WINDOW
    sigmas = list(noise) if noise is not None else [noise_std(s) for s in signals]
    for s, sigma in zip(signals, sigmas, strict=True):
        rms = _rms(estimate(s, w_max)[w_max:-w_max] if len(s) > 3 * w_max
                   else estimate(s, w_max))
        w = w_max
        if rms > 0:
            for cand in range(MIN_WINDOW, w_max + 1, 2):
                gain = float(np.sqrt(np.sum(weights(cand) ** 2)))
                if sigma * gain <= NOISE_RATIO * rms:
                    w = cand
                    break
        best = max(best, w)
    return best


def _per_segment(x: np.ndarray, bounds: tuple[tuple[int, int], ...] | None,
                 fn: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
    x = np.asarray(x, dtype=np.float64)
    if not bounds or len(bounds) == 1:
        return fn(x)
    return np.concatenate([fn(x[a:b]) for a, b in bounds], axis=0)


@dataclass(frozen=True)
class Smoother:
    """A cubic Savitzky–Golay filter: window (samples), step dt (s), segments.

    Each segment (rows between gaps, ``bounds``) is filtered on its own, its ends by the
    polynomial fit of its first/last window (scipy's ``mode="interp"``).
    """

    window: int
    dt: float
    bounds: tuple[tuple[int, int], ...] | None = None

    def __call__(self, x: np.ndarray, deriv: int = 0) -> np.ndarray:
        """Return the filtered signal (deriv=0) or its deriv-th time derivative (units/s^deriv)."""
        def one(seg: np.ndarray) -> np.ndarray:
            w = self.window if seg.shape[0] >= self.window else \
                max(POLYORDER + 2, (seg.shape[0] - 1) | 1 if seg.shape[0] % 2 == 0
                    else seg.shape[0])
            if seg.shape[0] < POLYORDER + 2:
                return np.zeros_like(seg) if deriv else seg.copy()
            return savgol_filter(seg, w, POLYORDER, deriv=deriv, delta=self.dt, axis=0,
                                 mode="interp")
        return _per_segment(x, self.bounds, one)

    def valid(self, n: int) -> np.ndarray:
        """Rows (n,) at least a window from their segment's ends (filter fully inside)."""
        return _valid_rows(n, self.bounds, self.window)


def _valid_rows(n: int, bounds: tuple[tuple[int, int], ...] | None, window: int
                ) -> np.ndarray:
    ok = np.zeros(n, dtype=bool)
    h = window // 2 + 1
    for a, b in bounds or ((0, n),):
        ok[a + h:b - h] = True
    return ok


#: Trapezoid weights of the mean over the two sample intervals around a sample
#: [t_{k−1}, t_{k+1}] of a quantity known at the samples (exact where it is linear on each
#: interval, kinks at the samples included).
INTERVAL_MEAN = (0.25, 0.5, 0.25)


@dataclass(frozen=True)
class KernelFilter:
    """One smooth kernel and its exact derivatives, applied per segment (see the module doc).

    ``self(x)`` = K*x, ``self(x, 1)`` = K'*x = K*ẋ, ``self(x, 2)`` = K''*x = K*ẍ on rows at
    least half a window from a segment's end (:meth:`valid`); nearer the ends the
    convolution repeats the end sample and the rows must not be fitted.

    ``interval=True`` is the **interval form** of the filtered equation: each row is first
    the mean over the two sample intervals [t_{k−1}, t_{k+1}] around its sample, then K.
    ``self(x)`` = K*(T x) with T the trapezoid mean (:data:`INTERVAL_MEAN`), ``self(x, 1)``
    = K*((x_{k+1} − x_{k−1})/(2Δt)), the *exact* mean of ẋ over those intervals, and
    :meth:`held` = K*x for a quantity that already is such a mean (a logged command held
    over each sample interval, averaged over the two: (u_{k−1} + u_k)/2, exact for a
    zero-order hold). The equation ṗ = u + … is then integrated over each sample interval:
    exact for a piecewise-constant input, where the point form K'*p (the kernel's derivative
    on the sampled momentum) assumes a smooth p and is off by (ω·Δt)²/6 of the input at
    frequency ω (measured: 2.6e-4 N·m on a noise-free arm log, 20x the interval form's).
    """

    window: int
    dt: float
    bounds: tuple[tuple[int, int], ...] | None = None
    interval: bool = False

    def held(self, x: np.ndarray) -> np.ndarray:
        """K * x per segment for an interval mean (e.g. a held input); = ``self(x)`` otherwise."""
        return self._apply(x, 0)

    def __call__(self, x: np.ndarray, deriv: int = 0) -> np.ndarray:
        """Return K^(deriv) * x per segment (units of x per s^deriv).

        In the interval form (``interval``) of the interval means of x (deriv 0) or of ẋ
        (deriv 1) instead; see the class doc.
        """
        if not self.interval:
            return self._apply(x, deriv)
        if deriv not in (0, 1):
            raise ValueError(f"interval form: derivative order {deriv} not supported (0, 1)")
        return self._apply(_per_segment(x, self.bounds, lambda seg: _interval_mean(
            seg, deriv, self.dt)), 0)

    def _apply(self, x: np.ndarray, deriv: int) -> np.ndarray:
        """K^(deriv) * x per segment (units of x per s^deriv).

        Rows nearer a segment's end than half a window use the same kernel shape on the
        widest symmetric window that fits (at least 5 samples), so that the filtered
        equation stays exact there too, only noisier; the first and last two rows repeat
        their neighbour's value.
        """
        w = _cached_weights(self.window, deriv, self.dt)
        h = self.window // 2

        def one(seg: np.ndarray) -> np.ndarray:
            out = _convolve_rows(seg, w)
            n = seg.shape[0]
            for d in range(min(h, (n - 1) // 2)):
                half = max(d, 2)
                if 2 * half + 1 > n:
                    break
                wd = _cached_weights(2 * half + 1, deriv, self.dt)[::-1]
                for row, lo in ((d, d - half), (n - 1 - d, n - 1 - d - half)):
                    lo = min(max(lo, 0), n - 2 * half - 1)
                    out[row] = np.tensordot(wd, seg[lo:lo + 2 * half + 1], axes=(0, 0))
            return out
        return _per_segment(x, self.bounds, one)

    def valid(self, n: int) -> np.ndarray:
        """Rows (n,) at least half a window from their segment's ends."""
        return _valid_rows(n, self.bounds, self.window)


#: Rows per block of the kernel's convolution: a block's lines stay in the CPU cache
#: (measured, best of 7 at load ≈ 6: 42 ns/row on 3·10⁴ rows, 81 ns/row on 3·10⁵ rows in one
#: piece, 60 ns/row in blocks); the values are the same (each block carries its halo).
CONV_BLOCK_ROWS = 1 << 14


@functools.lru_cache(maxsize=256)
def _cached_weights(window: int, deriv: int, dt: float) -> np.ndarray:
    """:func:`kernel_weights`, computed once per (window, deriv, dt) (read-only)."""
    w = kernel_weights(window, deriv, dt)
    w.flags.writeable = False
    return w


def _convolve_rows(x: np.ndarray, w: np.ndarray) -> np.ndarray:
    """``convolve1d(x, w, axis=0, mode="nearest")``, the same values, at less cost.

    All-zero columns (a channel a regressor does not act on) are not convolved, and long
    arrays are convolved in blocks of :data:`CONV_BLOCK_ROWS` rows, each with its halo.
    """
    live = _live_columns(x)
    if live is not None:
        out = np.zeros(x.shape)
        if live.size:
            out[:, live] = _convolve_rows(x[:, live], w)
        return out
    n, h = x.shape[0], w.size // 2
    if n <= 2 * CONV_BLOCK_ROWS:
        return convolve1d(x, w, axis=0, mode="nearest")
    out = np.empty(x.shape)
    for a in range(0, n, CONV_BLOCK_ROWS):
        b = min(a + CONV_BLOCK_ROWS, n)
        lo, hi = max(a - h, 0), min(b + h, n)
        out[a:b] = convolve1d(x[lo:hi], w, axis=0, mode="nearest")[a - lo:b - lo]
    return out


def _live_columns(x: np.ndarray) -> np.ndarray | None:
    """Indices of the columns of a 2-D ``x`` that are not all zero; None if all are."""
    if x.ndim != 2 or x.shape[1] < 2:
        return None
    live = np.flatnonzero([x[:, j].any() for j in range(x.shape[1])])   # stops early
    return None if live.size == x.shape[1] else live


def _interval_mean(seg: np.ndarray, deriv: int, dt: float) -> np.ndarray:
    """Mean over [t_{k−1}, t_{k+1}] of x (trapezoid, deriv 0) or of ẋ (exact, deriv 1).

    The end rows use the one interval they have; all-zero columns are left zero.
    """
    live = _live_columns(seg)
    if live is not None:
        out = np.zeros(seg.shape)
        if live.size:
            out[:, live] = _interval_mean(seg[:, live], deriv, dt)
        return out
    out = np.empty(seg.shape)
    if seg.shape[0] < 2:
        out[...] = 0.0 if deriv else seg
        return out
    if deriv:
        out[1:-1] = seg[2:] - seg[:-2]
        out[1:-1] *= 0.5 / dt
        out[0] = (seg[1] - seg[0]) / dt
        out[-1] = (seg[-1] - seg[-2]) / dt
        return out
    a, b, c = INTERVAL_MEAN
    out[1:-1] = a * seg[:-2]
    out[1:-1] += b * seg[1:-1]
    out[1:-1] += c * seg[2:]
    out[0] = 0.5 * (seg[0] + seg[1])
    out[-1] = 0.5 * (seg[-2] + seg[-1])
    return out


@dataclass(frozen=True)
class ResidualResult:
    """Residual of a recording on its grid (uniform inside each segment).

    Attributes:
        t: time of each row (s); uniform inside a segment, jumping across gaps.
        residual: physical residual, shape (N, n_channels), channel units.
        noise_rms: noise floor per channel (channel units): the residual's change under the
            columns' errors (white noise of their std; a quantised angle's rounding error
            propagated as a staircase, see :func:`noise_floor`) plus the numerical floor.
        signals: filtered signals and derivatives by name.
        raw: raw columns on the grid.
        smoother: the filter of the residual equation (the fit filters regressors with it).
        resampled: whether the recording's time stamps were non-uniform and resampled.
        column_noise: error std of each raw column (column units), quantisation included.
        segment: segment id of each row (gaps split the recording), shape (N,).
        column_models: the per-column error models (:mod:`simgap.diagnosis.errormodel`).
        warnings: one-line findings for the report (quantised or pre-filtered columns,
            gaps, columns replaced by a derivative, exact data).
        effective_samples: effective number of independent residual samples per channel
            (N/τ with τ the integrated autocorrelation time, summed over segments).
        valid: rows whose filter window lies inside their segment, shape (N,).
    """

    t: np.ndarray
    residual: np.ndarray
    noise_rms: np.ndarray
    signals: dict[str, np.ndarray]
    raw: dict[str, np.ndarray]
    smoother: Any
    resampled: bool
    column_noise: dict[str, float]
    segment: np.ndarray | None = None
    column_models: Mapping[str, ColumnErrorModel] = field(default_factory=dict)
    warnings: tuple[str, ...] = ()
    effective_samples: np.ndarray | None = None
    valid: np.ndarray | None = None


def error_models(raw: Mapping[str, np.ndarray], segment: np.ndarray
                 ) -> dict[str, ColumnErrorModel]:
    """Each column's error model, estimated on its longest segment (a gap is no jump)."""
    a, b = max(segment_bounds(segment), key=lambda ab: ab[1] - ab[0])
    return {k: column_error_model(k, np.asarray(v)[a:b]) for k, v in raw.items()}


def effective_counts(residual: np.ndarray, valid: np.ndarray, segment: np.ndarray
                     ) -> np.ndarray:
    """Effective independent samples per channel: Σ over segments of N_s/τ_s (valid rows)."""
    out = np.zeros(residual.shape[1])
    for a, b in segment_bounds(segment):
        rows = np.flatnonzero(valid[a:b]) + a
        if rows.size < 4:
            continue
        for j in range(residual.shape[1]):
            out[j] += effective_samples(residual[rows, j])
    return out


def grid_warnings(grid: Grid) -> list[str]:
    """One line per gap and per left-out stretch of a segmented grid."""
    out = [f"time gap from {a:.6g} s to {b:.6g} s ({b - a:.3g} s, more than {GAP_STEPS:g} "
           "sample periods): the recording is split there, nothing is interpolated across it"
           for a, b in grid.gaps]
    out += [f"samples from {a:.6g} s to {b:.6g} s left out: fewer than {MIN_SEGMENT} samples "
            "between gaps, too short to filter" for a, b in grid.dropped]
    if grid.retimed:
        out.append("time stamps jitter around a fixed rate: the samples were read at the "
                   f"regular instants ({grid.dt:.6g} s apart) the stamps scatter around, not "
                   "interpolated at the stamps (each sample is predicted better from its "
                   "neighbours on the regular instants)")
    return out


def noise_of(models: Mapping[str, ColumnErrorModel], warn: list[str],
             differentiated: Sequence[str]) -> dict[str, float]:
    """Error std per column (column units): the model's floor, never silently zero.

    A column without measurable noise (exact values, e.g. simulated data without noise)
    keeps a zero noise, but a column that will be differentiated is reported in ``warn``:
    the shortest filter window is then chosen because the data say so, not by accident.
    """
    out = {}
    for k, m in models.items():
        out[k] = m.floor_std
        warn.extend(m.notes)
        if out[k] == 0.0 and k in differentiated:
            warn.append(f"{k}: no measurable noise or quantisation (exact values?); the "
                        "shortest derivative filter window is used")
    return out


def noise_floor(raw: Mapping[str, np.ndarray], column_noise: Mapping[str, float],
                residual_fn: Callable[[Mapping[str, np.ndarray]], np.ndarray],
                base: np.ndarray, seed: int = 0,
                quantised: Mapping[str, tuple[float, np.ndarray]] | None = None
                ) -> np.ndarray:
    """Residual noise floor per channel by propagating the columns' errors.

    White noise of each column's std is added and the residual's change measured. A
    quantised column's error is not white: on a slow motion the rounding error is a
    sawtooth whose period (q / speed) lies in the derivative filter's pass band, so white
    noise of the same std q/√12 (spread over every frequency up to Nyquist) under-states
    what it does to a differentiated residual (measured: 0.18 vs 0.21 N·m on a 2π/4096 rad
    encoder, which flagged clean logs). Its error is therefore propagated as it arises: the
    column's smooth estimate is re-quantised with the same step on the lattice shifted by
    half a step from the recorded one, and the residual's change between the smooth and the
    re-quantised column is added in quadrature. Half a step, because the smooth estimate
    still holds the recorded rounding error's pass-band part: re-quantised on the recorded
    lattice it reproduces the recorded staircase and measures only what the filter removes
    (0.13 N·m in the case above); half a step off, the new transitions fall at the recorded
    plateaus' centres, a realisation independent of the recorded one (0.22 N·m).

    Args:
        raw: raw columns (uniform grid).
        column_noise: white-noise std per column (column units); give a quantised column
            its white std only (its quantisation is in ``quantised``).
        residual_fn: maps raw columns to the residual (N, n_channels).
        base: residual of ``raw`` itself.
        seed: seed of the added noise.
        quantised: column -> (step q in column units, smooth estimate of the column on
            the grid), for the columns whose error is dominated by quantisation; ``raw``
            holds the recorded (lattice) values.

    Returns:
        RMS per channel of the residual change caused by the columns' errors.
    """
    rng = np.random.default_rng(seed)
    noisy = {k: v + rng.normal(0.0, column_noise.get(k, 0.0), size=v.shape) if k != "t" else v
             for k, v in raw.items()}
    diff = residual_fn(noisy) - base
    ms = np.mean(diff**2, axis=0)
    if quantised:
        smooth = dict(raw)
        smooth.update({k: np.asarray(s, dtype=np.float64) for k, (_, s) in quantised.items()})
        stair = dict(smooth)
        for k, (q, _) in quantised.items():
            offset = float(np.min(raw[k])) + 0.5 * q       # recorded lattice + half a step
            stair[k] = np.round((smooth[k] - offset) / q) * q + offset
        ms = ms + np.mean((residual_fn(stair) - residual_fn(smooth)) ** 2, axis=0)
    return np.sqrt(ms)
