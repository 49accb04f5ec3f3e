"""Step 6 of the diagnosis: report.json, report.md with PNG figures, terminal summary.

:func:`write_report` builds everything in a temporary folder next to the target and moves
it into place at the end, so a failure leaves nothing half-written. Figures (matplotlib,
Agg backend):

* ``residual_time.png``: residual per channel over time, ± noise floor band, the fitted
  effects' total, the located segments shaded;
* ``residual_vs_variable.png``: residual per channel against the located variable, with the
  binned mean and the fitted effects' contribution;
* ``simulation.png``: recorded vs nominal vs augmented open-loop simulations over the first
  test windows.
"""

from __future__ import annotations

import json
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from simgap.diagnosis.augmented import save_model  # noqa: E402
from simgap.diagnosis.locate import binned  # noqa: E402
from simgap.diagnosis.pipeline import fmt  # noqa: E402
from simgap.outputs import output_folder  # noqa: E402

MAX_POINTS = 4000


def finite_json(obj: Any) -> Any:
    """Replace non-finite floats (NaN, ±inf) by ``None`` so that report.json is strict JSON."""
    if isinstance(obj, float):
        return obj if np.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: finite_json(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [finite_json(v) for v in obj]
    if isinstance(obj, np.generic):
        return finite_json(obj.item())
    return obj


def summary_lines(data: dict[str, Any]) -> list[str]:
    """Plain-words summary of a report (what the CLI prints)."""
    lines = [f"{data['recording']}: {data['samples']} samples, model {data['model']}"]
    mm = data["mismatch"]
    if not mm["significant"]:
        lines.append("No mismatch beyond the noise: the recording matches the nominal model "
                     "(no effect named).")
    else:
        for c in mm["channels"]:
            state = "ABOVE" if c["significant"] else "within"
            lines.append(f"  {c['channel']}: residual RMS {c['residual_rms']:.3g} "
                         f"{c.get('unit', '')}, noise {c['noise_rms']:.3g} ({state} noise)")
        for r in mm["regions"]:
            lines.append(f"  where: {r['channel']}: {r['text']}")
    for e in data["effects"]:
        lines.append(f"  found: {e['summary']}")
    for w in data.get("warnings", []):
        lines.append(f"  warning: {w['text']}")
    if mm["significant"]:
        lines.append(f"  unexplained: {100 * data['unexplained_fraction']:.0f} % of the "
                     "held-out residual is not explained by a named effect")
    f = data["fit"]
    lines.append(f"  held-out simulation error score ({f['horizon_s']:g} s windows): nominal "
                 f"{f['nominal']['rollout_score']:.3g} -> augmented "
                 f"{f['augmented']['rollout_score']:.3g}")
    return lines


def _thin(n: int) -> np.ndarray:
    return np.arange(0, n, max(1, n // MAX_POINTS))


def _fig_residual_time(report, path: Path) -> None:
    sys, t = report.system, report.system.t
    nc = len(sys.channels)
    fig, axes = plt.subplots(nc, 1, figsize=(9, 2.6 * nc), sharex=True, squeeze=False)
    idx = _thin(len(t))
    for i, ax in enumerate(axes[:, 0]):
        ax.plot(t[idx], report.residual[idx, i], lw=0.6, color="0.35", label="residual")
        ax.fill_between(t[idx], -report.noise[i], report.noise[i], color="tab:blue", alpha=0.2,
                        label="± noise floor")
        if report.term_preds:
            ax.plot(t[idx], report.fitted_pred[idx, i], lw=0.9, color="tab:red",
                    label="named effects")
        for s in report.data["mismatch"]["segments"]:
            if s["channel"] == sys.channels[i]:
                ax.axvspan(s["t_start"], s["t_end"], color="tab:orange", alpha=0.25)
        ax.axvline(report.data["fit"]["split"]["test"][0], color="k", ls="--", lw=0.8)
        ax.set_ylabel(f"{sys.channels[i]} ({sys.channel_units[i]})")
        ax.legend(loc="upper right", fontsize=7)
    axes[-1, 0].set_xlabel("time t (s)")
    axes[0, 0].set_title("Residual over time (shaded: located segments; dashed: train | test)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _fig_residual_vs(report, path: Path) -> None:
    sys = report.system
    variables = sys.locate_variables()
    nc = len(sys.channels)
    fig, axes = plt.subplots(1, nc, figsize=(5 * nc, 3.8), squeeze=False)
    regions = report.data["mismatch"]["regions"]
    idx = _thin(len(sys.t))
    for i, ax in enumerate(axes[0]):
        ch = sys.channels[i]
        cand = [r["variable"] for r in regions if r["channel"] == ch and r["variable"] in
                variables]
        var = cand[0] if cand else next(iter(variables))
        x, unit = variables[var]
        ax.scatter(x[idx], report.residual[idx, i], s=2, color="0.6", label="residual")
        xb, rb, _ = binned(x, report.residual[:, i])
        ax.plot(xb, rb, "o-", color="k", ms=3, lw=1, label="binned mean")
        if report.term_preds:
            ax.scatter(x[idx], report.fitted_pred[idx, i], s=2, color="tab:red",
                       label="fitted effects")
        ax.set_xlabel(f"{var} ({unit})")
        ax.set_ylabel(f"residual at {ch} ({sys.channel_units[i]})")
        ax.set_title(f"{ch}: residual vs {var}")
        ax.legend(fontsize=7, markerscale=3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _fig_simulation(report, path: Path) -> None:
    ex = report.comparison.example
    names, units = report.data["fit"]["rollout_names"], report.data["fit"]["rollout_units"]
    n = len(names)
    fig, axes = plt.subplots(n, 1, figsize=(9, 2.2 * n), sharex=True, squeeze=False)
    breaks = list(ex["breaks"])
    wl = int(ex["window_len"])
    seg = [np.arange(k, min(k + wl, len(ex["t"]))) for k in range(0, len(ex["t"]), wl)]
    for i, ax in enumerate(axes[:, 0]):
        for k, s in enumerate(seg):
            ax.plot(ex["t"][s], ex["recorded"][s, i], color="k", lw=1.2,
                    label="recording" if k == 0 else None)
            ax.plot(ex["t"][s], ex["nominal"][s, i], color="tab:blue", lw=1, ls="--",
                    label="nominal" if k == 0 else None)
            ax.plot(ex["t"][s], ex["augmented"][s, i], color="tab:red", lw=1,
                    label="augmented" if k == 0 else None)
        for b in breaks:
            ax.axvline(b, color="0.8", lw=0.6)
        ax.set_ylabel(f"{names[i]} ({units[i]})")
        ax.legend(loc="upper right", fontsize=7)
    axes[-1, 0].set_xlabel("time t (s)")
    axes[0, 0].set_title(f"Held-out open-loop simulations from recorded states "
                         f"({report.comparison.horizon:g} s windows)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def markdown(data: dict[str, Any]) -> str:
    """report.md text (figures referenced by relative path)."""
    f = data["fit"]
    out = [f"# simgap diagnosis: {data['recording']}", "",
           f"Model `{data['model']}`, {data['samples']} samples.", "", "## Summary", ""]
    out += [f"- {line.strip()}" for line in summary_lines(data)[1:]]
    out += ["", "## Where", "", "| channel | residual RMS | noise RMS | significant |",
            "|---|---|---|---|"]
    for c in data["mismatch"]["channels"]:
        out.append(f"| {c['channel']} | {c['residual_rms']:.4g} {c.get('unit', '')} | "
                   f"{c['noise_rms']:.4g} | {'yes' if c['significant'] else 'no'} |")
    if data["mismatch"]["segments"]:
        out += ["", "Segments where the residual is largest: " + ", ".join(
            f"{s['channel']} {s['t_start']:.2f}–{s['t_end']:.2f} s"
            for s in data["mismatch"]["segments"]) + "."]
    for r in data["mismatch"]["regions"]:
        out.append(f"- {r['channel']} / {r['variable']}: {r['text']}")
    out += ["", "![residual over time](residual_time.png)", "", "## What", ""]
    if data["effects"]:
        out += ["| effect | channel | parameters (± stderr) | explained |", "|---|---|---|---|"]
        for e in data["effects"]:
            ps = ", ".join("{} = {} ± {} {}".format(k, *fmt(v, e["stderr"][k]),
                                                    e.get("units", {}).get(k, "")).strip()
                           for k, v in e["parameters"].items())
            out.append(f"| {e['effect']} | {e['channel']} | {ps} | "
                       f"{100 * e['explained_fraction']:.0f} % |")
    else:
        out.append("No effect of the vocabulary improves the held-out fit beyond the noise.")
    for w in data.get("warnings", []):
        out.append(f"\n> Warning: {w['text']}")
    out += ["", f"Unexplained share of the held-out residual: "
            f"{100 * data['unexplained_fraction']:.0f} % (noise alone accounts for about "
            f"{100 * data['noise_fraction']:.0f} %).", "",
            "![residual against the located variable](residual_vs_variable.png)", "",
            "## How much better", "",
            f"Train {f['split']['train'][0]:.2f}–{f['split']['train'][1]:.2f} s, test "
            f"{f['split']['test'][0]:.2f}–{f['split']['test'][1]:.2f} s. {f['method']}.", "",
            "| error | " + " | ".join(f"{n} ({u})" for n, u in zip(
                f["derivative_names"], f["derivative_units"], strict=True)) + " |",
            "|---|" + "---|" * len(f["derivative_names"])]
    for m in ("nominal", "augmented"):
        out.append(f"| derivative RMSE, {m} | " + " | ".join(
            f"{v:.4g}" for v in f[m]["derivative_rmse"]) + " |")
    out += ["", "| error | " + " | ".join(f"{n} ({u})" for n, u in zip(
        f["rollout_names"], f["rollout_units"], strict=True)) + " | score |",
        "|---|" + "---|" * (len(f["rollout_names"]) + 1)]
    for m in ("nominal", "augmented"):
        out.append(f"| simulation RMSE, {m} | " + " | ".join(
            f"{v:.4g}" for v in f[m]["rollout_rmse"]) + f" | {f[m]['rollout_score']:.3g} |")
    out += ["", "![nominal vs augmented simulation](simulation.png)", "",
            "The augmented model is saved as `augmented_model.json` "
            "(`simgap.diagnosis.augmented.load_model`).", ""]
    return "\n".join(out)


def write_report(report, out_dir: str | os.PathLike, figures: bool = True,
                 inputs: Sequence[str | os.PathLike] = ()) -> Path:
    """Write report.json, report.md, figures and augmented_model.json into ``out_dir``.

    Transactional (:func:`simgap.outputs.output_folder`): everything is written to a fresh
    temporary sibling folder and moved into place at the end; an existing ``out_dir`` is
    replaced only if it is empty or a previous simgap output, and a target that is or holds
    one of ``inputs`` is refused (:class:`~simgap.errors.OutputError`).
    """
    with output_folder(out_dir, kind="diagnose", inputs=inputs) as tmp:
        (tmp / "report.json").write_text(json.dumps(finite_json(report.data), indent=2,
                                                    allow_nan=False),
                                         encoding="utf-8")
        (tmp / "report.md").write_text(markdown(report.data), encoding="utf-8")
        if hasattr(report.augmented, "to_dict"):
            save_model(report.augmented, tmp / "augmented_model.json")
        if figures:
            _fig_residual_time(report, tmp / "residual_time.png")
            _fig_residual_vs(report, tmp / "residual_vs_variable.png")
            _fig_simulation(report, tmp / "simulation.png")
    return Path(out_dir)
