"""Step 1 of the diagnosis: derivatives, the residual per channel, and its noise floor.

The residual of a recording against a nominal model is computed in physical units by the
system adapter (:mod:`simgap.diagnosis.systems`): joint torque (N·m) by inverse dynamics for
mechanical models, axle lateral force (N) by Delta = K⁻¹(dx/dt − f) for the bicycle. This
module supplies what every adapter shares:

* a uniform time grid: ``t`` need not be uniform; if the steps vary by more than 1 % the
  columns are linearly interpolated onto a grid at the median step (reported);
* the noise of each raw column, from its third differences (robust MAD estimate: white
  noise of std σ has third differences of std √20·σ);
* one Savitzky–Golay filter (cubic, scipy.signal.savgol_filter) for every signal and its
  derivatives. The window is the shortest one whose derivative noise (σ times the norm of
  the filter's derivative coefficients) stays below 2 % of the derivative's RMS, between
  5 samples and 0.15 s: it adapts to the sampling rate and the noise. Every signal (inputs
  too) goes through the same filter, so that the residual equation holds for the filtered
  signals and effect regressors can be filtered identically;
* the residual's noise floor per channel, by propagation: the residual is recomputed with
  an extra white noise of the estimated σ on every raw column and the RMS of the change is
  the floor (a seeded generator makes it reproducible).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np
from scipy.signal import savgol_coeffs, savgol_filter

POLYORDER = 3
MIN_WINDOW = 5
MAX_WINDOW_S = 0.15
NOISE_RATIO = 0.02
UNIFORM_TOL = 0.01


def noise_std(x: np.ndarray) -> float:
    """Robust white-noise std of a sampled signal from its third differences (signal units)."""
    d3 = np.diff(np.asarray(x, dtype=np.float64), n=3)
    if d3.size == 0:
        return 0.0
    mad = np.median(np.abs(d3 - np.median(d3)))
    return float(1.4826 * mad / np.sqrt(20.0))


def uniform_grid(t: np.ndarray, columns: Mapping[str, np.ndarray]
                 ) -> tuple[np.ndarray, dict[str, np.ndarray], bool]:
    """Put columns on a uniform time grid (s) if ``t`` is not uniform within 1 %.

    Returns:
        (t_uniform, columns_uniform, resampled?). Interpolation is linear (numpy.interp).
    """
    dt = np.diff(t)
    step = float(np.median(dt))
    if np.max(np.abs(dt - step)) <= UNIFORM_TOL * step:
        return t, dict(columns), False
    n = int(np.floor((t[-1] - t[0]) / step)) + 1
    tu = t[0] + step * np.arange(n)
    return tu, {k: np.interp(tu, t, v) for k, v in columns.items()}, True


def derivative_gain(window: int, deriv: int, dt: float) -> float:
    """Noise gain of the Savitzky–Golay derivative filter: output std per unit input std."""
    c = savgol_coeffs(window, POLYORDER, deriv=deriv, delta=dt, use="dot")
    return float(np.sqrt(np.sum(c**2)))


def choose_window(signals: list[np.ndarray], dt: float, deriv: int = 1) -> int:
    """Shortest odd SG window keeping each signal's derivative noise below 2 % of its RMS.

    Args:
        signals: raw signals that will be differentiated ``deriv`` times.
        dt: sample period (s).
        deriv: derivative order needed (1 or 2).

    Returns:
        Window length in samples (odd, at least 5, at most 0.15 s or the data length).
    """
    n = min(len(s) for s in signals)
    w_max = max(MIN_WINDOW, int(MAX_WINDOW_S / dt) | 1)
    w_max = min(w_max, (n - 1) | 1 if (n - 1) % 2 else n - 2)
    w_max = max(w_max, MIN_WINDOW)
    best = MIN_WINDOW
    for s in signals:
        sigma = noise_std(s)
        ref = savgol_filter(s, w_max, POLYORDER, deriv=deriv, delta=dt)
        rms = float(np.sqrt(np.mean(ref**2)))
        w = w_max
        if rms > 0:
            for cand in range(MIN_WINDOW, w_max + 1, 2):
                if sigma * derivative_gain(cand, deriv, dt) <= NOISE_RATIO * rms:
                    w = cand
                    break
        best = max(best, w)
    return best


@dataclass(frozen=True)
class Smoother:
    """The one Savitzky–Golay filter of a diagnosis: window (samples) and step dt (s)."""

    window: int
    dt: float

    def __call__(self, x: np.ndarray, deriv: int = 0) -> np.ndarray:
        """Return the filtered signal (deriv=0) or its deriv-th time derivative (units/s^deriv)."""
        return savgol_filter(np.asarray(x, dtype=np.float64), self.window, POLYORDER,
                             deriv=deriv, delta=self.dt, axis=0, mode="interp")


@dataclass(frozen=True)
class ResidualResult:
    """Residual of a recording on its uniform grid.

    Attributes:
        t: uniform time grid (s).
        residual: physical residual, shape (N, n_channels), channel units.
        noise_rms: noise floor per channel (channel units).
        signals: filtered signals and derivatives by name (uniform grid).
        raw: raw columns on the uniform grid.
        smoother: the filter used.
        resampled: whether the recording's time stamps were non-uniform and resampled.
        column_noise: estimated white-noise std of each raw column.
    """

    t: np.ndarray
    residual: np.ndarray
    noise_rms: np.ndarray
    signals: dict[str, np.ndarray]
    raw: dict[str, np.ndarray]
    smoother: Smoother
    resampled: bool
    column_noise: dict[str, float]


def noise_floor(raw: Mapping[str, np.ndarray], column_noise: Mapping[str, float],
                residual_fn: Callable[[Mapping[str, np.ndarray]], np.ndarray],
                base: np.ndarray, seed: int = 0) -> np.ndarray:
    """Residual noise floor per channel by propagating white noise of the columns' std.

    Args:
        raw: raw columns (uniform grid).
        column_noise: white-noise std per column (column units).
        residual_fn: maps raw columns to the residual (N, n_channels).
        base: residual of ``raw`` itself.
        seed: seed of the added noise.

    Returns:
        RMS per channel of the residual change caused by the added noise.
    """
    rng = np.random.default_rng(seed)
    noisy = {k: v + rng.normal(0.0, column_noise.get(k, 0.0), size=v.shape) if k != "t" else v
             for k, v in raw.items()}
    diff = residual_fn(noisy) - base
    return np.sqrt(np.mean(diff**2, axis=0))
