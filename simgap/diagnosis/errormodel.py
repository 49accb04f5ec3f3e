"""Per-column error model of a recording, estimated from the data alone.

Real logs rarely carry white Gaussian noise: encoders quantise, drives denoise velocities
upstream, loggers sample coarsely. A noise estimate that assumes white noise on a finely
sampled smooth signal then fails in known ways (zero noise on a quantised staircase, a 20x
too small noise on a median/wavelet-filtered column, signal mistaken for noise at 100 Hz).
This module estimates, per column:

* **white noise** σ (column units) from k-th differences. A white noise of std σ has k-th
  differences of variance C(2k, k)·σ², while a smooth signal's k-th difference shrinks like
  (ω·dt)^k (below 1 whenever the signal is sampled above its own bandwidth). Each order k
  gives an estimate biased *upwards* by the signal; the smallest over k = 2…6 (robust MAD,
  scaled by √C(2k, k)) is the least biased. At 500 Hz it equals the third-difference
  estimate; at 100 Hz it keeps the signal out of the noise.
* **quantisation**: most consecutive samples repeat and every value lies on a lattice
  x₀ + n·q. The step q is the smallest gap between distinct values, checked against the
  lattice; its floor is q/√12 (the std of a uniform rounding error). The column's error std
  is never below that floor, so a zero noise estimate cannot select the minimum window.
* **heavy tails / upstream filtering**: white noise gives k-th differences with a kurtosis
  of 3; a quantised staircase or a median/wavelet-denoised column gives a few large jumps
  between long smooth stretches (kurtosis ≫ 3, and a robust σ much below the classical
  one). Such a column's MAD-based σ says nothing about its real error, which is correlated
  and low-frequency; it is flagged, and a derivable column (velocity) is then better
  rebuilt from its integral (position) than trusted.
* **filtered upstream, or kinks of the signal**: heavy tails alone do not say who made
  them. A coarsely sampled signal with kinks (a friction reversal, a step of the commanded
  torque) has a few large third differences too, yet its error is still white. What an
  upstream filter does and a kink does not is change the top half of the spectrum (half to
  full Nyquist): either it is no longer flat (a filter's cut: spectral flatness, geometric
  over arithmetic mean of the Welch PSD, 0.06–0.41 for median + wavelet denoising against
  0.95–0.99 for white noise with or without kinks at 100 Hz or jitter), or, for a denoiser
  leaving plateaus and jumps, it holds far more power than the robust white-noise σ
  explains (``hf_excess``: mean top-band PSD over 2σ²/fs; ≈ 1 white, 1.4–2.2 for kinks at
  100 Hz and jittered logs, 8–180 for denoised columns, infinite on exact plateaus). Only
  a heavy-tailed column failing one of these counts as filtered upstream.
* **a velocity column that lags its position column** (:func:`velocity_lag`): a backward
  difference lags the true velocity by half a sample, a drive's moving average or low-pass
  by its group delay. The error model of each column alone cannot see it (a backward
  difference of a finely quantised, noisy angle is white-ish, a moving average is smooth),
  but the pair can: a velocity logged δ late satisfies dq(t) ≈ q̇(t) − δ·q̈(t), with q̇ the
  zero-phase derivative of the angle. A lag between the velocity and the angle is no
  physics: fitted through the velocity it becomes an input delay δ (measured: 1 ms, half a
  2 ms sample, named as an input delay at both joints on every clean 2^20-count encoder log
  with a backward-difference velocity).
* **effective sample count** of a residual: N / τ, with τ the integrated autocorrelation
  time (Geyer's initial positive sequence), so that statistics on correlated residuals do
  not count every sample as independent.

Nothing here uses a fixed physical threshold: every decision compares the data with what
white noise would give for the same length.
"""

from __future__ import annotations

from dataclasses import dataclass
from math import comb

import numpy as np
from scipy.signal import savgol_filter, welch

