"""Sampling MPC: nominal model vs nominal + frozen residual network (issue 6).

Bicycle at 20 m/s on a μ = 0.5 road tracking a yaw-rate sine whose lateral acceleration
(4.8 m/s², 0.98 μ·g) is at the tire limit; MPPI (simgap.control.mpc, 512 samples × 3
iterations) replanning every 10 ms step.
Reports yaw-rate tracking error (rad/s) and compute time per control step (s) for each
variant in ``bench_mpc.json`` and a figure ``bench_mpc.png``. Timings on a shared 2-core
machine are noisy.

Usage: .venv/bin/python benchmarks/bench_mpc.py [--train 60] [--eval 8] [--quick]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time
from pathlib import Path


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--train", type=float, default=60.0, help="pre-training length (s)")
    ap.add_argument("--eval", type=float, default=8.0, help="tracking run length (s)")
    ap.add_argument("--quick", action="store_true", help="5 s training, 1 s runs")
    ap.add_argument("--out", type=Path, default=Path("benchmarks/results"))
    args = ap.parse_args()
    from simgap.control.experiments import BicycleTask, mpc_study
    from simgap.control.figures import mpc_figure

    train, ev = (5.0, 1.0) if args.quick else (args.train, args.eval)
    t0 = time.time()
    res = mpc_study(train_seconds=train, eval_seconds=ev, task=BicycleTask(amplitude=0.24))
    res["wall_s"] = time.time() - t0
    res["machine"] = {"platform": platform.platform(), "cpus": os.cpu_count(),
                      "note": "shared 2-core machine; timings are noisy"}
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "bench_mpc.json").write_text(json.dumps(res))
    mpc_figure(res, args.out / "bench_mpc.png", overwrite=True)
    summary = {n: {k: v[k] for k in ("rmse_rad_s", "max_abs_rad_s", "compute_s")}
               for n, v in res["variants"].items()}
    print(json.dumps(summary, indent=1))


if __name__ == "__main__":
    main()
