"""Causes of the misses under noise artefacts (issue 13; quantised, coloured, 100 Hz logs).

Each test reproduces one case of ``benchmarks/diagnosis_artefacts.py`` that failed for a
general reason, and a counterpart that must keep its behaviour, so that each mechanism can
fail both ways:

* the input-hold choice must not be swamped by an unmodelled mass (a payload on a 100 Hz
  log of a 500 Hz loop kept ZOH, and the lag's leftover was named as a friction);
* a hypothesis that contains another (spring k·q + c ⊃ bias c) is named only when it beats
  it held out (a coloured-noise torque bias was named as a spring);
* Stribeck's velocity scale is not fitted below the slowest speed the fit reads (a
  quantised encoder's fit went to a spike vs = 0.007 rad/s, Fs = 620 N·m), and a term that
  passes its held-out test but whose parameters are not determined is said, not dropped
  silently ("No mismatch").
"""

import numpy as np
import pytest

from simgap.diagnosis.artefacts import ARTEFACTS
from simgap.diagnosis.fit import Fitter, Term
from simgap.diagnosis.generate import generate_manipulator
from simgap.diagnosis.pipeline import diagnose
from simgap.diagnosis.proof import draw
from simgap.diagnosis.systems import STICK_WIDTHS, MechanicalSystem
from simgap.models.manipulator import ManipulatorNominal
from simgap.recordings import Recording

PAIRS = {"dq1": "q1", "dq2": "q2"}


def _case(effect: str, artefact: str | None, seed: int):
    """The benchmark's recording of one effect × artefact × seed (its seeds)."""
    inj = draw(effect, np.random.default_rng(1000 + seed))
    rec = generate_manipulator([inj], seed=seed, duration=20.0)
    if artefact is not None:
        rec = ARTEFACTS[artefact].apply(rec, PAIRS, np.random.default_rng(9000 + seed))
    return inj, Recording(rec.name, dict(rec.columns))


def _found(rep) -> list[str]:
    return [f"{e['effect']}@{e['channel']}" for e in rep.effects]


# ---------------------------------------------------------------- the input's lag
@pytest.mark.parametrize("seed", [1, 2])
def test_a_payload_does_not_hide_the_input_lag_at_100hz(seed):
    """Before: hold 0.5 (ZOH, 5 ms) and a viscous friction / quadratic drag at joint 1
    beside the payload; the clean 100 Hz logs of the same loop get ≈ 0.1 sample."""
    inj, rec = _case("payload_mass", "coarse_100hz", seed)
    res = MechanicalSystem(ManipulatorNominal()).prepare(rec)
    assert 0.05 < res.plan.hold < 0.2, res.plan.hold
    rep = diagnose(rec, "manipulator2dof")
    assert _found(rep) == ["payload_mass@joint2"], _found(rep)
    assert abs(rep.effects[0]["parameters"]["mp"] / inj.params["mp"] - 1) < 0.05


def test_a_payload_at_the_controller_rate_keeps_zoh():
    """The same payload logged at the loop's own rate: the hold stays ZOH (bit for bit)."""
    _, rec = _case("payload_mass", None, 1)
    assert MechanicalSystem(ManipulatorNominal()).prepare(rec).plan.hold == 0.5


# ---------------------------------------------------------------- nested hypotheses
def test_nests_reads_generalizes_and_families():
    sys_ = MechanicalSystem(ManipulatorNominal())
    rec = generate_manipulator(seed=500, duration=4.0)
    res = sys_.prepare(rec)
    t = {f"{e.name}@{ch}": Term(e, j, ch) for e, j, ch in sys_.candidates(res)}
    assert Fitter._nests((t["spring@joint1"],), (t["torque_bias@joint1"],))
    assert not Fitter._nests((t["torque_bias@joint1"],), (t["spring@joint1"],))
    assert not Fitter._nests((t["spring@joint2"],), (t["torque_bias@joint1"],))
    assert Fitter._nests((t["stribeck_friction@joint2"],), (t["coulomb_friction@joint2"],))
    fam = (t["coulomb_friction@joint1"], t["viscous_friction@joint1"])
    assert Fitter._nests(fam, (t["viscous_friction@joint1"],))
    assert not Fitter._nests(fam, fam)


def test_a_bias_under_coloured_noise_is_not_named_as_a_spring():
    """Before: spring k = −0.080 ± 0.048 N·m/rad, q0 = 3.1 ± 1.5 rad (6 % more validation
    gain than the bias, beyond the 5 % tie, with a slope 1.7 stderr from zero)."""
    inj, rec = _case("torque_bias", "coloured_noise", 1)
    rep = diagnose(rec, "manipulator2dof")
    assert _found(rep) == ["torque_bias@joint1"], _found(rep)
    assert abs(rep.effects[0]["parameters"]["tau0"] / inj.params["tau0"] - 1) < 0.2
    spring = [e for e in rep.data["tried"] if e["effect"] == "spring"
              and e["channel"] == "joint1"]
    assert spring and spring[0]["decision"] != "named"


