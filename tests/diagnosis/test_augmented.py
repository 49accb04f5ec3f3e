"""Augmented model: same physics as the fitted effects, a NominalModel, JSON round trip."""

from __future__ import annotations

import numpy as np
import pytest

from simgap.diagnosis.augmented import (
    AugmentedBicycle,
    AugmentedManipulator,
    ModelFileError,
    load_model,
    save_model,
)
from simgap.diagnosis.effects import VOCABULARY
from simgap.diagnosis.generate import InjectedEffect, generate_manipulator, manipulator_plant
from simgap.diagnosis.systems import MechanicalSystem
from simgap.models import bicycle as bicycle_model
from simgap.models import manipulator as man
from simgap.models.base import MechanicalNominalModel, NominalModel

EFFECTS = [
    {"effect": "coulomb_friction", "channel": "joint1", "params": {"Fc": 0.2}},
    {"effect": "viscous_friction", "channel": "joint2", "params": {"b": 0.3}},
    {"effect": "stribeck_friction", "channel": "joint1", "params": {"Fs": 0.35, "vs": 0.1}},
    {"effect": "spring", "channel": "joint2", "params": {"k": 1.5, "q0": 0.2}},
    {"effect": "torque_bias", "channel": "joint1", "params": {"tau0": -0.1}},
    {"effect": "payload_mass", "channel": None, "params": {"mp": 0.3}},
    {"effect": "gravity_mismatch", "channel": None, "params": {"dG": 0.05}},
    {"effect": "inertia_mismatch", "channel": "joint2", "params": {"dI": 0.02}},
]


def test_augmented_manipulator_matches_effect_functions():
    """Inverse dynamics of the augmented model = nominal + the vocabulary's effect terms."""
    sigma = 1e-3
    effects = [e for e in EFFECTS if e["effect"] != "gravity_mismatch"]
    model = AugmentedManipulator(effects, sigma=sigma)
    assert isinstance(model, MechanicalNominalModel) and isinstance(model, NominalModel)
    nominal = man.ManipulatorNominal()
    sysm = MechanicalSystem(nominal)
    ctx = sysm.effect_context(np.array([sigma, sigma]))
    rng = np.random.default_rng(0)
    q, dq, ddq = rng.normal(size=(3, 50, 2))
    sig = {"q": q, "dq": dq, "ddq": ddq}
    total = sysm.inverse_dynamics(q, dq, ddq)
    internal = {  # report params -> internal (lin, nl)
        "coulomb_friction": ([0.2], []), "viscous_friction": ([0.3], []),
        "stribeck_friction": ([0.35 - 0.2], [0.1]), "spring": ([1.5, -1.5 * 0.2], []),
        "torque_bias": ([-0.1], []), "payload_mass": ([0.3], []),
        "gravity_mismatch": ([0.05], []), "inertia_mismatch": ([0.02], []),
    }
    for e in effects:
        lin, nl = internal[e["effect"]]
        idx = None if e["channel"] is None else int(e["channel"][-1]) - 1
        total = total + VOCABULARY[e["effect"]](np.array(lin), np.array(nl), sig, idx, ctx)
    aug = np.array([model.inverse_dynamics(q[k], dq[k], ddq[k]) for k in range(50)])
    np.testing.assert_allclose(aug, total, rtol=1e-9, atol=1e-9)
    # gravity_mismatch alone: G scaled by (1 + dG)
    g_only = AugmentedManipulator([e for e in EFFECTS if e["effect"] == "gravity_mismatch"])
    z = np.zeros(2)
    np.testing.assert_allclose(g_only.bias(q[0], z), 1.05 * nominal.G(q[0]), rtol=1e-12)


def test_augmented_equals_generator_plant():
    """The model built from the injected effects is the generator's plant (same theta)."""
    inj = [InjectedEffect(effect=e["effect"], channel=e["channel"], params=e["params"])
           for e in EFFECTS]
    theta = manipulator_plant(inj)
    model = AugmentedManipulator(EFFECTS)
    np.testing.assert_allclose(model.theta, theta)
    kw = model.env_kwargs()
    assert kw["true_params"].payload == pytest.approx(0.3)
    assert kw["friction"].array[0, 3] == pytest.approx(0.35)


def test_f_consistent_with_plant():
    model = AugmentedManipulator(EFFECTS)
    s = np.array([0.3, -0.4, 0.5, -0.2])
    u = np.array([1.0, -0.5])
    x = model.state(s)
    acc = man.plant_acceleration(s, u, model.theta)
    dx = model.f(x, u)
    np.testing.assert_allclose(dx[:2], s[2:])
    eps = 1e-6
    s2 = s.copy()
    s2[:2] += eps * s[2:]
    s2[2:] += eps * acc
    np.testing.assert_allclose(dx[2:], (model.state(s2)[2:] - x[2:]) / eps, rtol=1e-4,
                               atol=1e-5)


