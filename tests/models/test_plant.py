"""The Plant value object: the one producer of kernel arrays; envs derive their views from it."""

import numpy as np
import pytest

from simgap.control.rl import RandomFriction
from simgap.envs.bicycle import BicycleTireEnv
from simgap.envs.manipulator import ManipulatorFrictionEnv
from simgap.errors import EnvError, ModelError
from simgap.models import bicycle as bic
from simgap.models import manipulator as man
from simgap.models.effects import EffectInstance, Plant, format_unit
from simgap.models.friction import FRICTION_MODELS


@pytest.mark.parametrize("preset", sorted(FRICTION_MODELS))
def test_manipulator_plant_matches_plant_array(preset):
    fp = FRICTION_MODELS[preset]
    dist = man.JointDisturbance(tau0=(0.1, 0.0), k=(0.0, 2.0), q0=(0.0, 0.3))
    plant = man.make_plant(man.ManipulatorParams(payload=0.2), friction=fp, disturbance=dist)
    np.testing.assert_array_equal(plant.array,
                                  man.plant_array(man.ManipulatorParams(payload=0.2), fp, dist))


def test_bicycle_plant_matches_plant_array_and_round_trips():
    p = bic.BicycleParams(mu=0.6)
    plant = bic.make_plant(p, 15.0, tire=bic.MagicFormulaTire(C=1.4), steering_lag=0.05,
                           relaxation_length=(0.2, 0.3), yaw_bias=0.1)
    ref = bic.plant_array(p, 15.0, tire=bic.MagicFormulaTire(C=1.4), steering_lag=0.05,
                          relaxation_length=(0.2, 0.3), yaw_bias=0.1)
    np.testing.assert_array_equal(plant.array, ref)
    back = Plant.from_dict(plant.to_dict(), bic.PLANT_SCHEMA)
    np.testing.assert_array_equal(back.array, ref)


def test_with_effect_without_and_validation():
    plant = bic.PLANT_SCHEMA.plant(effects=(EffectInstance("tire_saturation", None, {"mu": 1}),))
    low = plant.with_effect("tire_saturation", mu=0.4)
    assert low.true_params.mu == 0.4 and plant.true_params.mu == 1.0  # values, not mutation
    assert (low.array[bic.MU_F], low.array[bic.MU_R]) == (0.4, 0.4)  # what the tires read
    assert low.array[bic.MU] == 0.4 and not low.without("tire_saturation").has("tire_saturation")
    with pytest.raises(ModelError, match="unknown effect"):
        plant.with_effect("warp_drive", x=1.0)
    with pytest.raises(ModelError, match="needs a channel"):
        plant.with_effect("cornering_stiffness", "joint1", ratio=0.9)
    with pytest.raises(ModelError, match="unknown bicycle plant option"):
        plant.with_options(speed=3.0)
    assert format_unit("{effort}·s/{position}", effort="N", position="m") == "N·s/m"


def test_env_views_follow_the_plant_and_cannot_go_stale():
    env = BicycleTireEnv(mu=0.8)
    env.plant = env.plant.with_effect("tire_saturation", mu=0.5)
    assert env.mu == 0.5 and env.true_params.mu == 0.5 and env.plant_theta[bic.MU] == 0.5
    with pytest.raises(AttributeError):
        env.mu = 0.7
    with pytest.raises(AttributeError):
        env.plant_theta = np.zeros(bic.PLANT.size)
    env.plant_theta[bic.MU_F] = 9.0  # a copy: the env's array is untouched
    assert env.plant.array[bic.MU_F] == 0.5 and env.mu_axles == (0.5, 0.5)
    with pytest.raises(EnvError, match="speed is fixed"):
        env.plant = env.plant.with_options(vx=10.0)
    wrapped = RandomFriction(BicycleTireEnv(), (0.3, 0.9))
    _, info = wrapped.reset(options={"mu": 0.42})
    assert wrapped.unwrapped.mu == info["mu"] == 0.42
    # an env whose axles differ: one road μ on every saturating axle, linear axles stay linear
    front_only = BicycleTireEnv(plant=bic.make_plant().without("tire_saturation")
                                .with_effect("tire_saturation", "front_axle", mu=0.6))
    assert front_only.mu_axles == (0.6, None)
    wrapped = RandomFriction(front_only, (0.3, 0.9))
    assert wrapped.mu == 0.6
    _, info = wrapped.reset(options={"mu": 0.42})
    assert front_only.mu_axles == (0.42, None) and info["mu"] == 0.42


