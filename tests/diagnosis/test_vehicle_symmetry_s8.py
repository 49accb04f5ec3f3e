"""Issue 13 (vehicle, s8): a declared symmetry is answered by its simplest member.

Mass, yaw inertia and both axles' tire laws scaled by one factor leave the single-track
motion unchanged (``BicycleSystem.symmetries``). A forward selection that picks a
cornering-stiffness ratio first ends on the three-term equivalent of one mass ratio
(Cf 0.86, Cr 0.87, Iz 0.88 ≈ 1/1.15, the proof's steering lag + mass pair, seed 4 on
s7). Two causes, each tested here:

* the inertia terms' instruments (first stage of the two-stage least squares) missed the
  speed's variation: a ±15 % speed left 0.47 m/s² of the lateral acceleration outside the
  projection (noise-free log; the derivative noise is 0.15 m/s²), a physical part of the mass
  regressor missing, so the symmetric equivalent in tire-law ratios fitted better;
* nothing preferred the simplest of equivalent descriptions: ``Fitter._simplest_members``
  replaces the chosen members by a smaller set of the same symmetry when the backward
  pass's held-out test does not reject it.
"""

from __future__ import annotations

import os

import numpy as np
import pytest

from simgap.diagnosis.fit import Fitter, Selection, Term
from simgap.diagnosis.generate import InjectedEffect, generate
from simgap.diagnosis.identifiability import Symmetry
from simgap.diagnosis.proof import run_case
from simgap.diagnosis.systems import BicycleSystem

SLOW = os.environ.get("SIMGAP_SLOW") == "1"
PAIR = [InjectedEffect(effect="steering_lag", params={"tau": 0.08}),
        InjectedEffect(effect="mass_mismatch", params={"ratio": 1.15})]
M, IZ, CF, CR = ("mass_mismatch", None), ("yaw_inertia_mismatch", None), \
    ("cornering_stiffness", 0), ("cornering_stiffness", 1)


def test_replacements_hold_every_absent_member_and_are_smaller() -> None:
    members = [M, IZ, CF, CR]
    # three tire/inertia scales: the absent member, alone first, then with one of them
    out = Symmetry.replacements([CF, CR, IZ], members)
    assert out == [(M,), (M, CF), (M, CR), (M, IZ)]
    # two scales: every equivalent needs both absent ones, never fewer than two
    assert Symmetry.replacements([CF, CR], members) == []
    assert Symmetry.replacements([M], members) == []
    # all four: any three of them (one scaled back to 1), down to none at all
    out = Symmetry.replacements([M, IZ, CF, CR], members)
    assert out[0] == () and len(out) == 1 + 4 + 6 + 4
    assert all(len(o) < 4 for o in out)


def test_the_vehicle_declares_its_symmetry() -> None:
    (sym,) = BicycleSystem.symmetries
    assert {"mass_mismatch", "yaw_inertia_mismatch", "cornering_stiffness"} == \
        set(sym.members)


def test_first_stage_spans_the_speed_variation() -> None:
    """Noise-free proof log (±15 % speed): the instruments now span the lateral
    acceleration to well below the derivative noise (before: 0.47 m/s² left)."""
    rec = generate("bicycle", PAIR, seed=4, duration=40.0, noise_vy=1e-9, noise_r=1e-9,
                   noise_vx=1e-9)
    p = BicycleSystem().prepare(rec)
    s, ok = p.signals, p.valid
    ay = s["dvy"] + s["vx"] * s["r"]
    assert np.std((ay - s["ay_ref"])[ok]) < 0.1
    assert np.std((s["dr"] - s["dr_ref"])[ok]) < 0.03


def test_three_scale_equivalent_is_replaced_by_the_mass_ratio() -> None:
    """The s7 answer of seed 4 (steering lag + Cf, Cr, Iz ratios) put in by hand: the rule
    names the one mass ratio in their place, at its true value."""
    rec = generate("bicycle", PAIR, seed=4, duration=40.0)
    form = BicycleSystem()
    p = form.prepare(rec)
    fitter = Fitter(form, p, mask=p.fit_mask, segments=p.segment)
    cands = [Term(e, j, ch) for e, j, ch in form.candidates(p)]
    by = {t.key: t for t in cands}
    chosen = [by[("steering_lag", 0)], by[CF], by[CR], by[IZ]]
    current = fitter.fit(chosen, full=False)
    sel = Selection(fit=current)
    tried: dict = {}
    out = fitter._simplest_members(current, sel, tried, cands)
    keys = [t.key for t in out.terms]
    assert keys == [("steering_lag", 0), M], keys
    ratio = 1.0 + float(out.lin[1][0])
    assert abs(ratio - 1.15) < 0.02, ratio
    assert tried[(M,)]["decision"] == "named"
    assert {tried[(k,)]["decision"] for k in (CF, CR, IZ)} == {"removed"}


@pytest.mark.parametrize("seed", [3, 4, 8] if not SLOW else list(range(10)))
def test_steering_lag_and_mass_pair_named(seed: int) -> None:
    """Seed 4: the three-scale equivalent before; seed 3: both axles' saturation stood in
    (mass then pushed them to μ = 3, the linear tire, and was rejected as 'on a limit')."""
    res = run_case(PAIR, "bicycle", seed, duration=40.0)
    assert res.named and res.param_error <= 0.02 and not res.extra, \
        [(f["effect"], f["channel"]) for f in res.found]


def _joint_scale(p, sig) -> np.ndarray:
    """Cornering-stiffness ratios and mass ratio fitted together (whitened least squares)."""
    from simgap.models.bicycle import VOCABULARY
    form = BicycleSystem()
    ctx = form.context(p)
    fits = {s.name: s.fit for s in VOCABULARY}
    ok = p.valid & p.fit_mask[:, 0]
    w = 1.0 / p.noise_rms
    one = np.ones(1)
    cols = [fits["cornering_stiffness"].fn(one, (), sig, i, ctx) for i in (0, 1)]
    cols.append(fits["mass_mismatch"].fn(one, (), sig, None, ctx))
    x = np.column_stack([(c * w)[ok].ravel() for c in cols])
    coef, *_ = np.linalg.lstsq(x, (p.residual * w)[ok].ravel(), rcond=None)
    return 1.0 + coef


@pytest.mark.parametrize("seed", [0, 1])
def test_slip_angle_noise_is_what_shrank_the_joint_scale(seed: int) -> None:
    """Item 2 of the s7 log (the stiffness terms 2-3 % low): with the *exact* ay as the mass
    regressor, the measured slip angles shrink the joint scale to ≈ 0.9 (their filtered-state
    noise is in the residual too); instrumented like the accelerations, within 2 % of 1."""
    import functools

    import simgap.diagnosis.scenarios as sc
    rec = sc.circles([], 500 + seed).recording
    orig = sc.generate_bicycle
    sc.generate_bicycle = functools.partial(orig, noise_vy=1e-9, noise_r=1e-9, noise_vx=1e-9)
    try:
        exact = BicycleSystem().prepare(sc.circles([], 500 + seed).recording).signals
    finally:
        sc.generate_bicycle = orig
    p = BicycleSystem().prepare(rec)
    sig = {**p.signals, "idx": np.arange(p.n),
           "ay_ref": exact["dvy"] + exact["vx"] * exact["r"]}
    measured = {k: v for k, v in sig.items() if k not in ("alpha_f_ref", "alpha_r_ref")}
    assert np.all(_joint_scale(p, measured) < 0.95)
    assert np.all(np.abs(_joint_scale(p, sig) - 1.0) < 0.02)
