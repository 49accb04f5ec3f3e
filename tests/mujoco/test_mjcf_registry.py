"""MJCF models through the one ``diagnose()`` (the registry's ``mjcf`` system) and signed
corrections of a nominal's own terms ("the nominal damping is 15 % too high")."""

from pathlib import Path

import pandas as pd
import pytest

mujoco = pytest.importorskip("mujoco")

from simgap.diagnosis import diagnose  # noqa: E402
from simgap.diagnosis.mjcf_record import record_mjcf  # noqa: E402
from simgap.recordings import Recording  # noqa: E402
from simgap.systems import system_of_file  # noqa: E402

ARM = Path(__file__).resolve().parents[2] / "examples" / "mujoco" / "arm2dof.xml"


def _xml(elbow_damping: float) -> str:
    old = 'name="elbow" type="hinge" axis="0 0 1"'
    return ARM.read_text().replace(old, f'{old} damping="{elbow_damping}"', 1)


@pytest.fixture(scope="module")
def over_damped(tmp_path_factory):
    """Nominal elbow damping 0.40 N·m·s/rad, the real one 0.34 (the nominal 15 % high)."""
    tmp = tmp_path_factory.mktemp("signed")
    nominal = tmp / "nominal.xml"
    nominal.write_text(_xml(0.40))
    cols = record_mjcf(mujoco.MjModel.from_xml_string(_xml(0.34)), duration=5.0, seed=4)
    log = tmp / "log.csv"
    pd.DataFrame(cols).to_csv(log, index=False)
    return nominal, log, cols


def test_mjcf_is_a_registered_model_file() -> None:
    assert system_of_file("robot.xml").name == "mjcf"
    assert system_of_file("model.py:NAME") is None


def test_too_high_nominal_damping_is_lowered(over_damped) -> None:
    nominal, log, _ = over_damped
    rep = diagnose(log, nominal)  # the one entry point, MJCF found through the registry
    named = {(e["effect"], e["channel"]): e for e in rep.effects}
    assert set(named) == {("viscous_friction", "elbow")}, rep.effects
    e = named[("viscous_friction", "elbow")]
    assert e["parameters"]["b"] == pytest.approx(-0.06, rel=0.15)
    corr = e["nominal_correction"]["b"]
    assert corr["nominal"] == 0.40
    assert corr["relative"] == pytest.approx(-0.15, abs=0.02)
    assert "damping 0.4 →" in e["text"]
    assert "mjcf" in rep.data  # the MJCF extras (corrected file) as with diagnose_mjcf


def test_in_memory_recording_with_an_mjcf(over_damped) -> None:
    nominal, _, cols = over_damped
    rec = Recording("log", {k: v for k, v in cols.items()})
    rep = diagnose(rec, str(nominal))
    assert [(e["effect"], e["channel"]) for e in rep.effects] == [("viscous_friction", "elbow")]
