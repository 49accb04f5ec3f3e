"""Issue 13, items 4 and 6: free decays against a nominal whose damping is too high, and
steady circles one turn direction per run (simgap.diagnosis.scenarios)."""

from __future__ import annotations

import numpy as np
import pytest

from simgap.diagnosis.generate import InjectedEffect, generate_bicycle
from simgap.diagnosis.pipeline import diagnose
from simgap.diagnosis.scenarios import circles, decay, join_runs
from simgap.diagnosis.validation import detectable
from simgap.models.pendulum import PendulumNominal, PendulumParams
from simgap.recordings import Recording


def _blind(rec: Recording) -> Recording:
    return Recording(rec.name, dict(rec.columns))


def _named(rep) -> dict[str, dict]:
    return {f"{e['effect']}@{e['channel']}": e for e in rep.effects}


def _tried(rep, effect: str) -> list[dict]:
    return [t for t in rep.data["tried"] if t["effect"] == effect]


# ----------------------------------------------------------------------- free decays
def test_pendulum_nominal_inverse_dynamics_and_own_damping() -> None:
    m = PendulumNominal(PendulumParams(inertia=0.05, mgl=1.0, damping=0.02))
    q, dq, ddq = np.array([[0.3]]), np.array([[1.5]]), np.array([[-2.0]])
    assert m.inverse_dynamics(q, dq, ddq)[0, 0] == pytest.approx(
        0.05 * -2.0 + 0.02 * 1.5 + np.sin(0.3))
    assert m.nominal_coefficients() == {"damping": (0.02,)}
    x = m.state(np.array([0.3, 1.5]))
    assert m.f(x, np.array([0.0]))[1] == pytest.approx(-0.02 * 1.5 - np.sin(0.3))


@pytest.mark.parametrize("seed", [0, 1])
def test_damping_too_high_is_named_as_a_signed_correction(seed: int) -> None:
    """No input, nominal damping 15 % too high, no friction: the answer is a negative
    viscous correction ("the nominal damping is 15 % too high"), confirmed on the outer
    held-out blocks, which hold large amplitudes too (before: the late, small-amplitude test
    part could only say "cannot test"; before that: "not confirmed", nothing named)."""
    sc = decay(seed, coulomb_friction=False)
    rep = diagnose(_blind(sc.recording), sc.model)
    named = _named(rep)
    assert list(named) == ["viscous_friction@joint1"]
    (want,) = sc.expected
    e = named["viscous_friction@joint1"]
    assert e["parameters"]["b"] < 0
    assert abs(e["parameters"]["b"] - want.params["b"]) < 0.2 * abs(want.params["b"])
    corr = e["nominal_correction"]["b"]
    assert corr["nominal_error"] == pytest.approx(0.15, abs=0.03)
    assert "% too high" in e["text"]
    # the outer held-out part holds blocks of every amplitude (validation.split_rows): the
    # correction is confirmed there, not only named on the validation blocks (main: the
    # late, small-amplitude test part could not test it, "cannot test")
    assert e["testable_held_out"] and e["explained_fraction"] > 0
    assert "cannot test" not in e["summary"]
    assert "% of the held-out residual explained" in rep.data["verdict"]
    assert rep.data["fit"]["split"]["test_blocks"]
    assert min(b[0] for b in rep.data["fit"]["split"]["test_blocks"]) < \
        0.5 * rep.data["fit"]["split"]["test"][0]


@pytest.mark.parametrize("seed", [0, 2])
def test_less_viscous_plus_coulomb_is_expressible(seed: int) -> None:
    """The nominal damping 15 % too high beside a real Coulomb friction: both named, the
    viscous correction negative (b ≥ 0 could not express it)."""
    sc = decay(seed, coulomb_friction=True)
    rep = diagnose(_blind(sc.recording), sc.model)
    named = _named(rep)
    assert set(named) == {"viscous_friction@joint1", "coulomb_friction@joint1"}
    for want in sc.expected:
        got = named[f"{want.effect}@joint1"]["parameters"]
        for k, v in want.params.items():
            assert abs(got[k] - v) < 0.2 * abs(v), (want.effect, k, got[k], v)


def test_decay_with_the_right_nominal_names_nothing() -> None:
    sc = decay(500, coulomb_friction=False, damping_error=0.0)
    assert sc.expected == []
    rep = diagnose(_blind(sc.recording), sc.model)
    assert rep.effects == []


def test_power_of_a_held_out_part() -> None:
    """A contribution far below the noise of a part cannot be detected there; a large one
    can."""
    rng = np.random.default_rng(0)
    e = rng.normal(0.0, 1.0, (400, 1))
    x = np.sin(np.linspace(0.0, 20.0, 400))[:, None]
    assert not detectable(e, 0.01 * x, 1, 0.01).detectable
    p = detectable(e, 0.5 * x, 1, 0.01)
    assert p.detectable and p.expected > p.critical


# ----------------------------------------------------------------------- steady circles
def test_tire_saturation_on_circles_is_not_a_mass_ratio() -> None:
    """Steady circles, left run then right run, real tire saturation (one road μ): main
    named a mass ratio of 1.22 (one vehicle-scope parameter gaining on both axles beat the
    saturation axle by axle); the saturation is now also tried on both axles at once."""
    sc = circles([InjectedEffect(effect="tire_saturation", params={"mu": 0.656})], 0)
    rep = diagnose(_blind(sc.recording), "bicycle")
    named = _named(rep)
    assert set(named) == {"tire_saturation@front_axle", "tire_saturation@rear_axle"}
    for e in named.values():
        assert abs(e["parameters"]["mu"] - 0.656) < 0.05 * 0.656


