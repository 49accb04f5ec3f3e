"""The actuator dead zone (issue 13's vocabulary): applied torque u − clip(u, −d, d).

Added through the registry like the other vocabulary additions: one formula
(:func:`simgap.models.manipulator.dead_zone`), one ``EffectSpec`` (name, unit, bounds,
injection range, fit side), injected by the generator and ``simgap record``, fitted blind
with its standard error. It is named only where the recording can identify it: the command
must pass through the band ±d (else a dead zone is a constant torque bias) and dwell inside
it (what tells it from a relay d·sign(u)), and it must stay determined with a torque bias
and a Coulomb friction of the same joint fitted beside it.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from simgap.diagnosis.effects import ARM_EFFECTS, MECHANICAL_EFFECTS, VOCABULARY
from simgap.diagnosis.generate import InjectedEffect, generate
from simgap.diagnosis.proof import TOLERANCE, draw, run_case
from simgap.models import manipulator as man

QUICK = 8.0


def _dz(channel: str, d: float) -> InjectedEffect:
    return InjectedEffect(effect="dead_zone", channel=channel, params={"d": d})


def _diagnosed(effects, seed: int, duration: float):
    from simgap.diagnosis.pipeline import diagnose

    return diagnose(generate("manipulator2dof", effects, seed=seed, duration=duration),
                    "manipulator2dof")


def _tried(report, name: str, channel: str) -> dict:
    return next(e for e in report.selection.tried
                if e["effect"] == name and e["channel"] == channel)


def test_formula_is_zero_inside_and_shifted_outside() -> None:
    u = np.array([-1.0, -0.3, -0.2, -0.1, 0.0, 0.15, 0.2, 0.5])
    out = man.dead_zone.py_func(u, 0.2)
    np.testing.assert_allclose(out, [-0.8, -0.1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.3], atol=1e-15)
    assert man.dead_zone(0.5, 0.2) == pytest.approx(0.3)      # the compiled scalar form
    assert man.dead_zone(-0.05, 0.2) == 0.0
    np.testing.assert_array_equal(man.dead_zone.py_func(u, 0.0), u)


def test_vocabulary_entry() -> None:
    spec = VOCABULARY["dead_zone"]
    assert spec.nl == ("d",) and spec.nl_units == ("N·m",) and spec.on_input
    assert spec.in_units(effort="N", position="m").nl_units == ("N",)
    assert "dead_zone" in {e.name for e in ARM_EFFECTS}
    assert "dead_zone" not in {e.name for e in MECHANICAL_EFFECTS}   # arm only for now


def test_zero_dead_zone_is_the_clean_recording() -> None:
    a = generate("manipulator2dof", [], seed=2, duration=1.0)
    b = generate("manipulator2dof", [_dz("joint2", 0.0)], seed=2, duration=1.0)
    for k in a.columns:
        np.testing.assert_array_equal(a[k], b[k])


def test_dead_zone_changes_the_motion_not_the_logged_command_law() -> None:
    a = generate("manipulator2dof", [], seed=2, duration=2.0, noise_q=0.0, noise_dq=0.0)
    b = generate("manipulator2dof", [_dz("joint2", 0.3)], seed=2, duration=2.0,
                 noise_q=0.0, noise_dq=0.0)
    assert not np.array_equal(a["q2"], b["q2"])
    np.testing.assert_array_equal(a["q1"][:1], b["q1"][:1])
    assert np.max(np.abs(a["q2"] - b["q2"])) < 0.05           # the loop still tracks


def test_named_at_its_joint_with_its_value_and_uncertainty() -> None:
    res = run_case([_dz("joint2", 0.2)], "manipulator2dof", 0, duration=QUICK)
    (hit,) = [e for e in res.found if e["effect"] == "dead_zone"]
    assert hit["channel"] == "joint2"
    assert hit["parameters"]["d"] == pytest.approx(0.2, rel=TOLERANCE)
    assert hit["units"]["d"] == "N·m"
    assert 0.0 < hit["stderr"]["d"] < 0.02
    assert not res.extra
    assert res.improvement >= 2.0           # the rollout applies it to the input


def test_too_few_passes_through_the_band_is_not_identifiable() -> None:
    """Seed 2's first 8 s: joint 2's command crosses ±d only twice. The dead zone fits
    (d ≈ 0.2) and gains, but is not named: on one side of the band it is a torque bias."""
    rep = _diagnosed([_dz("joint2", 0.2)], 2, QUICK)
    entry = _tried(rep, "dead_zone", "joint2")
    assert entry["decision"] == "not identifiable"
    assert entry["params"]["d"] == pytest.approx(0.2, rel=TOLERANCE)
    assert "passes through the fitted dead band" in entry["reason"]
    assert not rep.effects                    # and nothing else stands in for it


def test_no_dwell_inside_the_band_is_not_identifiable() -> None:
    """The proof's draw for seed 4 at joint 1 (d = 0.10 N·m): the joint-1 command carries
    the gravity torque and sits inside ±d on 17 of ~10,000 samples (expected χ² of the
    dead-zone-vs-relay difference 3.1 < 6.63); the diagnosis says so instead of naming a
    dead zone it cannot tell from a relay. (Seeds 0-3's draws at joint 1 are named.)"""
    inj = draw("dead_zone", np.random.default_rng(1004))
    inj = InjectedEffect(effect="dead_zone", channel="joint1", params=inj.params)
    rep = _diagnosed([inj], 4, 20.0)
    entry = _tried(rep, "dead_zone", "joint1")
    assert entry["decision"] == "not identifiable"
    assert "dwells inside the fitted dead band" in entry["reason"]
    assert not rep.effects


def test_excitation_rule() -> None:
    rule = VOCABULARY["dead_zone"].excitation
    t = np.linspace(0.0, 10.0, 5001)
    d, lin = np.array([0.2]), np.zeros(0)
    sine = np.sin(2 * np.pi * 0.5 * t)
    assert rule(None, lin, d, sine, 0.01) == ""
    assert "constant torque bias" in rule(None, lin, d, 1.0 + np.sin(t), 0.01)
    square = np.sign(sine) + (t == 0)           # jumps over the band: never inside
    assert "dwells inside" in rule(None, lin, d, square, 0.01)
    # the dwell needed grows with the noise: the same command, 200x noisier
    assert "dwells inside" in rule(None, lin, d, sine, 2.0)


def test_a_bias_on_a_one_sign_command_is_named_not_the_dead_zone() -> None:
    """Joint 1's command in seed 1's first 8 s never changes sign: a dead zone d and a
    torque bias d are the same function there and tie to 15 digits. The dead zone yields
    to its declared look-alike (``confusable_with``) instead of being picked, found not
    identifiable and kept as a combination that hides the bias (the quick proof case)."""
    inj = draw("torque_bias", np.random.default_rng(1001))
    assert inj.channel == "joint1"
    rep = _diagnosed([inj], 1, QUICK)
    assert [(e["effect"], e["channel"]) for e in rep.effects] == [("torque_bias", "joint1")]
    assert _tried(rep, "dead_zone", "joint1")["decision"] == "rejected"


@pytest.mark.parametrize(("name", "channel", "params"), [
    ("coulomb_friction", "joint2", {"Fc": 0.2}),
    ("torque_bias", "joint2", {"tau0": 0.2}),
    ("torque_bias", "joint1", {"tau0": -0.15}),
])
def test_other_effects_do_not_get_a_dead_zone(name, channel, params) -> None:
    res = run_case([InjectedEffect(effect=name, channel=channel, params=params)],
                   "manipulator2dof", 1, duration=QUICK)
    assert [(e["effect"], e["channel"]) for e in res.found] == [(name, channel)]


def test_clean_recordings_get_no_dead_zone() -> None:
    for seed in (510, 511):
        rep = _diagnosed([], seed, QUICK)
        assert not rep.effects, rep.effects
        for ch in ("joint1", "joint2"):
            assert _tried(rep, "dead_zone", ch)["decision"] == "rejected"


def test_record_cli_injects_a_dead_zone(tmp_path) -> None:
    from typer.testing import CliRunner

    from simgap.cli import app

    out = tmp_path / "rec.csv"
    res = CliRunner().invoke(app, ["record", str(out), "--model", "manipulator2dof",
                                   "--duration", "2", "--effect", "dead_zone:joint1:d=0.25"])
    assert res.exit_code == 0, res.output
    truth = json.loads(next(tmp_path.glob("*.truth.json")).read_text())
    assert truth["injected"] == [{"effect": "dead_zone", "channel": "joint1",
                                  "params": {"d": 0.25}}]
    plant = man.PLANT_SCHEMA.plant(None, (man.EffectInstance("dead_zone", "joint1",
                                                             {"d": 0.25}),))
    assert plant.folded.extras["dead_zone"] == (0.25, 0.0)
    bad = CliRunner().invoke(app, ["record", str(tmp_path / "b.csv"), "--duration", "2",
                                   "--effect", "dead_zone:joint1:d=-0.1"])
    assert bad.exit_code == 2 and "dead_zone" in bad.output
    listed = CliRunner().invoke(app, ["record", "--list-effects"])
    assert "dead_zone" in listed.output and "d (N·m)" in listed.output


def test_env_refuses_a_plant_with_a_dead_zone() -> None:
    from simgap.envs import ManipulatorFrictionEnv
    from simgap.errors import EnvError

    env = ManipulatorFrictionEnv()
    with pytest.raises(EnvError, match="dead_zone"):
        env.plant = env.plant.with_effect("dead_zone", "joint1", d=0.1)
