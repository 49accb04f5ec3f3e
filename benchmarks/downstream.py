"""Rerun the downstream studies with the current default preset; print old vs new tables.

One command after a change to the identifiers (issue 14):

    .venv/bin/python benchmarks/downstream.py            # compensation, MPC, highway (~2-3 min)
    .venv/bin/python benchmarks/downstream.py --tables   # only rebuild the tables from JSON

runs ``benchmarks/compensation.py``, ``benchmarks/bench_mpc.py`` and
``benchmarks/highway_identifiers.py`` one after the other (each writes its own JSON and PNG
in ``benchmarks/results/``), then writes ``benchmarks/results/downstream.md``: the README /
docs tables with the numbers before the rerun (``downstream_previous.json``: the previous
``auto`` run and the thesis presets) next to the new ones, and the RL summary of
``rl_residual.json`` next to its predecessor. The RL experiment is separate (about an hour):
``benchmarks/rl_residual.py``. Progress on stderr.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
KINDS = ("instantaneous", "integral", "minibatch")
STUDIES = ("compensation.py", "bench_mpc.py", "highway_identifiers.py")


def _f(v: float, digits: int = 4) -> str:
    return f"{v:.{digits}f}"


def _pct(new: float, ref: float) -> str:
    return f"{100.0 * (new - ref) / ref:+.0f} %"


def compensation_table(prev: dict, new: dict) -> list[str]:
    """Tracking RMSE per kind, frozen / online, previous auto | thesis | new."""
    old, thesis = prev["auto_previous"], prev["thesis"]
    man, bic = new["manipulator_rmse_rad"], new["bicycle"]
    rows = ["| tracking RMSE | kind | new `auto`: frozen / online | previous `auto` | "
            "thesis preset |", "|---|---|---|---|---|"]
    for plant, unit, get, digits in (
            ("arm", "rad", lambda k: (man[k]["frozen"], man[k]["online"]), 3),
            ("car", "rad/s", lambda k: (bic[k]["frozen"]["rmse_rad_s"],
                                        bic[k]["online"]["rmse_rad_s"]), 4)):
        for k in KINDS:
            fr, on = get(k)
            o, t = old[f"{plant}_{k}"], thesis[f"{plant}_{k}"]
            rows.append(f"| {plant} ({unit}) | {k} | {_f(fr, digits)} / {_f(on, digits)} | "
                        f"{_f(o[0], digits)} / {_f(o[1], digits)} | "
                        f"{_f(t[0], digits)} / {_f(t[1], digits)} |")
    rows.append(f"| arm (rad) | none / exact | {_f(man['plain'], 3)} / "
                f"{_f(man['true_residual'], 4)} | {_f(old['arm_plain'], 3)} / "
                f"{_f(old['arm_exact'], 4)} | |")
    rows.append(f"| car (rad/s) | none / exact | {_f(bic['plain']['rmse_rad_s'])} / "
                f"{_f(bic['true_residual']['rmse_rad_s'])} | {_f(old['car_plain'])} / "
                f"{_f(old['car_exact'])} | |")
    rows.append("")
    rows.append("RMS error of ĝ during the frozen runs (arm: ĝ_p, N·m, true "
                f"{man['residual_true_rms']:.2f}; car: ĝ, m/s² and rad/s²), new / previous: "
                + "; ".join(f"{k} arm {man[k]['residual_error_rms']:.2f} / "
                            f"{old[f'arm_{k}_g_error_rms']:.2f}, car "
                            f"{bic[k]['residual_error_rms']:.3f} / "
                            f"{old[f'car_{k}_g_error_rms']:.3f}" for k in KINDS))
    return rows


def mpc_table(prev: dict, new: dict) -> list[str]:
    """Yaw-rate RMSE of the MPC per prediction model, new | previous auto | thesis."""
    old, thesis = prev["auto_previous"], prev["thesis"]
    v = new["variants"]
    ref = v["nominal"]["rmse_rad_s"]
    rows = ["| prediction model | new `auto`: RMSE (rad/s) | peak (rad/s) | compute median / "
            "p99 (ms) | previous `auto` | thesis preset |", "|---|---|---|---|---|---|"]
    for name, r in v.items():
        c = r["compute_s"]
        o = old.get(name, {}).get("rmse_rad_s")
        t = thesis.get(name)
        rows.append(f"| {name} | {_f(r['rmse_rad_s'])} ({_pct(r['rmse_rad_s'], ref)}) | "
                    f"{_f(r['max_abs_rad_s'], 3)} | {1e3 * c['p50']:.1f} / "
                    f"{1e3 * c['p99']:.1f} | {_f(o) if o is not None else ''} | "
                    f"{_f(t) if t is not None else ''} |")
    return rows


def highway_table(prev: dict, new: dict) -> list[str]:
    """Axle-force RMS error and correlation, front / rear, new auto | thesis | previous."""
    old = prev["auto_previous"]
    rows = ["| kind | new `auto`: RMS error (N) | correlation | thesis preset (rerun): error | "
            "correlation | previous `auto` (docs) |", "|---|---|---|---|---|---|"]
    for k in KINDS:
        a, t = new["auto"][k], new["thesis_bicycle"][k]
        o = old.get(k, {})
        rows.append(
            f"| {k} | {a['rms_error_N'][0]:.3f} / {a['rms_error_N'][1]:.3f} | "
            f"{a['correlation'][0]:.2f} / {a['correlation'][1]:.2f} | "
            f"{t['rms_error_N'][0]:.3f} / {t['rms_error_N'][1]:.3f} | "
            f"{t['correlation'][0]:.2f} / {t['correlation'][1]:.2f} | "
            f"{o.get('rms_error_N', ['', ''])[0]} / {o.get('rms_error_N', ['', ''])[1]}, corr "
            f"{o.get('correlation', ['', ''])[0]} / {o.get('correlation', ['', ''])[1]} |")
    tr = new["auto"][KINDS[0]]["rms_true_N"]
    rows.append("")
    rows.append(f"Truth over the last {new['last_seconds']:.0f} s: {tr[0]:.3f} / {tr[1]:.3f} N "
                f"RMS (front / rear), μ = {new['mu']}, seed {new['seed']}.")
    return rows


def rl_table(prev: dict, new: dict) -> list[str]:
    """Final deterministic returns, new run vs the previous one."""
    s, st = new["summary"], new["settings"]
    rows = [f"New: SAC, {len(st['seeds'])} seeds × {st['steps_per_run']:,} steps per run, "
            f"{'complete' if new.get('complete') else 'INCOMPLETE (partial JSON)'}; previous: "
            f"{len(prev['seeds'])} seeds × {prev['steps_per_run']:,} steps, raw ĝ.", "",
            "| | new: mean ± 95 % CI | median | per seed | previous: mean | previous per seed |",
            "|---|---|---|---|---|---|"]
    for v in ("plain", "residual"):
        if v not in s:
            continue
        n, o = s[v], prev[v]
        rows.append(f"| {v} | {n['final_return_mean']:.2f} ± {n['final_return_ci95']:.2f} | "
                    f"{n['final_return_median']:.2f} | "
                    f"{', '.join(f'{x:.2f}' for x in n['per_seed'])} | "
                    f"{o['final_return_mean']:.2f} | "
                    f"{', '.join(f'{x:.2f}' for x in o['per_seed'])} |")
    if s.get("base_controller_return_mean") is not None:
        rows.append(f"| base controller alone | {s['base_controller_return_mean']:.2f} | | | "
                    f"{prev['base_controller_return_mean']:.2f} | |")
    if "residual_vs_plain_mannwhitney_p" in s:
        rows += ["", f"Mann-Whitney U, residual vs plain final returns: p = "
                     f"{s['residual_vs_plain_mannwhitney_p']:.3f}."]
    return rows


def tables(results: Path) -> str:
    """The markdown of every table whose JSON exists in ``results``."""
    prev = json.loads((results / "downstream_previous.json").read_text())
    out = ["# Downstream tables (generated by benchmarks/downstream.py)", ""]
    for title, fname, fn, key in (
            ("Compensation", "compensation.json", compensation_table, "compensation"),
            ("Sampling MPC", "bench_mpc.json", mpc_table, "mpc"),
            ("highway-env axle residual", "highway_identifiers.json", highway_table, "highway"),
            ("Residual RL", "rl_residual.json", rl_table, "rl")):
        path = results / fname
        if not path.exists():
            out += [f"## {title}", "", f"({fname} missing)", ""]
            continue
        data = json.loads(path.read_text())
        if key == "rl" and "settings" not in data:
            out += [f"## {title}", "", "(rl_residual.json is from before issue 14)", ""]
            continue
        out += [f"## {title}", "", *fn(prev[key], data), ""]
    return "\n".join(out)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tables", action="store_true", help="only rebuild downstream.md")
    ap.add_argument("--out", type=Path, default=Path("benchmarks/results"))
    args = ap.parse_args(argv)
    if not args.tables:
        for script in STUDIES:
            t0 = time.time()
            print(f"[downstream] {script} ...", file=sys.stderr, flush=True)
            subprocess.run([sys.executable, str(HERE / script), "--out", str(args.out)],
                           check=True, stdout=subprocess.DEVNULL)
            print(f"[downstream] {script}: {time.time() - t0:.0f} s", file=sys.stderr,
                  flush=True)
    md = tables(args.out)
    (args.out / "downstream.md").write_text(md + "\n")
    print(md)


if __name__ == "__main__":
    main()
