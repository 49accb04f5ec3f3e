"""The system registry: lookups, user registration, the wrappers' preset, deprecation alias."""

import warnings

import gymnasium as gym
import numpy as np
import pytest

from simgap.diagnosis.generate import generate
from simgap.diagnosis.pipeline import make_system
from simgap.errors import DiagnosisError, GeneratorError, IdentifierError, ModelError
from simgap.identifiers.config import preset
from simgap.models.bicycle import BicycleParams
from simgap.systems import SYSTEMS, SystemSpec, get_system, identifier_preset_of, register_system
from simgap.wrappers import IdentifierWrapper
from tests.wrappers.toy import DampedPendulumEnv, PendulumNominal


def test_unknown_names_raise_one_error_listing_the_systems():
    for call, err in ((lambda: get_system("tank"), ModelError),
                      (lambda: make_system("tank"), DiagnosisError),
                      (lambda: generate("tank"), GeneratorError)):
        with pytest.raises(err, match="unknown model 'tank'; registered systems: "
                                      "manipulator2dof, bicycle"):
            call()


def test_builtin_specs_resolve():
    bike = get_system("bicycle")
    assert bike.resolve("env_entry_point").__name__ == "BicycleTireEnv"
    assert bike.plant(BicycleParams(mu=0.5)).true_params.mu == 0.5
    assert {e.name for e in bike.vocabulary} >= {"tire_saturation", "steering_lag"}
    assert type(make_system("manipulator2dof")).__name__ == "MechanicalSystem"
    with pytest.raises(ModelError, match="already registered"):
        register_system(SystemSpec(name="bicycle"))


class _Unregistered(PendulumNominal):
    name = "my_unregistered_pendulum"


class _UnregisteredEnv(DampedPendulumEnv):
    def __init__(self):
        super().__init__()
        self.nominal_model = _Unregistered()


def test_unregistered_env_gets_the_scale_free_preset_not_the_manipulators():
    env = IdentifierWrapper(_UnregisteredEnv(), "integral")
    model = env.unwrapped.nominal_model
    assert env.identifier.config == preset("auto", "integral", dt=model.dt)
    assert env.identifier.config != preset("manipulator", "integral")  # not Table 4.3's
    # The thesis preset of a system comes from the registry, and only from there.
    with pytest.raises(IdentifierError, match="'my_unregistered_pendulum'.*not registered"):
        identifier_preset_of(model)
    register_system(SystemSpec(name="my_unregistered_pendulum", identifier_preset="bicycle"))
    try:
        assert identifier_preset_of(model) == "bicycle"
    finally:
        del SYSTEMS["my_unregistered_pendulum"]


def test_user_system_env_is_registered_by_the_registry():
    """register_system alone registers the env id (no register_envs call), idempotently."""
    from gymnasium.utils.env_checker import check_env

    from simgap.envs.registration import register_envs

    env_id = "simgap-test/ToyPendulum-v0"
    assert env_id not in gym.registry
    spec = SystemSpec(name="toy_env_system", identifier_preset="manipulator", env_id=env_id,
                      env_entry_point="tests.wrappers.toy:DampedPendulumEnv",
                      max_episode_steps=7)
    register_system(spec)
    try:
        env = gym.make(env_id)
        check_env(env.unwrapped, skip_render_check=True)
        env.reset(seed=0)
        truncated = [env.step(np.zeros(1))[3] for _ in range(7)]
        assert truncated == [False] * 6 + [True]  # the registry's max_episode_steps
        register_system(spec, replace=True)  # the same env again: a no-op
        register_envs()
        assert gym.registry[env_id].max_episode_steps == 7
        with pytest.raises(ModelError, match="already registered for"):  # id of another env
            register_system(SystemSpec(name="toy_other", env_id=env_id,
                                       env_entry_point="tests.wrappers.toy:Elsewhere"))
        assert "toy_other" not in SYSTEMS
        with pytest.raises(ModelError, match="go together"):
            register_system(SystemSpec(name="toy_half", env_id="simgap-test/Half-v0"))
        register_system(SystemSpec(name="toy_env_system", env_id=env_id, max_episode_steps=3,
                                   env_entry_point="tests.wrappers.toy:DampedPendulumEnv"),
                        replace=True)
        assert gym.make(env_id).spec.max_episode_steps == 3
    finally:
        del SYSTEMS["toy_env_system"]
        gym.registry.pop(env_id, None)


def test_preset_table_alias_warns():
    import simgap.wrappers.identifier_wrapper as iw

    with pytest.warns(DeprecationWarning, match="PRESET_FOR_MODEL is deprecated"):
        table = iw.PRESET_FOR_MODEL
    assert table["manipulator2dof"] == "manipulator" and table["bicycle"] == "bicycle"
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(AttributeError):
            iw.NO_SUCH_NAME  # noqa: B018


def test_wrappers_take_preset_and_info_keys_from_the_registry():
    """Default preset 'auto'; config='system' is the registry's reproduction preset; the
    extra physical-residual info keys are the registered system's, not a name comparison."""
    from simgap.envs.bicycle import BicycleTireEnv
    from simgap.wrappers import VectorIdentifierWrapper

    car = IdentifierWrapper(BicycleTireEnv(), "integral")
    assert car.identifier.config == preset("auto", "integral", dt=0.01)
    thesis = IdentifierWrapper(BicycleTireEnv(), "integral", config="system")
    assert thesis.identifier.config == preset("bicycle", "integral")
    assert IdentifierWrapper(BicycleTireEnv(), "minibatch", config="manipulator"
                             ).identifier.config == preset("manipulator", "minibatch")
    with pytest.raises(IdentifierError, match="'my_unregistered_pendulum'.*not registered"):
        IdentifierWrapper(_UnregisteredEnv(), "integral", config="system")
    with pytest.raises(IdentifierError, match="unknown preset system 'tank'"):
        IdentifierWrapper(_UnregisteredEnv(), "integral", config="tank")
    register_system(SystemSpec(name="my_unregistered_pendulum", identifier_preset="bicycle",
                               residual_info_keys=("joint_torque_estimate",)))
    try:
        env = IdentifierWrapper(_UnregisteredEnv(), "integral", config="system")
        assert env.identifier.config == preset("bicycle", "integral")
        env.reset(seed=0)
        info = env.step(np.zeros(1))[4]
        np.testing.assert_array_equal(info["joint_torque_estimate"],
                                      info["physical_residual_estimate"])
        assert "axle_force_residual_estimate" not in info
        vec = VectorIdentifierWrapper(gym.vector.SyncVectorEnv([_UnregisteredEnv] * 2))
        vec.reset(seed=0)
        vinfo = vec.step(np.zeros((2, 1)))[4]
        np.testing.assert_array_equal(vinfo["joint_torque_estimate"],
                                      vinfo["physical_residual_estimate"])
        assert vinfo["_joint_torque_estimate"].all()
    finally:
        del SYSTEMS["my_unregistered_pendulum"]
    # unregistered again: no extra keys
    plain = IdentifierWrapper(_UnregisteredEnv())
    plain.reset(seed=0)
    assert "joint_torque_estimate" not in plain.step(np.zeros(1))[4]
    assert get_system("bicycle").residual_info_keys == ("axle_force_residual_estimate",)
