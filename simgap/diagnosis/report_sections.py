"""Report sections a person needs to trust a diagnosis (markdown text, used by report.py).

* :func:`verdict` – the one-line verdict printed first: ``data["verdict"]`` when the
  selection wrote one, otherwise derived from what the report holds;
* :func:`explained_lines` – the additive "explained" shares (``data["explained"]``,
  :mod:`simgap.diagnosis.shares`) and how they are defined;
* :func:`tried_lines` – every effect tried, with its held-out evidence, the test applied and
  the decision (``data["tried"]``; without it, the forward selection's history);
* :func:`identifiability_lines` – the correlation matrix of the named parameters, its
  condition number and the identifiable combinations (``data["identifiability"]``; without
  it, the correlations of the fit's parameter covariance).

Every function reads a report dict and degrades gracefully: a missing key gives a fallback
or a plain sentence, never an exception. :func:`with_fallbacks` adds the fallbacks that need
the :class:`~simgap.diagnosis.pipeline.Report` object (history, covariance) to a copy of the
data used for rendering only; report.json keeps what the pipeline wrote.
"""

from __future__ import annotations

import copy
import json
from collections.abc import Callable
from typing import Any

import numpy as np


def _pct(x: Any) -> str:
    return f"{100.0 * float(x):.0f} %" if _is_num(x) else "–"


def _is_num(x: Any) -> bool:
    return isinstance(x, (int, float, np.integer, np.floating)) and not isinstance(x, bool) \
        and bool(np.isfinite(x))


def _num(x: Any) -> str:
    if x is None:
        return "–"
    if _is_num(x):
        return f"{float(x):.3g}"
    return _cell(x)


def _cell(x: Any) -> str:
    """Text for a markdown table cell (pipes escaped, no newlines)."""
    if x is None:
        return "–"
    if isinstance(x, dict):
        text = ", ".join(f"{k} = {_num(v)}" for k, v in x.items())
    elif isinstance(x, (list, tuple)):
        text = ", ".join(_num(v) for v in x)
    else:
        text = str(x)
    return text.replace("|", "\\|").replace("\n", " ") or "–"


def _effect_names(data: dict[str, Any]) -> list[str]:
    return [f"{e['effect'].replace('_', ' ')} at {e['channel']}" for e in data.get("effects", [])]


def verdict(data: dict[str, Any]) -> str:
    """One line: does the recording match, what explains the mismatch, how much better."""
    given = data.get("verdict")
    if isinstance(given, str) and given.strip():
        return " ".join(given.split())
    mm = data.get("mismatch", {})
    fit = data.get("fit", {})
    try:
        sim = (f"; held-out simulation error (RMSE / state std) "
               f"{fit['nominal']['rollout_score']:.3g} → "
               f"{fit['augmented']['rollout_score']:.3g}")
    except (KeyError, TypeError, ValueError):
        sim = ""
    if not mm.get("significant"):
        return "No mismatch beyond the noise: the recording matches the nominal model."
    names = _effect_names(data)
    unexplained = data.get("explained", {}).get("unexplained",
                                                data.get("unexplained_fraction"))
    if not names:
        where = ", ".join(c["channel"] for c in mm.get("channels", []) if c.get("significant"))
        return (f"Mismatch located{f' at {where}' if where else ''}, not explained by a named "
                f"effect{sim}.")
    explained = 1.0 - float(unexplained) if _is_num(unexplained) else None
    part = f" explain {_pct(explained)} of the held-out residual" if explained is not None \
        else ""
    return f"Mismatch: {', '.join(names)}{part}{sim}."


def explained_lines(data: dict[str, Any]) -> list[str]:
    """The additive shares table (markdown lines) and its definition."""
    ex = data.get("explained")
    if not isinstance(ex, dict) or "effects" not in ex:
        return [f"Unexplained share of the held-out residual: "
                f"{_pct(data.get('unexplained_fraction'))} (noise alone accounts for about "
                f"{_pct(data.get('noise_fraction'))}). No additive per-effect shares are "
                "available for this report."]
    out = ["| part | channel | share of the held-out residual |", "|---|---|---|"]
    for e in ex["effects"]:
        out.append(f"| {_cell(e['effect'])} | {_cell(e['channel'])} | {_pct(e['share'])} |")
    out.append(f"| unexplained | {', '.join(ex.get('channels', []))} | "
               f"{_pct(ex['unexplained'])} |")
    total = sum(float(e["share"]) for e in ex["effects"]) + float(ex["unexplained"])
    out += ["", f"The shares add up to {_pct(total)}. How they are defined: "
            f"{ex.get('method', 'not stated')}. White noise at the noise floor alone would "
            f"leave about {_pct(ex.get('noise'))} unexplained."]
    if any(float(e["share"]) < 0 for e in ex["effects"]):
        out.append("A negative share means that effect, given the others, makes the held-out "
                   "error larger.")
    return out


TRIED_COLUMNS = (("effect", "effect"), ("channel", "channel"), ("params", "parameters"),
                 ("gain", "held-out gain"), ("test", "test"), ("statistic", "statistic"),
                 ("p_value", "p-value"), ("decision", "decision"), ("reason", "reason"))


