"""Real EMPS and race-car logs through realistic degradations: does the diagnosis agree with itself?

The REAL recordings in ``../shared/data/real`` (never copied into the repository) are read
once and degraded in memory the way real logs differ from a laboratory log (issue 13):
the position re-quantised at a coarser encoder resolution, the log downsampled to 100 / 50 Hz
with and without an anti-alias filter, a velocity column filtered upstream (low-pass or
median), gaps cut out, only one direction of motion kept, only a short 10-20 s piece kept,
coloured noise added, and the columns given in other units (mapped back by a column map,
printed with seven significant digits).

Each degraded log is diagnosed blind and scored against the answer on the undegraded log
(the *reference*), effect by effect:

=================  =========================================================================
``agree``          the same effect at the same channel, every parameter within
                   ``Z_AGREE`` combined standard errors of the reference's
``off``            the same effect at the same channel, a parameter further away
``cannot tell``    not named, and the report says why (not identifiable, fitted as a
                   combination, or not testable on the held-out part)
``missed``         not named and nothing said about it
``different``      a named effect (or channel) that the reference does not name: a
                   confidently different answer, always a failure
=================  =========================================================================

A degraded log passes when it has no ``different``, ``off`` or ``missed`` (``cannot tell``
is an honest answer where the degradation removed the information: one direction of motion
cannot separate a Coulomb friction from a constant bias).

    .venv/bin/python benchmarks/diagnosis_real_degraded.py [--quick] [--only emps] \
        [--cases quant_10um,down_100] [--out F.json]

``--quick`` runs the CI subset (``QUICK``); ``tests/diagnosis/test_real_degraded.py`` runs
it in under 60 s, the full set behind ``SIMGAP_SLOW=1``.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from scipy.ndimage import median_filter
from scipy.signal import butter, decimate, lfilter

from simgap.diagnosis.artefacts import coloured_noise, cut_gap, quantise
from simgap.errors import SimgapError
from simgap.recordings import Recording

REPO_ROOT = Path(__file__).resolve().parents[1]
SHARED = REPO_ROOT.parent / "shared" / "data" / "real"
EMPS_FILE = SHARED / "emps" / "emps_estimation.csv"
RACECAR_FILE = SHARED / "racecar_sideslip_100hz" / "racecar_sideslip_100hz.csv"
EMPS_SPEC = f"{REPO_ROOT / 'examples' / 'emps_model.py'}:EMPS"
RACECAR_SPEC = f"{REPO_ROOT / 'examples' / 'racecar_model.py'}:RACECAR"
#: Race-car rows diagnosed (150-400 s: the CI slice of ``test_real_racecar.py``); the full
#: run (``--full-racecar``) uses all 55,001.
RACECAR_ROWS = 25_000
#: Parameters agree when |degraded − reference| ≤ Z_AGREE · sqrt(se_d² + se_ref²).
Z_AGREE = 3.0


# --------------------------------------------------------------------------- data
def load_emps() -> Recording:
    """The EMPS estimation log in the model's canonical columns t (s), q (m), u (N)."""
    from simgap.diagnosis.user_models import column_map_of, load_model_file
    from simgap.recordings import RecordingSchema, read

    model = load_model_file(EMPS_SPEC)
    return read(EMPS_FILE, RecordingSchema.of(model), column_map_of(model))


def load_racecar(rows: int | None = RACECAR_ROWS) -> Recording:
    """The race-car log in canonical columns (t, vx, vy, r, delta_f, delta_r), despiked."""
    from simgap.diagnosis.user_models import column_map_of, load_model_file
    from simgap.recordings import RecordingSchema, read

    model = load_model_file(RACECAR_SPEC)
    rec = read(RACECAR_FILE, RecordingSchema.of(model), column_map_of(model))
    if rows is None:
        return rec
    return Recording(rec.name, {k: v[:rows] for k, v in rec.columns.items()}, rec.meta)


