"""The bar of issue 14: the ``auto`` preset with every kind, on the thesis cases and on any env.

Scenarios (seeds 0-2 unless ``--seeds``), every kind with the ``auto`` preset
(``simgap.evaluation.run_case`` with ``preset_name="auto"``):

* thesis Cases 1, 2-1, 2-2;
* ``sines``: the arm (thesis friction) under gravity compensation plus two sines,
  u = G(q) + [1.5 sin(2π·0.5 t), 0.6 sin(2π·0.8 t + 1)] N·m, 120 s, freeze at 100 s / 120 s;
* ``slalom-mu0.5``: Case 2-2's slalom and tire relaxation on a road with μ = 0.5;
* ``1-noise10`` / ``1-noise50``: Case 1 with white sensor noise on the identifier state,
  std = k × the RMS per-step increment of each state component (k = 10, 50); the
  nominal f is evaluated at the noisy state, the target stays the true residual.

"Last part" = ĝ RMSE over the settled window (after the case's settle time) divided by the
RMS of the true residual there (``last_part_ratio``, the bar's ``met``); the literal last
part, the final 20 % of the run, is reported too (``last_20pct_ratio``,
``met_with_last_20pct``); consistency = the thesis' metric (frozen model at the last
freeze time against the true residual, on the identifier's own inputs), in the case's
units (primary channels).

* Gymnasium's ``Pendulum-v1`` with a user's nominal model (g = 9.0 against the env's 10.0,
  θ = atan2 declared periodic), every kind at its default (``auto``) preset, 10,000 uniformly
  random torque steps: divergence, max |ĝ|, median ‖x̃‖ over the last 2000 steps, and the
  same median for the observer alone (a frozen ``auto`` identifier: Ŵ_0 = 0, so ĝ ≡ 0).

Writes ``benchmarks/results/auto_bar.json`` (``auto_bar_quick.json`` with ``--quick``) and a
PNG of the Pendulum runs. Progress on stderr.

    .venv/bin/python benchmarks/bench_auto.py [--quick] [--seeds 0 1 2]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

OUT = Path(__file__).resolve().parent / "results"

_K = ("instantaneous", "integral", "minibatch")
#: Thresholds of the issue's bar (scenario → bound; per kind for the consistency). The
#: noise scenarios bound the integral law only (the issue's item); the other kinds are
#: measured and reported against no bound (None).
LAST_PART_MAX = {"1": 0.15, "sines": 0.15, "2-2": 0.15, "slalom-mu0.5": 0.15, "2-1": 0.40,
                 "1-noise10": None, "1-noise50": None}
CONSISTENCY_MAX = {"1": dict.fromkeys(_K, 0.04), "sines": dict.fromkeys(_K, 0.20),
                   "2-2": dict.fromkeys(_K, 0.15), "slalom-mu0.5": dict.fromkeys(_K, 0.14),
                   "2-1": {"minibatch": 0.25, "instantaneous": 0.60, "integral": 0.60},
                   "1-noise10": {"instantaneous": None, "integral": 0.05, "minibatch": None},
                   "1-noise50": {"instantaneous": None, "integral": 0.15, "minibatch": None}}
#: The integral law's own items on the sines (last part, consistency).
INTEGRAL_SINES = (0.08, 0.20)
SCENARIOS = ("1", "sines", "2-2", "slalom-mu0.5", "2-1", "1-noise10", "1-noise50")
PENDULUM_STEPS = 10_000
PENDULUM_TAIL = 2000


def _log(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


def pendulum_run(kind: str, seed: int, n_steps: int, *, frozen: bool = False) -> dict:
    """One wrapped ``Pendulum-v1`` run with uniformly random torques; metrics of the bar."""
    import gymnasium as gym

    from simgap.identifiers import IdentifierDivergedError
    from simgap.models.stock import PendulumNominal
    from simgap.wrappers import IdentifierWrapper

    env = gym.make("Pendulum-v1")
    env.unwrapped.nominal_model = PendulumNominal(g=9.0)
    env = IdentifierWrapper(env, kind, seed=seed, frozen=frozen)
    rng = np.random.default_rng(seed)
    env.reset(seed=seed)
    err = np.empty(n_steps)
    gmax = 0.0
    diverged = None
    for k in range(n_steps):
        try:
            _, _, term, trunc, info = env.step(rng.uniform(-2.0, 2.0, size=1))
        except IdentifierDivergedError as exc:
            diverged = f"step {k}: {exc}"
            err = err[:k]
            break
        err[k] = float(np.linalg.norm(info["estimation_error"]))
        gmax = max(gmax, float(np.max(np.abs(info["residual_estimate"]))))
        if term or trunc:
            env.reset()
    tail = err[-PENDULUM_TAIL:]
    return {"diverged": diverged, "max_abs_g_hat": gmax,
            "median_x_tilde_tail": float(np.median(tail)) if tail.size else None,
            "x_tilde": err}


def _sines_case():
    """The arm under gravity compensation plus two sines (120 s), as a ``Case``."""
    import dataclasses

    from simgap.evaluation.cases import Recording, get_case

    def record(n_steps: int, seed: int, progress: bool) -> Recording:
        from simgap.envs.manipulator import ManipulatorFrictionEnv
        from simgap.envs.rollout import rollout
        from simgap.models.manipulator import gravity_vector

        env = ManipulatorFrictionEnv(friction="thesis")
        la = env.nominal_model.params.array

        def act(obs: np.ndarray, t: float) -> np.ndarray:
            g = gravity_vector(np.ascontiguousarray(obs[:2], dtype=np.float64), la)
            return g + np.array([1.5 * np.sin(2 * np.pi * 0.5 * t),
                                 0.6 * np.sin(2 * np.pi * 0.8 * t + 1.0)])

        ro = rollout(env, act, n_steps, seed=seed, progress=progress)
        return Recording(rollout=ro, model=env.nominal_model,
                         env_description="arm, thesis friction, u = G(q) + two sines",
                         action_low=env._low, action_high=env._high)

    return dataclasses.replace(get_case("1"), name="sines", title="arm, G(q) + two sines",
                               duration=120.0, freeze_times=(100.0, 120.0), record=record,
                               thesis_key=None)


#: Front steering amplitude (rad) of the μ = 0.5 slalom. Case 2-2's 0.07 rad spins the car
#: out at μ = 0.5 (measured: the episode ends after 6.1 s). Half of it, 0.035 rad, is
#: Case 2-2 scaled by one half exactly (the Magic Formula scales with μ), so every ratio of
#: the scale-free preset came out identical to Case 2-2's (measured); 0.05 rad drives the
#: tires deeper into saturation than Case 2-2 (|g| RMS 1.29 / 0.38 against 0.64 overall)
#: and still finishes the 35 s.
SLALOM_MU05_FRONT = 0.05


def _slalom_case():
    """Case 2-2's slalom (tire relaxation on) at road friction μ = 0.5, half the steering."""
    import dataclasses

    from simgap.evaluation.cases import RELAXATION_LENGTH, Recording, get_case

    def record(n_steps: int, seed: int, progress: bool) -> Recording:
        from simgap.envs.bicycle import BicycleTireEnv
        from simgap.envs.rollout import rollout
        from simgap.envs.scenarios import slalom

        prog = slalom(front=SLALOM_MU05_FRONT, rear=SLALOM_MU05_FRONT * 0.015 / 0.07)
        env = BicycleTireEnv(vx=20.0, mu=0.5, tire="magic_formula",
                             relaxation_length=RELAXATION_LENGTH)
        ro = rollout(env, prog.act, n_steps, seed=seed, progress=progress)
        return Recording(rollout=ro, model=env.nominal_model,
                         env_description=f"bicycle, slalom, mu = 0.5, {prog!r}",
                         action_low=env._low, action_high=env._high)

    return dataclasses.replace(get_case("2-2"), name="slalom-mu0.5",
                               title="bicycle, slalom, mu = 0.5", record=record,
                               thesis_key=None)


