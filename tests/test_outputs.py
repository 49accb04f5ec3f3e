"""Transactional output (issue 15, data loss): every writer refuses to touch the user's files.

The three repros of the issue (``--out`` the recording's own folder, ``--out`` the input
file, ``--out`` an existing regular file) and the same rule for ``record``, ``reproduce``,
``demo`` and :mod:`simgap.outputs` itself.
"""

from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

from simgap.cli import app
from simgap.errors import OutputError
from simgap.outputs import MARKER, is_previous_output, output_files, output_folder
from tests.fuzz import snapshot

runner = CliRunner()


@pytest.fixture(scope="module")
def arm(tmp_path_factory):
    """``simgap record arm.csv --duration 6 --effect coulomb_friction:joint2:Fc=0.3 --seed 1``."""
    d = tmp_path_factory.mktemp("rec")
    res = runner.invoke(app, ["record", str(d / "arm.csv"), "--duration", "6", "--effect",
                              "coulomb_friction:joint2:Fc=0.3", "--seed", "1"])
    assert res.exit_code == 0, res.output
    return (d / "arm.csv").read_bytes()


def _one_line_exit_2(res, *words):
    assert res.exit_code == 2, (res.output, res.exception)
    lines = [ln for ln in res.output.strip().splitlines() if ln]
    assert len(lines) == 1, res.output
    for w in words:
        assert w in lines[0], lines[0]


def test_out_is_the_recordings_own_folder(arm, tmp_path):
    data = tmp_path / "data"
    data.mkdir()
    (data / "arm.csv").write_bytes(arm)
    (data / "notes.txt").write_text("x\n")
    before = snapshot(tmp_path)
    res = runner.invoke(app, ["diagnose", str(data / "arm.csv"), "--model", "manipulator2dof",
                              "--out", str(data)])
    _one_line_exit_2(res, "holds the input file")
    assert snapshot(tmp_path) == before


def test_out_equal_to_the_input_file(arm, tmp_path):
    (tmp_path / "arm.csv").write_bytes(arm)
    before = snapshot(tmp_path)
    res = runner.invoke(app, ["diagnose", str(tmp_path / "arm.csv"), "--model",
                              "manipulator2dof", "--out", str(tmp_path / "arm.csv")])
    _one_line_exit_2(res, "is the input file")
    assert snapshot(tmp_path) == before


def test_out_an_existing_regular_file(arm, tmp_path):
    (tmp_path / "arm.csv").write_bytes(arm)
    (tmp_path / "out").write_text("mine\n")
    before = snapshot(tmp_path)
    res = runner.invoke(app, ["diagnose", str(tmp_path / "arm.csv"), "--model",
                              "manipulator2dof", "--out", str(tmp_path / "out")])
    _one_line_exit_2(res, "is not a folder")
    assert snapshot(tmp_path) == before


def test_out_dot_is_one_line_not_a_traceback(arm, tmp_path, monkeypatch):
    (tmp_path / "arm.csv").write_bytes(arm)
    monkeypatch.chdir(tmp_path)
    before = snapshot(tmp_path)
    res = runner.invoke(app, ["diagnose", "arm.csv", "--model", "manipulator2dof",
                              "--out", "."])
    _one_line_exit_2(res, "holds the input file")
    assert snapshot(tmp_path) == before


def test_previous_report_is_replaced_but_not_one_with_user_files(arm, tmp_path):
    (tmp_path / "arm.csv").write_bytes(arm)
    args = ["diagnose", str(tmp_path / "arm.csv"), "--model", "manipulator2dof", "--out",
            str(tmp_path / "rep"), "--no-figures"]
    res = runner.invoke(app, args)
    assert res.exit_code == 0, res.output
    assert is_previous_output(tmp_path / "rep")
    marker = json.loads((tmp_path / "rep" / MARKER).read_text())
    assert "report.json" in marker["files"] and marker["kind"] == "diagnose"
    res = runner.invoke(app, args)  # a previous report: replaced
    assert res.exit_code == 0, res.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["arm.csv", "rep"]
    (tmp_path / "rep" / "my_notes.md").write_text("keep")
    before = snapshot(tmp_path)
    res = runner.invoke(app, args)
    _one_line_exit_2(res, "not a previous simgap output")
    assert snapshot(tmp_path) == before


