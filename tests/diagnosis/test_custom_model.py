"""User-defined nominal models: loading ``path.py:NAME``, column maps, the rigid-axis model."""

from __future__ import annotations

import textwrap
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from simgap.diagnosis import diagnose
from simgap.diagnosis.pipeline import make_system
from simgap.diagnosis.systems import MechanicalSystem, translate_unit
from simgap.diagnosis.user_models import check_model, column_map_of, with_columns
from simgap.diagnosis.user_models import load_model_file as load_model
from simgap.errors import CustomModelError
from simgap.models.bicycle import BicycleNominal
from simgap.models.prismatic import RigidAxisNominal, RigidAxisParams
from simgap.recordings import Column, ColumnMap, RecordingError, RecordingSchema, despike, read
from tests.conftest import REPO_ROOT

EXAMPLES = REPO_ROOT / "examples"


def read_mapped(path: Path, model: object):
    """A recording in the model's canonical columns, through its own column map."""
    return read(path, RecordingSchema.of(model), column_map_of(model))

AXIS_FILE = """
from simgap.diagnosis import Column, with_columns
from simgap.models.base import BaseNominalModel
from simgap.models.prismatic import RigidAxisNominal, RigidAxisParams

AXIS = with_columns(RigidAxisNominal(RigidAxisParams(mass=2.0)), t="time",
                    q="pos", u=Column(source="volts", scale=3.0))

def make_axis():
    return RigidAxisNominal(RigidAxisParams(mass=2.0, joint="revolute"), channel="motor")

def needs_args(mass):
    return RigidAxisNominal(RigidAxisParams(mass=mass))

def broken():
    raise RuntimeError("no licence server\\nsecond line")

NOT_A_MODEL = 3.5

class Plain(BaseNominalModel):
    state_names = ("x",)
    state_units = ("m",)
    input_names = ("u",)
    input_units = ("N",)
"""


@pytest.fixture
def model_file(tmp_path: Path) -> Path:
    path = tmp_path / "my_model.py"
    path.write_text(textwrap.dedent(AXIS_FILE))
    return path


def write_csv(path: Path, n: int = 200, **overrides: object) -> Path:
    t = np.arange(n) * 0.01
    frame = pd.DataFrame({"time": t, "pos": np.sin(t), "volts": np.cos(t), "extra": 1.0})
    for key, value in overrides.items():
        frame[key] = value
    frame.to_csv(path, index=False)
    return path


# --------------------------------------------------------------------------- loading
def test_load_instance_with_column_map(model_file: Path) -> None:
    model = load_model(f"{model_file}:AXIS")
    assert isinstance(model, RigidAxisNominal)
    assert model.column_map.sources == ("time", "pos", "volts")


def test_load_zero_argument_factory(model_file: Path) -> None:
    model = load_model(f"{model_file}:make_axis")
    assert model.channel_names == ("motor",)
    assert model.input_units == ("N·m",) and model.obs_units == ("rad", "rad/s")
    # no column map: the canonical columns are required, dq may be derived
    assert column_map_of(model).sources == ("t", "q", "u")


@pytest.mark.parametrize(("spec", "pattern"), [
    ("nowhere/model.py:X", r"nowhere/model\.py: model file not found"),
    ("{f}", r"expected a built-in model name or path/to/model\.py:NAME"),
    ("{f}:", r"expected path/to/model\.py:NAME"),
    ("{f}:1abc", r"NAME '1abc' is not a Python identifier"),
    ("{f}:MISSING", r"no attribute 'MISSING'; it defines AXIS, make_axis, needs_args, broken, "
                    r"Plain$"),
    ("{f}:NOT_A_MODEL", r"NOT_A_MODEL is a float, not a nominal model or a zero-argument"),
    ("{f}:needs_args", r"needs_args\(\) failed with TypeError: .*zero-argument factory"),
    ("{f}:broken", r"broken\(\) failed with RuntimeError: no licence server \(NAME"),
    ("{f}:Plain", r"Plain is a Plain: the diagnosis needs a MechanicalNominalModel"),
])
def test_load_errors_are_one_line(model_file: Path, spec: str, pattern: str) -> None:
    with pytest.raises(CustomModelError, match=pattern) as info:
        load_model(spec.format(f=model_file))
    assert "\n" not in str(info.value)