def test_a_real_spring_under_coloured_noise_is_still_a_spring():
    inj, rec = _case("spring", "coloured_noise", 0)
    rep = diagnose(rec, "manipulator2dof")
    assert _found(rep) == [f"spring@{inj.channel}"], _found(rep)
    assert abs(rep.effects[0]["parameters"]["k"] / inj.params["k"] - 1) < 0.2


# ---------------------------------------------------------------- Stribeck's scale
def test_stribeck_scale_is_bounded_by_the_slowest_fitted_speed():
    """Quantised encoder: the fit mask starts at 3 Coulomb widths (≈ 0.09 rad/s), the start
    grid below it goes; clean: the mask is ≈ 0.008 rad/s and the start grid stays."""
    for artefact, quantised in (("quantised_encoder", True), (None, False)):
        _, rec = _case("stribeck_friction", artefact, 0)
        sys_ = MechanicalSystem(ManipulatorNominal())
        res = sys_.prepare(rec)
        for e, j, _ch in sys_.candidates(res):
            if e.name != "stribeck_friction":
                continue
            floor = STICK_WIDTHS * res.coulomb_sigma[j]
            lo = e.nl_bounds[0][0]
            assert lo >= floor * (1 - 1e-12)
            assert all(v > lo for v in e.nl_grid[0])
            assert (lo > 0.05) == quantised, (artefact, lo, floor)
            assert (e.nl_grid[0] == (0.01, 0.03, 0.1, 0.3)) != quantised


def test_quantised_stribeck_is_found_not_silenced():
    """Before: vs = 0.007 rad/s, Fs = 620 N·m, held-out loss, and "No mismatch". Now the
    fit lands at the truth's scale (vs 0.21 rad/s) with a significant held-out gain and
    is named (Fs = 0.28 ± 0.08 N·m, vs = 0.19 ± 0.04 rad/s); were its (Fs, vs) shape not
    determined, the report would still say there is a mismatch at joint 2 and what fits
    it (a signed projection of ≈ 0 had called it undetermined)."""
    inj, rec = _case("stribeck_friction", "quantised_encoder", 0)
    rep = diagnose(rec, "manipulator2dof")
    st = [e for e in rep.data["tried"] if e["effect"] == "stribeck_friction"
          and e["channel"] == inj.channel][0]
    assert abs(st["params"]["vs"] / inj.params["vs"] - 1) < 0.3, st["params"]
    assert st["params"]["Fs"] < 2.0
    assert st["p_value"] is not None and st["p_value"] < 1e-3
    assert rep.significant
    assert "stribeck friction at joint 2" in rep.data["verdict"].lower().replace("_", " ")
    if rep.effects:
        # the named values must hold the truth within their stated uncertainty (3 standard
        # errors): with the rows refined (validation.refinement) this draw gives Fs = 0.231
        # ± 0.053 N·m (truth 0.304, 1.4 stderr) where the half-window rows gave 0.28 ± 0.08;
        # over seeds 0-7 of this preset two are named within 20 % now (5 %, 7 %), one
        # before (this one). A fixed 20 % on a term whose stderr is 23 % tested the draw.
        assert _found(rep) == ["stribeck_friction@joint2"]
        got, se = rep.effects[0]["parameters"], rep.effects[0]["stderr"]
        assert all(abs(got[k] - inj.params[k]) < 3.0 * se[k] for k in ("Fs", "vs")), (got, se)
        assert all(abs(got[k] / inj.params[k] - 1) < 0.3 for k in ("Fs", "vs")), got
    else:
        assert st["decision"] == "not identifiable"
        assert "No mismatch" not in rep.data["verdict"]


def test_clean_quantised_log_still_claims_nothing():
    for seed in (500, 501):
        rec = ARTEFACTS["quantised_encoder"].apply(generate_manipulator(seed=seed,
                                                                        duration=20.0),
                                                   PAIRS, np.random.default_rng(9000 + seed))
        rep = diagnose(Recording(rec.name, dict(rec.columns)), "manipulator2dof")
        assert not rep.effects and not rep.significant, rep.data["verdict"]


