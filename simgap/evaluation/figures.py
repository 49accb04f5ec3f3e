"""Figures of the thesis' evaluation (spirit of Fig. 4.2, 4.3, 4.5-4.8): matplotlib PNGs (Agg).

* :func:`plot_online`: per method (rows), ‖x̃‖ over time (left) and the online ĝ of the case's
  plot channel (joint 1 friction torque, front axle force) against the target (right).
* :func:`plot_consistency`: per method (rows) and freeze time (columns), the frozen model
  re-evaluated on the history t < T_f against the target, over the case's abscissa (joint 1
  velocity, front slip angle), which shows the friction curve / the tire saturation curve.
* :func:`plot_timing`: per-step compute-time distributions and run-wise maxima (Table 4.6).

Figures are built with :class:`matplotlib.figure.Figure` (no pyplot state), so they work in
any backend and thread; in Jupyter, ``%matplotlib inline`` (or ``display(fig)``) shows them.
Legends sit beside the axes, log axes start near the data's smallest meaningful value (1st
percentile) rather than at a near-zero first sample, and empty histogram bins are gaps.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from simgap._plotting import legend_outside, save_figure
from simgap.evaluation.cases import METHOD_LABELS
from simgap.evaluation.runner import CaseResult

_COLORS = {"instantaneous": "tab:red", "minibatch": "tab:green", "integral": "tab:blue"}
_MAX_POINTS = 6000


def _subsample(n: int, max_points: int = _MAX_POINTS) -> np.ndarray:
    """Evenly spaced indices (at most ``max_points``) of n samples."""
    if n <= max_points:
        return np.arange(n)
    return np.linspace(0, n - 1, max_points).astype(np.int64)


def log_floor(values: np.ndarray, percentile: float = 1.0) -> float | None:
    """Lower limit of a log axis: the ``percentile`` of the positive finite values.

    A single near-zero sample (an observer error of 1e−23 at t = 0) would otherwise stretch a
    log axis over twenty decades of nothing. ``None`` when no value is positive.
    """
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v) & (v > 0)]
    return float(np.percentile(v, percentile)) if v.size else None


def _thin_series(t: np.ndarray, y: np.ndarray, max_points: int = 20000
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Keep a line plot light: every k-th sample so that at most ``max_points`` remain."""
    step = max(1, int(np.ceil(t.size / max_points)))
    return t[::step], y[::step]


def plot_online(cr: CaseResult, path: Path | None = None, *,
                     overwrite: bool = False) -> Figure:
    """Online estimation figure of one case (thesis Fig. 4.2 / 4.5 / 4.7).

    Args:
        cr: the case result.
        path: if given, the PNG is written there (atomically).
        overwrite: replace an existing file at ``path`` (otherwise refused with
            :class:`~simgap.errors.OutputError`).

    Returns:
        The figure.
    """
    label, unit, channel = cr.case.plot_channel  # type: ignore[misc]
    kinds = list(cr.results)
    fig = Figure(figsize=(14, 2.6 * max(1, len(kinds)) + 0.6), layout="constrained")
    axes = np.atleast_2d(fig.subplots(max(1, len(kinds)), 2, sharex=True, squeeze=False))
    for row, kind in enumerate(kinds):
        res = cr.results[kind]
        t_next = res.t + cr.transitions.dt
        ax = axes[row, 0]
        ts, ys = _thin_series(t_next, res.x_tilde_norm)
        what = (r"$\|x_{k+1} - \hat{x}^{\mathrm{pred}}_{k+1}\|$ (one-step prediction)"
                if kind == "minibatch" else r"$\|\tilde{x}\| = \|x - \hat{x}\|$ (observer)")
        ax.plot(ts, ys, color=_COLORS.get(kind, "k"), lw=0.8)
        ax.set_ylabel("‖x̃‖ (state units)")
        ax.set_title(f"{METHOD_LABELS.get(kind, kind)}: {what}", fontsize=10)
        ax.set_yscale("log")
        floor = log_floor(ys)
        if floor is not None:
            ax.set_ylim(bottom=floor)
        ax = axes[row, 1]
        ts, yt = _thin_series(res.t, channel(res.target))
        _, yo = _thin_series(res.t, channel(res.g_online))
        ax.plot(ts, yt, color="0.4", lw=1.4, label="target g")
        ax.plot(ts, yo, color=_COLORS.get(kind, "k"), lw=0.8, ls="--", label="online ĝ")
        for k, tf in enumerate(cr.freeze_times):
            ax.axvline(tf, color="k", lw=0.6, ls=":",
                       label="freeze times T_f (consistency test)" if k == 0 else None)
        ax.set_ylabel(f"{label} ({unit})")
        ax.set_title(f"{METHOD_LABELS.get(kind, kind)}: online ĝ vs target")
        for a in axes[row]:
            a.grid(alpha=0.3)
        legend_outside(ax)
    for a in axes[-1]:
        a.set_xlabel("time (s)")
    fig.suptitle(f"{cr.case.title} — online estimation"
                 f"{' (quick run)' if cr.quick else ''}", fontsize=11)
    if path is not None:
        save_figure(fig, path, dpi=100, overwrite=overwrite)
    return fig


