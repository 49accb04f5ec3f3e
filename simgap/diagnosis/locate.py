"""Step 2 of the diagnosis: where the residual lives — channels, time segments, state region.

* Channels: a channel is significant when its residual RMS exceeds its noise floor by
  :data:`SIGNIFICANCE` (the structured part is then at least ~0.75 of the noise RMS).
* Segments: the moving RMS of the residual over :data:`SEGMENT_WINDOW_S` seconds; intervals
  where it exceeds both twice the noise floor and its own 90th percentile, merged when closer
  than one window, the strongest :data:`MAX_SEGMENTS` kept.
* Regions: for each candidate variable (positions, velocities, accelerations; slip angles,
  lateral acceleration, speed, ...) the residual's mean in 24 quantile bins of the variable;
  the share of residual variance these bin means explain (correlation ratio η²) ranks the
  variables (a second one is kept only if it explains at least 75 % as much as the best),
  and the shape of the binned curve of the best one(s) is put in plain words
  (constant offset, sign flip with the variable, growth with its magnitude, largest near a
  value).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

SIGNIFICANCE = 1.25
SEGMENT_WINDOW_S = 0.25
MAX_SEGMENTS = 5
N_BINS = 24
MIN_ETA2 = 0.1
SECOND_SHARE = 0.75


@dataclass(frozen=True)
class ChannelStat:
    """RMS of a channel's residual and of its noise floor (channel units)."""

    channel: str
    residual_rms: float
    noise_rms: float
    significant: bool


def channel_stats(channels: Sequence[str], residual: np.ndarray, noise: np.ndarray
                  ) -> list[ChannelStat]:
    """Significance per channel (residual RMS > SIGNIFICANCE × noise RMS)."""
    rms = np.sqrt(np.mean(residual**2, axis=0))
    return [ChannelStat(c, float(r), float(n), bool(r > SIGNIFICANCE * n))
            for c, r, n in zip(channels, rms, noise, strict=True)]


def segments(t: np.ndarray, residual: np.ndarray, noise: float, channel: str
             ) -> list[dict]:
    """Time intervals (s) where the channel's residual is largest."""
    dt = float(t[1] - t[0])
    w = max(1, int(round(SEGMENT_WINDOW_S / dt)))
    power = np.convolve(residual**2, np.ones(w) / w, mode="same")
    mrms = np.sqrt(power)
    thr = max(2.0 * noise, float(np.quantile(mrms, 0.9)))
    above = mrms > thr
    if not above.any():
        return []
    edges = np.diff(above.astype(int))
    starts = list(np.where(edges == 1)[0] + 1)
    ends = list(np.where(edges == -1)[0] + 1)
    if above[0]:
        starts.insert(0, 0)
    if above[-1]:
        ends.append(len(above))
    merged: list[list[int]] = []
    for s, e in zip(starts, ends, strict=True):
        if merged and s - merged[-1][1] < w:
            merged[-1][1] = e
        else:
            merged.append([s, e])
    scored = sorted(merged, key=lambda se: -float(np.sum(power[se[0]:se[1]])))[:MAX_SEGMENTS]
    return [{"channel": channel, "t_start": round(float(t[s]), 4),
             "t_end": round(float(t[min(e, len(t) - 1)]), 4)}
            for s, e in sorted(scored)]


def binned(x: np.ndarray, r: np.ndarray, n_bins: int = N_BINS
           ) -> tuple[np.ndarray, np.ndarray, float]:
    """Bin centres, bin means of r, and η² (share of var(r) explained by the bin means)."""
    edges = np.unique(np.quantile(x, np.linspace(0, 1, n_bins + 1)))
    if len(edges) < 3:
        return np.array([np.mean(x)]), np.array([np.mean(r)]), 0.0
    k = np.clip(np.searchsorted(edges, x, side="right") - 1, 0, len(edges) - 2)
    cnt = np.bincount(k, minlength=len(edges) - 1)
    ok = cnt > 0
    mean_r = np.bincount(k, weights=r, minlength=len(edges) - 1)[ok] / cnt[ok]
    mean_x = np.bincount(k, weights=x, minlength=len(edges) - 1)[ok] / cnt[ok]
    var = float(np.var(r))
    eta2 = float(np.sum(cnt[ok] * (mean_r - np.mean(r)) ** 2) / (len(r) * var)) if var > 0 \
        else 0.0
    return mean_x, mean_r, eta2


def describe(name: str, unit: str, unit_r: str, xb: np.ndarray, rb: np.ndarray,
             overall_mean: float, overall_rms: float) -> str:
    """Plain words for the shape of a binned residual curve against one variable."""
    span = float(np.max(rb) - np.min(rb))
    if abs(overall_mean) > 0.6 * overall_rms and span < abs(overall_mean):
        return (f"roughly constant offset of {overall_mean:.3g} {unit_r}, little dependence "
                f"on {name}")
    neg, pos = rb[xb < 0], rb[xb > 0]
    words = []
    if len(neg) and len(pos) and xb.min() < 0 < xb.max():
        mn, mp = float(np.mean(neg)), float(np.mean(pos))
        if mn * mp < 0 and min(abs(mn), abs(mp)) > 0.3 * max(abs(mn), abs(mp)):
            words.append(f"residual flips sign with {name} "
                         f"({'same' if mp > 0 else 'opposite'} sign as {name})")
    mag = np.abs(rb - (np.mean(rb) if not words else 0.0))
    order = np.argsort(np.abs(xb))
    inner = float(np.mean(mag[order[: max(1, len(order) // 4)]]))
    outer = float(np.mean(mag[order[-max(1, len(order) // 4):]]))
    if outer > 1.5 * inner:
        words.append(f"grows with |{name}|")
    elif inner > 1.5 * outer:
        words.append(f"largest near {name} = 0")
    if not words:
        i = int(np.argmax(np.abs(rb)))
        words.append(f"varies with {name}; largest near {name} = {xb[i]:.3g} {unit}")
    return "; ".join(words)


def regions(channel: str, unit_r: str, residual: np.ndarray,
            variables: Mapping[str, tuple[np.ndarray, str]], max_regions: int = 2
            ) -> list[dict]:
    """Variables the channel's residual depends on most, with plain-words text."""
    scored = []
    for name, (x, unit) in variables.items():
        if np.ptp(x) == 0:
            continue
        xb, rb, eta2 = binned(x, residual)
        scored.append((eta2, name, unit, xb, rb))
    scored.sort(key=lambda s: -s[0])
    mean, rms = float(np.mean(residual)), float(np.sqrt(np.mean(residual**2)))
    out = []
    if abs(mean) > 0.6 * rms and (not scored or scored[0][0] < 0.3):
        out.append({"channel": channel, "variable": "constant",
                    "text": f"roughly constant offset of {mean:.3g} {unit_r}",
                    "explained_share": 0.0})
    best = scored[0][0] if scored else 0.0
    for eta2, name, unit, xb, rb in scored[:max_regions]:
        # a weaker second variable is usually just correlated with the first one
        if eta2 < MIN_ETA2 or eta2 < SECOND_SHARE * best:
            continue
        out.append({"channel": channel, "variable": name,
                    "text": describe(name, unit, unit_r, xb, rb, mean, rms),
                    "explained_share": round(eta2, 3)})
    return out