# --------------------------------------------------------------------------- degradations
def _keep(rec: Recording, keep: np.ndarray, what: str) -> Recording:
    meta = dict(rec.meta)
    meta["artefacts"] = [*rec.meta.get("artefacts", []), what]
    return Recording(rec.name, {k: v[keep] for k, v in rec.columns.items()}, meta)


def _replace(rec: Recording, cols: dict[str, np.ndarray], what: str) -> Recording:
    meta = dict(rec.meta)
    meta["artefacts"] = [*rec.meta.get("artefacts", []), what]
    return Recording(rec.name, {**rec.columns, **cols}, meta)


def every_kth(rec: Recording, rate_hz: float) -> Recording:
    """Keep every k-th sample (no anti-alias filter), rate closest to ``rate_hz``."""
    dt = float(np.median(np.diff(rec.t)))
    k = max(1, int(round(1.0 / (rate_hz * dt))))
    return _keep(rec, np.arange(rec.n) % k == 0, f"every {k}th sample")


def decimated(rec: Recording, rate_hz: float) -> Recording:
    """Anti-alias filter (zero-phase FIR, as a logger's CIC/FIR stage) then every k-th sample.

    Every column except time is filtered: the logger filters what it records.
    """
    dt = float(np.median(np.diff(rec.t)))
    k = max(1, int(round(1.0 / (rate_hz * dt))))
    cols = {c: (v[::k] if c == "t" else decimate(v, k, ftype="fir", zero_phase=True))
            for c, v in rec.columns.items()}
    meta = dict(rec.meta)
    meta["artefacts"] = [*rec.meta.get("artefacts", []), f"decimate by {k} (FIR)"]
    return Recording(rec.name, cols, meta)


def with_velocity(rec: Recording, how: str) -> Recording:
    """Add a velocity column ``dq`` as a drive computes it, then filtered upstream.

    The EMPS controller's own velocity: first difference of the 2-tap averaged position
    (data README). ``how``: ``"lowpass"`` (causal 2nd-order Butterworth at 20 Hz, the
    position loop's bandwidth), ``"median"`` (7-sample running median) or ``"raw"``.
    """
    dt = float(np.median(np.diff(rec.t)))
    qf = rec["q"].copy()
    qf[1:] = 0.5 * (rec["q"][1:] + rec["q"][:-1])
    dq = np.empty_like(qf)
    dq[1:] = np.diff(qf) / dt
    dq[0] = dq[1]
    if how == "lowpass":
        b, a = butter(2, 20.0 * 2.0 * dt)
        dq = lfilter(b, a, dq - dq[0]) + dq[0]
    elif how == "median":
        dq = median_filter(dq, size=7, mode="nearest")
    return _replace(rec, {"dq": dq}, f"velocity column ({how})")


def lowpass_states(rec: Recording, columns: list[str], cutoff_hz: float) -> Recording:
    """Causal 2nd-order Butterworth on ``columns`` (a logger's upstream filter)."""
    dt = float(np.median(np.diff(rec.t)))
    b, a = butter(2, cutoff_hz * 2.0 * dt)
    return _replace(rec, {c: lfilter(b, a, rec[c] - rec[c][0]) + rec[c][0] for c in columns},
                    f"lowpass {cutoff_hz:g} Hz ({','.join(columns)})")


def median_states(rec: Recording, columns: list[str], size: int) -> Recording:
    """Running median of ``size`` samples on ``columns``."""
    return _replace(rec, {c: median_filter(rec[c], size=size, mode="nearest") for c in columns},
                    f"median {size} ({','.join(columns)})")


def piece(rec: Recording, start: float, length: float) -> Recording:
    """Keep ``start <= t - t0 < start + length`` (s)."""
    rel = rec.t - rec.t[0]
    return _keep(rec, (rel >= start) & (rel < start + length), f"piece {start:g}+{length:g} s")


