"""Issue 15 fuzz suite: seeded cases over every input category (tests/fuzz.py).

The quick subset (two cases per category) runs in the normal suite; ``SIMGAP_SLOW=1`` runs
1000 cases. Every case is under a time limit; the suite asserts 0 tracebacks, 0 hangs,
0 user files touched and no temporary files left, every rejection one line.
"""

from __future__ import annotations

import os

import pytest
from typer.testing import CliRunner

from simgap.cli import app
from tests import fuzz

SLOW = os.environ.get("SIMGAP_SLOW") == "1"


def _check(results):
    s = fuzz.summarize(results)
    bad = [r for r in results if r["outcome"] in ("traceback", "hang") or r["touched"]
           or r["leftovers"]]
    assert not bad, bad[:5]
    assert s["tracebacks"] == 0 and s["hangs"] == 0 and s["user_files_touched"] == 0
    assert s["rejected"] > 0 and s["accepted"] > 0  # both outcomes are exercised
    return s


def test_fuzz_quick():
    runner = CliRunner()
    results = [fuzz.run_case(c, runner, app) for c in fuzz.cases(2 * len(fuzz.CATEGORIES),
                                                                 seed=7)]
    s = _check(results)
    assert s["cases"] == 24


@pytest.mark.slow
@pytest.mark.skipif(not SLOW, reason="slow: set SIMGAP_SLOW=1 (CI runs the quick variant)")
def test_fuzz_1000_cases():
    runner = CliRunner()
    results = [fuzz.run_case(c, runner, app) for c in fuzz.cases(1000, seed=0)]
    s = _check(results)
    assert s["cases"] == 1000
