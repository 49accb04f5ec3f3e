"""The report a person can trust: verdict first, additive shares, tried/rejected effects,
identifiability matrix, and a self-contained report.html (synthetic dicts + one real run)."""

from __future__ import annotations

import base64
import copy
import json
import re

import numpy as np
import pytest

from simgap.diagnosis.generate import InjectedEffect, generate_manipulator
from simgap.diagnosis.pipeline import diagnose
from simgap.diagnosis.report import markdown, write_report
from simgap.diagnosis.report_html import html_page
from simgap.diagnosis.report_sections import verdict, with_fallbacks
from simgap.diagnosis.shares import shapley_reductions


# ------------------------------------------------------------------- additive shares
def test_shapley_shares_add_up_and_match_brute_force() -> None:
    rng = np.random.default_rng(0)
    r = rng.normal(size=(200, 2))
    base = 0.8 * r + 0.1 * rng.normal(size=r.shape)
    preds = [0.5 * base, 0.3 * base + 0.2 * rng.normal(size=r.shape), rng.normal(size=r.shape)]
    phi = shapley_reductions(r, preds)

    def sse(idx):
        return float(np.sum((r - sum((preds[i] for i in idx), np.zeros_like(r))) ** 2))

    assert phi.sum() == pytest.approx(sse([]) - sse([0, 1, 2]), rel=1e-12)
    # brute force over all orders of adding the three effects
    from itertools import permutations
    brute = np.zeros(3)
    orders = list(permutations(range(3)))
    for order in orders:
        for k, i in enumerate(order):
            brute[i] += sse(order[:k]) - sse(order[:k + 1])
    np.testing.assert_allclose(phi, brute / len(orders), rtol=1e-10)
    assert phi[2] < 0            # pure noise makes the held-out error larger: negative


def test_shares_are_independent_of_order() -> None:
    rng = np.random.default_rng(1)
    r = rng.normal(size=300)
    preds = [0.4 * r, 0.4 * r + rng.normal(size=300) * 0.1]
    np.testing.assert_allclose(shapley_reductions(r, preds)[::-1],
                               shapley_reductions(r, preds[::-1]))


# ------------------------------------------------------------------- one real run
@pytest.fixture(scope="module")
def report():
    effects = [InjectedEffect(effect="coulomb_friction", channel="joint2", params={"Fc": 0.3}),
               InjectedEffect(effect="viscous_friction", channel="joint1", params={"b": 0.3})]
    return diagnose(generate_manipulator(effects, duration=12.0, seed=2), "manipulator2dof")


def test_pipeline_shares_add_up_to_one(report) -> None:
    ex = report.data["explained"]
    assert {e["effect"] for e in ex["effects"]} == {e["effect"] for e in report.effects}
    total = sum(e["share"] for e in ex["effects"]) + ex["unexplained"]
    assert total == pytest.approx(1.0, abs=1e-9)
    assert ex["unexplained"] == pytest.approx(report.data["unexplained_fraction"], abs=1e-4)
    assert all(e["share"] > 0.05 for e in ex["effects"])


def test_report_files_verdict_first_and_html_self_contained(report, tmp_path) -> None:
    out = write_report(report, tmp_path / "rep")
    md = (out / "report.md").read_text(encoding="utf-8")
    lines = [ln for ln in md.splitlines() if ln.strip()]
    assert lines[0].startswith("# ") and lines[1].startswith("**Verdict:** ")
    assert "coulomb friction at joint 2" in lines[1].lower()
    for heading in ("## Tried and rejected", "## Identifiability of what was named",
                    "### Explained shares"):
        assert heading in md
    assert "add up to 100 %" in md and "Shapley" in md
    page = (out / "report.html").read_text(encoding="utf-8")
    assert page.startswith("<!DOCTYPE html>")
    assert "<script" not in page.lower() and "http://" not in page and "https://" not in page
    imgs = re.findall(r'<img src="([^"]+)"', page)
    pngs = sorted(p.name for p in out.glob("*.png"))
    assert len(imgs) == len(pngs) >= 4      # two effects -> identifiability.png too
    for src in imgs:
        assert src.startswith("data:image/png;base64,")
        assert base64.b64decode(src.split(",", 1)[1])[:8] == b"\x89PNG\r\n\x1a\n"
    assert "<table>" in page and "Verdict:" in page
    # report.json keeps what the pipeline wrote (fallbacks are for rendering only)
    data = json.loads((out / "report.json").read_text())
    assert "tried" not in data or data["tried"] == report.data.get("tried")