def one_direction(rec: Recording, column: str | None, sign: int, min_run: float = 0.5
                  ) -> Recording:
    """Keep only the runs where the velocity (``column``, or the SG derivative of q) has
    ``sign``; runs shorter than ``min_run`` s are dropped. The rest become gaps."""
    from scipy.signal import savgol_filter

    dt = float(np.median(np.diff(rec.t)))
    if column is None:
        v = savgol_filter(rec["q"], 2 * int(0.01 / dt) + 1, 2, deriv=1, delta=dt)
        thr = 0.005
    else:
        v = rec[column]
        thr = 0.02 * float(np.max(np.abs(v)))
    keep = sign * v > thr
    edges = np.flatnonzero(np.diff(np.concatenate([[0], keep.astype(int), [0]])))
    out = np.zeros_like(keep)
    for a, b in zip(edges[0::2], edges[1::2], strict=True):
        if (b - a) * dt >= min_run:
            out[a:b] = True
    return _keep(rec, out, f"one direction ({'+' if sign > 0 else '-'})")


def emps_other_units(rec: Recording) -> tuple[Recording, dict[str, Any]]:
    """Position in mm and the controller voltage (V), 7 significant digits, plus the map."""
    from examples.emps_model import GTAU

    def r7(x: np.ndarray) -> np.ndarray:
        return np.array([float(f"{v:.7g}") for v in x])

    raw = Recording(rec.name, {"time_s": rec.t.copy(), "pos_mm": r7(rec["q"] * 1e3),
                               "volt": r7(rec["u"] / GTAU)})
    cmap = {"t": "time_s", "q": {"source": "pos_mm", "scale": 1e-3},
            "u": {"source": "volt", "scale": GTAU}}
    return raw, cmap


def racecar_other_units(rec: Recording) -> tuple[Recording, dict[str, Any]]:
    """km/h, deg/s, degrees, 7 significant digits, plus the map back."""
    def r7(x: np.ndarray) -> np.ndarray:
        return np.array([float(f"{v:.7g}") for v in x])

    raw = Recording(rec.name, {"time_s": rec.t.copy(), "vx_kmh": r7(rec["vx"] * 3.6),
                               "vy_kmh": r7(rec["vy"] * 3.6),
                               "r_degps": r7(np.degrees(rec["r"])),
                               "steer_deg": r7(np.degrees(rec["delta_f"]))})
    cmap = {"t": "time_s", "vx": {"source": "vx_kmh", "scale": 1 / 3.6},
            "vy": {"source": "vy_kmh", "scale": 1 / 3.6},
            "r": {"source": "r_degps", "scale": np.pi / 180},
            "delta_f": {"source": "steer_deg", "scale": np.pi / 180}, "delta_r": 0.0}
    return raw, cmap


@dataclass(frozen=True, kw_only=True)
class Case:
    """One degradation of one real log.

    ``make(rec, rng)`` returns the degraded recording, or ``(recording, column_map)``.
    ``removes`` names what the degradation may honestly make untellable (effects that may
    then be "cannot tell"); a named effect absent from the reference is always a failure.
    """

    name: str
    system: str
    description: str
    make: Callable[[Recording, np.random.Generator], Any]
    removes: tuple[str, ...] = ()


