"""Sweep wall time: N seeds of one quick case, serial vs a local process pool vs local Ray.

All three in one run, one after the other, with the machine's load average before each;
each writes its own folder. Prints JSON (and writes it with --out).

    .venv/bin/python benchmarks/bench_sweeps.py [--seeds 10] [--case 2-1] [--jobs 2] \
        [--backends serial,process_pool,ray_local] [--out F.json]
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import sys
import tempfile
import time
from pathlib import Path

from simgap.evaluation.sweep import reproduce_sweep


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--case", default="2-1")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--out", type=Path, default=None)
    ap.add_argument("--backends", default="serial,process_pool,ray_local",
                    help="Which of serial, process_pool, ray_local to run (serial always).")
    args = ap.parse_args()
    wanted = {"serial", *args.backends.split(",")}
    seeds = list(range(args.seeds))
    backends = [("serial", 1, None), ("process_pool", args.jobs, None)]
    if importlib.util.find_spec("ray") is not None:
        backends.append(("ray_local", args.jobs, True))
    backends = [b for b in backends if b[0] in wanted]
    res = {"seeds": args.seeds, "case": args.case, "quick": True, "jobs": args.jobs,
           "cpus": os.cpu_count(), "runs": {}}
    with tempfile.TemporaryDirectory() as tmp:
        summaries = {}
        for name, jobs, ray in backends:
            load = os.getloadavg()[0]
            t0 = time.perf_counter()
            s = reproduce_sweep(Path(tmp) / name, seeds=seeds, cases=[args.case], quick=True,
                                jobs=jobs, ray=ray)
            wall = time.perf_counter() - t0
            summaries[name] = s["cases"]
            res["runs"][name] = {"wall_s": wall, "load_before": load,
                                 "failed": len(s["failed"])}
            print(f"{name}: {wall:.1f} s (load {load:.2f})", file=sys.stderr)
        res["identical_to_serial"] = {k: v == summaries["serial"] for k, v in summaries.items()}
    base = res["runs"]["serial"]["wall_s"]
    for r in res["runs"].values():
        r["speedup_vs_serial"] = base / r["wall_s"]
    text = json.dumps(res, indent=1)
    if args.out is not None:
        args.out.write_text(text)
    print(text)


if __name__ == "__main__":
    main()