def tried_lines(data: dict[str, Any]) -> list[str]:
    """Every effect tried, with held-out evidence, test and decision (markdown lines).

    Columns that no row fills are left out.
    """
    tried = data.get("tried")
    if not tried:
        return ["No record of the effects tried is available for this report."]
    out = []
    if data.get("_tried_source"):
        out += [f"Source: {data['_tried_source']}.", ""]
    cols = [(k, title) for k, title in TRIED_COLUMNS
            if any(row.get(k) not in (None, "", {}, []) for row in tried)]
    out += ["| " + " | ".join(title for _, title in cols) + " |",
            "|" + "---|" * len(cols)]
    for row in tried:
        out.append("| " + " | ".join(_num(row.get(k)) if k in ("gain", "statistic", "p_value")
                                     else _cell(row.get(k)) for k, _ in cols) + " |")
    return out


def identifiability_lines(data: dict[str, Any],
                          figure: Callable[[str], str] | None = None) -> list[str]:
    """Correlation matrix of the named parameters, conditioning, combinations (markdown)."""
    ident = data.get("identifiability")
    if not isinstance(ident, dict) or not ident.get("names"):
        return ["No named parameters: nothing to check for identifiability."
                if not data.get("effects") else
                "No identifiability analysis is available for this report."]
    names = [str(n) for n in ident["names"]]
    corr = np.asarray(ident.get("correlation", np.eye(len(names))), dtype=float)
    out = []
    if data.get("_identifiability_source"):
        out += [f"Source: {data['_identifiability_source']}.", ""]
    out += ["| | " + " | ".join(_cell(n) for n in names) + " |",
            "|---|" + "---|" * len(names)]
    for i, n in enumerate(names):
        out.append(f"| {_cell(n)} | " + " | ".join(
            f"{corr[i, j]:+.2f}" if np.isfinite(corr[i, j]) else "–"
            for j in range(len(names))) + " |")
    cond = ident.get("condition")
    if _is_num(cond):
        out += ["", f"Condition number of the named set: {float(cond):.3g} (large values, "
                "say above 10³, mean some direction of the parameters is poorly determined)."]
    combos = ident.get("combinations") or []
    if combos:
        out += ["", "Identifiable combinations / unidentifiable directions:"]
        for c in combos:
            text = c.get("text") if isinstance(c, dict) else None
            out.append(f"- {_cell(text if text else json.dumps(c) if isinstance(c, dict) else c)}")
    if figure is not None and len(names) >= 2:
        out += ["", f"![parameter correlation]({figure('identifiability.png')})"]
    return out


def _tried_from_history(history: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """One row per effect tried: its last held-out gain and the final decision."""
    rows: dict[str, dict[str, Any]] = {}
    for k, h in enumerate(history, start=1):
        effect, _, channel = h["term"].partition("@")
        if h.get("removed"):
            rows[h["term"]].update(decision="removed", reason=(
                "backward pass: a later effect explains the same held-out residual (removing "
                f"it costs {float(h.get('loss_per_sample', np.nan)):.3g} per test sample)"))
            continue
        for name, gain in h.get("runner_up", []):
            if name != h["term"]:
                eff, _, ch = name.partition("@")
                rows[name] = {"effect": eff, "channel": ch, "gain": float(gain),
                              "test": "selection thresholds", "decision": "not named",
                              "reason": f"round {k}: {effect} at {channel} gained more"}
        rows[h["term"]] = {
            "effect": effect, "channel": channel, "gain": float(h["gain"]),
            "test": "selection thresholds",
            "decision": "accepted" if h.get("accepted") else "rejected",
            "reason": f"round {k}: best remaining effect" + (
                "" if h.get("accepted") else ", below the thresholds")}
    order = {"accepted": 0, "removed": 1, "rejected": 2, "not named": 3}
    return sorted(rows.values(), key=lambda r: (order[r["decision"]], -r["gain"]))


def _identifiability_from_fit(fit: Any) -> dict[str, Any] | None:
    names = [f"{t.effect.name}@{t.channel}:{p}" for t in fit.terms
             for p in list(t.effect.lin) + list(t.effect.nl)]
    cov = np.asarray(fit.cov, dtype=float)
    if not names or cov.shape != (len(names), len(names)):
        return None
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    with np.errstate(divide="ignore", invalid="ignore"):
        corr = cov / np.outer(sd, sd)
    corr[~np.isfinite(corr)] = np.nan
    finite = np.nan_to_num(corr, nan=0.0)
    np.fill_diagonal(finite, 1.0)
    return {"names": names, "correlation": corr.tolist(),
            "condition": float(np.linalg.cond(finite)), "combinations": []}


def with_fallbacks(report: Any) -> dict[str, Any]:
    """A copy of ``report.data`` for rendering, with fallbacks for missing sections.

    ``tried`` comes from the forward selection's history and ``identifiability`` from the
    final fit's parameter covariance when the pipeline did not write them; their source is
    stated in the rendered report. report.json is not affected.
    """
    data = copy.deepcopy(report.data)
    sel = getattr(report, "selection", None)
    if not data.get("tried") and sel is not None and getattr(sel, "history", None):
        data["tried"] = _tried_from_history(sel.history)
        data["_tried_source"] = (
            "the forward selection's history; gain: reduction of the noise-whitened held-out "
            "squared residual when the effect is added to those already named (no "
            "statistical test was recorded)")
    if "identifiability" not in data and sel is not None and data.get("effects"):
        ident = _identifiability_from_fit(sel.fit)
        if ident is not None:
            data["identifiability"] = ident
            data["_identifiability_source"] = ("correlations of the final fit's parameter "
                                               "covariance s²(JᵀJ)⁻¹")
    return data
