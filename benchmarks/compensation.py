"""Tracking RMSE with and without feed-forward compensation of ĝ, per identifier (issue 6).

Manipulator: feedback linearisation (thesis eq. 4.8-4.9) on the quintic reference, plain vs
u = u_FL − ĝ_p with each identifier's network frozen after pre-training on random waypoints,
or learning online from scratch; plus the exact residual (upper bound). Bicycle: the
nominal-inverting yaw-rate controller on a μ = 0.5 road at 20 m/s, likewise.
Writes ``compensation.json`` and ``compensation.png``.

Usage: .venv/bin/python benchmarks/compensation.py [--train 60] [--eval 8] [--quick]
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--train", type=float, default=60.0, help="pre-training length (s)")
    ap.add_argument("--eval", type=float, default=8.0, help="tracking run length (s)")
    ap.add_argument("--quick", action="store_true", help="5 s training, 2 s runs")
    ap.add_argument("--out", type=Path, default=Path("benchmarks/results"))
    args = ap.parse_args()
    from simgap.control.experiments import compensation_study
    from simgap.control.figures import compensation_figure

    train, ev = (5.0, 2.0) if args.quick else (args.train, args.eval)
    t0 = time.time()
    res = compensation_study(train_seconds=train, eval_seconds=ev)
    res["wall_s"] = time.time() - t0
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "compensation.json").write_text(json.dumps(res, indent=1))
    compensation_figure(res, args.out / "compensation.png", overwrite=True)
    print(json.dumps(res, indent=1))


if __name__ == "__main__":
    main()
