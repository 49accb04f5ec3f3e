"""`simgap record` validates each effect's channel and parameters against the vocabulary."""

import pytest
from typer.testing import CliRunner

from simgap.cli import app
from simgap.diagnosis.generate import InjectedEffect, bicycle_plant, manipulator_plant
from simgap.errors import GeneratorError

runner = CliRunner()


@pytest.mark.parametrize(("model", "effect", "says"), [
    ("bicycle", "tire_saturation:joint1:mu=0.5", "joint1"),
    ("bicycle", "lateral_bias:front_axle:ay0=0.3", "takes no channel"),
    ("manipulator2dof", "coulomb_friction:Fc=0.2", "needs a channel"),
    ("manipulator2dof", "payload_mass:joint1:mp=0.3", "takes no channel"),
    ("manipulator2dof", "viscous_friction:joint2:b=-0.1", "within"),
    ("bicycle", "steering_lag:tau=0.1,k=2", "takes parameters"),
])
def test_record_rejects_a_wrong_channel_or_parameter(tmp_path, model, effect, says):
    out = tmp_path / "rec.csv"
    res = runner.invoke(app, ["record", str(out), "--model", model, "--effect", effect,
                              "--duration", "1"])
    assert res.exit_code == 2, res.output
    assert says in res.output and len(res.output.strip().splitlines()) == 1
    assert not out.exists() and not (tmp_path / "rec.csv.truth.json").exists()


def test_one_road_mu_and_per_axle_channels_are_accepted():
    one = bicycle_plant([InjectedEffect(effect="tire_saturation", params={"mu": 0.6})], 20.0)
    front = bicycle_plant([InjectedEffect(effect="tire_saturation", channel="front_axle",
                                          params={"mu": 0.6})], 20.0)
    assert (one == front).all()
    with pytest.raises(GeneratorError, match="unknown effect 'quadratic_friction'"):
        manipulator_plant([InjectedEffect(effect="quadratic_friction", channel="joint1",
                                          params={"c": 1.0})])
