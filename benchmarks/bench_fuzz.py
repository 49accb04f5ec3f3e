"""Issue 15 fuzz benchmark: run the seeded fuzz cases and write the counts to JSON.

    .venv/bin/python benchmarks/bench_fuzz.py [--cases 1000] [--seed 0]

Writes ``benchmarks/results/bench_fuzz.json``: cases, rejected, accepted, tracebacks, hangs,
user files touched, leftover temporary files, per-category counts, every non-clean case
(if any), the wall time and the machine load (``os.getloadavg``) at start and end. Progress
goes to stderr.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, default=1000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results" /
                    "bench_fuzz.json")
    args = ap.parse_args()

    from typer.testing import CliRunner

    from simgap.cli import app
    from tests import fuzz

    load0 = os.getloadavg()
    t0 = time.perf_counter()
    runner = CliRunner()
    results = []
    all_cases = fuzz.cases(args.cases, seed=args.seed)
    for k, case in enumerate(all_cases, 1):
        results.append(fuzz.run_case(case, runner, app))
        if k % 50 == 0 or k == len(all_cases):
            s = fuzz.summarize(results)
            print(f"[{k}/{len(all_cases)}] rejected {s['rejected']} accepted {s['accepted']} "
                  f"tracebacks {s['tracebacks']} hangs {s['hangs']} touched "
                  f"{s['user_files_touched']} ({time.perf_counter() - t0:.0f} s)",
                  file=sys.stderr, flush=True)
    summary = fuzz.summarize(results)
    summary.update({
        "seed": args.seed, "case_timeout_s": fuzz.CASE_TIMEOUT,
        "wall_s": round(time.perf_counter() - t0, 1),
        "load_avg_start": [round(x, 2) for x in load0],
        "load_avg_end": [round(x, 2) for x in os.getloadavg()],
        "machine": {"python": platform.python_version(), "cpus": os.cpu_count()},
        "not_clean": [r for r in results if r["outcome"] in ("traceback", "hang")
                      or r["touched"] or r["leftovers"]],
        "rejection_examples": sorted({r["detail"][:160] for r in results
                                      if r["outcome"] == "rejected"})[:40],
    })
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(summary, indent=2) + "\n", encoding="utf-8")
    print(json.dumps({k: summary[k] for k in ("cases", "rejected", "accepted", "tracebacks",
                                               "hangs", "user_files_touched")}))


if __name__ == "__main__":
    main()
