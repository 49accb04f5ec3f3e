"""Identify the axle-force residual of ``simgap/PacejkaLaneKeeping-v0`` per kind (issue 14).

20 s of two-sine steering on μ = 0.3 (simgap.highway.experiments.identify_lane_keeping),
every identifier kind with the wrapper's default (``auto``) preset and with the thesis'
bicycle preset (Table 4.4, the reproduction preset); RMS error and correlation of the axle
forces (N) over the last 10 s, front / rear. Writes ``highway_identifiers.json``.

Usage: .venv/bin/python benchmarks/highway_identifiers.py [--seconds 20] [--seed 0]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

KINDS = ("instantaneous", "integral", "minibatch")


def run(seconds: float = 20.0, seed: int = 0, mu: float = 0.3) -> dict:
    """The table as a dict: ``{"auto": {kind: scores}, "thesis_bicycle": {kind: scores}}``."""
    from simgap.highway.experiments import identify_lane_keeping
    from simgap.identifiers import preset

    out: dict = {"seconds": seconds, "seed": seed, "mu": mu, "last_seconds": seconds / 2,
                 "units": "N (highway-env vehicle, m = 1 kg)"}
    for label, cfg in (("auto", lambda k: None), ("thesis_bicycle",
                                                   lambda k: preset("bicycle", k))):
        out[label] = {}
        for kind in KINDS:
            t0 = time.time()
            res = identify_lane_keeping(mu=mu, seconds=seconds, identifier=kind, seed=seed,
                                        config=cfg(kind))
            out[label][kind] = {**res.scores(last_seconds=seconds / 2),
                                "wall_s": time.time() - t0}
            sc = out[label][kind]
            print(f"[highway] {label:14s} {kind:13s} error {sc['rms_error_N']} corr "
                  f"{sc['correlation']}", file=sys.stderr, flush=True)
    return out


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=20.0)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=Path("benchmarks/results"))
    args = ap.parse_args(argv)
    res = run(args.seconds, args.seed)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "highway_identifiers.json").write_text(json.dumps(res, indent=1))
    print(json.dumps(res, indent=1))
    return res


if __name__ == "__main__":
    main()