def test_not_a_python_file(tmp_path: Path) -> None:
    path = tmp_path / "model.txt"
    path.write_text("X = 1\n")
    with pytest.raises(CustomModelError, match=r"model\.txt: a model file must be a \.py file"):
        load_model(f"{path}:X")


def test_import_failure_is_one_line(tmp_path: Path) -> None:
    path = tmp_path / "bad.py"
    path.write_text("import numpy as np\nraise ImportError('no module named foo\\nmore')\n")
    with pytest.raises(CustomModelError, match=r"bad\.py: importing it failed with ImportError: "
                                               r"no module named foo$"):
        load_model(f"{path}:X")
    path.write_text("def broken(:\n")
    with pytest.raises(CustomModelError, match=r"importing it failed with SyntaxError"):
        load_model(f"{path}:X")


def test_bad_column_map_in_file(tmp_path: Path) -> None:
    path = tmp_path / "cm.py"
    path.write_text("from simgap.diagnosis import with_columns\n"
                    "from simgap.models.prismatic import RigidAxisNominal, RigidAxisParams\n"
                    "M = with_columns(RigidAxisNominal(RigidAxisParams(mass=1.0)), t='a', "
                    "x='b', u='c')\n")
    with pytest.raises(CustomModelError, match=r"cm\.py: column map of rigid_axis names 'x', "
                                               r"which is not one of its recording columns"):
        load_model(f"{path}:M")


def test_column_map_must_cover_required_columns() -> None:
    axis = RigidAxisNominal(RigidAxisParams(mass=1.0))
    with pytest.raises(CustomModelError, match=r"does not say where 'u' comes from"):
        with_columns(axis, t="a", q="b")
    with pytest.raises(CustomModelError, match=r"time 't' cannot be a constant"):
        with_columns(axis, t=0.0, q="b", u="c")
    axis.column_map = {"t": "a"}  # not a ColumnMap
    with pytest.raises(CustomModelError, match=r"column_map must be a simgap ColumnMap"):
        check_model(axis)


@pytest.mark.parametrize(("kwargs", "pattern"), [
    ({}, "exactly one of source= and constant="),
    ({"source": "a", "constant": 1.0}, "exactly one of source= and constant="),
    ({"source": "a", "scale": 0.0}, "scale must be non-zero"),
    ({"source": "a", "scale": float("nan")}, "scale must be a finite number"),
    ({"source": "a", "despike": -1.0}, "despike must be positive"),
    ({"source": ""}, "source must be a non-empty string"),
])
def test_column_validation(kwargs: dict, pattern: str) -> None:
    with pytest.raises(CustomModelError, match=pattern):
        Column(**kwargs)


def test_examples_load_with_their_maps() -> None:
    emps = load_model(f"{EXAMPLES / 'emps_model.py'}:EMPS")
    assert isinstance(emps, RigidAxisNominal)
    assert emps.params.mass == pytest.approx(95.1089)
    assert emps.channel_names == ("joint1",)
    assert emps.residual_units == ("N",) and emps.velocity_units == ("m/s",)
    cmap = emps.column_map.columns
    assert cmap["u"].source == "vir_V" and cmap["u"].scale == pytest.approx(35.15065188248547)
    assert "dq" not in cmap  # velocity is derived by the diagnosis
    car = load_model(f"{EXAMPLES / 'racecar_model.py'}:RACECAR")
    assert isinstance(car, BicycleNominal)
    p = car.params
    assert (p.m, p.lf, p.lr, p.C_af, p.C_ar) == (982.0, 1.33, 1.07, 0.7e5, 1.2e5)
    assert p.Iz == pytest.approx(1605.4, abs=0.05)
    assert car.column_map.columns["vx"].source == "vx_mps"
    assert car.column_map.columns["delta_r"].constant == 0.0


# --------------------------------------------------------------------------- reading
def test_read_mapped_scales_and_renames(model_file: Path, tmp_path: Path) -> None:
    model = load_model(f"{model_file}:AXIS")
    rec = read_mapped(write_csv(tmp_path / "rec.csv"), model)
    assert set(rec.columns) == {"t", "q", "u"}
    np.testing.assert_allclose(rec["u"], 3.0 * np.cos(rec.t))
    assert rec.meta["column_map"]["u"] == "3 × volts"


