"""Figures of the evaluation: no flat line over empty histogram bins, log axes that start at
the data, mathtext (not raw TeX) in legends, explained freeze-time lines, legends off the
data."""

from __future__ import annotations

import numpy as np
import pytest
from matplotlib.patches import StepPatch

from simgap.evaluation.cases import get_case
from simgap.evaluation.figures import log_floor, plot_online, plot_timing
from simgap.evaluation.runner import run_case


def _legends_outside(fig) -> None:
    fig.canvas.draw()
    for ax in fig.axes:
        leg = ax.get_legend()
        if leg is None:
            continue
        lb, ab = leg.get_window_extent(), ax.get_window_extent()
        assert lb.x0 >= ab.x1 - 1, f"legend of {ax.get_title()!r} sits on the data"


def _timing() -> dict:
    edges = np.geomspace(1e-4, 1.0, 9)
    raw = {kind: {"hist_counts": [0, 40, 0, 0, 7, 1, 0, 0], "hist_edges_ms": edges.tolist(),
                  "run_max_ms": [0.01, 0.02, 0.015]}
           for kind in ("instantaneous", "minibatch", "integral")}
    return {"raw": raw, "settings": {"deadline_ms": 0.5, "n_runs": 3, "n_steps": 48}}


def test_timing_histogram_leaves_empty_bins_empty() -> None:
    fig = plot_timing(_timing())
    steps = [p for p in fig.axes[0].patches if isinstance(p, StepPatch)]
    assert len(steps) == 3
    for p in steps:
        values = p.get_data().values
        counts = np.array(_timing()["raw"]["integral"]["hist_counts"], dtype=float)
        assert np.array_equal(np.isnan(values), counts == 0)
        np.testing.assert_array_equal(values[counts > 0], counts[counts > 0])
    _legends_outside(fig)


def test_log_floor_ignores_a_near_zero_first_sample() -> None:
    y = np.concatenate([[1e-23, 0.0], np.linspace(1e-3, 1e-1, 500)])
    floor = log_floor(y)
    assert 1e-3 <= floor < 2e-3
    assert log_floor(np.zeros(4)) is None


@pytest.fixture(scope="module")
def case_2_1():
    return run_case(get_case("2-1"), quick=True, seed=0)


def test_online_figure_labels_axes_and_legends(case_2_1) -> None:
    fig = plot_online(case_2_1)
    labels = [t.get_text() for ax in fig.axes if ax.get_legend()
              for t in ax.get_legend().get_texts()] + [ax.get_title() for ax in fig.axes]
    # subscripts and hats are mathtext ($...$), never raw TeX such as x_{k+1} in plain text
    for text in labels:
        plain = "".join(text.split("$")[::2])
        assert "_{" not in plain and "^{" not in plain and "\\" not in plain, text
    assert any("freeze times" in t for t in labels)  # the dotted lines are explained
    for ax in fig.axes:
        if ax.get_yscale() == "log":
            bottom = ax.get_ylim()[0]
            data = np.concatenate([ln.get_ydata() for ln in ax.get_lines()])
            assert bottom >= 0.9 * log_floor(data)
    _legends_outside(fig)