def test_fallbacks_from_history_and_covariance(report) -> None:
    view = with_fallbacks(report)
    if "tried" not in report.data:
        decisions = {r["decision"] for r in view["tried"]}
        assert "accepted" in decisions and decisions <= {"accepted", "rejected", "not named",
                                                         "removed"}
        names = [(r["effect"], r["channel"]) for r in view["tried"]]
        assert len(names) == len(set(names))          # one row per effect tried
        assert "history" in view["_tried_source"]
    ident = view["identifiability"]
    corr = np.asarray(ident["correlation"], dtype=float)
    assert corr.shape == (len(ident["names"]),) * 2
    np.testing.assert_allclose(np.diag(corr), 1.0)
    assert ident["condition"] >= 1.0


def test_no_figures_html_says_so(report, tmp_path) -> None:
    out = write_report(report, tmp_path / "nofig", figures=False)
    page = (out / "report.html").read_text(encoding="utf-8")
    assert "<img" not in page and "not written" in page
    assert not list(out.glob("*.png"))


# ------------------------------------------------------------------- synthetic dicts
def _synthetic(report) -> dict:
    data = copy.deepcopy(report.data)
    data["verdict"] = "Coulomb friction at joint 2 | and viscous friction at joint 1."
    data["tried"] = [
        {"effect": "coulomb_friction", "channel": "joint2", "params": {"Fc": 0.3},
         "gain": 120.5, "test": "held-out LR", "statistic": 240.1, "p_value": 1e-12,
         "decision": "accepted", "reason": ""},
        {"effect": "stribeck_friction", "channel": "joint2", "params": {"Fs": 0.1, "vs": 0.2},
         "gain": 0.4, "test": "held-out LR", "statistic": 0.8, "p_value": 0.45,
         "decision": "rejected", "reason": "not significant at the structure floor"},
    ]
    data["identifiability"] = {"names": ["Fc", "b", "tau0"],
                               "correlation": [[1, 0.2, -0.95], [0.2, 1, 0.1],
                                               [-0.95, 0.1, 1]],
                               "condition": 4.1e3,
                               "combinations": ["Fc − tau0 is determined, not each alone",
                                                {"text": "b alone"}]}
    return data


def test_synthetic_sections_rendered(report) -> None:
    data = _synthetic(report)
    md = markdown(data)
    lines = [ln for ln in md.splitlines() if ln.strip()]
    assert lines[1] == f"**Verdict:** {data['verdict']}"
    assert verdict(data) == data["verdict"]
    tried = [ln for ln in md.splitlines() if ln.startswith("| stribeck_friction")]
    assert len(tried) == 1 and "0.45" in tried[0] and "rejected" in tried[0]
    assert "Fs = 0.1, vs = 0.2" in tried[0]
    assert "| Fc | +1.00 | +0.20 | -0.95 |" in md
    assert "4.1e+03" in md and "- Fc − tau0 is determined" in md and "- b alone" in md
    page = html_page(data, {}, markdown)
    assert "<td>rejected</td>" in page and "Fc − tau0" in page
    assert "Coulomb friction at joint 2 | and" in page          # escaped pipe kept as text


def test_today_main_dict_degrades_gracefully(report) -> None:
    """A report dict without verdict/tried/identifiability/explained (today's main)."""
    data = copy.deepcopy(report.data)
    for key in ("verdict", "tried", "identifiability", "explained"):
        data.pop(key, None)
    md = markdown(data)
    assert "**Verdict:** Mismatch:" in md
    assert "No record of the effects tried" in md
    assert "No identifiability analysis" in md
    assert "No additive per-effect shares" in md
    html_page(data, {}, markdown)
    clean = copy.deepcopy(data)
    clean["mismatch"]["significant"] = False
    clean["effects"] = []
    assert verdict(clean).startswith("No mismatch beyond the noise")
    assert "No named parameters" in markdown(clean)


def test_markup_in_names_is_escaped(report) -> None:
    data = copy.deepcopy(report.data)
    data["recording"] = "<script>alert(1)</script>.csv"
    page = html_page(data, {}, markdown)
    assert "<script>" not in page and "&lt;script&gt;" in page
