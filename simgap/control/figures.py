"""Matplotlib figures (PNG) of the downstream studies; one function per study."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from simgap._plotting import save_figure


def _pyplot() -> Any:
    # No backend switch: headless, matplotlib picks Agg itself; in Jupyter the inline backend
    # stays (the figures are saved and closed, so nothing is shown twice).
    import matplotlib.pyplot as plt

    return plt


def rl_curves_figure(runs: list[dict], total: int, path: Path, *,
                     overwrite: bool = False) -> None:
    """Learning curves of ``train_agent`` runs to a PNG (mean over seeds ± 95 % t-interval).

    Each seed is a thin line; the axis is symmetric-log (linear within ±10). Left: the
    deterministic evaluation return (``run["evals"]``, if recorded) against env
    steps; right: the training episodes' returns, interpolated on a common step grid.
    """
    from simgap.control.rl import mean_ci95

    plt = _pyplot()
    styles = (("plain", "tab:gray", "plain observation"),
              ("residual", "tab:blue", "+ scaled ĝ (ResidualObservation)"),
              ("residual_fixed", "tab:orange", "+ ĝ, fixed declared scale"))
    has_evals = any(run.get("evals") for run in runs)
    fig, axes = plt.subplots(1, 2 if has_evals else 1, figsize=(12 if has_evals else 7, 4.2),
                             squeeze=False)
    axes = axes[0]
    base = [b for run in runs for b in run["base_returns"]]
    firsts = [run["episodes"][0]["step"] for run in runs if run["episodes"]]
    grid = np.linspace(max(firsts) if firsts else 0, total, 40)
    for variant, color, label in styles:
        rs = [r for r in runs if r["variant"] == variant]
        if not rs:
            continue
        panels = []
        if has_evals:
            steps = np.array([e["step"] for e in rs[0]["evals"]])
            panels.append((axes[0], steps, [[e["mean"] for e in r["evals"]] for r in rs
                                            if len(r["evals"]) == len(steps)]))
        train = [np.interp(grid, [e["step"] for e in r["episodes"]],
                           [e["r"] for e in r["episodes"]], left=np.nan)
                 for r in rs if r["episodes"]]
        panels.append((axes[-1], grid, train))
        for ax, x, curves in panels:
            if not curves:
                continue
            m, h = mean_ci95(np.array(curves))
            for c in curves:  # each seed, thin
                ax.plot(x, c, color=color, lw=0.6, alpha=0.5)
            ax.plot(x, m, color=color, marker="o" if ax is not axes[-1] else None, ms=3,
                    lw=2, label=f"{label}: mean of {len(curves)} seeds (thin: each seed)")
            ax.fill_between(x, m - h, m + h, color=color, alpha=0.2, lw=0)
    titles = (["deterministic evaluation, μ = 0.45 / 0.6 / 0.9 (mean)"] if has_evals else []) \
        + ["training episodes (stochastic policy, random μ)"]
    for ax, title in zip(axes, titles, strict=True):
        if base:
            ax.axhline(float(np.mean(base)), color="k", ls="--", lw=1,
                       label="base controller alone (eval)")
        # symmetric log: the returns near the base controller (≈ −4) and the blow-ups of
        # early policies (≈ −10⁴) on one axis
        ax.set_yscale("symlog", linthresh=10.0)
        ax.set_xlabel("environment steps (10 ms each)")
        ax.set_ylabel("episode return (rad²/s², symlog)")
        ax.set_title(title, fontsize=10)
    handles, labels = axes[-1].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=3, fontsize=8, frameon=False)
    fig.suptitle("SAC residual RL, yaw-rate tracking on random-μ roads; return "
                 "−100·Σ(r − r_ref)² per 4 s episode (band: 95 % t-interval of the mean)",
                 fontsize=10)
    fig.tight_layout(rect=(0, 0.07, 1, 1))
    save_figure(fig, path, dpi=120, overwrite=overwrite, close=True)


def compensation_figure(res: dict, path: Path, *, overwrite: bool = False) -> None:
    """Plot :func:`~simgap.control.experiments.compensation_study` as bars to a PNG.

    An existing file at ``path`` is replaced only with ``overwrite=True``.
    """
    plt = _pyplot()

    kinds = [k for k in ("instantaneous", "integral", "minibatch") if k in res["bicycle"]]
    man, bic = res["manipulator_rmse_rad"], res["bicycle"]
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    for ax, title, unit, plain, true, get in (
            (axes[0], "Manipulator FL + ĝ feed-forward", "joint RMSE (rad)", man["plain"],
             man["true_residual"], lambda k, m: man[k][m]),
            (axes[1], "Bicycle yaw-rate inversion + ĝ (μ = 0.5)", "yaw-rate RMSE (rad/s)",
             bic["plain"]["rmse_rad_s"], bic["true_residual"]["rmse_rad_s"],
             lambda k, m: bic[k][m]["rmse_rad_s"])):
        x = np.arange(len(kinds))
        ax.bar(x - 0.2, [get(k, "frozen") for k in kinds], 0.4, label="frozen network")
        ax.bar(x + 0.2, [get(k, "online") for k in kinds], 0.4, label="online (from scratch)")
        ax.axhline(plain, color="k", ls="--", label="no compensation")
        ax.axhline(true, color="tab:green", ls=":", label="exact residual (bound)")
        ax.set_ylim(0.0, 1.5 * max(plain, *[get(k, m) for k in kinds
                                            for m in ("frozen", "online")]))
        ax.set_xticks(x, kinds)
        ax.set_xlabel("identifier")
        ax.set_ylabel(unit)
        ax.set_title(title)
        ax.legend(fontsize=8)
    fig.tight_layout()
    save_figure(fig, path, dpi=120, overwrite=overwrite, close=True)

def mpc_figure(res: dict, path: Path, *, overwrite: bool = False) -> None:
    """Plot traces, errors and compute times of ``mpc_study`` to a PNG.

    An existing file at ``path`` is replaced only with ``overwrite=True``.
    """
    plt = _pyplot()

    variants = res["variants"]
    fig, axes = plt.subplots(1, 3, figsize=(15, 4))
    first = next(iter(variants.values()))["trace"]
    axes[0].plot(first["t"], first["r_ref"], "k--", label="r_ref")
    for name, v in variants.items():
        axes[0].plot(v["trace"]["t"], v["trace"]["r"], label=name)
        axes[1].plot(v["trace"]["t"], np.subtract(v["trace"]["r"], v["trace"]["r_ref"]),
                     label=name)
    axes[0].set(xlabel="time (s)", ylabel="yaw rate r (rad/s)", title="MPC yaw-rate tracking")
    axes[1].set(xlabel="time (s)", ylabel="r − r_ref (rad/s)", title="tracking error")
    names = list(variants)
    x = np.arange(len(names))
    axes[2].bar(x - 0.2, [variants[n]["rmse_rad_s"] for n in names], 0.4,
                label="yaw-rate RMSE (rad/s)")
    ax2 = axes[2].twinx()
    ax2.bar(x + 0.2, [1e3 * variants[n]["compute_s"]["p50"] for n in names], 0.4,
            color="tab:orange", label="compute per step, median (ms)")
    axes[2].set_xticks(x, names, rotation=15, fontsize=8)
    axes[2].set(ylabel="yaw-rate RMSE (rad/s)", title="error and compute time per step")
    ax2.set_ylabel("median compute per control step (ms)")
    h1, l1 = axes[2].get_legend_handles_labels()
    h2, l2 = ax2.get_legend_handles_labels()
    axes[2].legend(h1 + h2, l1 + l2, fontsize=8)
    for ax in axes[:2]:
        ax.legend(fontsize=8)
    fig.tight_layout()
    save_figure(fig, path, dpi=120, overwrite=overwrite, close=True)
