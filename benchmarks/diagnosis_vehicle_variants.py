"""Held-out vehicle variants: the bicycle diagnosis on logs unlike the tuned presets.

None of these variants is one of the artefact presets the diagnosis was tuned on
(``simgap.diagnosis.artefacts.ARTEFACTS``, the one-direction circles): each changes how the
car was driven or how it was logged, and the diagnosis runs blind on it.

* ``slow_8ms`` / ``fast_35ms``: mean speed 8 or 35 m/s (the generator's is 20 m/s);
* ``slalom``: a 0.5 Hz sine steering (the presets drive random sine periods or circles);
* ``imu_lowpass``: the yaw-rate column low-passed upstream (second-order Butterworth at
  :data:`IMU_CUTOFF_HZ`, causal, as an IMU's internal filter), undeclared;
* ``log_50hz`` / ``log_200hz``: the whole log (and its controller) at 50 or 200 Hz;
* ``quantised_steering``: the logged road-wheel command rounded to :data:`STEER_STEP`
  (the plant still steers with the exact command), undeclared.

Every bicycle vocabulary effect × seed (parameters drawn as the proof draws them) and clean
logs per variant. An effect passes when it is named within the proof's tolerance with
nothing else named; a clean log when nothing is named. Writes JSON (``--out``) and prints a
Markdown summary on stderr.

    .venv/bin/python benchmarks/diagnosis_vehicle_variants.py [--seeds 2] [--clean 5] \
        [--variants slalom,log_50hz] [--effects mass_mismatch] [--out F.json]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
from scipy.signal import butter, lfilter

from simgap.diagnosis.artefacts import quantise
from simgap.diagnosis.generate import InjectedEffect, generate_bicycle
from simgap.diagnosis.proof import RANGES, draw, run_case
from simgap.errors import SimgapError
from simgap.recordings import Recording

#: Length of each log (s), as the proof's vehicle cases.
DURATION = 40.0
#: Cut-off (Hz) of the upstream yaw-rate filter of ``imu_lowpass``.
IMU_CUTOFF_HZ = 10.0
#: Resolution (rad) of the logged steering command of ``quantised_steering`` (0.057°).
STEER_STEP = 1e-3
#: The bicycle's vocabulary effects (the proof's ranges).
EFFECTS = tuple(n for n, (model, _, _) in RANGES.items() if model == "bicycle")


def _lowpass_r(rec: Recording) -> Recording:
    t = np.asarray(rec["t"])
    fs = 1.0 / float(np.median(np.diff(t)))
    b, a = butter(2, IMU_CUTOFF_HZ / (fs / 2.0))
    r = np.asarray(rec["r"], dtype=np.float64)
    cols = dict(rec.columns)
    cols["r"] = lfilter(b, a, r - r[0]) + r[0]
    return Recording(rec.name, cols, meta=dict(rec.meta))


#: name -> (generator keywords, post-processing of the log or None).
VARIANTS: dict[str, tuple[dict, Callable[[Recording], Recording] | None]] = {
    "slow_8ms": ({"vx": 8.0}, None),
    "fast_35ms": ({"vx": 35.0}, None),
    "slalom": ({"program": "slalom"}, None),
    "imu_lowpass": ({}, _lowpass_r),
    "log_50hz": ({"rate": 50.0}, None),
    "log_200hz": ({"rate": 200.0}, None),
    "quantised_steering": ({}, lambda rec: quantise(rec, ["delta_f"], STEER_STEP)),
}


def recording(variant: str, effects: list[InjectedEffect], seed: int) -> Recording:
    """The log of ``variant`` with ``effects`` injected (seed of program and noise)."""
    kw, post = VARIANTS[variant]
    rec = generate_bicycle(effects, duration=DURATION, seed=seed, **kw)
    return post(rec) if post is not None else rec


def case(variant: str, effects: list[InjectedEffect], seed: int) -> dict:
    """Diagnose one log blind and score it against the injected effects."""
    try:
        r = run_case(effects, "bicycle", seed, recording=recording(variant, effects, seed))
    except SimgapError as err:
        return {"error": str(err)}
    return {"named": bool(r.named), "param_error": float(r.param_error), "extra": r.extra,
            "found": [f"{e['effect']}@{e['channel']}" for e in r.found],
            "found_params": [e["parameters"] for e in r.found],
            "significant": bool(r.significant)}


def run(variants: list[str], effects: list[str], seeds: int, n_clean: int,
        log: Callable[[str], None] = lambda s: None) -> dict:
    """Rows and clean rows of every variant; ``summary`` per variant."""
    rows, clean = [], []
    t0 = time.perf_counter()
    for v in variants:
        for name in effects:
            for seed in range(seeds):
                inj = draw(name, np.random.default_rng(1000 + seed))
                out = case(v, [inj], seed)
                rows.append({"variant": v, "effect": name, "seed": seed,
                             "injected": inj.to_dict(), **out})
                log(f"[{time.perf_counter() - t0:7.1f} s] {v} {name} seed {seed}: "
                    f"{out.get('named')} {out.get('found', out.get('error'))}")
        for seed in range(n_clean):
            out = case(v, [], 100 + seed)
            clean.append({"variant": v, "seed": 100 + seed, **out})
            log(f"[{time.perf_counter() - t0:7.1f} s] {v} clean {100 + seed}: "
                f"{out.get('found', out.get('error'))}")
    summary = {}
    for v in variants:
        mine = [r for r in rows if r["variant"] == v]
        cl = [r for r in clean if r["variant"] == v]
        summary[v] = {"cases": len(mine), "named": sum(bool(r.get("named")) for r in mine),
                      "with_extra": sum(bool(r.get("extra")) for r in mine),
                      "errors": sum("error" in r for r in mine + cl),
                      "clean": len(cl), "clean_named": sum(bool(r.get("found")) for r in cl),
                      "clean_flagged": sum(bool(r.get("significant")) for r in cl)}
    return {"rows": rows, "clean": clean, "summary": summary,
            "seconds": time.perf_counter() - t0}


def table(summary: dict) -> str:
    """Markdown table of a summary."""
    out = ["| variant | cases | named within tolerance | with extra effects | errors | clean | "
           "clean with named effects | clean flagged |", "|---|---|---|---|---|---|---|---|"]
    for v, s in summary.items():
        out.append(f"| {v} | {s['cases']} | {s['named']} | {s['with_extra']} | {s['errors']} "
                   f"| {s['clean']} | {s['clean_named']} | {s['clean_flagged']} |")
    return "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    """Command-line entry."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("--clean", type=int, default=5)
    ap.add_argument("--variants", default=",".join(VARIANTS))
    ap.add_argument("--effects", default=",".join(EFFECTS))
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)
    variants = [v for v in args.variants.split(",") if v]
    unknown = [v for v in variants if v not in VARIANTS]
    if unknown:
        ap.error(f"unknown variants {unknown}; choose from {', '.join(VARIANTS)}")
    effects = [e for e in args.effects.split(",") if e]
    res = run(variants, effects, args.seeds, args.clean,
              log=lambda s: print(s, file=sys.stderr, flush=True))
    print(table(res["summary"]), file=sys.stderr)
    if args.out is not None:
        args.out.write_text(json.dumps(res, indent=1, default=str))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
