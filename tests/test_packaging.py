"""The package as a user gets it: version, CLI entry points, and a wheel that holds LICENSE and
py.typed and installs into a fresh venv where ``simgap --version`` works.

The quick variant builds the wheel without build isolation (the build tools of this venv)
and installs it with ``--no-deps`` into a fresh venv whose dependencies come from this venv
through a ``.pth`` path line (so the fresh venv's simgap is the wheel's, not the editable
one). ``SIMGAP_SLOW=1`` also installs the wheel with its dependencies from the package index
into a fresh venv and runs the README quickstart there.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import sysconfig
import venv
import zipfile
from pathlib import Path

import pytest

import simgap
from tests.conftest import REPO_ROOT


def _run(args: list[str], **kw) -> subprocess.CompletedProcess:
    return subprocess.run(args, capture_output=True, text=True, timeout=600, **kw)


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("wheel")
    res = _run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation",
                "-q", "-w", str(out), str(REPO_ROOT)])
    assert res.returncode == 0, res.stderr[-2000:]
    (path,) = out.glob("simgap-*.whl")
    return path


def test_version_from_metadata() -> None:
    from importlib.metadata import version

    assert simgap.__version__ == version("simgap")
    assert re.fullmatch(r"\d+\.\d+\.\d+.*", simgap.__version__)


def test_cli_version_and_short_help() -> None:
    from typer.testing import CliRunner

    from simgap.cli import app

    runner = CliRunner()
    res = runner.invoke(app, ["--version"])
    assert res.exit_code == 0 and res.output.strip() == f"simgap {simgap.__version__}"
    for args in (["-h"], ["diagnose", "-h"], ["record", "-h"]):
        res = runner.invoke(app, args)
        assert res.exit_code == 0 and "Usage" in res.output, (args, res.output)


def test_wheel_holds_license_and_py_typed(wheel: Path) -> None:
    names = zipfile.ZipFile(wheel).namelist()
    assert "simgap/py.typed" in names
    assert any(re.fullmatch(r"simgap-[^/]+\.dist-info/licenses/LICENSE", n) for n in names), \
        names
    meta = next(n for n in names if n.endswith(".dist-info/METADATA"))
    text = zipfile.ZipFile(wheel).read(meta).decode()
    assert "License-Expression: MIT" in text


def test_wheel_installs_into_fresh_venv(wheel: Path, tmp_path: Path) -> None:
    env_dir = tmp_path / "fresh"
    venv.EnvBuilder(with_pip=False).create(env_dir)
    fresh_py = env_dir / "bin" / "python"
    site = _run([str(fresh_py), "-c", "import sysconfig; print(sysconfig.get_path('purelib'))"]
                ).stdout.strip()
    # dependencies from this venv, after the fresh venv's own site-packages
    (Path(site) / "deps.pth").write_text(sysconfig.get_path("purelib") + "\n")
    res = _run([sys.executable, "-m", "pip", "--python", str(fresh_py), "install", "--no-deps",
                "-q", str(wheel)])
    assert res.returncode == 0, res.stderr[-2000:]
    res = _run([str(env_dir / "bin" / "simgap"), "--version"], cwd=tmp_path)
    assert res.returncode == 0, res.stderr[-2000:]
    assert res.stdout.strip() == f"simgap {simgap.__version__}"
    where = _run([str(fresh_py), "-c", "import simgap; print(simgap.__file__)"], cwd=tmp_path)
    assert where.stdout.strip().startswith(site), where.stdout  # the wheel's copy, not ours


@pytest.mark.slow
def test_wheel_with_dependencies_runs_readme_quickstart(wheel: Path, tmp_path: Path) -> None:
    env_dir = tmp_path / "fresh"
    venv.EnvBuilder(with_pip=True).create(env_dir)
    py = env_dir / "bin" / "python"
    res = _run([str(py), "-m", "pip", "install", "-q", str(wheel)])
    assert res.returncode == 0, res.stderr[-2000:]
    assert _run([str(env_dir / "bin" / "simgap"), "--version"]).returncode == 0
    text = (REPO_ROOT / "README.md").read_text(encoding="utf-8")
    first = re.findall(r"```python\n(.*?)```", text, flags=re.S)[0]
    script = tmp_path / "quickstart.py"
    script.write_text(first)
    res = _run([str(py), str(script)], cwd=tmp_path, env={**os.environ, "MPLBACKEND": "Agg"})
    assert res.returncode == 0, res.stderr[-2000:]
