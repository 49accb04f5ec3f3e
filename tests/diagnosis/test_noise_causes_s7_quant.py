"""Causes of the remaining quantised/coloured misses on the arm (issue 13, s7 quantised).

* **The dead zone's dwell test overstated its information.** A dead zone differs from a
  relay d·sign(u) only while the command dwells inside ±d. The test read that difference
  on the raw command samples against the channel's white-noise floor (one independent
  sample per half window). The fit reads it through the equation's filter, which smears a
  dwell shorter than its window, against an error that on coloured noise is 8-9x the white
  floor. Read as the fit reads it (:meth:`simgap.diagnosis.fit.Fitter._excitation_floor`),
  the dwell of the quantised and coloured presets' dead zones carries χ² 0.2-6.5, not
  2.1-663: they are located and reported as not identifiable from a relay, not named.
* **The coloured torque bias (seed 2) is not a multiplicity error.** Its p = 5.6e-4 is
  above the level even when only the single-term hypotheses are counted (0.01/19 = 5.3e-4):
  no count of the families lets it pass; the data hold too little evidence.
"""

import numpy as np
import pytest

from simgap.diagnosis.effects import VOCABULARY
from simgap.diagnosis.fit import ALPHA
from simgap.diagnosis.pipeline import diagnose
from simgap.diagnosis.proof import draw
from tests.diagnosis.test_noise_causes_s7 import _case


def _moving_average(width: int):
    kernel = np.ones(width) / width

    def seen(fn):
        return np.convolve(fn(u_grid), kernel, mode="same")[::width // 2]
    return seen


t_grid = np.linspace(0.0, 20.0, 10001)
#: a command that sweeps through ±0.2 quickly (≈ 10 samples inside per pass, 40 passes)
u_grid = 2.0 * np.sin(2 * np.pi * 1.0 * t_grid)


# ---------------------------------------------------------------- the dwell rule
def test_dwell_read_through_the_filter_not_raw_samples():
    """Short dwells: the raw samples inside the band pass the test, the same dwells seen
    through a 125-sample window (as the equation reads them) do not; a command that lingers
    inside the band for seconds passes both ways."""
    rule = VOCABULARY["dead_zone"].excitation
    d, lin, noise = np.array([0.2]), np.zeros(0), 0.05
    assert rule(None, lin, d, u_grid, noise) == ""                 # raw: χ² well above 6.6
    why = rule(None, lin, d, u_grid, noise, _moving_average(125))
    assert "tell a dead zone from a relay" in why, why
    slow = 0.3 * np.sin(2 * np.pi * 0.25 * t_grid)                # lingers inside ±0.2

    def seen_slow(fn):
        return np.convolve(fn(slow), np.ones(125) / 125, mode="same")[::62]
    assert rule(None, lin, d, slow, noise, seen_slow) == ""


# ---------------------------------------------------------------- reports
def _dead_zone_located_not_named(rep) -> None:
    (dz,) = [e for e in rep.data["tried"] if e["effect"] == "dead_zone"
             and e["channel"] == "joint2"]
    assert dz["decision"] == "not identifiable", dz
    assert "relay" in dz["reason"]
    assert rep.significant
    assert rep.data["verdict"].startswith("Mismatch at"), rep.data["verdict"]
    assert "joint 2" in rep.data["verdict"].split(":")[0]
    assert "relay" in rep.data["verdict"]
    assert not rep.effects                   # nothing else stands in for it


def test_coloured_dead_zone_is_located_not_named_from_an_uninformative_dwell():
    """Coloured noise, seed 0: the dwell's χ² read as the fit reads it is 0.36 (before:
    180 from the raw samples against the white floor, and a dead zone named)."""
    inj = draw("dead_zone", np.random.default_rng(1000))
    _dead_zone_located_not_named(diagnose(_case([inj], "coloured_noise", 0),
                                          "manipulator2dof"))


@pytest.mark.slow
@pytest.mark.parametrize(("artefact", "seed"), [("quantised_encoder", 0),
                                                ("quantised_encoder", 2),
                                                ("coloured_noise", 1),
                                                ("coloured_noise", 2)])
def test_uninformative_dwell_is_said_not_missed(artefact, seed):
    inj = draw("dead_zone", np.random.default_rng(1000 + seed))
    _dead_zone_located_not_named(diagnose(_case([inj], artefact, seed), "manipulator2dof"))


@pytest.mark.slow
def test_coloured_bias_seed_2_is_short_of_evidence_not_of_a_family_count(monkeypatch):
    """The torque bias at joint 1 (τ0 = 0.145 N·m) under coloured noise, seed 2: on the one
    validation part (s7: no cross-validation, Bonferroni) its p-value is above the level
    even if only the single-term hypotheses of the round are counted. Cross-validation
    names it (tests/diagnosis/test_selection_cv_s8.py)."""
    from simgap.diagnosis import fit as fit_mod
    monkeypatch.setattr(fit_mod, "CROSS_VALIDATE", False)
    monkeypatch.setattr(fit_mod, "EFFECTIVE_TESTS", False)
    inj = draw("torque_bias", np.random.default_rng(1002))
    rep = diagnose(_case([inj], "coloured_noise", 2), "manipulator2dof")
    tried = rep.data["tried"]
    (bias,) = [e for e in tried if e["effect"] == "torque_bias" and e["channel"] == "joint1"]
    singles = [e for e in tried if "+" not in e["effect"]
               and not e["reason"].startswith(("a fitted parameter", "cannot test"))]
    assert bias["p_value"] > ALPHA / len(singles), (bias["p_value"], len(singles))
    assert rep.data["verdict"].startswith("Mismatch at joint 1"), rep.data["verdict"]
    assert not rep.effects
