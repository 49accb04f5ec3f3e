"""augmented_model.json holds the augmented Plant (Plant.to_dict + metadata); files of the
previous layout (no "plant") still read back to the same model."""

import json

import numpy as np

from simgap.diagnosis.augmented import AugmentedBicycle, AugmentedManipulator, model_from_dict

ARM_EFFECTS = [
    {"effect": "coulomb_friction", "channel": "joint1", "params": {"Fc": 0.2}},
    {"effect": "stribeck_friction", "channel": "joint1", "params": {"Fs": 0.35, "vs": 0.1}},
    {"effect": "cubic_stiffness", "channel": "joint2", "params": {"k3": -0.3}},
    {"effect": "quadratic_drag", "channel": "joint2", "params": {"c": 0.05}},
    {"effect": "payload_mass", "channel": None, "params": {"mp": 0.2}},
]


def _roundtrip(d):
    return model_from_dict(json.loads(json.dumps(d)))


def test_arm_plant_roundtrip_and_old_layout() -> None:
    aug = AugmentedManipulator(ARM_EFFECTS, sigma=(1e-3, 2e-3), dt=0.004)
    d = aug.to_dict()
    assert d["plant"]["system"] == "manipulator2dof" and d["schema"] == 1
    assert {e["effect"] for e in d["plant"]["effects"]} == {e["effect"] for e in ARM_EFFECTS}
    new = _roundtrip(d)
    old = _roundtrip({k: v for k, v in d.items() if k != "plant"})  # today's layout
    for back in (new, old):
        assert isinstance(back, AugmentedManipulator)
        np.testing.assert_array_equal(back.theta, aug.theta)
        assert back.dt == 0.004
    assert new.plant == aug.plant


def test_bicycle_plant_roundtrip_and_old_layout() -> None:
    effects = [{"effect": "tire_saturation", "channel": "front_axle", "params": {"mu": 0.6}},
               {"effect": "yaw_bias", "channel": None, "params": {"dr0": 0.1}}]
    aug = AugmentedBicycle(effects, vx=15.0, dt=0.02)
    d = aug.to_dict()
    assert d["plant"]["system"] == "bicycle"
    for back in (_roundtrip(d), _roundtrip({k: v for k, v in d.items() if k != "plant"})):
        assert isinstance(back, AugmentedBicycle)
        np.testing.assert_array_equal(back.plant_theta(), aug.plant_theta())
        assert back.vx == 15.0
