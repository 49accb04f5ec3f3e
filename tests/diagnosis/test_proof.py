"""Concealed-effect proof (issue 5): every vocabulary effect named blind, clean recordings
stay clean, two effects at once, rollout error drops ≥ 2× (a single effect whose exact
model cannot halve it, being little above the noise floor: 90 % of what the exact model gets).

CI runs a quick variant (short recordings, 2 seeds per effect); the full table (longer
recordings, 5 seeds) runs with SIMGAP_SLOW=1 and in benchmarks/diagnosis_proof.py.
"""

from __future__ import annotations

import numpy as np
import pytest

from simgap.diagnosis.generate import InjectedEffect
from simgap.diagnosis.proof import RANGES, TOLERANCE, draw, model_of, run_case

QUICK = {"manipulator2dof": 8.0, "bicycle": 20.0}
FULL = {"manipulator2dof": 20.0, "bicycle": 40.0}


#: Narrow Stribeck bumps (vs < 0.1 rad/s) need more velocity reversals than 8 s hold
#: (measured: 8 s recordings give up to 65 % error at vs = 0.075, 20 s stay below 19 %).
LONGER = {"stribeck_friction": 20.0}

#: Where even the injected effect at its true parameters lowers the held-out rollout error
#: less than 2x (an effect little above the noise floor, e.g. quadratic drag c = 0.0101 at
#: joint 1: exact model 1.73x), the fitted model must reach this share of that ceiling.
CEILING_SHARE = 0.9


def _check_single(name: str, seed: int, durations: dict[str, float]) -> None:
    inj = draw(name, np.random.default_rng(1000 + seed))
    model = model_of(name)
    res = run_case([inj], model, seed,
                   duration=max(durations[model], LONGER.get(name, 0.0)))
    assert res.named, f"{name} {inj} not named; found {res.found}"
    assert res.param_error <= TOLERANCE, f"{name} {inj}: parameter error {res.param_error:.2f}"
    assert not res.extra, f"{name}: extra effects named {res.extra}"
    need = CEILING_SHARE * res.ceiling if res.ceiling < 2.0 else 2.0  # NaN ceiling: 2
    assert res.improvement >= need, (f"{name}: rollout error only {res.improvement:.2f}× lower "
                                     f"(true parameters: {res.ceiling:.2f}×)")


@pytest.mark.parametrize("name", sorted(RANGES))
@pytest.mark.parametrize("seed", [0, 1])
def test_single_effect_named_quick(name: str, seed: int) -> None:
    _check_single(name, seed, QUICK)


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(RANGES))
@pytest.mark.parametrize("seed", range(2, 7))
def test_single_effect_named_full(name: str, seed: int) -> None:
    _check_single(name, seed, FULL)


@pytest.mark.parametrize("model", ["manipulator2dof", "bicycle"])
def test_clean_recordings_stay_clean(model: str) -> None:
    flagged = []
    for seed in range(20):
        res = run_case([], model, 500 + seed, duration=QUICK[model])
        if res.significant or res.found:
            flagged.append((seed, [e["effect"] for e in res.found]))
    assert not flagged, f"clean {model} recordings flagged: {flagged}"


def test_two_effects_manipulator() -> None:
    effects = [InjectedEffect(effect="coulomb_friction", channel="joint1", params={"Fc": 0.15}),
               InjectedEffect(effect="spring", channel="joint2", params={"k": 1.5, "q0": 0.2})]
    res = run_case(effects, "manipulator2dof", 3, duration=QUICK["manipulator2dof"])
    assert res.named and res.param_error <= TOLERANCE, res.found
    assert res.improvement >= 2.0


def test_two_effects_bicycle() -> None:
    effects = [InjectedEffect(effect="tire_saturation", params={"mu": 0.7}),
               InjectedEffect(effect="lateral_bias", params={"ay0": 0.4})]
    res = run_case(effects, "bicycle", 3, duration=QUICK["bicycle"])
    assert res.named and res.param_error <= TOLERANCE, res.found
    assert res.improvement >= 2.0


def test_interacting_effects_bicycle() -> None:
    """Steering lag acting through saturating tires: the lag term uses the fitted tire law."""
    effects = [InjectedEffect(effect="tire_saturation", params={"mu": 0.7}),
               InjectedEffect(effect="steering_lag", params={"tau": 0.08})]
    res = run_case(effects, "bicycle", 5, duration=QUICK["bicycle"])
    assert res.named and res.param_error <= TOLERANCE, res.found
    assert res.improvement >= 2.0


def test_out_of_vocabulary_not_forced() -> None:
    """Tire relaxation is not in the vocabulary: the mismatch is found and located, and a
    sizeable share stays unexplained instead of being forced into vocabulary terms."""
    from simgap.diagnosis.generate import generate_bicycle
    from simgap.diagnosis.pipeline import diagnose
    from simgap.recordings import Recording

    rec = generate_bicycle([InjectedEffect(effect="tire_relaxation", params={"length": 1.5})],
                           seed=4, duration=QUICK["bicycle"])
    rep = diagnose(Recording(rec.name, dict(rec.columns)), "bicycle")
    assert rep.significant
    assert rep.data["mismatch"]["segments"], "the mismatch must be located"
    assert rep.data["unexplained_fraction"] >= 0.3, rep.effects
    # ... and what stays unexplained is located too (spec: "with where it sits in mismatch")
    left = [r for r in rep.data["mismatch"]["regions"] if r["of"] == "unexplained"]
    assert left, rep.data["mismatch"]["regions"]
    assert all(r["text"].startswith("unexplained remainder") for r in left)


def test_explained_recording_has_no_unexplained_region() -> None:
    """When the named effect explains the residual, no remainder region is invented."""
    from simgap.diagnosis.generate import generate_manipulator
    from simgap.diagnosis.pipeline import diagnose

    rec = generate_manipulator([InjectedEffect(effect="coulomb_friction", channel="joint2",
                                               params={"Fc": 0.3})], duration=10.0, seed=1)
    regions = diagnose(rec, "manipulator2dof").data["mismatch"]["regions"]
    assert regions and all(r["of"] == "residual" for r in regions), regions