def test_record_never_overwrites(tmp_path):
    (tmp_path / "a.csv").write_text("precious\n")
    before = snapshot(tmp_path)
    res = runner.invoke(app, ["record", str(tmp_path / "a.csv"), "--duration", "1"])
    _one_line_exit_2(res, "exists")
    (tmp_path / "b.csv.truth.json").write_text("{}")
    before = snapshot(tmp_path)
    res = runner.invoke(app, ["record", str(tmp_path / "b.csv"), "--duration", "1"])
    _one_line_exit_2(res, "b.csv.truth.json")
    assert snapshot(tmp_path) == before


def test_reproduce_and_demo_refuse_a_folder_with_user_files(tmp_path):
    (tmp_path / "keep.txt").write_text("keep")
    before = snapshot(tmp_path)
    res = runner.invoke(app, ["reproduce", "--case", "2-1", "--quick", "--out", str(tmp_path)])
    assert res.exit_code == 2 and "not a previous simgap output" in res.output
    res = runner.invoke(app, ["demo", "--out", str(tmp_path)])
    _one_line_exit_2(res, "not a previous simgap output")
    assert snapshot(tmp_path) == before


@pytest.mark.parametrize("args", [["reproduce", "--case", "2-1", "--quick"],
                                  ["reproduce", "--seeds", "0", "--case", "2-1", "--quick"],
                                  ["demo"], ["diagnose", "{out}/missing.csv", "--model",
                                             "bicycle"]])
def test_cli_errors_are_one_line_at_any_terminal_width(tmp_path, args):
    """A long error (a long --out path) is one stderr line on a 40-column terminal: never
    wrapped by a rich console, no blank or progress-bar lines around it."""
    out = tmp_path / ("a-rather-long-folder-name-" * 4)
    out.mkdir()
    (out / "keep.txt").write_text("keep")
    before = snapshot(tmp_path)
    res = runner.invoke(app, [a.format(out=out) for a in args] + ["--out", str(out)],
                        env={"COLUMNS": "40"})
    assert res.exit_code == 2, (res.output, res.exception)
    assert res.stdout == ""
    lines = res.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), res.stderr
    assert len(lines[0]) > 120  # long enough that a 40-column console would wrap it
    assert snapshot(tmp_path) == before


def test_error_line_joins_every_line():
    from simgap._log import error_line

    assert error_line("a:\n  b  c\n") == "error: a: b c"
    assert error_line("") == "error: bad input"


def test_output_folder_leaves_nothing_on_failure(tmp_path):
    with pytest.raises(RuntimeError), output_folder(tmp_path / "r", kind="test") as tmp:
        (tmp / "half.txt").write_text("x")
        raise RuntimeError("boom")
    assert list(tmp_path.iterdir()) == []


def test_output_folder_into_empty_existing_folder_and_nested(tmp_path):
    (tmp_path / "r").mkdir()
    with output_folder(tmp_path / "r", kind="outer") as tmp:
        (tmp / "a.txt").write_text("a")
        with output_folder(tmp / "sub", kind="inner") as inner:
            (inner / "b.txt").write_text("b")
    assert (tmp_path / "r" / "sub" / "b.txt").read_text() == "b"
    assert is_previous_output(tmp_path / "r") and is_previous_output(tmp_path / "r" / "sub")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r"]
    # a symlink target, the file-system root, a folder under a file: refused
    (tmp_path / "link").symlink_to(tmp_path / "r")
    (tmp_path / "f").write_text("f")
    for bad in (tmp_path / "link", "/", tmp_path / "f" / "sub"):
        with pytest.raises(OutputError), output_folder(bad, kind="t"):
            pass
    assert (tmp_path / "f").read_text() == "f"


def test_output_files_rolls_back_and_never_replaces(tmp_path):
    with pytest.raises(RuntimeError), output_files([tmp_path / "x.csv"]) as (t,):
        t.write_text("half")
        raise RuntimeError("boom")
    assert list(tmp_path.iterdir()) == []
    with output_files([tmp_path / "x.csv", tmp_path / "x.json"]) as (a, b):
        a.write_text("1")
        b.write_text("2")
    assert (tmp_path / "x.csv").read_text() == "1"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.csv", "x.json"]
    with pytest.raises(OutputError, match="exists"), output_files([tmp_path / "x.csv"]):
        pass
    # a file that appears while writing is left alone
    with pytest.raises(OutputError, match="appeared"), \
            output_files([tmp_path / "y.csv"]) as (t,):
        t.write_text("new")
        (tmp_path / "y.csv").write_text("theirs")
    assert (tmp_path / "y.csv").read_text() == "theirs"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.csv", "x.json", "y.csv"]