CASES: dict[str, Case] = {c.name: c for c in (
    # ---------------------------------------------------------------- EMPS (1 kHz, 24.8 s)
    Case(name="emps_quant_1um", system="emps", description="position re-quantised to 1 µm "
         "(20 native counts)", make=lambda r, g: quantise(r, ["q"], 1e-6)),
    Case(name="emps_quant_10um", system="emps", description="position re-quantised to 10 µm",
         make=lambda r, g: quantise(r, ["q"], 1e-5)),
    Case(name="emps_quant_50um", system="emps", description="position re-quantised to 50 µm "
         "(0.4 count/ms at 20 mm/s)", make=lambda r, g: quantise(r, ["q"], 5e-5)),
    Case(name="emps_100hz", system="emps", description="every 10th sample (100 Hz, no "
         "anti-alias filter)", make=lambda r, g: every_kth(r, 100.0)),
    Case(name="emps_100hz_aa", system="emps", description="FIR anti-alias filter, 100 Hz",
         make=lambda r, g: decimated(r, 100.0)),
    Case(name="emps_50hz", system="emps", description="every 20th sample (50 Hz, no filter)",
         make=lambda r, g: every_kth(r, 50.0)),
    Case(name="emps_50hz_aa", system="emps", description="FIR anti-alias filter, 50 Hz",
         make=lambda r, g: decimated(r, 50.0)),
    Case(name="emps_dq_raw", system="emps", description="a velocity column: the controller's "
         "own difference of the averaged position", make=lambda r, g: with_velocity(r, "raw")),
    Case(name="emps_dq_lowpass", system="emps", description="velocity column low-passed "
         "upstream (causal Butterworth, 20 Hz)", make=lambda r, g: with_velocity(r, "lowpass")),
    Case(name="emps_dq_median", system="emps", description="velocity column median-filtered "
         "upstream (7 samples)", make=lambda r, g: with_velocity(r, "median")),
    Case(name="emps_gaps", system="emps", description="two 2 s gaps (at 7 s and 15 s)",
         make=lambda r, g: cut_gap(cut_gap(r, 15.0, 2.0), 7.0, 2.0)),
    Case(name="emps_positive_only", system="emps", description="only motion with dq > 0",
         make=lambda r, g: one_direction(r, None, +1),
         removes=("coulomb_friction", "torque_bias")),
    Case(name="emps_negative_only", system="emps", description="only motion with dq < 0",
         make=lambda r, g: one_direction(r, None, -1),
         removes=("coulomb_friction", "torque_bias")),
    Case(name="emps_first_15s", system="emps", description="0-15 s only",
         make=lambda r, g: piece(r, 0.0, 15.0)),
    Case(name="emps_last_12s", system="emps", description="12.8-24.8 s only",
         make=lambda r, g: piece(r, 12.8, 12.1)),
    Case(name="emps_coloured", system="emps", description="AR(1) noise, 20 ms: 2 µm on q, "
         "1 N on u", make=lambda r, g: coloured_noise(r, ["q", "u"], {"q": 2e-6, "u": 1.0},
                                                      0.02, g)),
    Case(name="emps_units", system="emps", description="q in mm, u in V (7 digits), mapped",
         make=lambda r, g: emps_other_units(r)),
    Case(name="emps_100hz_quant_10um", system="emps", description="10 µm encoder logged at "
         "100 Hz (no filter)", make=lambda r, g: every_kth(quantise(r, ["q"], 1e-5), 100.0)),
    # ---------------------------------------------------------------- race car (100 Hz)
    Case(name="car_50hz", system="racecar", description="every 2nd sample (50 Hz, no filter)",
         make=lambda r, g: every_kth(r, 50.0)),
    Case(name="car_50hz_aa", system="racecar", description="FIR anti-alias filter, 50 Hz",
         make=lambda r, g: decimated(r, 50.0)),
    Case(name="car_lowpass", system="racecar", description="vy, r low-passed upstream "
         "(causal Butterworth, 5 Hz)", make=lambda r, g: lowpass_states(r, ["vy", "r"], 5.0)),
    Case(name="car_median", system="racecar", description="vy, r median-filtered upstream "
         "(5 samples)", make=lambda r, g: median_states(r, ["vy", "r"], 5)),
    Case(name="car_gaps", system="racecar", description="two 10 s gaps",
         make=lambda r, g: cut_gap(cut_gap(r, 160.0, 10.0), 60.0, 10.0)),
    Case(name="car_left_only", system="racecar", description="only left turns (r > 0)",
         make=lambda r, g: one_direction(r, "r", +1, min_run=1.0),
         removes=("tire_saturation", "yaw_bias", "lateral_bias")),
    Case(name="car_first_20s", system="racecar", description="0-20 s only",
         make=lambda r, g: piece(r, 0.0, 20.0), removes=("tire_saturation",)),
    Case(name="car_coloured", system="racecar", description="AR(1) noise, 50 ms: 0.02 m/s on "
         "vy, 0.005 rad/s on r", make=lambda r, g: coloured_noise(
             r, ["vy", "r"], {"vy": 0.02, "r": 0.005}, 0.05, g)),
    Case(name="car_units", system="racecar", description="km/h, deg/s, degrees (7 digits), "
         "mapped", make=lambda r, g: racecar_other_units(r)),
)}