@pytest.mark.parametrize(("override", "pattern"), [
    ({"volts": "abc"}, r"rec\.csv: column 'volts' row 1 \(line 2\): non-numeric value 'abc'"),
    ({"pos": np.inf}, r"rec\.csv: column 'pos' row 1 \(line 2\): value .*inf.* is not finite"),
    ({"time": 1.0}, r"rec\.csv: column 'time' \(time\) row 2 \(line 3\): 1\.0 s is not after"),
])
def test_read_mapped_bad_values(model_file: Path, tmp_path: Path, override: dict,
                                pattern: str) -> None:
    model = load_model(f"{model_file}:AXIS")
    with pytest.raises(RecordingError, match=pattern):
        read_mapped(write_csv(tmp_path / "rec.csv", **override), model)


def test_read_mapped_missing_column_and_short_file(model_file: Path, tmp_path: Path) -> None:
    model = load_model(f"{model_file}:AXIS")
    path = tmp_path / "rec.csv"
    pd.DataFrame({"time": np.arange(100.0), "pos": 0.0}).to_csv(path, index=False)
    with pytest.raises(RecordingError, match=r"rec\.csv: missing column 'volts' \(the model's "
                                             r"column map reads time, pos, volts; found"):
        read_mapped(path, model)
    with pytest.raises(RecordingError, match=r"too few samples: 10 rows"):
        read_mapped(write_csv(path, n=10), model)
    with pytest.raises(RecordingError, match=r"file does not exist"):
        read_mapped(tmp_path / "absent.csv", model)


def test_despike_removes_isolated_glitches_not_steps() -> None:
    t = np.arange(100) * 0.01
    x = np.where(t >= 0.5, 0.1, 0.0) + 0.001 * np.sin(t)
    clean = x.copy()
    x[20] += 0.3      # isolated glitch
    x[70] -= 0.2      # another, after the step
    fixed, idx = despike(x, 0.05, t)
    assert list(idx) == [20, 70]
    np.testing.assert_allclose(fixed, clean, atol=2e-5)   # interpolation of a smooth signal
    # a genuine two-sample pulse and the step stay
    y = clean.copy()
    y[30:32] += 0.3
    fixed, idx = despike(y, 0.05, t)
    assert idx.size == 0 and np.array_equal(fixed, y)


def test_racecar_map_removes_exactly_the_four_glitches(tmp_path: Path) -> None:
    car = load_model(f"{EXAMPLES / 'racecar_model.py'}:RACECAR")
    n = 300
    t = 150.0 + 0.01 * np.arange(n)
    delta = 0.1 * np.sin(2 * np.pi * 0.5 * (t - t[0]))
    raw = delta.copy()
    raw[[40, 200]] = [0.478, -0.3]
    frame = pd.DataFrame({"t_s": t, "vx_mps": 30.0, "vy_mps": 0.1, "r_radps": 0.05,
                          "delta_rad": raw})
    path = tmp_path / "car.parquet"
    frame.to_parquet(path)
    rec = read_mapped(path, car)
    np.testing.assert_allclose(rec["delta_f"], delta, atol=1e-4)
    assert np.all(rec["delta_r"] == 0.0)
    assert any("2 isolated spike(s) in delta_rad" in note and "row 41" in note
               for note in rec.meta["notes"])


def test_column_map_of_builtin_is_identity() -> None:
    cmap = column_map_of(BicycleNominal())
    assert cmap.sources == ("t", "vx", "vy", "r", "delta_f", "delta_r")
    assert isinstance(cmap, ColumnMap)


