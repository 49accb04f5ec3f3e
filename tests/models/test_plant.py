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
    env.plant_theta[bic.MU] = 9.0  # a copy: the env's array is untouched
    assert env.plant.array[bic.MU] == 0.5
    with pytest.raises(EnvError, match="speed is fixed"):
        env.plant = env.plant.with_options(vx=10.0)
    wrapped = RandomFriction(BicycleTireEnv(), (0.3, 0.9))
    _, info = wrapped.reset(options={"mu": 0.42})
    assert wrapped.unwrapped.mu == info["mu"] == 0.42


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
