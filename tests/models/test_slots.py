"""Plant arrays are addressed by name: generated slots, and no slot number outside models/."""

import re
from pathlib import Path

import numpy as np
import pytest

from simgap.models import bicycle as bic
from simgap.models import manipulator as man
from simgap.models.friction import FRICTION_FIELDS, FrictionParams
from simgap.models.slots import Slots

ROOT = Path(__file__).resolve().parents[2]
SCANNED = ("simgap", "tests", "benchmarks", "examples")
# an index or slice with a leading number on an array named theta / th / *plant*
# (plant_state is the integrated state, not a parameter array)
SLOT_NUMBER = re.compile(r"(?<!\w)(\w*theta\w*|th|(?!plant_state)\w*plant\w*)\[\s*-?\d")


def test_no_slot_number_outside_models():
    hits = []
    for top in SCANNED:
        for path in sorted((ROOT / top).rglob("*.py")):
            rel = path.relative_to(ROOT)
            if rel.parts[:2] == ("simgap", "models") or path == Path(__file__).resolve():
                continue  # the kernels' own module, and this file's examples below
            for no, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
                if SLOT_NUMBER.search(line):
                    hits.append(f"{rel}:{no}: {line.strip()}")
    assert not hits, "plant slots by number outside simgap/models/:\n" + "\n".join(hits)


@pytest.mark.parametrize("line", ["th[7] = mu", "x = env.plant_theta[14]",
                                  "np.any(exact_plant[12:15] > 0)", "theta[8]",
                                  "self.theta[0:3]"])
def test_the_scan_catches_slot_numbers(line):
    assert SLOT_NUMBER.search(line)


@pytest.mark.parametrize("line", ["theta[MU]", "th[bic.VX] = v", "s = self._s[4:6]",
                                  "env.plant_state[0]", "obs[2:4]"])
def test_the_scan_allows_names(line):
    assert not SLOT_NUMBER.search(line)


def test_slots_layout_and_errors():
    s = Slots("a", ("rows", ("x", "y"), 3), "b")
    assert (s["a"], s["rows"], s["rows.y"], s["b"], s.size) == (0, 1, 2, 7, 8)
    assert s.stride("rows") == 2 and s.count("rows") == 3 and s.field("rows", "y") == 1
    assert s.names[1:3] == ("rows[0].x", "rows[0].y")
    with pytest.raises(KeyError, match="no slot"):
        s["c"]
    with pytest.raises(ValueError, match="twice"):
        Slots("a", "a")


def test_generated_slots_match_the_packed_arrays():
    th = bic.plant_array(bic.BicycleParams(mu=0.7), 17.0, steering_lag=0.05, yaw_bias=0.2)
    assert th.shape == (bic.PLANT.size,)
    assert (th[bic.MU], th[bic.VX], th[bic.STEER_LAG], th[bic.DR0]) == (0.7, 17.0, 0.05, 0.2)
    assert bic.has_lag_states(th) and bic.has_steering_lag(th)
    fp = FrictionParams(fc=(0.1, 0.2), b=(0.3, 0.4), fs=(0.5, 0.6), vs=(0.01, 0.02))
    dist = man.JointDisturbance(tau0=(1.0, 2.0), k=(3.0, 4.0), q0=(5.0, 6.0))
    th = man.plant_array(man.ManipulatorParams(), fp, dist)
    assert th.shape == (man.PLANT.size,)
    for j in range(2):
        row = th[man.FRICTION + j * man.FRICTION_STRIDE:][:len(FRICTION_FIELDS)]
        np.testing.assert_array_equal(row, fp.array[j])
        d = man.DISTURBANCE + j * man.DISTURBANCE_STRIDE
        assert (th[d + man.TAU0], th[d + man.K], th[d + man.Q0]) == (1.0 + j, 3.0 + j, 5.0 + j)
