"""Execute every jupytext notebook in notebooks/ (percent format) in quick mode.

Notebooks hold no logic of their own; they call the library. Each is converted with jupytext
and run with nbclient in a fresh kernel of this interpreter, with ``SIMGAP_QUICK=1`` so that
they use their short variants. A failing cell fails the test with the cell's error.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from tests.conftest import REPO_ROOT

NOTEBOOKS = sorted((REPO_ROOT / "notebooks").glob("*.py"))


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebook_runs(path: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    jupytext = pytest.importorskip("jupytext")
    nbclient = pytest.importorskip("nbclient")
    nb = jupytext.read(path)
    nb.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3",
                                 "language": "python"}
    monkeypatch.setenv("SIMGAP_QUICK", "1")
    monkeypatch.setenv("MPLBACKEND", "Agg")
    monkeypatch.setenv("SIMGAP_NOTEBOOK_OUT", str(tmp_path))
    client = nbclient.NotebookClient(nb, timeout=300, kernel_name="python3",
                                     resources={"metadata": {"path": str(REPO_ROOT)}})
    client.execute(env=dict(os.environ))