def test_json_round_trip(tmp_path):
    m = AugmentedManipulator(EFFECTS, sigma=[1e-3, 2e-3])
    m2 = load_model(save_model(m, tmp_path / "m.json"))
    np.testing.assert_allclose(m2.theta, m.theta)
    b = AugmentedBicycle([{"effect": "tire_saturation", "channel": "front_axle",
                           "params": {"mu": 0.7}},
                          {"effect": "mass_mismatch", "channel": "vehicle",
                           "params": {"ratio": 1.1}},
                          {"effect": "steering_lag", "channel": "front_axle",
                           "params": {"tau": 0.05}}], vx=25.0)
    b2 = load_model(save_model(b, tmp_path / "b.json"))
    x, u = np.array([0.2, 0.1]), np.array([0.05, 0.0])
    np.testing.assert_allclose(b2.f(x, u), b.f(x, u))
    assert b2.env_kwargs()["plant"].get("steering_lag", "front_axle").params["tau"] == 0.05
    assert b2.params.m == pytest.approx(1760.0)
    (tmp_path / "bad.json").write_text('{"model": "boat"}')
    with pytest.raises(ModelFileError):
        load_model(tmp_path / "bad.json")


def test_diagnosis_model_rediagnosed_clean():
    """Diagnosing a recording against the augmented model it produced finds nothing left."""
    from simgap.diagnosis.pipeline import diagnose
    from simgap.diagnosis.systems import MechanicalSystem as MS

    rec = generate_manipulator([InjectedEffect(effect="viscous_friction", channel="joint1",
                                               params={"b": 0.3})], duration=8, seed=2)
    rep = diagnose(rec, "manipulator2dof")
    assert [e["effect"] for e in rep.effects] == ["viscous_friction"]
    again = diagnose(rec, MS(rep.augmented, name="augmented"))
    assert not again.effects and not again.significant


def test_env_built_from_augmented_model():
    """'The simulator now includes the missing physics': the env's plant is the model."""
    from simgap.envs.bicycle import BicycleTireEnv
    from simgap.envs.manipulator import ManipulatorFrictionEnv

    m = AugmentedManipulator(EFFECTS, sigma=1e-3)
    env = ManipulatorFrictionEnv(**m.env_kwargs())
    np.testing.assert_allclose(env.plant_theta, m.theta)
    env.reset(seed=0)
    env.step(np.zeros(2))
    b = AugmentedBicycle([{"effect": "tire_saturation", "channel": "front_axle",
                           "params": {"mu": 0.7}},
                          {"effect": "tire_saturation", "channel": "rear_axle",
                           "params": {"mu": 0.7}},
                          {"effect": "steering_lag", "channel": "front_axle",
                           "params": {"tau": 0.05}},
                          {"effect": "lateral_bias", "channel": "vehicle",
                           "params": {"ay0": 0.3}}], vx=20.0)
    benv = BicycleTireEnv(**b.env_kwargs())
    np.testing.assert_allclose(benv.plant_theta, b.plant_theta())
    # the fitted per-axle mu reaches the env as it is (no mean of the axles)
    split = AugmentedBicycle([{"effect": "tire_saturation", "channel": "front_axle",
                               "params": {"mu": 0.9}},
                              {"effect": "tire_saturation", "channel": "rear_axle",
                               "params": {"mu": 0.6}}], vx=15.0)
    senv = BicycleTireEnv(**split.env_kwargs())
    assert senv.mu_axles == (0.9, 0.6) and senv.vx == 15.0
    np.testing.assert_array_equal(senv.plant_theta, split.plant_theta())
    x, u = np.array([0.3, 0.25]), np.array([0.06, 0.0])
    s = np.concatenate([x, np.zeros(4)])
    np.testing.assert_allclose(bicycle_model.plant_derivative(s, u, senv.plant_theta)[:2],
                               split.f(x, u), rtol=1e-12)


def test_generator_reproducible():
    a = generate_manipulator([], duration=2, seed=9)
    b = generate_manipulator([], duration=2, seed=9)
    c = generate_manipulator([], duration=2, seed=10)
    for k in a.columns:
        np.testing.assert_array_equal(a[k], b[k])
    assert not np.array_equal(a["q1"], c["q1"])