def _noisy(tr, model, k: float, seed: int):
    """``tr`` with white noise of std k × RMS per-step increment on every state component."""
    import dataclasses

    x_all = np.vstack([tr.x, tr.x_next[-1:]])
    std = k * np.sqrt(np.mean(np.diff(x_all, axis=0) ** 2, axis=0))
    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(int(k),)))
    xn = x_all + std * rng.standard_normal(x_all.shape)
    f = np.array([model.f(xi, ui) for xi, ui in zip(xn[:-1], tr.u, strict=True)])
    return dataclasses.replace(tr, x=xn[:-1], x_next=xn[1:], f=f)


def get_scenario(name: str):
    """(case, noise k or None) of a bar scenario."""
    from simgap.evaluation.cases import get_case

    if name == "sines":
        return _sines_case(), None
    if name == "slalom-mu0.5":
        return _slalom_case(), None
    if name.startswith("1-noise"):
        return get_case("1"), float(name.removeprefix("1-noise"))
    return get_case(name), None


def case_runs(name: str, kinds: tuple[str, ...], seed: int, quick: bool) -> dict:
    """One bar scenario with the auto preset: last-part ratio and consistency per kind."""
    from simgap.evaluation.runner import record_case, run_case
    from simgap.models.manipulator import ManipulatorNominal

    case, noise = get_scenario(name)
    transitions = None
    if noise is not None:
        tr, desc = record_case(case, quick=quick, seed=seed)
        transitions = (_noisy(tr, ManipulatorNominal(), noise, seed), desc + f", noise k={noise:g}")
    res = run_case(case, quick=quick, seed=seed, methods=kinds, preset_name="auto",
                   transitions=transitions)
    ch = case.channels[0]
    out: dict = {}
    for kind in kinds:
        if kind in res.diverged:
            out[kind] = {"diverged": res.diverged[kind]}
            continue
        r = res.results[kind]
        m = r.t >= res.settle_time
        g_rms = float(np.sqrt(np.mean(ch.apply(r.target[m]) ** 2)))
        met = res.metrics[f"{ch.name}|settled|x_bar"][kind] if \
            f"{ch.name}|settled|x_bar" in res.metrics else None
        if met is None:
            key = next(k for k in res.metrics if k.startswith(ch.name))
            met = res.metrics[key][kind]
        last = max(met["consistency"], key=float)
        # the literal last part: the final 20 % of the run (online ĝ, primary channels)
        tail = r.t >= r.t[0] + 0.8 * (r.t[-1] - r.t[0])
        err = ch.apply(r.g_online[tail] - r.target[tail])
        tail_ratio = float(np.sqrt(np.mean(err ** 2))
                           / np.sqrt(np.mean(ch.apply(r.target[tail]) ** 2)))
        out[kind] = {"diverged": None, "last_part_ratio": met["accuracy"] / g_rms,
                     "g_rms": g_rms, "last_20pct_ratio": tail_ratio,
                     "consistency": met["consistency"][last], "consistency_at": last}
    return out