#: Difference orders over which the white-noise estimate is minimised.
ORDERS = (2, 3, 4, 5, 6)
#: MAD → std for a Gaussian.
MAD_TO_STD = 1.4826
#: A column is quantised when at least this share of its values lie within 5 % of a step
#: on one lattice (a continuous-valued column puts about 10 % there by chance).
LATTICE_SHARE = 0.98
#: Quantisation dominates the error when q/√12 exceeds this share of the white-noise std
#: (a CSV printed with 6 decimals is quantised too, harmlessly).
QUANT_DOMINANT = 0.5
#: Kurtosis of white noise's k-th differences is 3; its sampling std for N samples is
#: about sqrt(24/N). A column is heavy-tailed when its kurtosis exceeds 3 by this many
#: sampling stds (and by a factor of 2, so that very long logs do not flag mild tails).
KURTOSIS_SIGMAS = 8.0
#: Spectral flatness of the upper half band below which the high frequencies are not white:
#: white noise gives ≈ exp(−1/(2K)) ≥ 0.9 for K ≥ 5 Welch segments; a spectrum falling by a
#: decade or more across the band (a filter's cut) gives well below 0.5.
FLATNESS_WHITE = 0.5
#: Top-band power over the white-noise estimate's above which that estimate misses most of
#: the high-frequency error (a factor 2 in std).
HF_EXCESS = 4.0
#: Welch segment length (samples) of the flatness estimate, shortened to keep ≥ 8 segments.
WELCH_SEGMENT = 256
#: Savitzky–Golay window (samples, cubic) of the velocity-lag estimate: both sides of
#: dq ≈ q̇ − δ·q̈ go through the same zero-phase filter, so its length sets the noise only.
LAG_WINDOW = 11
#: A velocity column lags its angle when the lag estimate exceeds this many standard errors
#: (autocorrelation-corrected). A consistent pair gives |z| of order 1 at any length; the
#: lags this is meant for give z in the tens to hundreds (half a sample at 500 Hz: 40-60).
LAG_Z = 5.0


@dataclass(frozen=True)
class ColumnErrorModel:
    """What the data say about one column's measurement error.

    Attributes:
        name: column name.
        white_std: white-noise std from k-th differences (column units); 0 for an exact
            staircase.
        order: the difference order that gave ``white_std``.
        quantum: quantisation step (column units), or None when the column is not quantised
            (reported even where harmless, e.g. 6 printed decimals).
        heavy_tailed: the k-th differences are far from Gaussian (quantised, despiked or
            denoised upstream): ``white_std`` then under-states the real error.
        kurtosis: kurtosis of the third differences (3 for white noise).
        notes: one-line findings a report can show.
        flatness: spectral flatness of the column's upper half band (≈ 1 white, ≪ 1 when
            the high frequencies were filtered away); 1 when too short to tell or when
            quantisation dominates.
        hf_excess: mean PSD of the upper half band over white noise's of std
            ``white_std`` (≈ 1 white; ≫ 1 when the noise estimate misses that band's power).
    """

    name: str
    white_std: float
    order: int
    quantum: float | None
    heavy_tailed: bool
    kurtosis: float
    notes: tuple[str, ...] = ()
    flatness: float = 1.0
    hf_excess: float = 1.0

    @property
    def quantisation_dominant(self) -> bool:
        """The quantisation step's error q/√12 dominates the white noise: a staircase."""
        return bool(self.quantum) and self.quantum / np.sqrt(12.0) > QUANT_DOMINANT * \
            self.white_std

    @property
    def filtered_upstream(self) -> bool:
        """Heavy tails with the high frequencies gone: filtered upstream (not quantisation)."""
        return bool(self.heavy_tailed and not self.quantisation_dominant
                    and (self.flatness < FLATNESS_WHITE or self.hf_excess > HF_EXCESS))

    @property
    def low_passed(self) -> bool:
        """The upper half band is not white: the column was low-passed before logging.

        A causal low-pass (a drive's Butterworth on its angle) leaves Gaussian differences,
        so it is no heavy-tailed column, but its cut shows in the spectrum (flatness
        0.08–0.13 for 2nd-order Butterworth at 10–20 Hz on 500 Hz logs, ≥ 0.95 for white
        noise at 50–1000 Hz, coloured noise and jitter). Such a column lags the physics by
        the filter's group delay. Not judged on a quantised staircase (its flatness says
        nothing about a filter).
        """
        return bool(not self.quantisation_dominant and self.flatness < FLATNESS_WHITE)

    @property
    def floor_std(self) -> float:
        """Smallest credible error std (column units): white noise or q/√12, the larger."""
        q = self.quantum / np.sqrt(12.0) if self.quantum else 0.0
        return float(max(self.white_std, q))


