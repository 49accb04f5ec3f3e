"""A declared input hold reaches the diagnosis (issue 13, Task B of session 5).

How the inputs were logged (``zoh``: held until the next sample, ``sample``: point samples)
can be declared in the column map (``"input_hold"`` in its JSON, ``ColumnMap.of(...,
input_hold=...)``), on the command line (``--input-hold``) or in a model's recording
schema. Before, the adapter's columns kept ``"auto"`` whatever the user said (and a JSON
map with ``"input_hold"`` was refused as naming an unknown column).
"""

from __future__ import annotations

import json

import pytest

from simgap.diagnosis import pipeline
from simgap.diagnosis.generate import generate
from simgap.diagnosis.systems import MechanicalSystem
from simgap.diagnosis.user_models import with_columns
from simgap.errors import ColumnMapError
from simgap.models.prismatic import RigidAxisNominal, RigidAxisParams
from simgap.recordings import Column, ColumnMap, write_recording
from simgap.schema import RecordingSchema


class _Stop(Exception):
    """Raised by the patched pipeline once the adapter is built (nothing is fitted)."""


@pytest.fixture
def seen(monkeypatch) -> dict:
    """The hold of the adapter the diagnosis would run with."""
    out: dict = {}

    def run(rec, system, horizon, train_fraction):
        out["hold"] = system.columns.input_hold
        raise _Stop

    monkeypatch.setattr(pipeline, "_run", run)
    return out


@pytest.fixture(scope="module")
def log(tmp_path_factory):
    path = tmp_path_factory.mktemp("hold") / "arm.csv"
    write_recording(path, generate("manipulator2dof", [], seed=3, duration=2.0).columns)
    return path


def _diagnose(*args, **kwargs) -> None:
    with pytest.raises(_Stop):
        pipeline.diagnose(*args, **kwargs)


@pytest.mark.parametrize("hold", ["zoh", "sample"])
def test_column_map_file_declares_the_hold(tmp_path, log, seen, hold) -> None:
    cmap = tmp_path / "map.json"
    cmap.write_text(json.dumps({"t": "t", "input_hold": hold}), encoding="utf-8")
    _diagnose(log, "manipulator2dof", columns=cmap)
    assert seen["hold"] == hold


def test_column_map_object_and_argument(log, seen) -> None:
    _diagnose(log, "manipulator2dof", columns=ColumnMap.of(t="t", input_hold="sample"))
    assert seen["hold"] == "sample"
    # the argument wins over the map
    _diagnose(log, "manipulator2dof", columns=ColumnMap.of(input_hold="sample"),
              input_hold="zoh")
    assert seen["hold"] == "zoh"


def test_undeclared_hold_stays_auto(log, seen) -> None:
    _diagnose(log, "manipulator2dof")
    assert seen["hold"] == "auto"
    _diagnose(log, "manipulator2dof", columns={"t": "t"})
    assert seen["hold"] == "auto"


def test_cli_option_and_map_reach_the_diagnosis(tmp_path, log, seen) -> None:
    from typer.testing import CliRunner

    from simgap.cli import app

    res = CliRunner().invoke(app, ["diagnose", str(log), "--model", "manipulator2dof",
                                   "--out", str(tmp_path / "r1"), "--input-hold", "sample"])
    assert isinstance(res.exception, _Stop), res.output
    assert seen["hold"] == "sample"
    cmap = tmp_path / "map.json"
    cmap.write_text(json.dumps({"input_hold": "zoh"}), encoding="utf-8")
    res = CliRunner().invoke(app, ["diagnose", str(log), "--model", "manipulator2dof",
                                   "--out", str(tmp_path / "r2"), "--columns", str(cmap)])
    assert isinstance(res.exception, _Stop), res.output
    assert seen["hold"] == "zoh"
    res = CliRunner().invoke(app, ["diagnose", str(log), "--model", "manipulator2dof",
                                   "--out", str(tmp_path / "r3"), "--input-hold", "held"])
    assert res.exit_code == 2 and "--input-hold" in res.output


def test_user_model_column_map_and_schema_declare_it() -> None:
    from simgap.diagnosis.systems import declared_hold

    axis = with_columns(RigidAxisNominal(RigidAxisParams(mass=2.0)),
                        ColumnMap.of(t="time", q="pos", u=Column(source="force", scale=2.0),
                                     input_hold="sample"))
    assert declared_hold(axis) == "sample"
    assert MechanicalSystem(axis).columns.input_hold == "sample"
    plain = RigidAxisNominal(RigidAxisParams(mass=2.0))
    assert MechanicalSystem(plain).columns.input_hold == "auto"
    plain.recording_schema = RecordingSchema(canonical=("t", "q", "dq", "u"),
                                             derivable=("dq",), input_hold="zoh")
    assert MechanicalSystem(plain).columns.input_hold == "zoh"


def test_map_round_trip_and_bad_value() -> None:
    cmap = ColumnMap.from_dict({"t": "time", "input_hold": "sample"})
    assert cmap.input_hold == "sample" and set(cmap.columns) == {"t"}
    assert ColumnMap.from_dict(cmap.to_dict()) == cmap
    assert "input_hold" not in ColumnMap.of(t="time").to_dict()
    schema = RecordingSchema(canonical=("t", "q", "u"))
    assert cmap.completed(schema, ["time", "q", "u"]).input_hold == "sample"
    with pytest.raises(ColumnMapError, match="input_hold"):
        ColumnMap.from_dict({"t": "time", "input_hold": "held"})
    with pytest.raises(ColumnMapError, match="input_hold"):
        RecordingSchema(canonical=("t", "q"), input_hold="held")


def test_mjcf_column_map_and_argument_declare_it(tmp_path, seen) -> None:
    pytest.importorskip("mujoco")
    from pathlib import Path

    from simgap.diagnosis.mujoco import diagnose_mjcf, load_mjcf_inputs

    xml = Path(__file__).resolve().parents[2] / "examples" / "mujoco" / "arm2dof.xml"
    rec = generate("manipulator2dof", [], seed=3, duration=2.0)
    cols = {"t": rec["t"], "q_shoulder": rec["q1"], "q_elbow": rec["q2"],
            "tau_shoulder": rec["tau1"], "tau_elbow": rec["tau2"]}
    log = tmp_path / "mj.csv"
    write_recording(log, cols)
    system, _ = load_mjcf_inputs(xml, log, ColumnMap.of(input_hold="sample"))
    assert system.columns.input_hold == "sample"
    system, _ = load_mjcf_inputs(xml, log)
    assert system.columns.input_hold == "auto"
    with pytest.raises(_Stop):
        diagnose_mjcf(xml, log, input_hold="zoh")
    assert seen["hold"] == "zoh"