# --------------------------------------------------------------------------- rigid axis
def test_rigid_axis_inverse_dynamics_and_residual() -> None:
    rng = np.random.default_rng(0)
    mass = 95.1089
    axis = RigidAxisNominal(RigidAxisParams(mass=mass))
    q, dq, ddq = rng.normal(size=(3, 50, 1))
    # a "true" axis with viscous + Coulomb friction: u = M ddq + b dq + Fc sign(dq)
    tau_d = 203.5 * dq + 20.4 * np.sign(dq)
    u = mass * ddq + tau_d
    np.testing.assert_allclose(u - axis.inverse_dynamics(q, dq, ddq), tau_d)
    assert axis.M(q).shape == (50, 1, 1) and axis.M(np.zeros(1)).shape == (1, 1)
    # state residual g = dx/dt - f in (q, p) coordinates maps back to tau_d
    x = axis.state(np.concatenate([q, dq], axis=1))
    dxdt = np.concatenate([dq, mass * ddq], axis=1)
    g = dxdt - axis.f(x, u)
    np.testing.assert_allclose(axis.physical_residual(x, g), tau_d, atol=1e-9)
    np.testing.assert_allclose(axis.observation(x), np.concatenate([q, dq], axis=1))


def test_rigid_axis_units_and_validation() -> None:
    rotor = RigidAxisNominal(RigidAxisParams(mass=0.01, joint="revolute"))
    assert rotor.state_units == ("rad", "kg·m²/s") and rotor.residual_units == ("N·m",)
    slider = RigidAxisNominal(RigidAxisParams(mass=1.0))
    assert slider.state_units == ("m", "kg·m/s") and slider.position_units == ("m",)
    with pytest.raises(ValueError, match="mass must be a finite positive"):
        RigidAxisParams(mass=0.0)
    with pytest.raises(ValueError, match="joint must be one of"):
        RigidAxisParams(mass=1.0, joint="spherical")
    with pytest.raises(ValueError, match="channel must be a non-empty string"):
        RigidAxisNominal(RigidAxisParams(mass=1.0), channel="")


# --------------------------------------------------------------------------- adapters
def test_units_follow_the_joint() -> None:
    assert translate_unit("N·m·s", "m", "N") == "N·s/m"
    assert translate_unit("N·m/rad", "m", "N") == "N/m"
    assert translate_unit("kg·m²", "m", "N") == "kg"
    assert translate_unit("rad/s", "m", "N") == "m/s"
    assert translate_unit("N·m·s", "rad", "N·m") == "N·m·s"   # revolute: unchanged
    assert translate_unit("-", "m", "N") == "-"


def test_make_system_uses_recorded_velocity_when_mapped() -> None:
    axis = with_columns(RigidAxisNominal(RigidAxisParams(mass=1.0), channel="slider"),
                        t="a", q="b", dq="c", u="d")
    system = make_system(axis)
    assert isinstance(system, MechanicalSystem)
    assert system.columns.dq == ("dq",) and system.channels == ("slider",)
    assert system.channel_units == ("N",) and system.state_units == ("m", "m/s")
    no_dq = make_system(with_columns(RigidAxisNominal(RigidAxisParams(mass=1.0)), t="a",
                                     q="b", u="d"))
    assert no_dq.columns.dq is None


def test_name_may_be_a_ready_adapter(tmp_path: Path) -> None:
    path = tmp_path / "adapter.py"
    path.write_text(
        "from simgap.diagnosis.systems import AdapterColumns, MechanicalSystem\n"
        "from simgap.models.prismatic import RigidAxisNominal, RigidAxisParams\n"
        "def SYSTEM():\n"
        "    return MechanicalSystem(RigidAxisNominal(RigidAxisParams(mass=2.0)),\n"
        "        columns=AdapterColumns(t='time', q=('pos',), u=('volts',), u_scale=(3.0,)))\n")
    system = load_model(f"{path}:SYSTEM")
    assert make_system(system) is system


# --------------------------------------------------------------------------- end to end
def _readme_example() -> str:
    text = (EXAMPLES / "README.md").read_text(encoding="utf-8")
    return text.split("```python\n", 1)[1].split("```", 1)[0]


