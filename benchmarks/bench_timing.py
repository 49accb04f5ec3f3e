"""Per-step identifier compute time on Case 1 (thesis Table 4.6), printed as JSON.

Usage: ``python benchmarks/bench_timing.py [n_runs] [seconds]`` (default 10 runs of 20 s).
The full thesis protocol (100 runs of 220 s) is ``simgap reproduce --case timing``.
Target (thesis Sec. 4.5.2): baseline 1 and the proposed law never exceed the 2 ms deadline.
"""

from __future__ import annotations

import json
import sys

from simgap.evaluation.cases import get_case
from simgap.evaluation.runner import record_case
from simgap.evaluation.timing import run_timing


def main() -> None:
    n_runs = int(sys.argv[1]) if len(sys.argv) > 1 else 10
    seconds = float(sys.argv[2]) if len(sys.argv) > 2 else 20.0
    tr, _ = record_case(get_case("1"), duration=seconds)
    res = run_timing(tr, n_runs=n_runs)
    out = {"benchmark": "identifier_step_time_case1", "settings": res["settings"],
           "machine": res["machine"], "summary": res["summary"],
           "deadline_met": {k: v["miss_steps_pct"] == 0.0 for k, v in res["summary"].items()}}
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
