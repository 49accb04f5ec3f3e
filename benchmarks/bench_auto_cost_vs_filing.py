"""Issue 14's cost bar against the code the issue was filed on, side by side.

"cost per step stays within 1.3× today's": ``today`` is the identifier step of the commit
the issue was filed against (``--old``, a checkout of it, e.g. ``git worktree add --detach
/tmp/old14 5073903^`` with the built ``_call`` extension copied in), when the default was
the thesis preset. This compares, per kind, on the thesis manipulator trajectory (500 Hz):

* ``filed_thesis``: the thesis preset on the old checkout;
* ``thesis``: the thesis preset now (shared code has become faster since, so the ratio to
  it is the stricter reading);
* ``auto``: ``preset("auto", kind, dt)`` now.

Two persistent worker processes (one per code version, same interpreter and venv) time
whole loops of :meth:`Identifier.step` (per-step mean, µs) in turns A, B, C, A, B, C …;
medians and best runs over ``--runs`` rounds; the load is recorded. A worker's compiled
code keeps one memory layout for its lifetime, and on the shared 2-core machine one pair
of workers read the ratio anywhere from 1.03 to 1.24 (integral law, 61 rounds each,
load 1.5-2.8): ``--repeats`` starts fresh workers that many times and pools the rounds
(the ratios per repeat are recorded too). Usage::

    .venv/bin/python benchmarks/bench_auto_cost_vs_filing.py --old /tmp/old14 \\
        --out benchmarks/results/auto_cost_vs_filing.json
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve()
ROOT = HERE.parents[1]
KINDS = ("instantaneous", "integral", "minibatch")


def worker(rows_path: str) -> None:
    """Serve ``kind preset seed`` lines: print the per-step mean (µs) of one loop."""
    from simgap.identifiers import make_identifier, preset

    d = np.load(rows_path)
    x, u, f = d["x"], d["u"], d["f"]
    rows = [(x[k], u[k], f[k], x[k + 1]) for k in range(len(u) - 1)]
    clock = time.perf_counter_ns
    for line in sys.stdin:
        kind, name, seed = line.split()
        cfg = (preset("auto", kind, dt=0.002) if name == "auto"
               else preset("manipulator", kind))
        ident = make_identifier(kind, 4, 2, 0.002, config=cfg, seed=int(seed))
        step = ident.step
        for xk, uk, fk, xn in rows[:200]:       # warm (compiled kernels, caches)
            step(xk, uk, fk, xn)
        ident = make_identifier(kind, 4, 2, 0.002, config=cfg, seed=int(seed))
        step = ident.step
        t0 = clock()
        for xk, uk, fk, xn in rows:
            step(xk, uk, fk, xn)
        print((clock() - t0) / len(rows) / 1e3, flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--old", type=Path, required=True, help="checkout of the filing commit")
    ap.add_argument("--runs", type=int, default=41)
    ap.add_argument("--steps", type=int, default=5000)
    ap.add_argument("--repeats", type=int, default=1,
                    help="fresh worker pairs, each running --runs rounds (pooled)")
    ap.add_argument("--out", type=Path, default=None)
    ap.add_argument("--worker", default=None, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.worker:
        worker(args.worker)
        return
    sys.path.insert(0, str(HERE.parent))
    from bench_identifiers import record

    x, u, f = record(args.steps)
    tmp = Path(tempfile.mkdtemp()) / "rows.npz"
    np.savez(tmp, x=x, u=u, f=f)

    def spawn(tree: Path) -> subprocess.Popen:
        env = dict(os.environ, PYTHONPATH=str(tree), PYTHONDONTWRITEBYTECODE="1")
        return subprocess.Popen([sys.executable, str(HERE), "--old", str(tree), "--worker",
                                 str(tmp)], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                text=True, env=env, cwd=tree)

    def ask(p: subprocess.Popen, kind: str, name: str, seed: int) -> float:
        p.stdin.write(f"{kind} {name} {seed}\n")
        p.stdin.flush()
        return float(p.stdout.readline())

    load0 = os.getloadavg()
    names = ("filed_thesis", "thesis", "auto")
    t: dict = {kind: {name: [] for name in names} for kind in KINDS}
    per_repeat: dict = {kind: [] for kind in KINDS}
    for rep in range(args.repeats):
        old, new = spawn(args.old.resolve()), spawn(ROOT)
        plan = (("filed_thesis", old, "thesis"), ("thesis", new, "thesis"),
                ("auto", new, "auto"))
        for kind in KINDS:
            for _name, p, pre in plan:                 # one untimed round: compile, warm
                ask(p, kind, pre, 0)
            here: dict[str, list[float]] = {name: [] for name in names}
            for r in range(args.runs):
                for name, p, pre in (plan if r % 2 == 0 else plan[::-1]):
                    here[name].append(ask(p, kind, pre, r))
                print(f"repeat {rep + 1}/{args.repeats} {kind}: round {r + 1}/{args.runs}",
                      file=sys.stderr, end="\r")
            for name in names:
                t[kind][name] += here[name]
            per_repeat[kind].append(float(np.median(here["auto"])
                                          / np.median(here["filed_thesis"])))
        for p in (old, new):
            p.stdin.close()
            p.wait()
    out: dict = {}
    for kind in KINDS:
        med = {k: float(np.median(v)) for k, v in t[kind].items()}
        best = {k: float(np.min(v)) for k, v in t[kind].items()}
        out[kind] = {"median_us": med, "best_us": best,
                     "auto_vs_filed_thesis": med["auto"] / med["filed_thesis"],
                     "auto_vs_filed_thesis_best": best["auto"] / best["filed_thesis"],
                     "auto_vs_thesis_now": med["auto"] / med["thesis"],
                     "auto_vs_thesis_now_best": best["auto"] / best["thesis"],
                     "auto_vs_filed_thesis_per_repeat": per_repeat[kind]}
    res = {"benchmark": "issue 14 cost bar: auto now vs the thesis preset at the filing "
                        "commit and now (Identifier.step, thesis trajectory, 500 Hz)",
           "old_tree": str(args.old), "runs": args.runs, "repeats": args.repeats,
           "steps": args.steps,
           "loadavg_start": load0, "loadavg_end": os.getloadavg(), "bar": 1.3,
           "kinds": out}
    text = json.dumps(res, indent=2)
    print(text)
    if args.out:
        args.out.write_text(text + "\n")


if __name__ == "__main__":
    main()