#: The CI subset (``--quick``): one case per kind of degradation that runs in seconds.
QUICK = ("emps_quant_50um", "emps_100hz", "emps_dq_lowpass", "emps_gaps",
         "emps_positive_only", "emps_units")


# --------------------------------------------------------------------------- scoring
def _diagnose(system: str, made: Any) -> Any:
    from simgap.diagnosis.pipeline import diagnose

    rec, cmap = made if isinstance(made, tuple) else (made, None)
    spec = EMPS_SPEC if system == "emps" else RACECAR_SPEC
    return diagnose(rec, spec, columns=cmap)


def effects_of(report: Any) -> dict[tuple[str, str], dict[str, Any]]:
    """Named effects keyed by (effect, channel)."""
    return {(e["effect"], e["channel"]): e for e in report.data["effects"]}


#: Constant effects: on one direction of motion they are the same regressor as a friction
#: whose sign follows the direction, so a report that says so has said why for them too.
CONSTANT_EFFECTS = ("torque_bias", "lateral_bias", "yaw_bias")


def _said_why(report: Any, effect: str, channel: str) -> str | None:
    """The report's own reason when ``effect`` at ``channel`` is not named, else None.

    A "No mismatch beyond the noise" verdict never says why: it claims the nominal model
    explains the log.
    """
    if report.data.get("verdict", "").startswith("No mismatch"):
        return None
    for t in report.data.get("tried", []):
        if t["effect"] == effect and t.get("channel") == channel and t.get("decision") in (
                "not identifiable", "combination", "cannot test"):
            return f"{t['decision']}: {t.get('reason', '')}"[:200]
    if effect in CONSTANT_EFFECTS:
        for t in report.data.get("tried", []):
            if t.get("channel") == channel and "one direction" in str(t.get("reason", "")):
                return f"one direction: {t['reason']}"[:200]
    v = report.data.get("verdict", "")
    if effect in v and ("Not identifiable" in v or "Not determined" in v):
        return "verdict: not identifiable / not determined"
    return None


def score(ref: dict[tuple[str, str], dict], report: Any, removes: tuple[str, ...] = ()
          ) -> dict[str, Any]:
    """Compare a degraded log's report with the reference effects (see the module doc)."""
    got = effects_of(report)
    rows = []
    for key, e in ref.items():
        if key in got:
            g = got[key]
            zs = {}
            for k, v in e["parameters"].items():
                se = float(np.hypot(e["stderr"].get(k, 0.0), g["stderr"].get(k, 0.0)))
                zs[k] = abs(g["parameters"][k] - v) / se if se > 0 else float("inf")
            ok = all(z <= Z_AGREE for z in zs.values())
            rows.append({"effect": key[0], "channel": key[1],
                         "outcome": "agree" if ok else "off",
                         "reference": e["parameters"], "reference_se": e["stderr"],
                         "degraded": g["parameters"], "degraded_se": g["stderr"],
                         "z": {k: round(z, 2) for k, z in zs.items()}})
        else:
            why = _said_why(report, *key)
            rows.append({"effect": key[0], "channel": key[1],
                         "outcome": "cannot tell" if why else "missed", "why": why,
                         "expected_loss": key[0] in removes})
    for key, g in got.items():
        if key not in ref:
            rows.append({"effect": key[0], "channel": key[1], "outcome": "different",
                         "degraded": g["parameters"], "degraded_se": g["stderr"],
                         "explained_fraction": g.get("explained_fraction")})
    outcomes = [r["outcome"] for r in rows]
    # "missed" fails even where the degradation removed the information: the report must
    # then say "cannot tell", not that the nominal model explains the log
    passed = not any(o in ("different", "off", "missed") for o in outcomes)
    return {"rows": rows, "passed": bool(passed), "verdict": report.data["verdict"],
            "warnings": [w["text"] if isinstance(w, dict) else str(w)
                         for w in report.data.get("warnings", [])],
            "signal_notes": report.data["processing"].get("signal_notes", []),
            "window": report.data["processing"].get("savgol_window_samples"),
            "samples": report.data["samples"]}


