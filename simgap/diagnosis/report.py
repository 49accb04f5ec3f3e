"""Step 6 of the diagnosis: report.json, report.md, report.html, PNG figures, summary.

report.md starts with a one-line verdict, then where the mismatch is, what explains it
(with additive shares, :mod:`simgap.diagnosis.shares`), the effects tried and rejected, the
identifiability of the named parameters (:mod:`simgap.diagnosis.report_sections`) and how
much better the augmented model simulates held-out data. report.html is the same text in one
self-contained file (:mod:`simgap.diagnosis.report_html`).

:func:`write_report` builds everything in a temporary folder next to the target and moves
it into place at the end, so a failure leaves nothing half-written. Figures are
:class:`matplotlib.figure.Figure` objects (no pyplot state, no backend switch, so importing
this module leaves a notebook's inline backend alone):

* ``residual_time.png``: residual per channel over time, ± noise floor band, the fitted
  effects' total, the located segments shaded;
* ``residual_vs_variable.png``: residual per channel against the located variable, with the
  binned mean and the fitted effects' contribution;
* ``simulation.png``: recorded vs nominal vs augmented open-loop simulations over the whole
  test part;
* ``identifiability.png``: correlation matrix of the named parameters (two or more).

Fitted contributions are drawn only where they were fitted: samples the fit leaves out (a
joint's stick phases, ``prepared.fit_mask``) are NaN, so the curve has a gap there instead of
dropping to zero. Legends sit beside the axes, never on the data; figures of long recordings
grow wider (:func:`figure_width`).
"""

from __future__ import annotations

import io
import json
import os
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from simgap._plotting import legend_outside
from simgap.diagnosis.augmented import save_model
from simgap.diagnosis.locate import binned
from simgap.diagnosis.pipeline import fmt
from simgap.diagnosis.report_html import correlation_figure, html_page
from simgap.diagnosis.report_sections import (
    explained_lines,
    identifiability_lines,
    tried_lines,
    verdict,
    with_fallbacks,
)
from simgap.outputs import output_folder

MAX_POINTS = 4000
#: Figure width (in) of recordings up to :data:`WIDE_AFTER_S` long; longer ones grow to
#: :data:`MAX_WIDTH_IN` at :data:`WIDTH_S_PER_IN` seconds per extra inch.
BASE_WIDTH_IN, MAX_WIDTH_IN, WIDE_AFTER_S, WIDTH_S_PER_IN = 9.0, 24.0, 60.0, 25.0
#: Text that defines the simulation score wherever it is printed.
SCORE_MEANING = ("RMS over the states of simulation RMSE / the state's standard deviation "
                 "on the test part; 0 is perfect, 1 is an error as large as the signal's "
                 "spread")


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
    lines = [f"{data['recording']}: {data['samples']} samples, model {data['model']}",
             f"  verdict: {verdict(data)}"]
    mm = data["mismatch"]
    if mm["significant"]:
        for c in mm["channels"]:
            state = "ABOVE" if c["significant"] else "within"
            unit = unit_suffix(c.get("unit", ""))
            lines.append(f"  {c['channel']}: residual RMS {c['residual_rms']:.3g}{unit}, "
                         f"noise {c['noise_rms']:.3g}{unit} ({state} noise)")
        for r in mm["regions"]:
            lines.append(f"  where: {r['channel']}: {r['text']}")
    shares = data.get("explained", {}).get("effects", [])
    for i, e in enumerate(data["effects"]):
        if len(shares) == len(data["effects"]) and "text" in e:
            lines.append(f"  found: {e['text']}, {100 * shares[i]['share']:.0f} % of the "
                         "held-out residual (additive share)")
        else:
            lines.append(f"  found: {e['summary']}")
    for w in data.get("warnings", []):
        lines.append(f"  warning: {w['text']}")
    for text in data.get("processing", {}).get("signal_notes", []):
        lines.append(f"  signals: {text}")
    if mm["significant"]:
        lines.append(f"  unexplained: {100 * data['unexplained_fraction']:.0f} % of the "
                     "held-out residual is not explained by a named effect")
    f = data["fit"]
    lines.append(f"  held-out simulation error ({f['horizon_s']:g} s windows, RMSE / state std):"
                 f" nominal {f['nominal']['rollout_score']:.3g} -> augmented "
                 f"{f['augmented']['rollout_score']:.3g}")
    return lines


