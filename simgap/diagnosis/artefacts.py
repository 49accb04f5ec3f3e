"""Realistic recording artefacts, applied to a clean (generated) recording.

The diagnosis must hold on logs it was never tuned on. Real logs differ from a generator's
output in a few recurring ways, each imitated here as a pure function
``Recording -> Recording`` (seeded by a ``numpy.random.Generator`` where random):

=========================  ================================================================
``quantise``               encoder angles rounded to a step (rad or m): most samples repeat
``finite_difference``      the velocity column replaced by the backward difference of the
                           (quantised) position, as a drive without a tachometer logs it
``upstream_denoise``       a velocity column median-filtered and wavelet-shrunk upstream
                           (heavy-tailed, correlated error)
``coloured_noise``         first-order (AR(1)) noise of a given std and correlation time
``downsample``             a coarser logging rate (every k-th sample, no anti-alias filter)
``jitter``                 logged time stamps off the true sampling instants
``cut_gap``                a stretch of samples missing (logger pause)
``truncate``               a short log
=========================  ================================================================

Three presets change what is recorded rather than spoil a recording (``scenario`` set,
see :mod:`simgap.diagnosis.scenarios`): ``free_decay_damping`` (a pendulum released with
no input, the nominal damping 15 % too high, with and without a real Coulomb friction),
``one_direction_circles`` (the vehicle on steady circles, one turn direction per run, two
runs joined by a gap), and ``one_direction_single_run`` (one run turning left only). Their
``apply`` only notes the scenario in ``meta``; a benchmark builds their recordings with the
scenario.

``ARTEFACTS`` names one preset of each (with the position/velocity column pairs of the
recording given by the caller) so that a benchmark can iterate every effect × artefact.
The functions never touch the recording's ``meta`` except to append what was applied under
``meta["artefacts"]``.

The upstream denoiser is a median filter followed by a Haar wavelet soft threshold written
here in numpy (20 lines): a wavelet library would be a dependency for a test artefact only.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.ndimage import median_filter
from scipy.signal import lfilter

from simgap.diagnosis.errormodel import MAD_TO_STD
from simgap.errors import GeneratorError
from simgap.recordings import Recording


def _noted(rec: Recording, columns: dict[str, np.ndarray], what: str) -> Recording:
    """A new recording with ``columns`` and ``what`` appended to ``meta["artefacts"]``."""
    meta = dict(rec.meta)
    meta["artefacts"] = [*rec.meta.get("artefacts", []), what]
    return Recording(rec.name, columns, meta)


def _with(rec: Recording, columns: Mapping[str, np.ndarray], what: str) -> Recording:
    cols = dict(rec.columns)
    cols.update({k: np.asarray(v, dtype=np.float64) for k, v in columns.items()})
    n = {v.shape[0] for v in cols.values()}
    if len(n) != 1:
        raise GeneratorError(f"artefact {what}: columns of unequal length {sorted(n)}")
    return _noted(rec, cols, what)


def _rows(rec: Recording, keep: np.ndarray, what: str) -> Recording:
    return _noted(rec, {k: v[keep] for k, v in rec.columns.items()}, what)


def _need(rec: Recording, columns: Sequence[str], what: str) -> None:
    missing = [c for c in columns if c not in rec.columns]
    if missing:
        raise GeneratorError(f"artefact {what}: recording {rec.name!r} has no column "
                             f"{missing[0]!r}")


def quantise(rec: Recording, columns: Sequence[str], step: float) -> Recording:
    """Round ``columns`` to multiples of ``step`` (column units, e.g. 2π/4096 rad)."""
    if not step > 0:
        raise GeneratorError(f"artefact quantise: step must be > 0, got {step!r}")
    _need(rec, columns, "quantise")
    return _with(rec, {c: np.round(rec[c] / step) * step for c in columns},
                 f"quantise({','.join(columns)}, step={step:.4g})")


def finite_difference(rec: Recording, pairs: Mapping[str, str]) -> Recording:
    """Replace each velocity column by the backward difference of its position column.

    Args:
        rec: the recording.
        pairs: velocity column → position column (e.g. ``{"dq1": "q1"}``).
    """
    _need(rec, [*pairs, *pairs.values()], "finite_difference")
    t = rec.t
    out = {}
    for vel, pos in pairs.items():
        d = np.empty_like(rec[pos])
        d[1:] = np.diff(rec[pos]) / np.diff(t)
        d[0] = d[1]
        out[vel] = d
    return _with(rec, out, f"finite_difference({','.join(pairs)})")


def _haar_shrink(x: np.ndarray, levels: int) -> np.ndarray:
    """Haar wavelet soft-threshold denoising, threshold σ_j√(2 ln n) per level j (MAD σ_j)."""
    n0 = x.size
    size = 1 << int(np.ceil(np.log2(max(n0, 2))))
    a = np.concatenate([x, np.full(size - n0, x[-1])])
    details = []
    for _ in range(levels):
        if a.size < 2:
            break
        even, odd = a[0::2], a[1::2]
        details.append((even - odd) / np.sqrt(2.0))
        a = (even + odd) / np.sqrt(2.0)
    universal = np.sqrt(2.0 * np.log(size))
    for d in reversed(details):
        thr = universal * MAD_TO_STD * float(np.median(np.abs(d)))  # per level: coloured noise
        d = np.sign(d) * np.maximum(np.abs(d) - thr, 0.0)
        out = np.empty(2 * a.size)
        out[0::2] = (a + d) / np.sqrt(2.0)
        out[1::2] = (a - d) / np.sqrt(2.0)
        a = out
    return a[:n0]


def upstream_denoise(rec: Recording, columns: Sequence[str], median_window: int = 5,
                     levels: int = 4) -> Recording:
    """Median filter then Haar wavelet shrinkage of ``columns``, as some drives log velocity."""
    _need(rec, columns, "upstream_denoise")
    out = {c: _haar_shrink(median_filter(rec[c], size=median_window, mode="nearest"), levels)
           for c in columns}
    return _with(rec, out, f"upstream_denoise({','.join(columns)})")


def coloured_noise(rec: Recording, columns: Sequence[str], std: Mapping[str, float] | float,
                   corr_time: float, rng: np.random.Generator) -> Recording:
    """Add AR(1) noise of stationary std ``std`` (column units) and correlation time (s)."""
    _need(rec, columns, "coloured_noise")
    dt = float(np.median(np.diff(rec.t)))
    phi = float(np.exp(-dt / corr_time)) if corr_time > 0 else 0.0
    out = {}
    for c in columns:
        s = float(std[c] if isinstance(std, Mapping) else std)
        w = rng.normal(0.0, s * np.sqrt(1.0 - phi**2), size=rec.n)
        w[0] = rng.normal(0.0, s)                       # start in the stationary law
        out[c] = rec[c] + lfilter([1.0], [1.0, -phi], w)  # e[k] = φ e[k-1] + w[k]
    return _with(rec, out, f"coloured_noise({','.join(columns)}, tau={corr_time:g}s)")


def downsample(rec: Recording, rate_hz: float) -> Recording:
    """Keep every k-th sample so that the rate is closest to ``rate_hz`` (no anti-aliasing)."""
    dt = float(np.median(np.diff(rec.t)))
    k = max(1, int(round(1.0 / (rate_hz * dt))))
    keep = np.zeros(rec.n, dtype=bool)
    keep[::k] = True
    return _rows(rec, keep, f"downsample({1.0 / (k * dt):.4g} Hz)")


def jitter(rec: Recording, std_s: float, rng: np.random.Generator) -> Recording:
    """Log time stamps off the true sampling instants by N(0, std_s) (clipped to ±0.45 dt)."""
    dt = float(np.median(np.diff(rec.t)))
    e = np.clip(rng.normal(0.0, std_s, size=rec.n), -0.45 * dt, 0.45 * dt)
    return _with(rec, {"t": rec.t + e}, f"jitter({std_s:.3g} s)")


def cut_gap(rec: Recording, start: float, length: float) -> Recording:
    """Remove the samples with ``start <= t - t0 < start + length`` (s)."""
    rel = rec.t - rec.t[0]
    keep = (rel < start) | (rel >= start + length)
    return _rows(rec, keep, f"cut_gap({start:g}s+{length:g}s)")


def truncate(rec: Recording, duration: float) -> Recording:
    """Keep the first ``duration`` seconds."""
    return _rows(rec, rec.t - rec.t[0] <= duration, f"truncate({duration:g}s)")


@dataclass(frozen=True, kw_only=True)
class Artefact:
    """One named artefact preset: ``apply(recording, pairs, rng) -> recording``.

    ``scenario`` names a :mod:`simgap.diagnosis.scenarios` scenario (``"decay"``,
    ``"circles"``) that makes the recording itself (``apply`` then only notes it).

    ``pairs`` maps each velocity column to its position column (empty for systems without
    positions, e.g. the bicycle's vy, r); artefacts that need positions then do nothing
    more than their other parts and say so in ``needs_positions``.
    """

    name: str
    description: str
    apply: Callable[[Recording, Mapping[str, str], np.random.Generator], Recording]
    needs_positions: bool = False
    scenario: str | None = None


def _std_of(rec: Recording, columns: Sequence[str], share: float) -> dict[str, float]:
    return {c: share * float(np.std(rec[c])) for c in columns}


ARTEFACTS: dict[str, Artefact] = {a.name: a for a in (
    Artefact(name="quantised_encoder", needs_positions=True,
             description="positions rounded to 2π/4096, velocities by finite difference",
             apply=lambda r, p, g: finite_difference(quantise(r, list(p.values()),
                                                              2 * np.pi / 4096), p)),
    Artefact(name="denoised_velocity",
             description="velocities median-filtered and wavelet-shrunk upstream",
             apply=lambda r, p, g: upstream_denoise(r, list(p) or _velocities(r))),
    Artefact(name="coloured_noise",
             description="AR(1) noise, 2 % of each signal's std, 50 ms correlation time",
             apply=lambda r, p, g: coloured_noise(
                 r, _signals(r), _std_of(r, _signals(r), 0.02), 0.05, g)),
    Artefact(name="coarse_100hz", description="logged at 100 Hz",
             apply=lambda r, p, g: downsample(r, 100.0)),
    Artefact(name="timestamp_jitter", description="time stamps off by 20 % of a step (std)",
             apply=lambda r, p, g: jitter(r, 0.2 * float(np.median(np.diff(r.t))), g)),
    Artefact(name="gap", description="a 25 % stretch missing in the middle",
             apply=lambda r, p, g: cut_gap(r, 0.4 * _span(r), 0.25 * _span(r))),
    Artefact(name="short_15s", description="only the first 15 s",
             apply=lambda r, p, g: truncate(r, 15.0)),
    Artefact(name="free_decay_damping", scenario="decay",
             description="pendulum free decays (u = 0), nominal damping 15 % too high, "
                         "with and without a real Coulomb friction",
             apply=lambda r, p, g: _noted(r, dict(r.columns), "scenario(decay)")),
    Artefact(name="one_direction_circles", scenario="circles",
             description="steady circles, one turn direction per run (left run, gap, "
                         "right run)",
             apply=lambda r, p, g: _noted(r, dict(r.columns), "scenario(circles)")),
    Artefact(name="one_direction_single_run", scenario="circles_one_run",
             description="steady circles turning left only (one 20 s run)",
             apply=lambda r, p, g: _noted(r, dict(r.columns), "scenario(circles_one_run)")),
)}


def _span(rec: Recording) -> float:
    return float(rec.t[-1] - rec.t[0])


def _signals(rec: Recording) -> list[str]:
    return [c for c in rec.columns if c != "t"]


def _velocities(rec: Recording) -> list[str]:
    return [c for c in rec.columns if c.startswith("d") and c[1:] in rec.columns]