def test_mass_ratio_on_circles_is_reported_as_the_identifiable_combination() -> None:
    """On steady circles a mass ratio and a common scale of both tire laws are the same
    motion: fitted with the cornering-stiffness ratios freed beside it, the mass ratio is
    undetermined. It is reported as that combination, not named, and nothing stands in."""
    sc = circles([InjectedEffect(effect="mass_mismatch", params={"ratio": 1.2})], 0)
    rep = diagnose(_blind(sc.recording), "bicycle")
    assert rep.effects == []
    (mass,) = _tried(rep, "mass_mismatch")
    assert mass["decision"] == "not identifiable"
    assert "identifiable combination" in mass["reason"]
    assert "Not identifiable on this data" in rep.data["verdict"]


def test_yaw_bias_whose_sign_follows_the_turn_direction_is_demoted() -> None:
    """Left run with a yaw bias +0.15 rad/s², right run with −0.15: a constant fitted over
    both is not a constant; fitted on each direction it flips sign: demoted."""
    runs = [generate_bicycle([InjectedEffect(effect="yaw_bias", params={"dr0": s * 0.15})],
                             duration=20.0, seed=seed, program=f"circles_{d}", ay_peak=6.0,
                             vx_variation=0.05)
            for s, d, seed in ((1.0, "left", 3), (-1.0, "right", 1003))]
    rep = diagnose(_blind(join_runs(runs)), "bicycle")
    assert "yaw_bias@vehicle" not in _named(rep)
    (yaw,) = _tried(rep, "yaw_bias")
    assert yaw["decision"] in ("demoted", "rejected", "not identifiable")
    if yaw["decision"] == "demoted":
        assert "not a constant" in yaw["reason"]


def test_constant_on_one_direction_only_is_flagged() -> None:
    """One run turning left only: a constant yaw bias and an effect whose sign follows the
    turn direction are the same function; flagged as not identifiable from one direction,
    fitted as that combination and not named (nothing stands in for it)."""
    sc = circles([InjectedEffect(effect="yaw_bias", params={"dr0": 0.15})], 0,
                 directions=("left",))
    rep = diagnose(_blind(sc.recording), "bicycle")
    assert "yaw_bias@vehicle" not in _named(rep)
    (yaw,) = _tried(rep, "yaw_bias")
    assert yaw["decision"] == "not identifiable"
    assert "one direction" in yaw["reason"]
    assert rep.effects == []


def test_clean_circles_name_nothing() -> None:
    rep = diagnose(_blind(circles([], 501).recording), "bicycle")
    assert rep.effects == []
    assert not rep.significant


# ------------------------------------------------- out of the vocabulary: turn-following yaw
def test_turn_yaw_offset_scenario_flips_with_the_direction() -> None:
    """The generator: +offset on the left run, −offset on the right run, truth only."""
    sc = circles([], 0, turn_yaw_offset=0.15)
    assert sc.expected == [] and sc.truth["turn_yaw_offset"] == 0.15
    again = circles([], 0, turn_yaw_offset=0.15)
    for k in sc.recording.columns:
        assert np.array_equal(sc.recording[k], again.recording[k])
    plain = circles([], 0)
    r, r0, t = sc.recording["r"], plain.recording["r"], sc.recording.t
    left = t < t[-1] / 2
    # a positive yaw acceleration raises the left run's yaw rate, lowers the right run's
    assert np.mean((r - r0)[left]) > 0 > np.mean((r - r0)[~left])
    with pytest.raises(Exception, match="turn_yaw_offset"):
        circles([], 0, turn_yaw_offset=-0.1)


def test_turn_following_yaw_offset_is_located_not_named() -> None:
    """Out of the vocabulary: a yaw acceleration of +0.15 rad/s² on left turns and −0.15 on
    right turns. Before, a rear cornering-stiffness ratio (0.87) and a front tire saturation
    (μ 1.22), with a mass ratio kept as a combination, were named together: bent into one
    odd step of the turn direction. As a set they are no better on the validation blocks
    than that offset (out of the vocabulary), so none is named; the mismatch stays
    located."""
    sc = circles([], 0, turn_yaw_offset=0.15)
    rep = diagnose(_blind(sc.recording), "bicycle")
    assert rep.effects == [], _named(rep)
    assert rep.significant and rep.data["mismatch"]["segments"]
    demoted = [t for t in rep.data["tried"] if t["decision"] == "demoted"]
    assert demoted and all("sign follows the direction" in t["reason"] for t in demoted)


def test_true_cornering_stiffness_on_circles_beats_the_direction_offset() -> None:
    """A real rear cornering-stiffness ratio scales the force with the slip angle (with the
    level of each circle), which no direction-following offset reproduces: still named."""
    sc = circles([InjectedEffect(effect="cornering_stiffness", channel="rear_axle",
                                 params={"ratio": 0.8})], 1)
    rep = diagnose(_blind(sc.recording), "bicycle")
    named = _named(rep)
    assert set(named) == {"cornering_stiffness@rear_axle"}
    assert abs(named["cornering_stiffness@rear_axle"]["parameters"]["ratio"] - 0.8) < 0.04
    assert not [t for t in rep.data["tried"] if "sign follows the direction" in
                str(t.get("reason", ""))]