def unit_suffix(unit: str) -> str:
    """`` N·m`` for a unit, empty for dimensionless values (``-`` or no unit)."""
    return "" if unit in ("", "-") else f" {unit}"


def figure_width(duration: float) -> float:
    """Figure width (in) for a time axis of ``duration`` seconds (wider for long recordings)."""
    extra = max(0.0, duration - WIDE_AFTER_S) / WIDTH_S_PER_IN
    return float(min(MAX_WIDTH_IN, BASE_WIDTH_IN + extra))


def fitted_for_plot(report) -> np.ndarray:
    """The fitted contribution (N, C) with NaN where the fit left a channel's samples out."""
    pred = np.array(report.fitted_pred, dtype=float)
    prepared = getattr(report, "prepared", None)
    if prepared is not None:
        mask = np.asarray(prepared.fit_mask, dtype=bool)
        if mask.shape == pred.shape:
            pred[~mask] = np.nan
    return pred


def _legend_outside(ax) -> None:
    legend_outside(ax, fontsize=7, markerscale=3)


def _thin(n: int) -> np.ndarray:
    return np.arange(0, n, max(1, n // MAX_POINTS))


def residual_time_figure(report):
    """``residual_time.png``'s figure (a ``matplotlib.figure.Figure``, no pyplot state)."""
    sys, t = report.system, report.prepared.t
    nc = len(sys.channels)
    fig = Figure(figsize=(figure_width(float(t[-1] - t[0])), 2.6 * nc))
    axes = fig.subplots(nc, 1, sharex=True, squeeze=False)
    idx = _thin(len(t))
    fitted = fitted_for_plot(report)
    for i, ax in enumerate(axes[:, 0]):
        ax.plot(t[idx], report.residual[idx, i], lw=0.6, color="0.35", label="residual")
        ax.fill_between(t[idx], -report.noise[i], report.noise[i], color="tab:blue", alpha=0.2,
                        label="± noise floor")
        if report.term_preds:
            ax.plot(t[idx], fitted[idx, i], lw=0.9, color="tab:red",
                    label="named effects")
        for s in report.data["mismatch"]["segments"]:
            if s["channel"] == sys.channels[i]:
                ax.axvspan(s["t_start"], s["t_end"], color="tab:orange", alpha=0.25)
        ax.axvline(report.data["fit"]["split"]["test"][0], color="k", ls="--", lw=0.8,
                   label="train | test")
        ax.set_ylabel(f"{sys.channels[i]} ({sys.channel_units[i]})")
        _legend_outside(ax)
    axes[-1, 0].set_xlabel("time t (s)")
    axes[0, 0].set_title("Residual over time (shaded: located segments; dashed: train | test)")
    fig.tight_layout()
    return fig


def residual_vs_figure(report):
    """``residual_vs_variable.png``'s figure (a ``matplotlib.figure.Figure``, no pyplot state)."""
    sys = report.system
    variables = sys.locate_variables(report.prepared)
    nc = len(sys.channels)
    fig = Figure(figsize=(6 * nc, 3.8))
    axes = fig.subplots(1, nc, squeeze=False)
    regions = report.data["mismatch"]["regions"]
    idx = _thin(report.prepared.n)
    fitted = fitted_for_plot(report)
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
            ax.scatter(x[idx], fitted[idx, i], s=2, color="tab:red", label="fitted effects")
        ax.set_xlabel(f"{var} ({unit})")
        ax.set_ylabel(f"residual at {ch} ({sys.channel_units[i]})")
        ax.set_title(f"{ch}: residual vs {var}")
        _legend_outside(ax)
    fig.tight_layout()
    return fig


def simulation_figure(report):
    """``simulation.png``'s figure (a ``matplotlib.figure.Figure``, no pyplot state)."""
    ex = report.comparison.example
    names, units = report.data["fit"]["rollout_names"], report.data["fit"]["rollout_units"]
    n = len(names)
    span = float(ex["t"][-1] - ex["t"][0]) if len(ex["t"]) else 0.0
    fig = Figure(figsize=(figure_width(span), 2.2 * n))
    axes = fig.subplots(n, 1, sharex=True, squeeze=False)
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
        for k, b in enumerate(breaks):
            ax.axvline(b, color="0.8", lw=0.6,
                       label="restart from the recorded state" if k == 0 else None)
        ax.set_ylabel(f"{names[i]} ({units[i]})")
        _legend_outside(ax)
    axes[-1, 0].set_xlabel("time t (s)")
    axes[0, 0].set_title(f"Held-out open-loop simulations from recorded states "
                         f"({report.comparison.horizon:g} s windows, whole test part)")
    fig.tight_layout()
    return fig


def markdown(data: dict[str, Any], figure: Callable[[str], str] | None = None) -> str:
    """report.md text: the verdict first, then where, what, how much better.

    Args:
        data: the report dict (``report.data``, or :func:`with_fallbacks`'s copy).
        figure: maps a figure's file name to the image source written into the text
            (default: the relative file name; report.html passes base64 data URIs).
    """
    src = figure or (lambda name: name)
    f = data["fit"]
    out = [f"# simgap diagnosis: {data['recording']}", "",
           f"**Verdict:** {verdict(data)}", "",
           f"Model `{data['model']}`, {data['samples']} samples.", "", "## Summary", ""]
    out += [f"- {line.strip()}" for line in summary_lines(data)[2:]]  # after the verdict
    out += ["", "## Where", "", "| channel | residual RMS | noise RMS | significant |",
            "|---|---|---|---|"]
    for c in data["mismatch"]["channels"]:
        unit = unit_suffix(c.get("unit", ""))
        out.append(f"| {c['channel']} | {c['residual_rms']:.4g}{unit} | "
                   f"{c['noise_rms']:.4g}{unit} | {'yes' if c['significant'] else 'no'} |")
    if data["mismatch"]["segments"]:
        out += ["", "Segments where the residual is largest: " + ", ".join(
            f"{s['channel']} {s['t_start']:.2f}–{s['t_end']:.2f} s"
            for s in data["mismatch"]["segments"]) + "."]
    for r in data["mismatch"]["regions"]:
        out.append(f"- {r['channel']} / {r['variable']}: {r['text']}")
    out += ["", f"![residual over time]({src('residual_time.png')})", "", "## What", ""]
    if data["effects"]:
        out += ["| effect | channel | parameters (± stderr) | drop-one share² |",
                "|---|---|---|---|"]
        for e in data["effects"]:
            ps = ", ".join("{} = {} ± {}".format(k, *fmt(v, e["stderr"][k]))
                           + unit_suffix(e.get("units", {}).get(k, ""))
                           for k, v in e["parameters"].items())
            out.append(f"| {e['effect']} | {e['channel']} | {ps} | "
                       f"{100 * e['explained_fraction']:.0f} % |")
        out += ["", "² drop-one: how much more held-out residual is left at the effect's "
                "channels without it, given the others (not additive; the additive shares "
                "follow)."]
    else:
        out.append("No effect of the vocabulary improves the held-out fit beyond the noise.")
    for w in data.get("warnings", []):
        out.append(f"\n> Warning: {w['text']}")
    for text in data.get("processing", {}).get("signal_notes", []):
        out.append(f"\n> Signals: {text}")
    out += ["", "### Explained shares", ""] + explained_lines(data)
    out += ["", f"![residual against the located variable]({src('residual_vs_variable.png')})",
            "", "## Tried and rejected", ""] + tried_lines(data)
    out += ["", "## Identifiability of what was named", ""]
    out += identifiability_lines(data, src)
    out += ["", "## How much better", "",
            f"Train {f['split']['train'][0]:.2f}–{f['split']['train'][1]:.2f} s, test "
            f"{f['split']['test'][0]:.2f}–{f['split']['test'][1]:.2f} s. {f['method']}.", "",
            "| error | " + " | ".join(f"{n} ({u})" for n, u in zip(
                f["derivative_names"], f["derivative_units"], strict=True)) + " |",
            "|---|" + "---|" * len(f["derivative_names"])]
    for m in ("nominal", "augmented"):
        out.append(f"| derivative RMSE, {m} | " + " | ".join(
            f"{v:.4g}" for v in f[m]["derivative_rmse"]) + " |")
    out += ["", "| error | " + " | ".join(f"{n} ({u})" for n, u in zip(
        f["rollout_names"], f["rollout_units"], strict=True)) + " | score¹ |",
        "|---|" + "---|" * (len(f["rollout_names"]) + 1)]
    for m in ("nominal", "augmented"):
        out.append(f"| simulation RMSE, {m} | " + " | ".join(
            f"{v:.4g}" for v in f[m]["rollout_rmse"]) + f" | {f[m]['rollout_score']:.3g} |")
    out += ["", f"¹ score: {SCORE_MEANING}.", "",
            f"![nominal vs augmented simulation]({src('simulation.png')})", "",
            "The augmented model is saved as `augmented_model.json` "
            "(`simgap.diagnosis.load_augmented`).", ""]
    return "\n".join(out)


def figures_png(report, data: dict[str, Any]) -> dict[str, bytes]:
    """Every figure of the report as PNG bytes, by file name (one figure alive at a time)."""
    makers = {"residual_time.png": lambda: residual_time_figure(report),
              "residual_vs_variable.png": lambda: residual_vs_figure(report),
              "simulation.png": lambda: simulation_figure(report)}
    ident = data.get("identifiability")
    if isinstance(ident, dict) and len(ident.get("names") or []) >= 2:
        makers["identifiability.png"] = lambda: correlation_figure(ident)
    out = {}
    for name, make in makers.items():
        buf = io.BytesIO()
        make().savefig(buf, format="png", dpi=110)
        out[name] = buf.getvalue()
    return out


def write_report(report, out_dir: str | os.PathLike, figures: bool = True,
                 inputs: Sequence[str | os.PathLike] = ()) -> Path:
    """Write report.json, report.md, report.html, figures and augmented_model.json.

    report.html is one self-contained file (the same text as report.md, figures embedded as
    base64 PNG, no network access, no scripts). Transactional
    (:func:`simgap.outputs.output_folder`): everything is written to a fresh
    temporary sibling folder and moved into place at the end; an existing ``out_dir`` is
    replaced only if it is empty or a previous simgap output, and a target that is or holds
    one of ``inputs`` is refused (:class:`~simgap.errors.OutputError`).
    """
    view = with_fallbacks(report)
    pngs = figures_png(report, view) if figures else {}
    with output_folder(out_dir, kind="diagnose", inputs=inputs) as tmp:
        (tmp / "report.json").write_text(json.dumps(finite_json(report.data), indent=2,
                                                    allow_nan=False),
                                         encoding="utf-8")
        (tmp / "report.md").write_text(markdown(view), encoding="utf-8")
        (tmp / "report.html").write_text(html_page(view, pngs, markdown), encoding="utf-8")
        save_model(report.augmented, tmp / "augmented_model.json")  # every model has one
        if getattr(report, "mjcf_text", None):  # an MJCF nominal: the corrected MJCF
            (tmp / "augmented_model.xml").write_text(report.mjcf_text, encoding="utf-8")
        for name, png in pngs.items():
            (tmp / name).write_bytes(png)
    return Path(out_dir)
