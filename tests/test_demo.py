"""The demo job writes its figures."""

from __future__ import annotations

import numpy as np
import pytest
from matplotlib.image import imread

from simgap.demo import run_demo


def test_run_demo_writes_pngs(tmp_path):
    paths = run_demo(tmp_path / "out", seed=0, duration_scale=0.1, reproduce=False)
    names = {p.name for p in paths}
    assert {"manipulator_thesis.png", "manipulator_waypoints.png", "bicycle_step_steer.png",
            "bicycle_slalom.png", "bicycle_chirp.png", "bicycle_tire_residual.png",
            "env_frames.png"} <= names
    for p in paths:
        img = imread(p)
        assert img.shape[0] > 300 and img.shape[1] > 300
        assert np.std(img) > 0.01  # not blank


def test_run_demo_rejects_bad_scale(tmp_path):
    with pytest.raises(ValueError, match="duration_scale"):
        run_demo(tmp_path, duration_scale=0.0)
