"""`simgap diagnose LOG --model arm.xml` on recordings that MuJoCo itself made."""

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

mujoco = pytest.importorskip("mujoco")

from typer.testing import CliRunner  # noqa: E402

from simgap.cli import app  # noqa: E402
from simgap.diagnosis.mjcf_record import record_mjcf  # noqa: E402
from simgap.diagnosis.mjcf_writer import compile_text, holdout_rmse  # noqa: E402

ARM = Path(__file__).resolve().parents[2] / "examples" / "mujoco" / "arm2dof.xml"
DURATION = 5.0


def _real(**joint_attrs: str) -> str:
    xml = ARM.read_text()
    for joint, attrs in joint_attrs.items():
        old = f'name="{joint}" type="hinge" axis="0 0 1"'
        xml = xml.replace(old, f"{old} {attrs}", 1)
    return xml


def _log(tmp_path: Path, xml: str, name: str, seed: int = 3) -> Path:
    cols = record_mjcf(mujoco.MjModel.from_xml_string(xml), duration=DURATION, seed=seed)
    path = tmp_path / name
    pd.DataFrame(cols).to_csv(path, index=False)
    return path


@pytest.fixture(scope="module")
def hidden(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("mjcf")
    real = _real(shoulder='frictionloss="0.4"', elbow='damping="0.25"')
    log = _log(tmp, real, "arm_log.csv")
    out = tmp / "report"
    res = CliRunner().invoke(app, ["diagnose", str(log), "--model", str(ARM), "--out", str(out),
                                   "--no-figures"])
    assert res.exit_code == 0, res.output
    return real, log, out, res.output


def test_hidden_damping_and_frictionloss_are_named_at_their_joints(hidden):
    _, _, out, output = hidden
    data = json.loads((out / "report.json").read_text())
    named = {(e["effect"], e["channel"]): e["parameters"] for e in data["effects"]}
    assert set(named) == {("coulomb_friction", "shoulder"), ("viscous_friction", "elbow")}
    assert named[("coulomb_friction", "shoulder")]["Fc"] == pytest.approx(0.4, rel=0.03)
    assert named[("viscous_friction", "elbow")]["b"] == pytest.approx(0.25, rel=0.03)
    assert "corrected MJCF" in output


def test_corrected_mjcf_loads_and_predicts_the_held_out_part_better(hidden):
    real, log, out, _ = hidden
    text = (out / "augmented_model.xml").read_text()
    assert text.count("<!-- simgap:") == 2
    corrected = compile_text(text, ARM)
    assert corrected.dof_frictionloss[0] == pytest.approx(0.4, rel=0.03)
    assert corrected.dof_damping[1] == pytest.approx(0.25, rel=0.03)
    data = json.loads((out / "report.json").read_text())
    rmse = data["mjcf"]["holdout_position_rmse"]
    assert np.all(np.array(rmse["corrected"]) < 0.2 * np.array(rmse["original"]))
    # an independent check on the raw log, with MuJoCo's own simulation of both files
    cols = {k: v.to_numpy() for k, v in pd.read_csv(log).items()}
    t_split = data["fit"]["split"]["test"][0]
    assert np.all(holdout_rmse(corrected, cols, t_split) < holdout_rmse(ARM, cols, t_split))


def test_clean_pair_names_nothing(tmp_path):
    log = _log(tmp_path, ARM.read_text(), "clean.csv", seed=4)
    out = tmp_path / "report"
    res = CliRunner().invoke(app, ["diagnose", str(log), "--model", str(ARM), "--out", str(out),
                                   "--no-figures"])
    assert res.exit_code == 0, res.output
    data = json.loads((out / "report.json").read_text())
    assert data["effects"] == []
    assert (out / "augmented_model.xml").is_file()


def test_column_map_and_bad_input(tmp_path):
    log = _log(tmp_path, ARM.read_text(), "renamed.csv", seed=5)
    frame = pd.read_csv(log).rename(columns={"t": "time_ms", "tau_elbow": "cmd2"})
    frame["time_ms"] *= 1e3
    frame.to_csv(log, index=False)
    cmap = tmp_path / "map.json"
    cmap.write_text(json.dumps({"t": {"source": "time_ms", "scale": 1e-3},
                                "tau_elbow": "cmd2"}))
    runner = CliRunner()
    res = runner.invoke(app, ["diagnose", str(log), "--model", str(ARM), "--out",
                              str(tmp_path / "r"), "--no-figures"])
    assert res.exit_code == 2 and "renamed.csv: no column 't'" in res.output
    res = runner.invoke(app, ["diagnose", str(log), "--model", str(ARM), "--columns", str(cmap),
                              "--out", str(tmp_path / "r"), "--no-figures"])
    assert res.exit_code == 0, res.output
    res = runner.invoke(app, ["diagnose", str(log), "--model", str(tmp_path / "nope.xml")])
    assert res.exit_code == 2 and "nope.xml: MJCF file not found" in res.output


def test_proof_benchmark_quick_variant():
    import subprocess
    import sys

    root = Path(__file__).resolve().parents[2]
    proc = subprocess.run([sys.executable, str(root / "benchmarks" / "mujoco_proof.py"),
                           "--quick"], capture_output=True, text=True, timeout=600, cwd=root)
    assert proc.returncode == 0, proc.stderr[-2000:]
    res = json.loads(proc.stdout)
    rows = res["systems"]["arm2dof"]
    assert [r["case"] for r in rows] == ["clean", "damping", "delay"]
    for row in rows:
        assert row["correct"], row
        assert row["corrected_better"], row
    assert rows[1]["relative_error"] < 0.02 and rows[2]["relative_error"] < 0.15