def _simulate_axis(path: Path, *, mass: float, b: float, fc: float, seed: int) -> None:
    """A 12 kg carriage with viscous + Coulomb friction, driven by a logged motor current."""
    rng = np.random.default_rng(seed)
    dt, n = 1e-3, 20_000
    t = np.arange(n) * dt
    amps = rng.uniform(20.0, 40.0, 3)
    freqs = rng.uniform(0.2, 1.5, 3)
    phases = rng.uniform(0, 2 * np.pi, 3)
    force = sum(a * np.sin(2 * np.pi * f * t + p) for a, f, p in zip(amps, freqs, phases,
                                                                      strict=True))
    q = np.zeros(n)
    v = np.zeros(n)
    sub = 10   # semi-implicit Euler sub-steps within each 1 ms sample (force held)
    for k in range(n - 1):
        qk, vk = q[k], v[k]
        for _ in range(sub):
            acc = (force[k] - b * vk - fc * np.tanh(vk / 1e-3)) / mass
            vk += acc * dt / sub
            qk += vk * dt / sub
        q[k + 1], v[k + 1] = qk, vk
    frame = pd.DataFrame({
        "time_ms": t * 1e3,
        "pos_mm": q * 1e3 + rng.normal(0.0, 1e-4, n),     # 0.1 µm encoder noise
        "current_A": force / 48.0 + rng.normal(0.0, 1e-3, n),
    })
    frame.to_csv(path, index=False)


def test_readme_one_dof_example_finds_the_hidden_friction(tmp_path: Path) -> None:
    model_file = tmp_path / "my_axis.py"
    model_file.write_text(_readme_example(), encoding="utf-8")
    log = tmp_path / "axis_log.csv"
    _simulate_axis(log, mass=12.0, b=30.0, fc=5.0, seed=3)
    report = diagnose(log, f"{model_file}:AXIS")
    eff = {e["effect"]: e for e in report.data["effects"]}
    assert {"viscous_friction", "coulomb_friction"} <= set(eff)
    assert eff["viscous_friction"]["channel"] == "x_axis"
    assert eff["viscous_friction"]["parameters"]["b"] == pytest.approx(30.0, rel=0.2)
    assert eff["viscous_friction"]["units"]["b"] == "N·s/m"
    assert eff["coulomb_friction"]["parameters"]["Fc"] == pytest.approx(5.0, rel=0.2)
    assert report.data["processing"]["column_map"]["t"] == "0.001 × time_ms"


@settings(max_examples=40, deadline=None)
@given(steps=st.lists(st.floats(-0.02, 0.02), min_size=5, max_size=60),
       spike=st.floats(0.2, 1.0), where=st.integers(2, 50))
def test_despike_property(steps: list[float], spike: float, where: int) -> None:
    """Signals moving by at most half the threshold per sample are never touched; one
    isolated spike well above the threshold is always removed, and only it."""
    x = np.cumsum(steps)
    fixed, idx = despike(x, 0.05)
    assert idx.size == 0 and np.array_equal(fixed, x)
    i = min(where, x.size - 2)
    y = x.copy()
    y[i] += spike
    fixed, idx = despike(y, 0.05)
    assert list(idx) == [i]
    assert abs(fixed[i] - x[i]) <= 0.02 + 1e-12


@pytest.mark.parametrize("case", ["missing_column", "params", "bad_name", "not_a_model"])
def test_cli_bad_input_exit_2(model_file: Path, tmp_path: Path, case: str) -> None:
    from typer.testing import CliRunner

    from simgap.cli import app

    rec = write_csv(tmp_path / "rec.csv")
    spec = f"{model_file}:AXIS"
    extra: list[str] = []
    expect = ""
    if case == "missing_column":
        pd.read_csv(rec).drop(columns="volts").to_csv(rec, index=False)
        expect = "rec.csv: missing column 'volts'"
    elif case == "params":
        (tmp_path / "p.json").write_text('{"mass": 3}')
        extra = ["--params", str(tmp_path / "p.json")]
        expect = "--params applies to built-in models only"
    elif case == "bad_name":
        spec = f"{model_file}:AXES"
        expect = "no attribute 'AXES'"
    else:
        spec = f"{model_file}:NOT_A_MODEL"
        expect = "not a nominal model"
    out = tmp_path / "report"
    result = CliRunner().invoke(app, ["diagnose", str(rec), "--model", spec, "--out",
                                      str(out), *extra])
    assert result.exit_code == 2
    assert result.output.startswith("error: ") and result.output.count("\n") == 1
    assert expect in result.output
    assert not out.exists() and not any(p.name.startswith(".report") for p in
                                        tmp_path.iterdir())