# ---------------------------------------------------------------- identifiability
def test_a_nonlinear_direction_is_not_undetermined_by_a_cancelling_projection():
    """Two parameters whose scaled values are equal: the signed projection on their
    difference is 0. Every direction, linear or with a nonlinear parameter (a scale), is
    compared with Σ|vⱼθⱼ| and is determined when its standard error is small; with a large
    error it is still undetermined. (Linear pairs used the signed projection until the real
    EMPS log at 100 Hz: viscous and Coulomb friction of equal scaled size were "not
    determined" and the viscous term alone took the Coulomb force; see
    benchmarks/results/diagnosis_s8-real_causes.md.)"""
    from simgap.diagnosis.identifiability import analyse

    rng = np.random.default_rng(0)
    a = rng.normal(size=400)
    j = np.column_stack([a, 0.8 * a + 0.6 * rng.normal(size=400)])   # correlated columns
    norms = np.linalg.norm(j, axis=0)
    values = 5.0 / norms                           # equal scaled sizes: projection 0
    names = ["e@j:A", "e@j:vs"]
    lin = analyse(j, names, noise_std=1.0, values=values, nonlinear=[False, False])
    mixed = analyse(j, names, noise_std=1.0, values=values, nonlinear=[False, True])
    assert lin.identifiable
    assert mixed.identifiable
    assert not analyse(j, names, noise_std=50.0, values=values,
                       nonlinear=[False, False]).identifiable
    noisy = analyse(j, names, noise_std=50.0, values=values, nonlinear=[False, True])
    assert not noisy.identifiable


def test_verdict_says_when_what_fits_is_not_determined():
    from simgap.diagnosis.locate import ChannelStat
    from simgap.diagnosis.pipeline import verdict

    stats = [ChannelStat("joint1", 0.1, 0.1, False), ChannelStat("joint2", 0.13, 0.12, True)]
    plain = verdict([], stats, None, None)
    said = verdict([], stats, None, None, undetermined=True)
    assert plain.startswith("Mismatch at joint 2") and said.startswith("Mismatch at joint 2")
    assert "not determined" in said and "not determined" not in plain


# ---------------------------------------------------------------- coloured error
def test_coloured_error_lengthens_the_equations_window_white_does_not():
    """2 % AR(1) noise (50 ms): the residual's upper band holds 6-7x the white floor's
    error, and the window is re-chosen for it (0.25 s at most); the same log without it
    keeps its window and has no note."""
    from simgap.diagnosis.systems import EXCESS_WINDOW_S

    clean = generate_manipulator(seed=500, duration=20.0)
    coloured = ARTEFACTS["coloured_noise"].apply(clean, PAIRS, np.random.default_rng(9500))
    sys_ = MechanicalSystem(ManipulatorNominal())
    a, b = sys_.prepare(clean), sys_.prepare(Recording(coloured.name,
                                                       dict(coloured.columns)))
    note = "high-frequency error is"
    assert not any(note in w for w in a.warnings)
    assert any(note in w for w in b.warnings), b.warnings
    assert a.smoother.window < b.smoother.window <= int(EXCESS_WINDOW_S / a.dt) | 1


def test_an_inertia_error_under_coloured_noise_is_named():
    """Before: 3.5 % of the held-out residual, p = 0.013, not named (window 55 samples)."""
    inj, rec = _case("inertia_mismatch", "coloured_noise", 0)
    rep = diagnose(rec, "manipulator2dof")
    assert _found(rep) == [f"inertia_mismatch@{inj.channel}"], _found(rep)
    assert abs(rep.effects[0]["parameters"]["dI"] / inj.params["dI"] - 1) < 0.2


# ---------------------------------------------------------------- the long variant
@pytest.mark.slow
@pytest.mark.parametrize("seed", range(5))
def test_noise_presets_hold_over_seeds(seed):
    """SIMGAP_SLOW=1: over five seeds, a payload at 100 Hz is named alone, a bias under
    coloured noise is never named as a spring, and the clean quantised, coloured and 100 Hz
    logs claim nothing."""
    _, rec = _case("payload_mass", "coarse_100hz", seed)
    assert _found(diagnose(rec, "manipulator2dof")) == ["payload_mass@joint2"]
    inj, rec = _case("torque_bias", "coloured_noise", seed)
    found = _found(diagnose(rec, "manipulator2dof"))
    assert not any(f.startswith("spring") for f in found), found
    for artefact in ("quantised_encoder", "coloured_noise", "coarse_100hz"):
        clean = ARTEFACTS[artefact].apply(generate_manipulator(seed=500 + seed, duration=20.0),
                                          PAIRS, np.random.default_rng(9500 + seed))
        rep = diagnose(Recording(clean.name, dict(clean.columns)), "manipulator2dof")
        assert not rep.effects and not rep.significant, (artefact, rep.data["verdict"])
