"""Speed of `simgap diagnose` (issue 5): a 60 s, 500 Hz manipulator recording (30,001
samples) must be diagnosed in ≤ 10 s on the project's 2-core machine.

Prints JSON: the diagnosis time (median of 3, after a warm-up that loads numba's cache),
the time to write report.json/report.md/figures, and the target.

    .venv/bin/python benchmarks/bench_diagnosis.py
"""

from __future__ import annotations

import json
import os
import tempfile
import time

import numpy as np

from simgap.diagnosis.generate import InjectedEffect, generate_manipulator
from simgap.diagnosis.pipeline import diagnose
from simgap.diagnosis.report import write_report


def main() -> None:
    effects = [InjectedEffect(effect="coulomb_friction", channel="joint2", params={"Fc": 0.2}),
               InjectedEffect(effect="viscous_friction", channel="joint1", params={"b": 0.2})]
    rec = generate_manipulator(effects, duration=60.0, rate=500.0, seed=0)
    diagnose(generate_manipulator(effects, duration=4.0, seed=1))  # warm-up (numba cache)
    times = []
    for _ in range(3):
        t0 = time.perf_counter()
        rep = diagnose(rec, "manipulator2dof")
        times.append(time.perf_counter() - t0)
    with tempfile.TemporaryDirectory() as d:
        t0 = time.perf_counter()
        write_report(rep, os.path.join(d, "r"))
        t_write = time.perf_counter() - t0
    print(json.dumps({
        "benchmark": "diagnose manipulator2dof, 60 s at 500 Hz",
        "samples": rec.n,
        "diagnose_s_median": round(float(np.median(times)), 3),
        "diagnose_s_all": [round(t, 3) for t in times],
        "write_report_s": round(t_write, 3),
        "target_s": 10.0,
        "meets_target": bool(np.median(times) <= 10.0),
        "effects_found": [e["effect"] + "@" + e["channel"] for e in rep.effects],
        "cpu_count": os.cpu_count(),
    }, indent=2))


if __name__ == "__main__":
    main()
