"""The documentation site builds with warnings as errors, and the diagnosis contract page is
the project's spec, word for word."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from tests.conftest import REPO_ROOT, shared_path

CONTRACT = REPO_ROOT / "docs" / "diagnosis-contract.md"


def test_contract_page_is_the_spec() -> None:
    spec = shared_path("spec", "diagnosis.md").read_text(encoding="utf-8")
    page = CONTRACT.read_text(encoding="utf-8")
    head, sep, body = page.partition("# `simgap diagnose`: contract")
    assert sep, "docs/diagnosis-contract.md lost the spec's title"
    assert sep + body == spec, ("docs/diagnosis-contract.md differs from spec/diagnosis.md: "
                                "copy the spec into the page below its note")
    assert "Copied verbatim" in head


def test_docs_build_strict(tmp_path) -> None:
    pytest.importorskip("mkdocs")
    pytest.importorskip("mkdocstrings")
    res = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--quiet",
                          "-f", str(REPO_ROOT / "mkdocs.yml"), "-d", str(tmp_path / "site")],
                         cwd=REPO_ROOT, capture_output=True, text=True, timeout=300,
                         env={**os.environ, "NO_MKDOCS_2_WARNING": "1"})
    assert res.returncode == 0, res.stderr[-3000:]
    site = tmp_path / "site"
    for page in ("index.html", "getting-started.html", "envs.html", "identifiers.html",
                 "diagnosis-contract.html", "performance.html", "gallery.html",
                 "api/wrappers.html"):
        assert (site / page).is_file(), page
    api = (site / "api" / "wrappers.html").read_text(encoding="utf-8")
    assert "IdentifierWrapper" in api and "ResidualObservation" in api  # rendered docstrings
