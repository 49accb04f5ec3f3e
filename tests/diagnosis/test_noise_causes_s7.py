"""Causes of the remaining noise-artefact misses on the arm (issue 13, s7).

* **Few rows on a long window.** Rows a half filter window apart hold too little of the
  filtered residual's information when the window is long (a coloured error chose 125
  samples: 133 usable rows in 20 s). A Stribeck term fitted on 93 such rows overshot
  (Fs = 0.43 for 0.30) and its validation gain did not replicate; an inertia error lost to
  its spring/cubic-stiffness aliases. Such logs now read each half-window row as up to
  four finer rows (:func:`simgap.diagnosis.validation.refinement`), with the blocks and
  their assignment unchanged (:func:`simgap.diagnosis.validation.refine`); the tests count
  N/τ effective samples.
* **Two look-alikes at one joint.** A dead zone and a Coulomb friction at joint 2: each
  alone leaves the other's structure error in its test's floor (τ ≈ 10 rows: ≈ 10
  effective samples) and neither passed; they are now also tried together
  (``FitSpec.confusable_with`` pairs in :meth:`simgap.diagnosis.fit.Fitter.hypotheses`).
"""

import numpy as np
import pytest

from simgap.diagnosis import validation
from simgap.diagnosis.artefacts import ARTEFACTS
from simgap.diagnosis.fit import Fitter, Term
from simgap.diagnosis.generate import InjectedEffect, generate_manipulator
from simgap.diagnosis.pipeline import diagnose
from simgap.diagnosis.proof import TOLERANCE, draw
from simgap.diagnosis.systems import MechanicalSystem
from simgap.models.manipulator import ManipulatorNominal
from simgap.recordings import Recording

PAIRS = {"dq1": "q1", "dq2": "q2"}


def _case(effects, artefact: str | None, seed: int) -> Recording:
    rec = generate_manipulator(effects, seed=seed, duration=20.0)
    if artefact is not None:
        rec = ARTEFACTS[artefact].apply(rec, PAIRS, np.random.default_rng(9000 + seed))
    return Recording(rec.name, dict(rec.columns))


def _found(rep) -> list[str]:
    return [f"{e['effect']}@{e['channel']}" for e in rep.effects]


def _error(rep, inj) -> float:
    (hit,) = [e for e in rep.effects if e["effect"] == inj.effect
              and e["channel"] == inj.channel]
    return max(abs(hit["parameters"][k] / v - 1) for k, v in inj.params.items())


# ---------------------------------------------------------------- refined rows
def test_refinement_only_where_half_window_rows_are_few():
    assert validation.refinement(validation.MIN_ROWS) == 1
    assert validation.refinement(5000) == 1
    assert validation.refinement(133) == 3
    assert validation.refinement(10) == validation.MAX_REFINE


def test_refine_keeps_each_block_and_part():
    """Each fine row joins its owner's part and block; nothing is in two parts."""
    t = np.arange(4000) * 0.002
    mask = np.ones((4000, 1), bool)
    mask[1500:1700] = False                        # a stick phase: its fine rows are dropped
    coarse = validation.usable_rows(4000, 40, mask, None)
    fine = validation.usable_rows(4000, 40, mask, None, step=5)
    regions = np.sin(t)[:, None]
    split = validation.split_rows(t, coarse, None, 0.7, regions=regions)
    out = validation.refine(split, coarse, fine, 20)
    owner = coarse[np.searchsorted(coarse, fine, side="right") - 1]
    for part in ("train", "valid", "test", "tail", "guard"):
        a, b = getattr(split, part), getattr(out, part)
        assert np.isin(b, fine).all()
        assert set(owner[np.isin(fine, b)]) <= set(a)          # owned by rows of the part
        assert len(b) >= len(a)
    assert len(out.fit) == len(out.train) + len(out.valid)
    parts = [out.train, out.valid, out.test, out.guard]
    assert sum(len(p) for p in parts) == len(np.unique(np.concatenate(parts)))
    own_valid = coarse[np.searchsorted(coarse, out.valid, side="right") - 1]
    np.testing.assert_array_equal(
        out.valid_block, split.valid_block[np.searchsorted(split.valid, own_valid)])
    assert not np.isin(np.arange(1500, 1700), np.concatenate(parts)).any()
    assert out.t_split == split.t_split


def test_a_long_window_reads_finer_rows_a_short_one_does_not():
    inj = draw("stribeck_friction", np.random.default_rng(1000))
    system = MechanicalSystem(ManipulatorNominal())
    coloured = system.prepare(_case([inj], "coloured_noise", 0))
    f = Fitter(system, coloured)
    coarse = validation.usable_rows(coloured.n, coloured.smoother.window,
                                    coloured.fit_mask, coloured.segment)
    assert len(coarse) < validation.MIN_ROWS
    assert len(f.fit_rows) + len(f.test) > 2 * 0.8 * len(coarse)   # 3 per coarse row here
    plain = system.prepare(_case([inj], None, 0))
    g = Fitter(system, plain)
    coarse = validation.usable_rows(plain.n, plain.smoother.window, plain.fit_mask,
                                    plain.segment)
    assert len(coarse) >= validation.MIN_ROWS
    np.testing.assert_array_equal(np.union1d(g.fit_rows, g.test),
                                  np.intersect1d(coarse, np.union1d(g.fit_rows, g.test)))


def test_coloured_stribeck_is_named():
    """Before: Fs = 0.43, vs = 0.245 on 93 rows; validation p = 2e-5, test p = 0.078: not
    confirmed, "No mismatch". Now Fs = 0.356 ± 0.097, vs = 0.210 ± 0.036 (truth 0.304,
    0.209)."""
    inj = draw("stribeck_friction", np.random.default_rng(1000))
    rep = diagnose(_case([inj], "coloured_noise", 0), "manipulator2dof")
    assert _found(rep) == ["stribeck_friction@joint2"], _found(rep)
    assert _error(rep, inj) <= TOLERANCE