def plot_consistency(cr: CaseResult, path: Path | None = None, *,
                     overwrite: bool = False) -> Figure:
    """Model-consistency figure of one case (thesis Fig. 4.3 / 4.6 / 4.8).

    Each panel shows, for t < T_f, the target residual and the frozen model's output
    ĝ = Ŵ_{T_f} tanh(V̂_{T_f} x̄(t)) against the case's abscissa (points, subsampled).

    Args:
        cr: the case result.
        path: if given, the PNG is written there (atomically).
        overwrite: replace an existing file at ``path`` (otherwise refused with
            :class:`~simgap.errors.OutputError`).

    Returns:
        The figure.
    """
    label, unit, channel = cr.case.plot_channel  # type: ignore[misc]
    xlab, xunit, abscissa = cr.case.plot_abscissa  # type: ignore[misc]
    kinds = list(cr.results)
    n_f = len(cr.freeze_times)
    fig = Figure(figsize=(5.5 * n_f + 2.5, 3.0 * max(1, len(kinds)) + 0.6),
                 layout="constrained")
    axes = fig.subplots(max(1, len(kinds)), n_f, squeeze=False, sharex=True, sharey=True)
    xs_all = abscissa(cr.transitions.extra)
    for row, kind in enumerate(kinds):
        res = cr.results[kind]
        for col, fm in enumerate(res.frozen):
            ax = axes[row, col]
            idx = _subsample(fm.n_history)
            xs = xs_all[:fm.n_history][idx]
            ax.plot(xs, channel(res.target[:fm.n_history][idx]), ".", ms=2.5, color="0.5",
                    label="target g")
            ax.plot(xs, channel(fm.g_frozen[idx]), ".", ms=2.0,
                    color=_COLORS.get(kind, "k"), alpha=0.7,
                    label=f"frozen ĝ (Ŵ, V̂ at {fm.t_freeze:g} s)")
            ax.set_title(f"{METHOD_LABELS.get(kind, kind)}, frozen at T_f = {fm.t_freeze:g} s",
                         fontsize=10)
            ax.grid(alpha=0.3)
            if col == n_f - 1:
                legend_outside(ax, markerscale=4)
            if col == 0:
                ax.set_ylabel(f"{label} ({unit})")
            if row == len(kinds) - 1:
                ax.set_xlabel(f"{xlab} ({xunit})")
    fig.suptitle(f"{cr.case.title}\nreproducibility test: frozen model on the history t < T_f"
                 f"{' (quick run)' if cr.quick else ''}", fontsize=11)
    if path is not None:
        save_figure(fig, path, dpi=100, overwrite=overwrite)
    return fig


def plot_timing(timing: dict[str, Any], path: Path | None = None, *,
                     overwrite: bool = False) -> Figure:
    """Plot step-time histograms and run-wise maxima per method (thesis Sec. 4.5.2).

    Args:
        timing: the dict returned by :func:`simgap.evaluation.timing.run_timing` (with its
            ``"raw"`` entry).
        path: if given, the PNG is written there (atomically).
        overwrite: replace an existing file at ``path`` (otherwise refused with
            :class:`~simgap.errors.OutputError`).

    Returns:
        The figure.
    """
    raw = timing["raw"]
    deadline_ms = timing["settings"]["deadline_ms"]
    fig = Figure(figsize=(14, 4.2), layout="constrained")
    ax_h, ax_m = fig.subplots(1, 2)
    for kind, r in raw.items():
        hist = np.asarray(r["hist_counts"], dtype=float)
        # empty bins are gaps (NaN), not a line drawn at a made-up floor across them
        ax_h.stairs(np.where(hist > 0, hist, np.nan), np.asarray(r["hist_edges_ms"]),
                    color=_COLORS.get(kind, "k"), label=METHOD_LABELS.get(kind, kind))
        mx = np.asarray(r["run_max_ms"])
        ax_m.plot(np.arange(1, mx.size + 1), mx, "o-", ms=3, lw=0.8,
                  color=_COLORS.get(kind, "k"), label=METHOD_LABELS.get(kind, kind))
    ax_h.axvline(deadline_ms, color="k", ls=":", label=f"deadline {deadline_ms:g} ms")
    ax_m.axhline(deadline_ms, color="k", ls=":", label=f"deadline {deadline_ms:g} ms")
    ax_h.set_xscale("log")
    ax_h.set_yscale("log")
    ax_h.set_xlabel("per-step compute time (ms)")
    ax_h.set_ylabel("number of steps")
    ax_h.set_title("Distribution of per-step compute time (all runs)")
    ax_m.set_yscale("log")
    ax_m.set_xlabel("run")
    ax_m.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax_m.set_ylabel("run-wise maximum step time (ms)")
    ax_m.set_title("Worst step of each run")
    ax_h.set_ylim(bottom=0.5)  # one step is the smallest non-empty count
    for ax in (ax_h, ax_m):
        ax.grid(alpha=0.3)
    legend_outside(ax_m)
    s = timing["settings"]
    fig.suptitle(f"Identifier step time, Case 1 ({s['n_runs']} runs × {s['n_steps']} steps per "
                 f"method; perf_counter_ns)")
    if path is not None:
        save_figure(fig, path, dpi=100, overwrite=overwrite)
    return fig
