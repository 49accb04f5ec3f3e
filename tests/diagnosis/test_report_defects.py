"""Diagnosis figures and report text: masked samples are gaps (NaN), legends sit beside the
data, long recordings get wider figures, the simulation figure spans the whole test part;
noise RMS carries its unit, the score is defined, dimensionless values carry no stray "-"."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from simgap.diagnosis.fit import _share
from simgap.diagnosis.generate import InjectedEffect, generate_manipulator
from simgap.diagnosis.pipeline import diagnose
from simgap.diagnosis.report import (
    SCORE_MEANING,
    _thin,
    figure_width,
    fitted_for_plot,
    markdown,
    residual_time_figure,
    residual_vs_figure,
    simulation_figure,
    summary_lines,
)


@pytest.fixture(scope="module")
def report():
    hidden = InjectedEffect(effect="coulomb_friction", channel="joint2", params={"Fc": 0.3})
    return diagnose(generate_manipulator([hidden], duration=10.0, seed=1), "manipulator2dof")


def _legends_outside(fig) -> None:
    fig.canvas.draw()
    for ax in fig.axes:
        leg = ax.get_legend()
        if leg is not None:
            assert leg.get_window_extent().x0 >= ax.get_window_extent().x1 - 1


def test_masked_samples_are_gaps_not_zeros(report) -> None:
    mask = np.asarray(report.prepared.fit_mask, dtype=bool)
    assert (~mask[:, 1]).any() and mask[:, 1].any()  # stick phases exist at joint 2
    pred = fitted_for_plot(report)
    assert np.all(np.isnan(pred[~mask])) and np.all(np.isfinite(pred[mask]))
    fig = residual_time_figure(report)
    (line,) = [ln for ln in fig.axes[1].get_lines() if ln.get_label() == "named effects"]
    idx = _thin(report.prepared.n)
    np.testing.assert_array_equal(np.isnan(line.get_ydata()), ~mask[idx, 1])
    _legends_outside(fig)
    _legends_outside(residual_vs_figure(report))


def test_simulation_figure_spans_the_test_part(report) -> None:
    fig = simulation_figure(report)
    t = report.comparison.example["t"]
    t0, t1 = report.data["fit"]["split"]["test"]
    horizon = report.comparison.horizon
    assert t[0] - t0 <= horizon and t1 - t[-1] <= 2 * horizon
    _legends_outside(fig)


def test_long_recordings_get_wider_figures() -> None:
    assert figure_width(10.0) == figure_width(60.0)
    assert figure_width(550.0) >= 2 * figure_width(60.0)
    assert figure_width(1e5) == figure_width(1e6)  # capped


def test_report_text_units_and_definitions(report) -> None:
    data = copy.deepcopy(report.data)
    unit = data["mismatch"]["channels"][0]["unit"]
    assert unit and unit != "-"
    md = markdown(data)
    where = [ln for ln in md.splitlines() if ln.startswith("| joint")]
    assert where and all(ln.count(unit) >= 2 for ln in where)  # residual and noise RMS
    assert "score¹" in md and SCORE_MEANING in md
    summary = "\n".join(summary_lines(data))
    assert "RMSE / state std" in summary and "score" not in summary
    # a dimensionless parameter: no stray "-" after its value
    data["effects"][0]["units"] = {k: "-" for k in data["effects"][0]["parameters"]}
    row = next(ln for ln in markdown(data).splitlines() if ln.startswith("| coulomb"))
    assert " - |" not in row and " -," not in row


def test_alias_warning_states_gains_as_shares() -> None:
    assert _share(25.0, 100.0) == "25 %" and _share(1.0, 0.0) == "n/a"
