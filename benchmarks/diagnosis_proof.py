"""The concealed-effect proof table (issue 5): effect × seeds → named?, parameter error,
fit before/after, and clean recordings.

Each vocabulary effect is injected alone at random parameters (ranges in
``simgap.diagnosis.proof.RANGES``) into a generated recording; the diagnosis sees only the
columns. Columns of the table: named at the right channel, worst relative parameter error,
extra effects named, held-out rollout score nominal → augmented and the ratio (in brackets:
the ratio with the injected effect at its true parameters, the most the rollout can gain). Then two
effects at once, and clean recordings (false positives). Prints Markdown and, last, JSON.

    .venv/bin/python benchmarks/diagnosis_proof.py [--seeds 5] [--clean 20]
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np
from rich.progress import Progress

from simgap.diagnosis.generate import InjectedEffect
from simgap.diagnosis.proof import RANGES, TOLERANCE, draw, model_of, run_case

DURATION = {"manipulator2dof": 20.0, "bicycle": 40.0}
PAIRS = [
    [InjectedEffect(effect="coulomb_friction", channel="joint1", params={"Fc": 0.15}),
     InjectedEffect(effect="spring", channel="joint2", params={"k": 1.5, "q0": 0.2})],
    [InjectedEffect(effect="viscous_friction", channel="joint2", params={"b": 0.3}),
     InjectedEffect(effect="payload_mass", params={"mp": 0.25})],
    [InjectedEffect(effect="tire_saturation", params={"mu": 0.7}),
     InjectedEffect(effect="lateral_bias", params={"ay0": 0.4})],
    [InjectedEffect(effect="steering_lag", params={"tau": 0.08}),
     InjectedEffect(effect="mass_mismatch", params={"ratio": 1.15})],
    [InjectedEffect(effect="tire_saturation", params={"mu": 0.7}),
     InjectedEffect(effect="steering_lag", params={"tau": 0.08})],
]


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--clean", type=int, default=20)
    args = ap.parse_args()
    rows, pairs, clean = [], [], {}
    t0 = time.perf_counter()
    n_tasks = len(RANGES) * args.seeds + len(PAIRS) + 2 * args.clean
    with Progress(transient=True) as prog:
        task = prog.add_task("proof", total=n_tasks)
        for name in RANGES:
            for seed in range(args.seeds):
                inj = draw(name, np.random.default_rng(1000 + seed))
                m = model_of(name)
                r = run_case([inj], m, seed, duration=DURATION[m])
                rows.append({"effect": name, "seed": seed, "channel": inj.channel,
                             "injected": inj.params, "named": r.named,
                             "param_error": r.param_error, "extra": r.extra,
                             "score_nominal": r.score_nominal,
                             "score_augmented": r.score_augmented,
                             "improvement": r.improvement, "ceiling": r.ceiling,
                             "z": r.z})
                prog.advance(task)
        for k, effects in enumerate(PAIRS):
            m = model_of(effects[0].effect)
            r = run_case(effects, m, 50 + k, duration=DURATION[m])
            pairs.append({"effects": [e.effect for e in effects], "named": r.named,
                          "param_error": r.param_error, "extra": r.extra,
                          "improvement": r.improvement})
            prog.advance(task)
        for m in ("manipulator2dof", "bicycle"):
            flagged = 0
            for seed in range(args.clean):
                r = run_case([], m, 500 + seed, duration=DURATION[m])
                flagged += int(r.significant or bool(r.found))
                prog.advance(task)
            clean[m] = {"recordings": args.clean, "flagged": flagged}
    print("| effect | seeds | named | worst param. error | median param. error | median "
          "\\|error\\|/stderr | extra named | rollout score nominal → augmented (median) "
          "| min improvement (true parameters) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name in RANGES:
        rs = [r for r in rows if r["effect"] == name]
        errs = [r["param_error"] for r in rs]
        worst = min(rs, key=lambda r: r["improvement"])
        print(f"| {name} | {len(rs)} | {sum(r['named'] for r in rs)}/{len(rs)} | "
              f"{100 * max(errs):.1f} % | {100 * float(np.median(errs)):.1f} % | "
              f"{float(np.median([r['z'] for r in rs])):.1f} | "
              f"{sum(bool(r['extra']) for r in rs)} | "
              f"{np.median([r['score_nominal'] for r in rs]):.3g} → "
              f"{np.median([r['score_augmented'] for r in rs]):.3g} | "
              f"{worst['improvement']:.1f}× ({worst['ceiling']:.1f}×) |")
    print("\n| two effects | named | worst param. error | extra | improvement |\n"
          "|---|---|---|---|---|")
    for p in pairs:
        print(f"| {' + '.join(p['effects'])} | {p['named']} | {100 * p['param_error']:.1f} % | "
              f"{p['extra'] or '-'} | {p['improvement']:.1f}× |")
    print("\n| clean recordings | flagged (significant or any effect) |\n|---|---|")
    for m, c in clean.items():
        print(f"| {m} | {c['flagged']}/{c['recordings']} |")
    ok = all(r["named"] and r["param_error"] <= TOLERANCE for r in rows)
    print(json.dumps({"all_named_within_20pct": ok, "rows": rows, "pairs": pairs,
                      "clean": clean, "seconds": round(time.perf_counter() - t0, 1)},
                     default=float))


if __name__ == "__main__":
    main()