def test_envs_accept_a_plant_and_agree_with_their_keyword_form():
    kw = ManipulatorFrictionEnv(friction="stribeck")
    env = ManipulatorFrictionEnv(plant=kw.plant)
    for e in (kw, env):
        e.reset(seed=1)
    for _ in range(20):
        np.testing.assert_array_equal(kw.step([1.0, -1.0])[0], env.step([1.0, -1.0])[0])
    with pytest.raises(EnvError, match="either plant"):
        ManipulatorFrictionEnv(plant=kw.plant, friction=None)
    with pytest.raises(EnvError, match="bicycle Plant"):
        BicycleTireEnv(plant=kw.plant)
    car = BicycleTireEnv(plant=bic.make_plant(vx=12.0))
    assert car.vx == 12.0 and car.tire is None


def test_quadratic_drag_is_one_vocabulary_entry_end_to_end(tmp_path):
    """Added in models/friction.py + models/manipulator.py only: plant, env, generator, record."""
    from typer.testing import CliRunner

    from simgap.cli import app
    from simgap.diagnosis.augmented import AugmentedManipulator
    from simgap.diagnosis.generate import InjectedEffect, manipulator_plant

    plant = man.make_plant(friction=None).with_effect("quadratic_drag", "joint2", c=0.05)
    q, dq = np.array([0.1, 0.2]), np.array([1.5, -2.0])
    np.testing.assert_allclose(man.tau_d(q, dq, plant.array), [0.0, 0.05 * -2.0 * 2.0])
    env = ManipulatorFrictionEnv(plant=plant)
    assert env.friction.c2 == (0.0, 0.05)
    injected = manipulator_plant([InjectedEffect(effect="quadratic_drag", channel="joint2",
                                                 params={"c": 0.05})])
    np.testing.assert_array_equal(injected, plant.array)
    aug = AugmentedManipulator([{"effect": "quadratic_drag", "channel": "joint2",
                                 "params": {"c": 0.05}}])
    np.testing.assert_array_equal(aug.theta, plant.array)
    out = tmp_path / "drag.csv"
    res = CliRunner().invoke(app, ["record", str(out), "--effect", "quadratic_drag:joint1:c=0.05",
                                   "--duration", "0.5"])
    assert res.exit_code == 0, res.output
    bad = CliRunner().invoke(app, ["record", str(tmp_path / "x.csv"), "--effect",
                                   "quadratic_drag:joint1:c=-1"])
    assert bad.exit_code == 2 and "within" in bad.output


def _rollout(env, n=200):
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    return np.array([env.step(rng.uniform(-0.1, 0.1, 2))[0] for _ in range(n)])


def test_per_axle_mu_each_tire_reads_its_own_and_equal_axles_are_bit_identical():
    """μ per axle: equal axles = the one-road-μ env bit for bit; else each tire its own μ."""
    sat = bic.PLANT_SCHEMA.plant(effects=(
        EffectInstance("tire_saturation", "front_axle", {"mu": 0.7}),
        EffectInstance("tire_saturation", "rear_axle", {"mu": 0.7})))
    one = BicycleTireEnv(mu=0.7)
    both = BicycleTireEnv(plant=sat)
    np.testing.assert_array_equal(both.plant_theta, one.plant_theta)
    np.testing.assert_array_equal(_rollout(both), _rollout(one))
    assert both.mu == one.mu == 0.7 and both.mu_axles == (0.7, 0.7)
    # different axles: the view is per axle, the scalar view refuses to pick one
    split = BicycleTireEnv(plant=sat.with_effect("tire_saturation", "rear_axle", mu=0.4))
    assert split.mu_axles == (0.7, 0.4)
    with pytest.raises(EnvError, match="differs per axle.*mu_axles"):
        _ = split.mu
    front = BicycleTireEnv(plant=sat.without("tire_saturation", "rear_axle"))
    assert front.mu_axles == (0.7, None) and front.tire is not None
    assert BicycleTireEnv(tire="linear").mu_axles == (None, None)
    assert BicycleTireEnv(tire="linear").mu == 1.0  # the parameter, as before
    s, u = np.array([0.5, 0.2, 0, 0, 0, 0]), np.array([0.08, 0.0])
    p = bic.BicycleParams()
    fzf, fzr = p.axle_loads()
    fyf, fyr, af, ar = bic.plant_forces(s, u, split.plant_theta)
    assert fyf == bic.magic_formula(af, p.C_af, fzf, 0.7, 1.3, -0.5)
    assert fyr == bic.magic_formula(ar, p.C_ar, fzr, 0.4, 1.3, -0.5)
    fyf, fyr, af, ar = bic.plant_forces(s, u, front.plant_theta)
    assert fyr == p.C_ar * ar  # no saturation named on the rear axle: its tire is linear
    assert not np.array_equal(_rollout(split), _rollout(both))
    with pytest.raises(ValueError, match="needs a Magic Formula tire"):
        bic.plant_array(p, 20.0, mu=(0.5, 0.6))
    with pytest.raises(ValueError, match="mu must be a finite positive"):
        bic.plant_array(p, 20.0, tire=bic.MagicFormulaTire(), mu=(0.5, -1.0))
