"""Effects added through the registry (issue 13's vocabulary): quadratic_drag, cubic_stiffness,
input_delay. Each is injected by the generator (or ``simgap record``), diagnosed blind, named at
the right joint with its parameter within the proof's tolerance; a clean recording stays clean.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from simgap.diagnosis.effects import ARM_EFFECTS, MECHANICAL_EFFECTS, VOCABULARY
from simgap.diagnosis.generate import InjectedEffect, generate
from simgap.diagnosis.proof import TOLERANCE, run_case
from simgap.models import manipulator as man

QUICK = 8.0


def _named(res, name: str, channels: tuple[str, ...]) -> list[dict]:
    hits = [e for e in res.found if e["effect"] == name and e["channel"] in channels]
    assert {e["channel"] for e in hits} == set(channels), res.found
    return hits


@pytest.mark.parametrize(("name", "channel", "params"), [
    ("quadratic_drag", "joint1", {"c": 0.04}),
    ("cubic_stiffness", "joint2", {"k3": -0.3}),   # softening: the sign is fitted
    ("cubic_stiffness", "joint1", {"k3": 0.25}),   # hardening
])
def test_channel_effect_named_at_its_joint(name, channel, params) -> None:
    inj = InjectedEffect(effect=name, channel=channel, params=params)
    res = run_case([inj], "manipulator2dof", 4, duration=QUICK)
    (hit,) = _named(res, name, (channel,))
    for k, v in params.items():
        assert abs(hit["parameters"][k] - v) <= TOLERANCE * abs(v), hit
    assert not res.extra, res.extra
    assert res.improvement >= 2.0


def test_input_delay_of_both_drives_named_with_its_value() -> None:
    """One delay on both drives. On this seed joint 1's share is below the selection gate
    (held-out gain 0.23 noise-floor units per sample): it is named at joint 2 only, and the
    rollout error then drops by 1 % only. The test records that rather than hiding it
    (the proof's draws, seeds 0-2, name it on both joints with 10-14× lower rollout error);
    every named delay has the injected value."""
    inj = InjectedEffect(effect="input_delay", params={"delay": 0.01})
    res = run_case([inj], "manipulator2dof", 6, duration=QUICK)
    hits = [e for e in res.found if e["effect"] == "input_delay"]
    assert "joint2" in {e["channel"] for e in hits}, res.found
    for hit in hits:
        assert hit["parameters"]["delay"] == pytest.approx(0.01, rel=TOLERANCE)
        assert hit["units"]["delay"] == "s"
    assert not res.extra


def test_input_delay_on_one_joint_only() -> None:
    """A delay on joint 2's drive alone is named there, not on joint 1."""
    inj = InjectedEffect(effect="input_delay", channel="joint2", params={"delay": 0.012})
    res = run_case([inj], "manipulator2dof", 7, duration=QUICK)
    (hit,) = _named(res, "input_delay", ("joint2",))
    assert hit["parameters"]["delay"] == pytest.approx(0.012, rel=TOLERANCE)
    assert not res.extra


def test_zero_delay_is_the_undelayed_recording() -> None:
    a = generate("manipulator2dof", [], seed=2, duration=1.0)
    b = generate("manipulator2dof", [InjectedEffect(effect="input_delay",
                                                    params={"delay": 0.0})], seed=2,
                 duration=1.0)
    for k in a.columns:
        np.testing.assert_array_equal(a[k], b[k])


def test_delay_of_whole_samples_shifts_the_applied_torque() -> None:
    """With d = 2 samples the plant feels tau[k − 2]: the recorded motion differs."""
    a = generate("manipulator2dof", [], seed=2, duration=1.0, noise_q=0.0, noise_dq=0.0)
    b = generate("manipulator2dof", [InjectedEffect(effect="input_delay",
                                                    params={"delay": 0.004})], seed=2,
                 duration=1.0, noise_q=0.0, noise_dq=0.0)
    assert not np.array_equal(a["q1"], b["q1"])
    assert np.max(np.abs(a["q1"] - b["q1"])) < 0.05  # the loop still tracks


def test_clean_recording_names_none_of_the_new_effects() -> None:
    assert "quadratic_drag" in {e.name for e in MECHANICAL_EFFECTS}  # any mechanical model
    assert {"cubic_stiffness", "input_delay"} <= {e.name for e in ARM_EFFECTS}  # arm (+MJCF)
    for seed in (510, 511):
        res = run_case([], "manipulator2dof", seed, duration=QUICK)
        assert not res.found, res.found


def test_units_come_from_the_templates() -> None:
    assert VOCABULARY["quadratic_drag"].lin_units == ("N·m·s²/rad²",)
    assert VOCABULARY["cubic_stiffness"].lin_units == ("N·m/rad³",)
    prismatic = VOCABULARY["cubic_stiffness"].in_units(effort="N", position="m")
    assert prismatic.lin_units == ("N/m³",)
    assert VOCABULARY["inertia_mismatch"].in_units(effort="N", position="m").lin_units == \
        ("kg",)


def test_record_cli_injects_cubic_stiffness(tmp_path) -> None:
    from typer.testing import CliRunner

    from simgap.cli import app

    out = tmp_path / "rec.csv"
    res = CliRunner().invoke(app, ["record", str(out), "--model", "manipulator2dof",
                                   "--duration", "2",
                                   "--effect", "cubic_stiffness:joint2:k3=-0.4"])
    assert res.exit_code == 0, res.output
    truth = json.loads(next(tmp_path.glob("*.truth.json")).read_text())
    assert truth["injected"][0]["effect"] == "cubic_stiffness"
    plant = man.PLANT_SCHEMA.plant(None, (man.EffectInstance("cubic_stiffness", "joint2",
                                                             {"k3": -0.4}),))
    assert plant.folded.extras["disturbance"].k3 == (0.0, -0.4)


def test_env_refuses_a_plant_with_an_input_delay() -> None:
    from simgap.envs import ManipulatorFrictionEnv
    from simgap.errors import EnvError

    env = ManipulatorFrictionEnv()
    with pytest.raises(EnvError, match="input_delay"):
        env.plant = env.plant.with_effect("input_delay", "joint1", delay=0.01)


def test_nonlinear_basis_cache_changes_no_number(monkeypatch) -> None:
    """The fitter's cache of nonlinear terms' bases (issue 13's cost) returns what
    recomputing gives, bit for bit: the same delay diagnosis with the cache off
    (``NL_CACHE = 0``) has the same selection record, and the cache did serve hits."""
    from simgap.diagnosis import fit as fit_mod
    from simgap.diagnosis.pipeline import diagnose

    rec = generate("manipulator2dof",
                   [InjectedEffect(effect="input_delay", params={"delay": 0.01})],
                   duration=QUICK, seed=6)
    calls = {"n": 0}
    output = fit_mod.Fitter.output

    def counted(self, *a, **k):
        calls["n"] += 1
        return output(self, *a, **k)

    monkeypatch.setattr(fit_mod.Fitter, "output", counted)
    cached = diagnose(rec, "manipulator2dof")
    with_cache = calls["n"]
    monkeypatch.setattr(fit_mod, "NL_CACHE", 0)
    calls["n"] = 0
    plain = diagnose(rec, "manipulator2dof")
    assert calls["n"] > with_cache
    assert json.dumps(cached.selection.tried, default=str) == \
        json.dumps(plain.selection.tried, default=str)
    assert cached.selection.history == plain.selection.history
    assert [e["effect"] for e in cached.effects] == [e["effect"] for e in plain.effects]
    assert any(e["effect"] == "input_delay" for e in cached.effects)
