"""One ``diagnose()`` entry point: user models, column maps, augmented_model.json (issue 12).

Each of the three diagnosis defects of issue 12 has a test here that fails on main 37ffcf9:
a user model without a column map, the missing ``augmented_model.json`` of user models, and
the Python API and the CLI disagreeing about the same 1-DOF axis.
"""

from __future__ import annotations

import json
import textwrap
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from simgap.diagnosis import diagnose, load_augmented, write_report
from simgap.models.prismatic import RigidAxisNominal, RigidAxisParams

MASS, B, FC = 2.0, 3.0, 1.0

AXIS_FILE = """
from simgap.models.prismatic import RigidAxisNominal, RigidAxisParams

AXIS = RigidAxisNominal(RigidAxisParams(mass={mass}), channel="slider")
"""


def _axis_frame(seed: int = 0, n: int = 6000, dt: float = 1e-3) -> pd.DataFrame:
    """A 2 kg slider with viscous (3 N·s/m) and Coulomb (1 N) friction, canonical columns."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * dt
    force = 8.0 * np.sin(2 * np.pi * 0.7 * t) + 5.0 * np.sin(2 * np.pi * 1.9 * t + 1.0)
    q, v = np.zeros(n), np.zeros(n)
    for k in range(n - 1):
        qk, vk = q[k], v[k]
        for _ in range(10):
            vk += (force[k] - B * vk - FC * np.tanh(vk / 1e-3)) / MASS * dt / 10
            qk += vk * dt / 10
        q[k + 1], v[k + 1] = qk, vk
    return pd.DataFrame({"t": t, "q": q + rng.normal(0.0, 1e-7, n), "dq": v,
                         "u": force + rng.normal(0.0, 1e-3, n)})


@pytest.fixture(scope="module")
def axis_csv(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("axis") / "axis.csv"
    _axis_frame().drop(columns="dq").to_csv(path, index=False)
    return path


@pytest.fixture(scope="module")
def axis_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("model") / "axis_model.py"
    path.write_text(textwrap.dedent(AXIS_FILE.format(mass=MASS)), encoding="utf-8")
    return path


@pytest.fixture(scope="module")
def api_report(axis_csv: Path):
    return diagnose(axis_csv, RigidAxisNominal(RigidAxisParams(mass=MASS), channel="slider"))


# --------------------------------------------------------------------------- defect a
def test_user_model_without_column_map_is_diagnosed(api_report) -> None:
    """The canonical file t, q, u (no dq): the velocity is derived, friction is named."""
    eff = {e["effect"]: e for e in api_report.data["effects"]}
    assert {"viscous_friction", "coulomb_friction"} <= set(eff)
    assert eff["viscous_friction"]["parameters"]["b"] == pytest.approx(B, rel=0.1)
    assert eff["coulomb_friction"]["parameters"]["Fc"] == pytest.approx(FC, rel=0.15)
    assert api_report.system.columns.dq is None


def test_recorded_velocity_is_used_when_present(tmp_path: Path) -> None:
    path = tmp_path / "with_dq.csv"
    _axis_frame(n=3000).to_csv(path, index=False)
    report = diagnose(path, RigidAxisNominal(RigidAxisParams(mass=MASS)))
    assert report.system.columns.dq == ("dq",)
    assert report.data["fit"]["rollout_names"] == ["q", "dq"]


# --------------------------------------------------------------------------- defect c
def test_api_and_cli_agree_on_a_user_axis(api_report, axis_csv: Path, axis_file: Path,
                                          tmp_path: Path) -> None:
    """Same columns, units and numbers through diagnose(rec, model) and the CLI."""
    from typer.testing import CliRunner

    from simgap.cli import app

    out = tmp_path / "cli-report"
    result = CliRunner().invoke(app, ["diagnose", str(axis_csv), "--model",
                                      f"{axis_file}:AXIS", "--out", str(out),
                                      "--no-figures"])
    assert result.exit_code == 0, result.output
    cli = json.loads((out / "report.json").read_text(encoding="utf-8"))
    api = json.loads(json.dumps(api_report.data))
    assert api["fit"]["rollout_names"] == ["q", "dq"]
    assert api["fit"]["rollout_units"] == ["m", "m/s"]
    assert [c["unit"] for c in api["mismatch"]["channels"]] == ["N"]
    assert api["mismatch"]["channels"][0]["channel"] == "slider"
    units = {e["effect"]: e["units"] for e in api["effects"]}
    assert units["viscous_friction"]["b"] == "N·s/m" and units["coulomb_friction"]["Fc"] == "N"
    assert cli["processing"].pop("model_file") == f"{axis_file}:AXIS"
    assert cli == api


# --------------------------------------------------------------------------- defect b
def test_user_model_gets_augmented_model_json(api_report, axis_file: Path,
                                              tmp_path: Path) -> None:
    out = write_report(api_report, tmp_path / "rep", figures=False)
    path = out / "augmented_model.json"
    assert path.is_file()
    assert "augmented_model.json" in (out / "report.md").read_text(encoding="utf-8")
    saved = json.loads(path.read_text(encoding="utf-8"))
    assert saved["schema"] == 1 and saved["kind"] == "mechanical"
    assert {e["effect"] for e in saved["effects"]} >= {"viscous_friction", "coulomb_friction"}
    # read back (the API report has no model file: the model is passed in)
    model = RigidAxisNominal(RigidAxisParams(mass=MASS), channel="slider")
    again = load_augmented(path, model=model)
    rng = np.random.default_rng(1)
    for x, u in zip(rng.normal(size=(5, 2)), rng.normal(size=(5, 1)), strict=True):
        np.testing.assert_array_equal(again.f(x, u), api_report.augmented.f(x, u))
    # a report of a model file names the file, and the reader loads it from there
    saved["model_file"] = f"{axis_file}:AXIS"
    path.write_text(json.dumps(saved), encoding="utf-8")
    again = load_augmented(path)
    np.testing.assert_array_equal(again.f(np.array([0.1, 0.2]), np.array([1.0])),
                                  api_report.augmented.f(np.array([0.1, 0.2]), np.array([1.0])))


def test_user_model_augmented_model_is_a_plant(api_report, tmp_path: Path) -> None:
    """A user model's augmented model is a serialisable Plant of the generic mechanical
    schema (the model's joints + the vocabulary), written like the arm's (issue 12)."""
    from simgap.diagnosis.augmented import AugmentedMechanical, mechanical_schema
    from simgap.models.effects import Plant

    aug = api_report.augmented
    assert isinstance(aug, AugmentedMechanical) and isinstance(aug.plant, Plant)
    saved = aug.to_dict()
    assert "fitted" not in saved
    plant = saved["plant"]
    assert plant["system"] == "rigid_axis" and plant["params"]["mass"] == MASS
    assert {(e["effect"], e["channel"]) for e in plant["effects"]} >= {
        ("viscous_friction", "slider"), ("coulomb_friction", "slider")}
    model = RigidAxisNominal(RigidAxisParams(mass=MASS), channel="slider")
    again = Plant.from_dict(json.loads(json.dumps(plant)),
                            mechanical_schema(model, ("slider",)))
    assert again == aug.plant
    # the plant alone simulates the model the diagnosis compared
    rebuilt = AugmentedMechanical(model, api_report.system, plant=again)
    x, u = np.array([0.1, 0.3]), np.array([2.0])
    np.testing.assert_array_equal(rebuilt.f(x, u), aug.f(x, u))
    assert rebuilt.f(x, u)[1] != model.f(x, u)[1]        # the friction is in it


def test_reader_keeps_the_fitted_layout_of_user_models(api_report, tmp_path: Path) -> None:
    """A user model's augmented_model.json as written before the plant ("fitted" terms in
    fit coordinates, no "plant") still reads, to the same model."""
    aug = api_report.augmented
    old = {k: v for k, v in aug.to_dict().items() if k != "plant"}
    old["fitted"] = [{"effect": e.name, "index": i, "lin": [float(v) for v in lin],
                      "nl": [float(v) for v in nl]} for e, i, lin, nl in aug.fitted]
    path = tmp_path / "augmented_model.json"
    path.write_text(json.dumps(old), encoding="utf-8")
    model = RigidAxisNominal(RigidAxisParams(mass=MASS), channel="slider")
    again = load_augmented(path, model=model)
    x, u = np.array([0.1, -0.3]), np.array([1.5])
    np.testing.assert_array_equal(again.f(x, u), aug.f(x, u))
    assert again.plant == aug.plant


def test_fit_coordinates_invert_the_reported_parameters() -> None:
    """FitSpec.coordinates is the inverse of to_report (Stribeck's Fs − Fc, the spring's
    c = −k·q0, a ratio − 1, identity elsewhere); an effect without a declared inverse says
    so."""
    import dataclasses

    from simgap.diagnosis.effects import VOCABULARY, report_params
    from simgap.errors import ModelError

    for name, lin, nl, ctx in (("stribeck_friction", [0.2], [0.05], {"Fc": 0.3}),
                               ("spring", [2.5, -0.4], [], {}),
                               ("mass_mismatch", [0.15], [], {}),
                               ("viscous_friction", [0.7], [], {})):
        eff = VOCABULARY[name]
        cov = np.zeros((len(lin) + len(nl),) * 2)
        params, _, _ = report_params(eff, np.array(lin), np.array(nl), cov, ctx)
        got_lin, got_nl = eff.coordinates(params, {"Fc": ctx.get("Fc", 0.0)})
        np.testing.assert_allclose(got_lin, lin, rtol=1e-15, atol=1e-15)
        np.testing.assert_array_equal(got_nl, nl)
    with pytest.raises(ModelError, match="inverse"):
        dataclasses.replace(VOCABULARY["mass_mismatch"], from_report=None
                            ).coordinates({"ratio": 1.1})


def test_reader_keeps_todays_files(tmp_path: Path) -> None:
    """augmented_model.json of a built-in model as written on main still reads."""
    path = tmp_path / "augmented_model.json"
    path.write_text(json.dumps({
        "schema": 1, "model": "manipulator2dof", "base_params": {},
        "effects": [{"effect": "coulomb_friction", "channel": "joint2", "params": {"Fc": 0.26}}],
        "options": {"coulomb_sigma": [0.001, 0.001], "dt": 0.002}}), encoding="utf-8")
    model = load_augmented(path)
    assert model.friction.fc == (0.0, 0.26)


def test_reader_errors_are_typed(tmp_path: Path) -> None:
    from simgap.errors import ModelFileError

    path = tmp_path / "augmented_model.json"
    path.write_text(json.dumps({"schema": 1, "model": "x", "kind": "mechanical",
                                "fitted": [], "options": {"coulomb_sigma": [1e-3]}}))
    with pytest.raises(ModelFileError, match=r"names no model file"):
        load_augmented(path)


# --------------------------------------------------------------------------- column maps
def test_builtin_bicycle_with_a_column_map(tmp_path: Path) -> None:
    """A bicycle log whose steering is a steering-wheel angle in degrees, mapped with a scale,
    gives the same report as the canonical file (CLI --columns and the API)."""
    from typer.testing import CliRunner

    from simgap.cli import app
    from simgap.diagnosis import Column, ColumnMap, InjectedEffect, generate

    rec = generate("bicycle", [InjectedEffect(effect="tire_saturation", params={"mu": 0.6})],
                   duration=12.0, seed=4)
    ratio = 15.0  # steering-wheel angle / road-wheel angle
    canonical = tmp_path / "car.csv"
    frame = rec.to_frame()
    frame.to_csv(canonical, index=False)
    logged = frame.rename(columns={"t": "time_s"})
    logged["wheel_deg"] = np.degrees(ratio * frame["delta_f"])
    logged = logged.drop(columns=["delta_f"])
    log = tmp_path / "car_log.csv"
    logged.to_csv(log, index=False)
    scale = np.radians(1.0) / ratio
    mapping = {"t": "time_s", "delta_f": {"source": "wheel_deg", "scale": scale}}
    cmap_file = tmp_path / "map.json"
    cmap_file.write_text(json.dumps(mapping), encoding="utf-8")

    base = diagnose(canonical, "bicycle").data
    mapped = diagnose(log, "bicycle", columns=ColumnMap.of(
        t="time_s", delta_f=Column(source="wheel_deg", scale=scale))).data
    assert mapped["processing"].pop("column_map")["delta_f"] == f"{scale:g} × wheel_deg"
    assert mapped["processing"].pop("notes") == []
    assert mapped["effects"][0]["effect"] == "tire_saturation"
    # deg -> rad is not exact in floating point: equal up to rounding, not bit for bit
    assert [(e["effect"], e["channel"]) for e in mapped["effects"]] == \
        [(e["effect"], e["channel"]) for e in base["effects"]]
    np.testing.assert_allclose([e["parameters"]["mu"] for e in mapped["effects"]],
                               [e["parameters"]["mu"] for e in base["effects"]], rtol=1e-6)
    out = tmp_path / "cli"
    result = CliRunner().invoke(app, ["diagnose", str(log), "--model", "bicycle", "--columns",
                                      str(cmap_file), "--out", str(out), "--no-figures"])
    assert result.exit_code == 0, result.output
    cli = json.loads((out / "report.json").read_text(encoding="utf-8"))
    assert cli["effects"] == json.loads(json.dumps(diagnose(log, "bicycle",
                                                            columns=mapping).data["effects"]))


@pytest.mark.parametrize(("mapping", "pattern"), [
    ({"t": "time_s", "nonsense": "x"}, r"names 'nonsense', which is not one of its"),
    ({"delta_f": {"source": "w", "gain": 2.0}}, r"column 'delta_f' has unknown field 'gain'"),
    ({"t": 0.0}, r"time 't' cannot be a constant"),
])
def test_bad_column_map_exits_2(tmp_path: Path, mapping: dict, pattern: str) -> None:
    import re

    from typer.testing import CliRunner

    from simgap.cli import app

    rec = tmp_path / "r.csv"
    pd.DataFrame({"t": np.arange(60.0), "vx": 10.0, "vy": 0.0, "r": 0.0, "delta_f": 0.0,
                  "delta_r": 0.0}).to_csv(rec, index=False)
    cmap = tmp_path / "m.json"
    cmap.write_text(json.dumps(mapping), encoding="utf-8")
    result = CliRunner().invoke(app, ["diagnose", str(rec), "--model", "bicycle",
                                      "--columns", str(cmap), "--out", str(tmp_path / "o")])
    assert result.exit_code == 2
    assert re.search(pattern, result.output), result.output
    assert not (tmp_path / "o").exists()


def test_canonical_recording_with_a_mapped_model(tmp_path: Path) -> None:
    """A model's own map translates a file; a Recording already in canonical columns is
    used as is (reading a file with the map, then diagnosing the result, is the same)."""
    from simgap.diagnosis import with_columns
    from simgap.recordings import RecordingSchema, read

    frame = _axis_frame(n=3000).drop(columns="dq")
    log = tmp_path / "log.csv"
    frame.rename(columns={"t": "time", "q": "pos", "u": "force"}).to_csv(log, index=False)
    model = with_columns(RigidAxisNominal(RigidAxisParams(mass=MASS)), t="time", q="pos",
                         u="force")
    from_file = diagnose(log, model).data
    rec = read(log, RecordingSchema.of(model), model.column_map)
    in_memory = diagnose(rec, model).data
    assert from_file["processing"].pop("column_map") == in_memory["processing"].pop(
        "column_map") == {"t": "time", "q": "pos", "u": "force"}
    assert json.dumps(from_file) == json.dumps(in_memory)


# --------------------------------------------------------------------------- aliases
@pytest.mark.parametrize(("module", "name", "new"), [
    ("simgap.diagnosis.custom", "ColumnMap", "simgap.recordings.ColumnMap"),
    ("simgap.diagnosis.custom", "Column", "simgap.recordings.Column"),
    ("simgap.diagnosis.custom", "despike", "simgap.recordings.despike"),
    ("simgap.diagnosis.custom", "load_model", "simgap.diagnosis.user_models.load_model_file"),
    ("simgap.diagnosis.custom", "with_columns", "simgap.diagnosis.user_models.with_columns"),
    ("simgap.diagnosis.custom", "make_system", "simgap.diagnosis.pipeline.make_system"),
    ("simgap.diagnosis.custom", "ModelMechanicalSystem",
     "simgap.diagnosis.systems.MechanicalSystem"),
    ("simgap.diagnosis.systems", "ModelMechanicalSystem",
     "simgap.diagnosis.systems.MechanicalSystem"),
    ("simgap.diagnosis.systems", "ColumnMap", "simgap.diagnosis.systems.AdapterColumns"),
])
def test_moved_names_warn_and_still_work(module: str, name: str, new: str) -> None:
    import importlib

    mod = importlib.import_module(module)
    new_mod, new_name = new.rsplit(".", 1)
    with pytest.warns(DeprecationWarning, match=rf"{module}\.{name} is deprecated"):
        old = getattr(mod, name)
    assert old is getattr(importlib.import_module(new_mod), new_name)


def test_deprecated_diagnose_custom_is_the_entry_point(axis_csv: Path, axis_file: Path,
                                                       api_report) -> None:
    from simgap.diagnosis import custom

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        report = custom.diagnose_custom(f"{axis_file}:AXIS", axis_csv)
    data = json.loads(json.dumps(report.data))
    data["processing"].pop("model_file")
    assert data == json.loads(json.dumps(api_report.data))


def test_facade_is_lazy_and_complete() -> None:
    import subprocess
    import sys

    code = ("import sys, simgap.diagnosis as d; "
            "assert 'simgap.diagnosis.pipeline' not in sys.modules; "
            "assert callable(d.generate) and callable(d.diagnose); "
            "import simgap.diagnosis.generate; assert callable(d.generate); "
            "from simgap.diagnosis.generate import InjectedEffect as I; "
            "assert d.InjectedEffect is I; "
            "assert d.generate is sys.modules['simgap.diagnosis.generate'].generate; "
            "print(sorted(d.__all__))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    for name in ("diagnose", "Report", "generate", "InjectedEffect", "ColumnMap", "Column",
                 "write_report", "summary_lines", "load_augmented", "ResidualForm", "Prepared"):
        assert f"'{name}'" in out
