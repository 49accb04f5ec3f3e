"""The input latency a log can identify (issue 13, 100 Hz input delay read 4 ms short).

A log cannot tell how long each logged input was held before it acted from a transport
delay: only their sum acts. On a 100 Hz log of the generator's 500 Hz loop the hold test
keeps ZOH (5 ms) and the delay is fitted on top of it, 4 ms short of the injected one
(true hold 1 ms). With the hold undeclared the report must say that the total is what was
measured and that the split is not determined; a declared hold fixes the split. The proof
scores the total only when the report states it.
"""

import numpy as np
import pytest

from simgap.diagnosis.artefacts import ARTEFACTS
from simgap.diagnosis.generate import generate_manipulator
from simgap.diagnosis.pipeline import diagnose
from simgap.diagnosis.proof import GENERATOR_HOLD_S, _matches, draw
from simgap.recordings import Recording


def _delay_100hz(seed: int):
    inj = draw("input_delay", np.random.default_rng(1000 + seed))
    rec = generate_manipulator([inj], seed=seed, duration=20.0)
    rec = ARTEFACTS["coarse_100hz"].apply(rec, {}, np.random.default_rng(9000 + seed))
    return inj, Recording(rec.name, dict(rec.columns))


def test_undeclared_hold_reports_the_total_latency_and_an_undetermined_split():
    """Seed 0: delay 13.3 ms; the fitted delay alone is ≈ 9.6 ms (28 % short), the total
    (hold lag 5 ms + delay) ≈ 14.6 ms against the true 13.3 + 1 ms."""
    inj, rec = _delay_100hz(0)
    rep = diagnose(rec, "manipulator2dof")
    hits = [e for e in rep.effects if e["effect"] == "input_delay"]
    assert hits, rep.effects
    truth = inj.params["delay"] + GENERATOR_HOLD_S
    for e in hits:
        lat = e["input_latency"]
        assert lat["split_determined"] is False
        assert lat["total"] == pytest.approx(e["parameters"]["delay"] + lat["hold_lag"])
        assert lat["total"] == pytest.approx(truth, rel=0.05), (lat, truth)
        assert lat["stderr"] == e["stderr"]["delay"]
        # the delay alone is not the injected one: the confound is real, not a rounding
        assert abs(e["parameters"]["delay"] / inj.params["delay"] - 1) > 0.2
        assert "not determined" in e["text"] and "--input-hold" in e["text"]


def test_a_declared_hold_fixes_the_split():
    """The same log with ``input_hold="zoh"`` declared: the delay is the declaration's
    split, no latency caveat."""
    _, rec = _delay_100hz(0)
    rep = diagnose(rec, "manipulator2dof", input_hold="zoh")
    hits = [e for e in rep.effects if e["effect"] == "input_delay"]
    assert hits, rep.effects
    assert all("input_latency" not in e for e in hits)
    assert all("not determined" not in e["text"] for e in hits)


def _entry(delay: float, latency: dict | None) -> dict:
    e = {"effect": "input_delay", "channel": "joint1", "parameters": {"delay": delay},
         "stderr": {"delay": 1e-4}}
    return e if latency is None else {**e, "input_latency": latency}


def test_the_proof_scores_the_total_only_when_the_report_states_it():
    inj = draw("input_delay", np.random.default_rng(1000))
    d = inj.params["delay"]
    short = d - 0.004                       # the delay on a 5 ms assumed hold
    lat = {"total": short + 0.005, "stderr": 1e-4, "hold_lag": 0.005,
           "split_determined": False}
    found = [_entry(short, lat), {**_entry(short, lat), "channel": "joint2"}]
    ok, err, _ = _matches(inj, found)
    assert ok and err == pytest.approx(abs(short + 0.005 - GENERATOR_HOLD_S - d) / d)
    assert err < 0.01
    # the same numbers without the statement: scored on the delay alone (4 ms short)
    ok, err, _ = _matches(inj, [_entry(short, None), {**_entry(short, None),
                                                      "channel": "joint2"}])
    assert ok and err == pytest.approx(0.004 / d)
    # a determined split is scored on the delay too
    lat_d = {**lat, "split_determined": True}
    _, err, _ = _matches(inj, [_entry(short, lat_d), {**_entry(short, lat_d),
                                                      "channel": "joint2"}])
    assert err == pytest.approx(0.004 / d)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 2, 3, 4])
def test_the_total_latency_holds_over_seeds(seed):
    """SIMGAP_SLOW=1: every input delay named on a 100 Hz log states an undetermined split
    and a total within 5 % of the injected delay + the generator's hold."""
    inj, rec = _delay_100hz(seed)
    rep = diagnose(rec, "manipulator2dof")
    hits = [e for e in rep.effects if e["effect"] == "input_delay"]
    assert hits, rep.effects
    truth = inj.params["delay"] + GENERATOR_HOLD_S
    for e in hits:
        assert e["input_latency"]["split_determined"] is False
        assert e["input_latency"]["total"] == pytest.approx(truth, rel=0.05)
