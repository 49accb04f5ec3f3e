"""The demo job writes its figures, a diagnosis of a concealed effect, and index.html."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest
from matplotlib.image import imread

from simgap.demo import caption, run_demo


def test_run_demo_writes_pngs_diagnosis_and_index(tmp_path):
    out = tmp_path / "out"
    paths = run_demo(out, seed=0, duration_scale=0.1, reproduce=False)
    names = {p.name for p in paths}
    assert {"manipulator_thesis.png", "manipulator_waypoints.png", "bicycle_step_steer.png",
            "bicycle_slalom.png", "bicycle_chirp.png", "bicycle_tire_residual.png",
            "env_frames.png", "residual_time.png", "residual_vs_variable.png",
            "simulation.png"} <= names
    for p in paths:
        img = imread(p)
        assert img.shape[0] > 300 and img.shape[1] > 300
        assert np.std(img) > 0.01  # not blank
    # the diagnosis ran on a recording with a concealed Coulomb friction and names it
    report = json.loads((out / "diagnosis" / "report.json").read_text())
    assert report["mismatch"]["significant"]
    assert any(e["effect"] == "coulomb_friction" and e["channel"] == "joint2"
               for e in report["effects"])
    # index.html shows every PNG in the folder, each with its own caption
    page = (out / "index.html").read_text()
    pngs = sorted(p.relative_to(out).as_posix() for p in out.rglob("*.png"))
    assert pngs and sorted(re.findall(r'<img src="([^"]+)"', page)) == pngs
    for rel in pngs:
        assert caption(rel) in page.replace("&#x27;", "'")


def test_every_demo_figure_name_has_a_caption():
    for rel in ("reproduce/case1_online.png", "reproduce/case2_1_consistency.png",
                "reproduce/case2_2_norelax_online.png", "reproduce/timing.png",
                "diagnosis/simulation.png"):
        assert caption(rel)
    assert "2-1" in caption("reproduce/case2_1_online.png")
    with pytest.raises(KeyError, match="no caption"):
        caption("something_new.png")


def test_run_demo_rejects_bad_scale(tmp_path):
    with pytest.raises(ValueError, match="duration_scale"):
        run_demo(tmp_path, duration_scale=0.0)
