"""Residual forms hand effects an immutable EffectContext, never themselves (issue 12)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from simgap.diagnosis.effects import BICYCLE_EFFECTS, MECHANICAL_EFFECTS, Effect
from simgap.diagnosis.fit import Fitter, Term
from simgap.diagnosis.forms import EffectContext, Prepared, ResidualForm
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

    fitter = Fitter(system, res, mask=res.fit_mask)
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
    prepared = system.prepare(rec)
    sat = next(e for e in BICYCLE_EFFECTS if e.name == "tire_saturation")
    lag = next(e for e in BICYCLE_EFFECTS if e.name == "steering_lag")
    terms = [(sat, 0, np.zeros(0), np.array([0.8])), (lag, 0, np.zeros(0), np.array([0.05]))]
    ctx = system.context(prepared, terms)
    assert dict(ctx.axle_mu) == {0: 0.8}
    assert dict(system.context(prepared).axle_mu) == {}     # the form kept nothing
    assert not hasattr(system, "axle_mu")
    with pytest.raises(TypeError):
        ctx.axle_mu[1] = 0.5                          # type: ignore[index]
    # the lag goes through the fitted Magic Formula: with mu it differs from the linear tire
    sig = prepared.rows(np.arange(prepared.n))
    with_mu = lag(np.zeros(0), np.array([0.05]), sig, 0, ctx)
    linear = lag(np.zeros(0), np.array([0.05]), sig, 0, system.context(prepared))
    assert np.any(with_mu != linear)
    assert isinstance(lag, Effect)


def test_prepare_returns_immutable_data_and_keeps_nothing_on_the_form() -> None:
    """One form, two recordings: each Prepared is read-only and independent (issue 12)."""
    form = MechanicalSystem(ManipulatorNominal())
    before = dict(vars(form))
    recs = [generate("manipulator2dof", [InjectedEffect(effect="viscous_friction",
                                                        channel="joint1", params={"b": b})],
                     seed=s, duration=4.0) for s, b in ((0, 0.2), (1, 0.4))]
    first, second = (form.prepare(r) for r in recs)
    assert vars(form).keys() == before.keys()          # nothing stored on the form
    assert isinstance(first, Prepared) and not np.array_equal(first.residual, second.residual)
    assert not first.raw and first.state is None  # not stored twice (issue 17)
    for arr in (first.t, first.residual, first.noise_rms, first.signals["dq"],
                first.inputs, first.fit_mask, first.coulomb_sigma):
        with pytest.raises(ValueError):
            arr[0] = 1.0
    with pytest.raises(TypeError):
        first.signals["dq"] = np.zeros(3)               # type: ignore[index]
    with pytest.raises(dataclasses.FrozenInstanceError):
        first.residual = np.zeros(3)                    # type: ignore[misc]
    # the recording's own columns stay writable (prepare froze copies, not the caller's data)
    recs[0].columns["q1"][0] = recs[0].columns["q1"][0]
    # the protocol is the slim one: no recording-derived state, every step takes Prepared
    assert isinstance(form, ResidualForm)
    for gone in ("t", "sig", "raw", "smoother", "fit_mask", "rows", "state_at"):
        assert not hasattr(form, gone)
    idx = np.arange(10, 20)
    assert form.derivative(second, idx, []).shape == (10, 2)
    assert form.step(second, second.state_at(idx), idx, [], second.dt).shape == (10, 4)


def test_prepared_state_is_built_from_the_signals_and_the_noise_pass_residual_is_the_same(
) -> None:
    """The state is not stored twice but equals (q, dq) bit for bit; the noise-floor passes'
    shorter signal set (``residual_only``) gives the very residual ``prepare`` computed."""
    rec = generate("manipulator2dof", [InjectedEffect(effect="coulomb_friction",
                                                      channel="joint2", params={"Fc": 0.2})],
                   seed=1, duration=4.0)
    form = MechanicalSystem(ManipulatorNominal())
    prep = form.prepare(rec)
    full = np.concatenate([prep.signals["q"], prep.signals["dq"]], axis=1)
    assert np.array_equal(prep.state_at(slice(None)), full)
    idx = np.array([3, 0, 500, 7])
    assert np.array_equal(prep.state_at(idx), full[idx])
    assert prep.state_at(idx).flags.c_contiguous
    bike = BicycleSystem()
    bprep = bike.prepare(generate("bicycle", [], seed=0, duration=6.0))
    assert np.array_equal(bprep.state_at(idx),
                          np.stack([bprep.signals["vy"], bprep.signals["r"]], axis=1)[idx])
    raw = {k: np.asarray(rec[k], dtype=np.float64) for k in form.columns.required
           if k != form.columns.t}
    assert prep.plan.kernel is not None
    assert np.array_equal(form.residual_of(raw, prep.plan), prep.residual)


def test_fitter_called_the_old_way_says_what_to_pass() -> None:
    rec = generate("manipulator2dof", [], seed=0, duration=4.0)
    form = MechanicalSystem(ManipulatorNominal())
    res = form.prepare(rec)
    with pytest.raises(TypeError, match="Prepared"):
        Fitter(form, res.residual, res.noise_rms)       # type: ignore[arg-type]


def test_batch_rk4_is_the_integrators_formula() -> None:
    """The diagnosis' batch RK4 equals the models' numba RK4 row by row, bit for bit."""
    from simgap.models import manipulator as man
    from simgap.models.integrators import rk4_batch_step, rk4_step

    la = man.ManipulatorParams().array
    rng = np.random.default_rng(0)
    x = rng.normal(size=(5, 4))
    u = rng.normal(size=2)

    def batch(xs):
        return np.stack([man.nominal_derivative(r, u, la) for r in xs])
    got = rk4_batch_step(batch, x, 0.002)
    want = np.stack([rk4_step(man.nominal_derivative, r, u, la, 0.002) for r in x])
    assert np.array_equal(got, want)


def test_forms_take_data_rules_and_coupling_from_the_vocabulary() -> None:
    """The Stribeck bound, the gravity exclusion and the steering lag's coupling are the
    effects' declarations (FitSpec.for_data, EffectSpec.needs), not the adapters' code."""
    import inspect

    from simgap.diagnosis import systems
    from simgap.models import manipulator as man
    from simgap.models.prismatic import RigidAxisNominal, RigidAxisParams

    source = inspect.getsource(systems)
    for name in ("stribeck_friction", "gravity_mismatch", "tire_saturation", "steering_lag"):
        assert f'"{name}"' not in source
    specs = {s.name: s for s in man.VOCABULARY}
    assert specs["stribeck_friction"].fit.for_data is not None
    assert specs["gravity_mismatch"].fit.for_data is not None
    # a horizontal slider: no gravity term is tried; vs is bounded by its recorded speed
    form = systems.MechanicalSystem(RigidAxisNominal(RigidAxisParams(mass=2.0)))
    t = np.arange(3000) * 1e-3
    q = 0.05 * np.sin(2 * np.pi * t)
    rec = form.prepare(_axis_recording(form, t, q))
    cands = {(e.name, j): e for e, j, _ in form.candidates(rec)}
    assert ("gravity_mismatch", None) not in cands
    vmax = float(np.max(np.abs(rec.signals["dq"])))
    assert cands[("stribeck_friction", 0)].nl_bounds[0][1] == pytest.approx(
        man.STRIBECK_MAX_SHARE * vmax)
    assert systems.STRIBECK_MAX_SHARE == man.STRIBECK_MAX_SHARE      # kept alias


def _axis_recording(form, t, q):
    from simgap.recordings import Recording

    cols = {"t": t, "q": q, "dq": np.gradient(q, t), "u": 2.0 * np.gradient(np.gradient(q, t), t)}
    return Recording("axis", {k: cols[k] for k in form.columns.required}, {})


def test_one_mechanical_form_for_the_arm_and_user_models() -> None:
    """The arm is one more mechanical model: the same form class, columns and units from
    the model; only its declared capabilities differ (fast kernels, payload, fixed bounds)."""
    from simgap.diagnosis import systems
    from simgap.diagnosis.pipeline import make_system
    from simgap.models.prismatic import RigidAxisNominal, RigidAxisParams

    arm, axis = make_system("manipulator2dof"), make_system(
        RigidAxisNominal(RigidAxisParams(mass=2.0)))
    assert type(arm) is type(axis) is MechanicalSystem
    assert arm.columns == systems.MANIPULATOR_COLUMNS and arm.channel_units == ("N·m",) * 2
    assert arm.state_units == ("rad", "rad", "rad/s", "rad/s")
    assert axis.channel_units == ("N",) and axis.state_units == ("m", "m/s")
    assert not arm.scaled_to_data and axis.scaled_to_data
    with pytest.warns(DeprecationWarning, match="ModelMechanicalSystem is deprecated"):
        assert systems.ModelMechanicalSystem is MechanicalSystem


def test_steering_lag_is_tried_only_where_the_command_varies() -> None:
    """The bicycle's steering-lag rule is its vocabulary entry's ``for_data``."""
    from simgap.diagnosis import systems
    from simgap.diagnosis.generate import generate_bicycle
    from simgap.models import bicycle as bic

    specs = {s.name: s for s in bic.VOCABULARY}
    assert specs["steering_lag"].fit.for_data is not None
    form = systems.BicycleSystem()
    front_only = form.prepare(generate_bicycle(duration=8.0, seed=0))
    both = form.prepare(generate_bicycle(duration=8.0, seed=0, rear_steer=0.3))
    lag = {j for e, j, _ in form.candidates(front_only) if e.name == "steering_lag"}
    assert lag == {0}
    lag = {j for e, j, _ in form.candidates(both) if e.name == "steering_lag"}
    assert lag == {0, 1}
