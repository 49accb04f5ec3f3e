"""Residual forms hand effects an immutable EffectContext, never themselves (issue 12)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from simgap.diagnosis.effects import BICYCLE_EFFECTS, MECHANICAL_EFFECTS, Effect
from simgap.diagnosis.fit import Fitter, Term
from simgap.diagnosis.forms import EffectContext, ResidualForm
from simgap.diagnosis.generate import InjectedEffect, generate
from simgap.diagnosis.systems import BicycleSystem, MechanicalSystem
from simgap.models.manipulator import ManipulatorNominal


def test_effects_receive_a_read_only_context() -> None:
    rec = generate("manipulator2dof", [InjectedEffect(effect="viscous_friction",
                                                      channel="joint1", params={"b": 0.2})],
                   seed=0, duration=4.0)
    system = MechanicalSystem(ManipulatorNominal())
    res = system.prepare(rec)
    assert isinstance(system, ResidualForm)
    seen = []
    viscous = next(e for e in MECHANICAL_EFFECTS if e.name == "viscous_friction")

    def spy(lin, nl, sig, j, ctx):
        seen.append(ctx)
        return viscous.fn(lin, nl, sig, j, ctx)

    fitter = Fitter(system, res.residual, res.noise_rms, mask=system.fit_mask())
    sel = fitter.select([Term(dataclasses.replace(viscous, fn=spy), 0, "joint1")])
    assert sel.fit.terms and seen
    assert all(isinstance(c, EffectContext) for c in seen)
    ctx = seen[0]
    assert ctx.n_channels == 2 and ctx.payload_regressor is not None
    with pytest.raises(ValueError):
        ctx.coulomb_sigma[0] = 1.0          # a read-only copy of the form's smoothing
    with pytest.raises(dataclasses.FrozenInstanceError):
        ctx.n_channels = 3


def test_bicycle_coupling_lives_in_the_context_not_the_form() -> None:
    rec = generate("bicycle", [], seed=1, duration=8.0)
    system = BicycleSystem()
    system.prepare(rec)
    sat = next(e for e in BICYCLE_EFFECTS if e.name == "tire_saturation")
    lag = next(e for e in BICYCLE_EFFECTS if e.name == "steering_lag")
    terms = [(sat, 0, np.zeros(0), np.array([0.8])), (lag, 0, np.zeros(0), np.array([0.05]))]
    ctx = system.context(terms)
    assert dict(ctx.axle_mu) == {0: 0.8}
    assert dict(system.context().axle_mu) == {}     # the form kept nothing
    assert not hasattr(system, "axle_mu")
    with pytest.raises(TypeError):
        ctx.axle_mu[1] = 0.5                          # type: ignore[index]
    # the lag goes through the fitted Magic Formula: with mu it differs from the linear tire
    sig = system.rows(np.arange(len(system.t)))
    with_mu = lag(np.zeros(0), np.array([0.05]), sig, 0, ctx)
    linear = lag(np.zeros(0), np.array([0.05]), sig, 0, system.context())
    assert np.any(with_mu != linear)
    assert isinstance(lag, Effect)
