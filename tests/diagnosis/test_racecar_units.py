"""The race-car diagnosis does not change with the units of the input (issue 13).

The same slice of ../shared/data/real/racecar_sideslip_100hz is diagnosed twice: as
recorded (m/s, rad/s, rad) and converted to km/h, deg/s and degrees, printed with seven
significant digits (so every value's last digits are rounded differently) and mapped back by
a column map. Named effects, warnings, identifiability verdict and the decisions on every
term tried must be the same; parameters agree to the rounding.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from simgap.diagnosis.pipeline import diagnose
from tests.conftest import REPO_ROOT, shared_path

MODEL_SPEC = f"{REPO_ROOT / 'examples' / 'racecar_model.py'}:RACECAR"
ROWS = 15_000


@pytest.fixture(scope="module")
def two_runs(tmp_path_factory):
    path = shared_path("data", "real", "racecar_sideslip_100hz", "racecar_sideslip_100hz.csv")
    raw = pd.read_csv(path, nrows=ROWS, usecols=["t_s", "vx_mps", "vy_mps", "r_radps",
                                                  "delta_rad"])
    tmp = tmp_path_factory.mktemp("units")
    si = tmp / "si.csv"
    raw.to_csv(si, index=False)
    other = pd.DataFrame({"time_s": raw["t_s"], "vx_kmh": raw["vx_mps"] * 3.6,
                          "vy_kmh": raw["vy_mps"] * 3.6,
                          "r_degps": np.degrees(raw["r_radps"]),
                          "steer_deg": np.degrees(raw["delta_rad"])})
    conv = tmp / "other_units.csv"
    other.to_csv(conv, index=False, float_format="%.7g")
    cmap = {"t": "time_s", "vx": {"source": "vx_kmh", "scale": 1 / 3.6},
            "vy": {"source": "vy_kmh", "scale": 1 / 3.6},
            "r": {"source": "r_degps", "scale": np.pi / 180},
            "delta_f": {"source": "steer_deg", "scale": np.pi / 180,
                        "despike": 0.05},
            "delta_r": 0.0}
    return diagnose(si, MODEL_SPEC), diagnose(conv, MODEL_SPEC, columns=cmap)


def test_verdicts_do_not_depend_on_units_or_rounding(two_runs) -> None:
    a, b = (r.data for r in two_runs)
    assert [(e["effect"], e["channel"]) for e in a["effects"]] == \
        [(e["effect"], e["channel"]) for e in b["effects"]]
    assert any(e["effect"] == "tire_saturation" for e in a["effects"])
    assert [w["text"].split(":")[0] for w in a["warnings"]] == \
        [w["text"].split(":")[0] for w in b["warnings"]]
    assert a["identifiability"]["names"] == b["identifiability"]["names"]
    assert len(a["identifiability"]["combinations"]) == \
        len(b["identifiability"]["combinations"])
    assert {(t["effect"], t["channel"], t["decision"]) for t in a["tried"]} == \
        {(t["effect"], t["channel"], t["decision"]) for t in b["tried"]}
    for ea, eb in zip(a["effects"], b["effects"], strict=True):
        for k, v in ea["parameters"].items():
            assert eb["parameters"][k] == pytest.approx(v, rel=1e-3, abs=1e-6)
    assert a["verdict"].split(";")[0] == b["verdict"].split(";")[0]


def test_report_data_carries_tried_identifiability_and_verdict(two_runs) -> None:
    data = two_runs[0].data
    keys = {"effect", "channel", "params", "gain", "test", "statistic", "p_value",
            "decision", "reason"}
    assert data["tried"] and all(keys <= set(t) for t in data["tried"])
    named = {(e["effect"], e["channel"]) for e in data["effects"]}
    decided = {(t["effect"], t["channel"]) for t in data["tried"] if t["decision"] == "named"}
    assert named == decided
    ident = data["identifiability"]
    p = len(ident["names"])
    assert p >= 1 and np.array(ident["correlation"]).shape == (p, p)
    assert np.isfinite(ident["condition"]) and isinstance(ident["combinations"], list)
    assert data["verdict"].startswith("Named: ") and "\n" not in data["verdict"]