def _met(name: str, kind: str, r: dict) -> bool | None:
    """Whether row ``r`` meets the bar (None: the scenario bounds no item of this kind)."""
    lim_last, lim_cons = LAST_PART_MAX[name], CONSISTENCY_MAX[name][kind]
    if name == "sines" and kind == "integral":
        lim_last, lim_cons = min(lim_last, INTEGRAL_SINES[0]), INTEGRAL_SINES[1]
    if lim_last is None and lim_cons is None:
        return None
    if r["diverged"] is not None:
        return False
    return ((lim_last is None or r["last_part_ratio"] <= lim_last)
            and (lim_cons is None or r["consistency"] <= lim_cons))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="short runs (CI)")
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    ap.add_argument("--cases", nargs="*", default=list(SCENARIOS), choices=SCENARIOS)
    ap.add_argument("--pendulum-steps", type=int, default=None,
                    help="Pendulum-v1 steps (default 10,000; 2,000 with --quick)")
    ap.add_argument("--out", type=Path, default=None, help="JSON path (default: results/)")
    ap.add_argument("--merge", type=Path, nargs="+", default=None,
                    help="combine per-seed JSON files (written with --out) into --out")
    args = ap.parse_args()
    if args.merge:
        merge(args.merge, args.out or OUT / "auto_bar.json")
        return
    from simgap.identifiers import KINDS

    t0 = time.time()
    load = os.getloadavg()
    rows: list[dict] = []
    n_pend = args.pendulum_steps or (2000 if args.quick else PENDULUM_STEPS)
    pend_traces: dict = {}
    for seed in args.seeds:
        obs_only = pendulum_run("instantaneous", seed, n_pend, frozen=True)
        for kind in KINDS:
            _log(f"[{time.time() - t0:6.0f} s] Pendulum-v1 {kind} seed {seed}")
            r = pendulum_run(kind, seed, n_pend)
            ok = (r["diverged"] is None and r["max_abs_g_hat"] < 100
                  and r["median_x_tilde_tail"] <= 0.08
                  and r["median_x_tilde_tail"] <= 0.5 * obs_only["median_x_tilde_tail"])
            pend_traces[(kind, seed)] = r.pop("x_tilde")
            rows.append({"scenario": "Pendulum-v1", "kind": kind, "seed": seed, **r,
                         "observer_only_median": obs_only["median_x_tilde_tail"], "met": ok})
        pend_traces[("observer only", seed)] = obs_only.pop("x_tilde")
        for name in args.cases:
            _log(f"[{time.time() - t0:6.0f} s] Case {name} seed {seed}")
            res = case_runs(name, KINDS, seed, args.quick)
            for kind, r in res.items():
                tail = r | {"last_part_ratio": r.get("last_20pct_ratio")}
                rows.append({"scenario": f"Case {name}", "kind": kind, "seed": seed, **r,
                             "met": _met(name, kind, r),
                             "met_with_last_20pct": _met(name, kind, tail)})
    OUT.mkdir(exist_ok=True)
    stem = "auto_bar_quick" if args.quick else "auto_bar"
    doc = {"benchmark": "bench_auto", "quick": args.quick, "seeds": args.seeds,
           "pendulum_steps": n_pend,
           "loadavg_start": load, "loadavg_end": os.getloadavg(),
           "seconds": time.time() - t0,
           "thresholds": {"last_part": LAST_PART_MAX, "consistency": CONSISTENCY_MAX,
                          "integral_sines": INTEGRAL_SINES,
                          "pendulum": {"max_abs_g_hat": 100, "median_x_tilde_tail": 0.08,
                                       "vs_observer_only": 0.5}},
           "rows": rows, "summary": summary(rows)}
    out = args.out or OUT / f"{stem}.json"
    out.write_text(json.dumps(doc, indent=1))
    _plot(pend_traces, out.with_name(out.stem + "_pendulum.png"))
    _plot_bar(rows, out.with_name(out.stem + ".png"))
    for r in rows:
        _log(json.dumps({k: v for k, v in r.items() if k != "diverged"} | {
            "diverged": bool(r.get("diverged"))}))