def run(cases: list[str], *, seed: int = 0, racecar_rows: int | None = RACECAR_ROWS,
        progress: bool = True) -> dict[str, Any]:
    """Diagnose the references and every degraded log; the scored table."""
    systems = sorted({CASES[c].system for c in cases})
    base = {"emps": load_emps} if "emps" in systems else {}
    if "racecar" in systems:
        base["racecar"] = lambda: load_racecar(racecar_rows)
    recs = {s: f() for s, f in base.items()}
    refs, out = {}, {"reference": {}, "cases": {}, "z_agree": Z_AGREE,
                     "racecar_rows": racecar_rows}
    for s, rec in recs.items():
        t0 = time.perf_counter()
        rep = _diagnose(s, rec)
        refs[s] = effects_of(rep)
        out["reference"][s] = {"effects": [{"effect": k[0], "channel": k[1], **{
            x: v[x] for x in ("parameters", "stderr")}} for k, v in refs[s].items()],
            "verdict": rep.data["verdict"], "seconds": round(time.perf_counter() - t0, 2)}
        if progress:
            print(f"reference {s}: {rep.data['verdict'][:160]}", file=sys.stderr)
    for name in cases:
        case = CASES[name]
        rng = np.random.default_rng(seed)
        t0 = time.perf_counter()
        try:
            rep = _diagnose(case.system, case.make(recs[case.system], rng))
            res = score(refs[case.system], rep, case.removes)
        except SimgapError as err:
            res = {"error": f"{type(err).__name__}: {err}", "passed": False, "rows": []}
        res["description"] = case.description
        res["seconds"] = round(time.perf_counter() - t0, 2)
        out["cases"][name] = res
        if progress:
            print(f"{name}: {'pass' if res['passed'] else 'FAIL'} "
                  f"{[(r['effect'], r['outcome']) for r in res['rows']]} "
                  f"{res.get('error', '')} ({res['seconds']} s)", file=sys.stderr)
    return out


def markdown(out: dict[str, Any]) -> str:
    """The scored table as Markdown."""
    lines = ["| case | passed | outcomes | verdict (start) |", "|---|---|---|---|"]
    for name, res in out["cases"].items():
        oc = "; ".join(f"{r['effect']}@{r['channel']}: {r['outcome']}"
                       + (f" (z {max(r['z'].values()):.1f})" if r.get("z") else "")
                       for r in res["rows"]) or res.get("error", "")
        lines.append(f"| {name} | {'yes' if res['passed'] else 'NO'} | {oc} | "
                     f"{res.get('verdict', '')[:90]} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """Command line: run, print the Markdown table on stderr, write JSON."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="the CI subset")
    ap.add_argument("--only", choices=("emps", "racecar"), default=None)
    ap.add_argument("--cases", default=None, help="comma-separated case names")
    ap.add_argument("--full-racecar", action="store_true", help="all 55,001 race-car rows")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)
    names = list(QUICK) if args.quick else list(CASES)
    if args.cases:
        names = args.cases.split(",")
    if args.only:
        names = [n for n in names if CASES[n].system == args.only]
    t0 = time.perf_counter()
    out = run(names, seed=args.seed, racecar_rows=None if args.full_racecar else RACECAR_ROWS)
    out["seconds"] = round(time.perf_counter() - t0, 1)
    print(markdown(out), file=sys.stderr)
    passed = sum(r["passed"] for r in out["cases"].values())
    print(f"{passed}/{len(out['cases'])} degraded logs agree ({out['seconds']} s)",
          file=sys.stderr)
    if args.out:
        args.out.write_text(json.dumps(out, indent=1, default=float))
    return 0


if __name__ == "__main__":
    sys.path.insert(0, str(REPO_ROOT))
    raise SystemExit(main())