def white_noise_std(x: np.ndarray, orders: tuple[int, ...] = ORDERS) -> tuple[float, int]:
    """Least signal-biased white-noise std over k-th differences (column units).

    Args:
        x: sampled signal.
        orders: difference orders k to try; each gives 1.4826·MAD(Δᵏx)/√C(2k, k).

    Returns:
        (std, k) with the smallest estimate and its order; (0.0, orders[0]) if too short.
    """
    x = np.asarray(x, dtype=np.float64)
    best, best_k = np.inf, orders[0]
    for k in orders:
        if x.size <= k + 1:
            continue
        d = np.diff(x, n=k)
        s = MAD_TO_STD * float(np.median(np.abs(d - np.median(d)))) / np.sqrt(comb(2 * k, k))
        if s < best:
            best, best_k = s, k
    return (0.0, orders[0]) if not np.isfinite(best) else (float(best), best_k)


def quantisation_step(x: np.ndarray) -> float | None:
    """The quantisation step q of a column (column units), or None if it is not quantised.

    A column is quantised when at least ``LATTICE_SHARE`` of the samples lie on one lattice
    x₀ + n·q (within 5 % of q). q is the smallest gap between distinct values that the lattice
    confirms (a gap of 2q between the two smallest values would fail the lattice test only
    if q itself is never visited, in which case 2q is the resolution that matters).
    """
    x = np.asarray(x, dtype=np.float64)
    if x.size < 3:
        return None
    u = np.unique(x)
    if u.size < 2:
        return None
    gaps = np.diff(u)
    scale = max(float(np.max(np.abs(u))), 1e-300)
    gaps = gaps[gaps > 1e-12 * scale]
    if gaps.size == 0:
        return None
    for q in np.unique(np.sort(gaps)[: min(gaps.size, 8)]):
        r = (x - u[0]) / q
        if np.mean(np.abs(r - np.round(r)) < 0.05) >= LATTICE_SHARE:
            return float(q)
    return None


