"""Command-line polish: --list-effects, plain progress lines, one output-folder scheme, and
arguments checked before the numerical modules are imported."""

from __future__ import annotations

import io
import re
import subprocess
import sys
import time

from typer.testing import CliRunner

from simgap._cli_paths import DEMO_OUT, REPORT_ROOT, REPRODUCE_OUT
from simgap._log import line, progress_lines, stage
from simgap.cli import app
from simgap.diagnosis.catalog import injectable_effects
from simgap.diagnosis.generate import BICYCLE_EFFECTS, MANIPULATOR_EFFECTS

runner = CliRunner()
PLAIN = re.compile(r"^\[\d\d:\d\d:\d\d\] .*\S$")


def test_list_effects_matches_the_generator_table() -> None:
    for model, table in (("manipulator2dof", MANIPULATOR_EFFECTS),
                         ("bicycle", BICYCLE_EFFECTS)):
        res = runner.invoke(app, ["record", "--list-effects", "--model", model])
        assert res.exit_code == 0, res.output
        rows = {ln.split()[0]: ln for ln in res.output.splitlines()[2:]}
        assert set(rows) == set(table)
        for info in injectable_effects(model):
            assert all(f"{p.name} ({p.unit}" in rows[info.name] for p in info.params)
            assert all(p.unit != "?" for p in info.params), info
    spring = next(e for e in injectable_effects("manipulator2dof") if e.name == "spring")
    assert [(p.name, p.default) for p in spring.params] == [("k", None), ("q0", 0.0)]
    res = runner.invoke(app, ["record", "--list-effects", "--model", "tank"])
    assert res.exit_code == 2 and "unknown model 'tank'" in res.output


def test_record_without_output_is_one_line_exit_2() -> None:
    res = runner.invoke(app, ["record"])
    assert res.exit_code == 2 and len(res.output.strip().splitlines()) == 1


def test_progress_lines_are_plain() -> None:
    assert PLAIN.match(line("wrote x.png"))
    buf = io.StringIO()
    with stage("quick step", after=5.0, stream=buf):
        pass
    assert buf.getvalue() == ""  # a quick step stays silent
    buf = io.StringIO()
    with stage("slow step", after=0.05, every=0.05, stream=buf):
        time.sleep(0.3)
    out = buf.getvalue().splitlines()
    assert len(out) >= 3 and all(PLAIN.match(s) for s in out), out
    assert "still slow step" in out[1] and re.search(r"done in \d+\.\d s$", out[-1])
    assert not any("\x1b" in s or ".py:" in s for s in out)  # no colour codes, no source


def test_one_output_folder_scheme() -> None:
    assert DEMO_OUT == REPORT_ROOT / "demo" and REPRODUCE_OUT == REPORT_ROOT / "reproduce"
    from simgap.diagnosis.pipeline import default_out_dir

    assert default_out_dir("runs/arm.csv") == REPORT_ROOT / "arm"
    for cmd in ("demo", "reproduce"):
        res = runner.invoke(app, [cmd, "-h"])
        assert "simgap-report" in res.output, cmd


def _run_cli(argv: list[str]) -> subprocess.CompletedProcess:
    code = ("import sys\nfrom simgap.cli import main\n"
            f"sys.argv = ['simgap', *{argv!r}]\n"
            "try:\n    main()\nexcept SystemExit as e:\n    code = e.code\n"
            "heavy = ('matplotlib', 'scipy.signal')\n"
            "print(code, *(m in sys.modules for m in heavy))\n")
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120)


def test_bad_arguments_fail_before_heavy_imports(tmp_path) -> None:
    # matplotlib and scipy.signal are the seconds-long imports. numba is imported by
    # ``import simgap`` itself (the system registry loads the models' kernels).
    res = _run_cli(["diagnose", str(tmp_path / "none.csv"), "--model", "bicycle"])
    assert res.stdout.split() == ["2", "False", "False"], (res.stdout, res.stderr)
    assert "none.csv: file does not exist" in res.stderr
    res = _run_cli(["record", str(tmp_path / "x.txt")])
    assert res.stdout.split() == ["2", "False", "False"], (res.stdout, res.stderr)
    assert "unknown file type" in res.stderr
    # The model name is looked up in the system registry, which imports the models: one
    # line and exit 2, after the cheap path checks.
    res = _run_cli(["record", str(tmp_path / "x.csv"), "--model", "tank"])
    assert res.stdout.split()[0] == "2", (res.stdout, res.stderr)
    assert "unknown model 'tank'" in res.stderr and "manipulator2dof" in res.stderr


def test_progress_lines_are_throttled() -> None:
    buf = io.StringIO()
    progress = progress_lines(every=3600.0, stream=buf)
    for k in range(1, 101):
        progress("case 1, baseline 1", k, 100)
    out = buf.getvalue().splitlines()
    assert len(out) == 2 and "1/100" in out[0] and "100/100 (100 %)" in out[1], out
    assert all(PLAIN.match(s) for s in out)


def test_bad_reproduce_case_fails_before_heavy_imports() -> None:
    res = _run_cli(["reproduce", "--case", "3", "--out", "/nonexistent/never-written"])
    assert res.stdout.split() == ["2", "False", "False"], (res.stdout, res.stderr)
    assert "--case must be one of" in res.stderr and len(res.stderr.strip().splitlines()) == 1