# -- the API's writers: nothing of the user's is overwritten without overwrite=True -------
_MPC_RES = {"variants": {"nominal": {
    "trace": {"t": [0.0, 0.1], "r": [0.0, 0.1], "r_ref": [0.0, 0.2]},
    "rmse_rad_s": 0.05, "compute_s": {"p50": 1e-3}}}}


def _writers(tmp_path):
    """(name, suffix, write(path, **kw)) for every file writer of the package's API."""
    import numpy as np
    from matplotlib.figure import Figure

    from simgap._plotting import save_figure
    from simgap.control.figures import mpc_figure
    from simgap.demo import write_index
    from simgap.diagnosis.augmented import AugmentedManipulator, save_model
    from simgap.identifiers import BatchIdentifier, make_identifier
    from simgap.recordings import write_recording

    ident = make_identifier("integral", 4, 2, 0.002, seed=0)
    batch = BatchIdentifier("integral", 2, 4, 2, 0.002)
    model = AugmentedManipulator([])
    rec = {"t": np.arange(3) * 0.1, "q1": np.ones(3)}
    return [
        ("write_recording", ".csv", lambda p, **kw: write_recording(p, rec, **kw)),
        ("write_recording", ".parquet", lambda p, **kw: write_recording(p, rec, **kw)),
        ("Identifier.save", ".npz", lambda p, **kw: ident.save(p, **kw)),
        ("BatchIdentifier.save", ".npz", lambda p, **kw: batch.save(p, **kw)),
        ("save_model", ".json", lambda p, **kw: save_model(model, p, **kw)),
        ("write_index", ".html", lambda p, **kw: write_index(p.parent, [], **kw)),
        # every figure function (control/, evaluation/) saves through save_figure
        ("save_figure", ".png", lambda p, **kw: save_figure(Figure(), p, dpi=20, **kw)),
        ("mpc_figure", ".png", lambda p, **kw: mpc_figure(_MPC_RES, p, **kw)),
    ]


def test_api_writers_never_overwrite_without_opt_in(tmp_path):
    for k, (name, suffix, write) in enumerate(_writers(tmp_path)):
        folder = tmp_path / f"w{k}"
        folder.mkdir()
        target = folder / ("index.html" if name == "write_index" else f"out{suffix}")
        target.write_bytes(b"the user's precious file")
        before = snapshot(folder)
        with pytest.raises(OutputError, match=r"exists.*overwrite=True") as err:
            write(target)
        assert str(target) in str(err.value) and "\n" not in str(err.value), name
        assert snapshot(folder) == before, name  # untouched, no temporary left behind
        write(target, overwrite=True)  # the explicit opt-in replaces it, atomically
        assert target.read_bytes() != b"the user's precious file", name
        assert sorted(p.name for p in folder.iterdir()) == [target.name], name
        # a folder of that name is never replaced, even with the opt-in
        (folder / "sub").mkdir()
        sub = folder / "sub" / target.name
        sub.mkdir()
        with pytest.raises(OutputError, match="folder of that name"):
            write(sub, overwrite=True)


def test_api_writer_failing_midway_leaves_nothing(tmp_path, monkeypatch):
    """A write that fails half-way leaves neither a partial file nor a temporary one."""
    import pandas as pd

    from simgap.recordings import write_recording

    def boom(self, path, *a, **k):
        with open(path, "w") as fh:
            fh.write("t,q1\n0.0,")
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(pd.DataFrame, "to_csv", boom)
    with pytest.raises(OutputError, match="new.csv.*No space left"):
        write_recording(tmp_path / "new.csv", {"t": [0.0, 1.0]})
    (tmp_path / "old.csv").write_text("old")
    with pytest.raises(OutputError, match="old.csv"):
        write_recording(tmp_path / "old.csv", {"t": [0.0, 1.0]}, overwrite=True)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["old.csv"]
    assert (tmp_path / "old.csv").read_text() == "old"
    with pytest.raises(OutputError, match="does not exist"):
        write_recording(tmp_path / "missing" / "a.csv", {"t": [0.0]})
