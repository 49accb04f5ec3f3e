"""Shared test fixtures: the read-only ``../shared`` folder and the slow-test switch."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

REPO_ROOT = Path(__file__).resolve().parents[1]
SHARED = REPO_ROOT.parent / "shared"


def shared_path(*parts: str) -> Path:
    """Path under ``../shared`` (relative to the repo root); fail clearly if it is absent."""
    path = SHARED.joinpath(*parts)
    if not path.exists():
        pytest.fail(f"{path} is missing: these tests read the project's shared folder at "
                    f"../shared relative to the repo root ({REPO_ROOT}); check it out beside "
                    f"the repository", pytrace=False)
    return path


@pytest.fixture
def shared_dir() -> Path:
    """The ``../shared`` folder."""
    return shared_path()


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Deselect ``@pytest.mark.slow`` tests unless SIMGAP_SLOW=1 or ``-m`` names them."""
    if os.environ.get("SIMGAP_SLOW") == "1" or config.getoption("-m"):
        return
    skip = pytest.mark.skip(reason="slow: set SIMGAP_SLOW=1 (CI runs the quick variant)")
    for item in items:
        if "slow" in item.keywords:
            item.add_marker(skip)
