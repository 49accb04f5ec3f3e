"""Execute every jupytext notebook in notebooks/ (percent format) in quick mode, as Jupyter does.

Notebooks hold no logic of their own; they call the library. Each is converted with jupytext
and run with nbclient in a fresh kernel of this interpreter, with its own folder as the
working directory (as Jupyter runs it), ``SIMGAP_QUICK=1`` so that it uses its short variant,
and the kernel's own (inline) matplotlib backend. A failing cell fails the test with the
cell's error; a notebook that draws must show its figures inline (``image/png`` outputs), and
no cell may print a figure's text form (``<Figure size ...>``) instead.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from tests.conftest import REPO_ROOT

NOTEBOOKS = sorted((REPO_ROOT / "notebooks").glob("*.py"))
#: Notebooks that only print (no figure expected).
TEXT_ONLY = {"00_quickstart"}


def _outputs(nb) -> list[dict]:
    return [o for cell in nb.cells if cell.cell_type == "code" for o in cell.get("outputs", [])]


def test_every_notebook_has_a_jupytext_header() -> None:
    for path in NOTEBOOKS:
        head = path.read_text(encoding="utf-8").splitlines()[:12]
        assert head[0] == "# ---" and "#   jupytext:" in head and "#   kernelspec:" in head, path


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebook_runs(path: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    jupytext = pytest.importorskip("jupytext")
    nbclient = pytest.importorskip("nbclient")
    nb = jupytext.read(path)
    monkeypatch.setenv("SIMGAP_QUICK", "1")
    monkeypatch.delenv("MPLBACKEND", raising=False)  # the kernel's inline backend, as in Jupyter
    monkeypatch.setenv("SIMGAP_NOTEBOOK_OUT", str(tmp_path))
    client = nbclient.NotebookClient(nb, timeout=300, kernel_name="python3",
                                     resources={"metadata": {"path": str(path.parent)}})
    client.execute(env=dict(os.environ))
    outputs = _outputs(nb)
    # a figure's text form alone (no image beside it) means it was not rendered inline
    texts = [o.get("data", {}).get("text/plain", "") or o.get("text", "") for o in outputs
             if "image/png" not in o.get("data", {})]
    assert not [t for t in texts if "<Figure size" in t], f"{path.name}: a figure printed as text"
    if path.stem not in TEXT_ONLY:
        images = [o for o in outputs if "image/png" in o.get("data", {})]
        assert images, f"{path.name}: no figure shown inline"