def top_band(x: np.ndarray, white_std: float) -> tuple[float, float]:
    """(flatness, excess) of the upper half band of a column's Welch PSD.

    Flatness is the geometric over the arithmetic mean of the PSD between half and full
    Nyquist frequency (Hann window, linear detrend per segment): ≈ 1 for white noise.
    Excess is that band's mean PSD over white noise's of std ``white_std`` (2σ² per unit
    of normalised frequency): ≈ 1 when the white estimate explains the band, infinite when
    it is 0 and the band is not. Both are 1.0 when the column is too short for 8 segments of
    32 samples or has no power there (nothing to tell).

    Args:
        x: the column's samples on a uniform grid.
        white_std: its white-noise std estimate (column units).
    """
    x = np.asarray(x, dtype=np.float64)
    seg = min(WELCH_SEGMENT, x.size // 8)
    if seg < 32:
        return 1.0, 1.0
    _, p = welch(x, nperseg=seg, detrend="linear")
    top = p[p.size // 2:]
    if not np.all(top > 0):
        return 1.0, 1.0
    mean = float(np.mean(top))
    excess = mean / (2.0 * white_std**2) if white_std > 0 else float("inf")
    return float(np.exp(np.mean(np.log(top))) / mean), excess


def kurtosis(d: np.ndarray) -> float:
    """Pearson kurtosis E[(d−μ)⁴]/σ⁴ (3 for a Gaussian; inf for a constant)."""
    d = np.asarray(d, dtype=np.float64)
    c = d - d.mean()
    v = float(np.mean(c**2))
    return float(np.mean(c**4) / v**2) if v > 0 else float("inf")


def column_error_model(name: str, x: np.ndarray) -> ColumnErrorModel:
    """Estimate one column's error model from its samples (see the module docstring)."""
    x = np.asarray(x, dtype=np.float64)
    std, order = white_noise_std(x)
    q = quantisation_step(x)
    d3 = np.diff(x, n=3) if x.size > 4 else np.zeros(1)
    kurt = kurtosis(d3)
    n = max(d3.size, 1)
    limit = max(2.0 * 3.0, 3.0 + KURTOSIS_SIGMAS * np.sqrt(24.0 / n))
    dominant = q is not None and q / np.sqrt(12.0) > QUANT_DOMINANT * std
    heavy = bool(dominant or not np.isfinite(kurt) or kurt > limit)
    flat, excess = top_band(x, std) if not dominant else (1.0, 1.0)
    filtered = flat < FLATNESS_WHITE or excess > HF_EXCESS
    notes = []
    if dominant:
        notes.append(f"{name} is quantised (step {q:.4g}); error floor q/√12 = "
                     f"{q / np.sqrt(12.0):.3g}")
    elif heavy and filtered:
        notes.append(f"{name} looks filtered or despiked upstream (kurtosis of its third "
                     f"differences {kurt:.3g}, white noise gives 3; high-frequency spectral "
                     f"flatness {flat:.2f} and power {excess:.3g}x its noise estimate's, "
                     "white noise gives ≈ 1 and 1): its noise estimate under-states its "
                     "error")
    elif heavy:
        notes.append(f"{name}: heavy-tailed third differences (kurtosis {kurt:.3g}) but a "
                     f"white high-frequency spectrum at its noise level (flatness {flat:.2f}, "
                     f"power {excess:.3g}x): kinks of the signal, not upstream filtering; "
                     "its noise estimate is kept")
    return ColumnErrorModel(name=name, white_std=std, order=order, quantum=q,
                            heavy_tailed=heavy, kurtosis=kurt, notes=tuple(notes),
                            flatness=flat, hf_excess=excess)


def velocity_lag(q: np.ndarray, dq: np.ndarray, dt: float,
                 segment: np.ndarray | None = None) -> tuple[float, float]:
    """Lag (s) of a velocity column behind the zero-phase derivative of its position column.

    Fits dq_s(t) − q̇_s(t) = −δ·q̈_s(t) by least squares over every segment, where dq_s is
    the velocity column smoothed, q̇_s the angle's derivative and q̈_s the velocity column's
    derivative, all by one cubic Savitzky–Golay filter of :data:`LAG_WINDOW` samples (zero
    phase, so a consistent pair gives δ ≈ 0 whatever the filter's bias). The standard error
    counts the fit residual's effective samples (N/τ, :func:`autocorrelation_time`).

    Args:
        q: position column (rad or m) on a uniform grid per segment.
        dq: velocity column (rad/s or m/s), same rows.
        dt: sample period (s).
        segment: segment id per row (gaps split the filter); None = one segment.

    Returns:
        (δ, stderr) in seconds; (0.0, inf) when too short or without acceleration.
    """
    q = np.asarray(q, dtype=np.float64)
    dq = np.asarray(dq, dtype=np.float64)
    seg = np.zeros(q.size, dtype=np.int64) if segment is None else np.asarray(segment)
    w, h = LAG_WINDOW, LAG_WINDOW // 2
    es, xs = [], []
    for s_id in np.unique(seg):
        rows = np.flatnonzero(seg == s_id)
        if rows.size < 4 * w:
            continue
        qs, vs = q[rows], dq[rows]
        v = savgol_filter(vs, w, 3)[h:-h]
        dq_of_q = savgol_filter(qs, w, 3, deriv=1, delta=dt)[h:-h]
        acc = savgol_filter(vs, w, 3, deriv=1, delta=dt)[h:-h]
        es.append(v - dq_of_q)
        xs.append(acc)
    if not es:
        return 0.0, float("inf")
    e, x = np.concatenate(es), np.concatenate(xs)
    sxx = float(x @ x)
    if not sxx > 0:
        return 0.0, float("inf")
    lag = -float(e @ x) / sxx
    r = e + lag * x
    tau = float(np.mean([autocorrelation_time(ei + lag * xi) for ei, xi in zip(es, xs,
                                                                              strict=True)]))
    var = float(r @ r) / max(r.size - 1, 1) * tau / sxx
    return lag, float(np.sqrt(var)) if var > 0 else float("inf")


#: An extreme value held on at least this many samples can be a saturation level.
CLIP_MIN_SAMPLES = 5
#: ... when it holds this many times the samples of the level just inside it (a quantised
#: column's extreme level holds 1-3x its neighbour's near a smooth peak).
CLIP_RATIO = 10.0


def clipped(x: np.ndarray) -> np.ndarray:
    """Samples of a column that sit on a saturation level (clipped before logging).

    A continuous-valued column takes its maximum (minimum) once; a clipped one holds it on
    every sample the true value exceeded the limit. An extreme level is a clip when it holds
    at least :data:`CLIP_MIN_SAMPLES` samples and :data:`CLIP_RATIO` times as many as the
    equally wide band just inside it (one quantisation step, or the float resolution of a
    continuous column), so that a quantised column's top level near a smooth peak is none.

    Args:
        x: the column's samples (column units).

    Returns:
        Boolean mask, shape like ``x`` (all False when nothing is clipped).
    """
    x = np.asarray(x, dtype=np.float64)
    out = np.zeros(x.size, dtype=bool)
    if x.size < 3 * CLIP_MIN_SAMPLES or not np.all(np.isfinite(x)):
        return out
    q = quantisation_step(x)
    scale = max(float(np.max(np.abs(x))), 1e-300)
    width = q if q is not None else 1e-9 * scale
    for level, sign in ((float(np.max(x)), 1.0), (float(np.min(x)), -1.0)):
        at = np.abs(x - level) <= 0.5 * width
        d = sign * (level - x)                       # distance inside the level (≥ 0)
        inside = int(np.count_nonzero((d > 0.5 * width) & (d <= 1.5 * width)))
        n = int(np.count_nonzero(at))
        if n >= CLIP_MIN_SAMPLES and n >= CLIP_RATIO * max(inside, 1):
            out |= at
    return out


def autocorrelation_time(r: np.ndarray) -> float:
    """Integrated autocorrelation time τ = 1 + 2 Σ ρ_k (samples) of a residual series.

    The sum runs over Geyer's initial positive sequence (pairs ρ_{2m} + ρ_{2m+1} while they
    stay positive), so that noise in the far lags does not inflate it. White noise gives 1.

    Args:
        r: one residual channel (any units); its mean is removed.
    """
    r = np.asarray(r, dtype=np.float64)
    r = r - r.mean()
    n = r.size
    if n < 4 or not np.any(r):
        return 1.0
    size = 1 << int(np.ceil(np.log2(2 * n)))
    f = np.fft.rfft(r, size)
    acf = np.fft.irfft(f * np.conj(f), size)[:n]
    rho = acf / acf[0]
    pairs = rho[1:n - 1:2] + rho[2:n:2]          # (ρ1+ρ2), (ρ3+ρ4), …
    stop = np.flatnonzero(pairs <= 0)
    kept = pairs[: stop[0] if stop.size else pairs.size]
    return float(max(1.0 + 2.0 * float(np.sum(kept)), 1.0))


def effective_samples(r: np.ndarray) -> float:
    """Effective number of independent samples N/τ of a residual channel."""
    r = np.asarray(r, dtype=np.float64)
    return float(r.size / autocorrelation_time(r))