def _plot_bar(rows: list[dict], path: Path) -> None:
    """Bar figure: last-part ratio and consistency per scenario and kind (seed means),
    each divided by its threshold (≤ 1 meets it)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    scen = [s for s in SCENARIOS if any(r["scenario"] == f"Case {s}" for r in rows)]
    if not scen:
        return
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.5), sharey=True)
    width = 0.27
    for ax, key, title in ((axes[0], "last_part_ratio", "last-part ĝ RMSE / |g| RMS"),
                           (axes[1], "consistency", "consistency (thesis metric)")):
        for j, kind in enumerate(_K):
            vals = []
            for s in scen:
                lim_last, lim_cons = LAST_PART_MAX[s], CONSISTENCY_MAX[s][kind]
                if s == "sines" and kind == "integral":
                    lim_last, lim_cons = INTEGRAL_SINES
                lim = lim_last if key == "last_part_ratio" else lim_cons
                rs = [r[key] for r in rows if r["scenario"] == f"Case {s}"
                      and r["kind"] == kind and r.get(key) is not None]
                vals.append(np.mean(rs) / lim if rs and lim else np.nan)
            ax.bar(np.arange(len(scen)) + (j - 1) * width, vals, width, label=kind)
        ax.axhline(1.0, color="k", lw=1, ls="--")
        ax.set_xticks(np.arange(len(scen)), scen, rotation=30)
        ax.set_title(f"{title}, mean over seeds / threshold")
        ax.set_xlabel("scenario")
    axes[0].set_ylabel("value / threshold (≤ 1 meets the bar)")
    axes[1].legend(loc="upper left", bbox_to_anchor=(1.01, 1.0))
    fig.suptitle("Issue 14 bar, auto preset (bars missing: no threshold for that kind)")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def merge(paths: list[Path], out: Path) -> None:
    """Combine per-seed JSON files of this benchmark into one (rows concatenated)."""
    docs = [json.loads(p.read_text()) for p in paths]
    doc = dict(docs[0])
    doc["seeds"] = sorted(s for d in docs for s in d["seeds"])
    doc["rows"] = [r for d in docs for r in d["rows"]]
    doc["seconds"] = max(d["seconds"] for d in docs)
    doc["loadavg_start"] = [d["loadavg_start"] for d in docs]
    doc["loadavg_end"] = [d["loadavg_end"] for d in docs]
    doc["merged_from"] = [p.name for p in paths]
    doc["summary"] = summary(doc["rows"])
    out.write_text(json.dumps(doc, indent=1))
    _plot_bar(doc["rows"], out.with_name(out.stem + ".png"))


def summary(rows: list[dict]) -> dict:
    """Per scenario and kind: items met over the seeds run ("2/3"), None = no item."""
    out: dict = {}
    for r in rows:
        if r["met"] is None:
            continue
        cell = out.setdefault(r["scenario"], {}).setdefault(r["kind"], [0, 0])
        cell[0] += bool(r["met"])
        cell[1] += 1
    return {s: {k: f"{a}/{b}" for k, (a, b) in d.items()} for s, d in out.items()}


def _plot(traces: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 4.5))
    kw = 200
    for (kind, seed), e in traces.items():
        if seed != 0 or e.size < kw:
            continue
        sm = np.convolve(e, np.ones(kw) / kw, mode="valid")
        t = (np.arange(sm.size) + kw) * 0.05
        ax.plot(t, sm, label=kind)
    ax.set_yscale("log")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("‖x̃‖, 10 s moving mean (rad, rad/s)")
    ax.set_title("Pendulum-v1 (g = 9 nominal vs 10), random torques, auto preset, seed 0")
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0))
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    main()
