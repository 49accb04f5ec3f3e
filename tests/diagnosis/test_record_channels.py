"""`simgap record` validates each effect's channel and parameters against the vocabulary."""

import numpy as np
import pytest
from typer.testing import CliRunner

from simgap.cli import app
from simgap.diagnosis.generate import (
    InjectedEffect,
    bicycle_plant,
    generate_bicycle,
    manipulator_plant,
)
from simgap.errors import GeneratorError
from simgap.models import bicycle as bic

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
    def sat(channel, mu):
        return InjectedEffect(effect="tire_saturation", channel=channel, params={"mu": mu})

    one = bicycle_plant([sat(None, 0.6)], 20.0)
    both = bicycle_plant([sat("front_axle", 0.6), sat("rear_axle", 0.6)], 20.0)
    front = bicycle_plant([sat("front_axle", 0.6)], 20.0)
    assert (one == both).all()  # one road mu = the same mu on each axle, slot for slot
    # a front-only saturation saturates the front tire only; the rear stays linear
    assert (front[bic.MU_F], front[bic.MU_R]) == (0.6, 0.0)
    assert (one[bic.MU_F], one[bic.MU_R]) == (0.6, 0.6)
    s, u = np.array([0.5, 0.2, 0, 0, 0, 0]), np.array([0.08, 0.0])  # past the tire peak
    fyf, fyr, af, ar = bic.plant_forces(s, u, front)
    p = bic.BicycleParams()
    fzf, fzr = p.axle_loads()
    assert fyf == bic.magic_formula(af, p.C_af, fzf, 0.6, 1.3, -0.5) != p.C_af * af
    assert fyr == p.C_ar * ar != bic.magic_formula(ar, p.C_ar, fzr, 0.6, 1.3, -0.5)
    assert bic.plant_forces(s, u, one)[1] == bic.magic_formula(ar, p.C_ar, fzr, 0.6, 1.3, -0.5)
    # and the generator's recording differs from the both-axles one on the same seed
    effects = {"front": [sat("front_axle", 0.6)], "one": [sat(None, 0.6)]}
    recs = {k: generate_bicycle(v, duration=3.0, seed=1) for k, v in effects.items()}
    assert not np.array_equal(recs["front"]["r"], recs["one"]["r"])
    with pytest.raises(GeneratorError, match="unknown effect 'quadratic_friction'"):
        manipulator_plant([InjectedEffect(effect="quadratic_friction", channel="joint1",
                                          params={"c": 1.0})])



def test_low_speed_recording_steers_like_a_car_and_passes_the_unit_checks(tmp_path):
    """At vx = 3 m/s the steady-state gain asked for up to 2.7 rad to reach ay_peak: the
    amplitude is capped at MAX_STEER, and the file's own diagnosis does not read degrees."""
    from simgap.diagnosis.generate import MAX_STEER, generate_bicycle

    slow = generate_bicycle(duration=20.0, vx=3.0, seed=0)
    assert np.max(np.abs(slow["delta_f"])) <= MAX_STEER + 1e-12
    fast = generate_bicycle(duration=20.0, vx=20.0, seed=0)
    assert np.max(np.abs(fast["delta_f"])) < MAX_STEER  # the cap binds only when slow
    path = tmp_path / "car.csv"
    runner = CliRunner()
    res = runner.invoke(app, ["record", str(path), "--model", "bicycle", "--vx", "3",
                              "--duration", "20"])
    assert res.exit_code == 0, res.output
    res = runner.invoke(app, ["diagnose", str(path), "--model", "bicycle",
                              "--out", str(tmp_path / "rep")])
    assert res.exit_code == 0, res.output
    assert "degree" not in res.output.lower()