def test_coloured_inertia_is_not_lost_to_its_aliases():
    """Before: spring 0.229, inertia 0.210, cubic stiffness 0.202 (validation gains), the
    spring picked, not confirmed (p = 0.04), "No mismatch". Now inertia 0.151 against a
    spring at 0.108, named dI = 0.0223 ± 0.0014 (truth 0.0245)."""
    inj = draw("inertia_mismatch", np.random.default_rng(1002))
    rep = diagnose(_case([inj], "coloured_noise", 2), "manipulator2dof")
    assert _found(rep) == ["inertia_mismatch@joint2"], _found(rep)
    assert _error(rep, inj) <= TOLERANCE


# ---------------------------------------------------------------- look-alikes together
def test_look_alikes_are_also_tried_together_once():
    system = MechanicalSystem(ManipulatorNominal())
    prep = system.prepare(_case([], None, 500))
    terms = [Term(e, j, ch) for e, j, ch in system.candidates(prep)]
    pairs = [tuple(t.label for t in h) for h in Fitter.hypotheses(terms) if len(h) == 2]
    for j in ("joint1", "joint2"):
        assert (f"dead_zone@{j}", f"torque_bias@{j}") in pairs
        assert (f"dead_zone@{j}", f"coulomb_friction@{j}") in pairs
    assert len(pairs) == len(set(pairs))
    dz = [h for h in pairs if h[0].startswith("dead_zone@")]
    assert len(dz) == 4 and all(h[0].split("@")[1] == h[1].split("@")[1] for h in dz)


@pytest.mark.parametrize("seed", [0, 1])
def test_dead_zone_and_coulomb_at_one_joint_are_both_named(seed):
    """Before: nothing named (each alone p = 0.001-0.03 at level 5e-4, its test's floor
    holding the other's structure error). Now both, within 1 % (d, Fc)."""
    dz = draw("dead_zone", np.random.default_rng(1000 + seed))
    fc = draw("coulomb_friction", np.random.default_rng(1000 + seed))
    fc = InjectedEffect(effect="coulomb_friction", channel="joint2", params=fc.params)
    rep = diagnose(_case([dz, fc], None, seed), "manipulator2dof")
    assert sorted(_found(rep)) == ["coulomb_friction@joint2", "dead_zone@joint2"]
    assert _error(rep, dz) < 0.05 and _error(rep, fc) < 0.05


# ---------------------------------------------------------------- combinations are a mismatch
def test_a_mismatch_fitted_as_a_combination_is_not_called_no_mismatch():
    """A quantised dead zone the command cannot tell from a relay (dwell χ² 0.9; 2.1 as read
    before s7-quant, from raw samples against the white floor) removes
    44 % of the validation error (p = 1e-44) and is fitted as a combination, not named.
    Before: "No mismatch beyond the noise" (its fit explained the residual the mismatch
    test reads), and the significant pairs of that round read "not significant (p = 2e-43
    ≥ 0.00043)". Now the mismatch is located at joint 2 and the pairs say they were
    significant."""
    inj = draw("dead_zone", np.random.default_rng(1002))
    rep = diagnose(_case([inj], "quantised_encoder", 2), "manipulator2dof")
    (dz,) = [e for e in rep.data["tried"] if e["effect"] == "dead_zone"
             and e["channel"] == "joint2"]
    assert dz["decision"] == "not identifiable", dz
    assert rep.significant
    assert rep.data["verdict"].startswith("Mismatch at joint 2"), rep.data["verdict"]
    assert not rep.effects
    for e in rep.data["tried"]:
        if e.get("p_value") is not None and e["p_value"] < 1e-10:
            assert "not significant" not in e["reason"], e


# ---------------------------------------------------------------- the long variants
def _stribeck_fs(rec: Recording, channel: str) -> float:
    system = MechanicalSystem(ManipulatorNominal())
    prep = system.prepare(rec)
    f = Fitter(system, prep)
    (term,) = [Term(e, j, ch) for e, j, ch in system.candidates(prep)
               if e.name == "stribeck_friction" and ch == channel]
    fit = f.fit_new(f.fit([], full=False), term, full=False)
    return float(f.fit(fit.terms, fit.nl, rows=f.fit_rows, full=False).lin[0][0])


@pytest.mark.slow
def test_refined_rows_halve_the_stribeck_scatter(monkeypatch):
    """SIMGAP_SLOW=1: over six coloured-noise draws of one Stribeck log, Fs scatters with
    sd 0.20 N·m on the half-window rows and 0.10 on the refined ones (measured)."""
    inj = draw("stribeck_friction", np.random.default_rng(1000))
    clean = generate_manipulator([inj], seed=0, duration=20.0)
    recs = [ARTEFACTS["coloured_noise"].apply(clean, PAIRS, np.random.default_rng(9000 + k))
            for k in range(6)]
    recs = [Recording(r.name, dict(r.columns)) for r in recs]
    refined = [_stribeck_fs(r, inj.channel) for r in recs]
    monkeypatch.setattr(validation, "MIN_ROWS", 0)
    coarse = [_stribeck_fs(r, inj.channel) for r in recs]
    assert np.std(refined, ddof=1) < 0.6 * np.std(coarse, ddof=1), (refined, coarse)


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(4))
def test_dead_zone_and_coulomb_over_seeds(seed):
    """SIMGAP_SLOW=1: seeds 0-3 of the pair, both named within 5 %."""
    test_dead_zone_and_coulomb_at_one_joint_are_both_named(seed)
