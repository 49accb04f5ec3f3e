"""Held-out artefact variants of mechanical logs: where the diagnosis does not generalise.

The diagnosis was tuned on the presets of :data:`simgap.diagnosis.artefacts.ARTEFACTS`
(encoder 2π/4096 with a backward difference, denoised velocity, coloured noise, 100 Hz,
jitter, one gap, 15 s). This benchmark builds *variants* it was never tuned on, on the
2-DOF arm, and scores them the same way (:func:`simgap.diagnosis.proof.run_case`): an effect
named at the right channel within :data:`~simgap.diagnosis.proof.TOLERANCE` and no other
effect named beside it (``ok``; the artefact table counts such extras apart); clean logs of
every variant: no effect named; effects outside :data:`~simgap.diagnosis.proof.RANGES`
(half the lower end, twice the upper end): never a wrong effect named ("not confidently
wrong"). The variants are deliberately *not* added to the presets' table.

Variants (:data:`VARIANTS`): encoders of 2^10 / 2^20 counts per revolution with a backward
difference and 2^12 with a device-style filtered difference; angles low-passed upstream by
a causal 2nd-order Butterworth (20 Hz, and 10 Hz with the velocity from a moving
average); a torque column quantised by a 12-bit DAC or clipped at a saturation limit;
logging rates 50, 200 and 1000 Hz; large time-stamp jitter; three gaps; unix time stamps
(t0 ≈ 1.7e9 s); a 120 s and an 8 s log; a heavier and a lighter arm as the nominal; effect
sizes at a tenth and half the lower end and twice the upper end of the proof's ranges.

Quick mode (default; CI runs a slice of it through ``tests/test_benchmarks.py``) runs
``--variants``/``--effects`` given on the command line; the full table (every variant, the
default effects, 1 seed, 5 clean logs per variant) runs with ``--full`` or SIMGAP_SLOW=1.

    .venv/bin/python benchmarks/diagnosis_variants.py [--full] [--seeds 1] [--clean 5] \
        [--variants enc_2p10,rate_50hz] [--effects coulomb_friction] [--out F.json]
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from _results import clean_counts, markdown_table, write_table
from scipy.signal import butter, lfilter

from simgap.diagnosis import artefacts as art
from simgap.diagnosis.generate import InjectedEffect, generate
from simgap.diagnosis.proof import RANGES, TOLERANCE, draw, run_case
from simgap.errors import SimgapError
from simgap.models import manipulator as man
from simgap.recordings import Recording

MODEL = "manipulator2dof"
PAIRS = {"dq1": "q1", "dq2": "q2"}
TORQUES = ("tau1", "tau2")
#: Effects of the full table: one of each family (friction, offset, stiffness, mass).
DEFAULT_EFFECTS = ("coulomb_friction", "viscous_friction", "torque_bias", "spring",
                   "payload_mass", "inertia_mismatch")
#: Quick mode's default slice.
QUICK_VARIANTS = ("enc_2p10", "butter_10hz_ma", "rate_50hz")
QUICK_EFFECTS = ("coulomb_friction",)

Transform = Callable[[Recording, np.random.Generator], Recording]


def _noted(rec: Recording, cols: Mapping[str, np.ndarray], what: str) -> Recording:
    c = dict(rec.columns)
    c.update({k: np.asarray(v, dtype=np.float64) for k, v in cols.items()})
    meta = dict(rec.meta)
    meta["artefacts"] = [*rec.meta.get("artefacts", []), what]
    return Recording(rec.name, c, meta)


def filtered_difference(rec: Recording, window: int) -> Recording:
    """Velocity as a drive computes it: backward difference, then a causal moving average.

    Args:
        rec: the recording.
        window: moving-average length (samples).
    """
    fd = art.finite_difference(rec, PAIRS)
    k = np.full(window, 1.0 / window)
    return _noted(fd, {v: lfilter(k, [1.0], fd[v]) for v in PAIRS},
                  f"filtered_difference(ma{window})")


def butter_lowpass(rec: Recording, columns: list[str], cutoff_hz: float) -> Recording:
    """Causal 2nd-order Butterworth low-pass of ``columns`` (phase-lagging, as a drive)."""
    fs = 1.0 / float(np.median(np.diff(rec.t)))
    b, a = butter(2, cutoff_hz, fs=fs)
    out = {}
    for c in columns:
        x = rec[c]
        out[c] = x[0] + lfilter(b, a, x - x[0])          # start at rest on the first value
    return _noted(rec, out, f"butter2({','.join(columns)}, {cutoff_hz:g} Hz)")


def moving_average(rec: Recording, columns: list[str], window: int) -> Recording:
    """Causal moving average of ``columns`` over ``window`` samples."""
    k = np.full(window, 1.0 / window)
    out = {}
    for c in columns:
        x = rec[c]
        out[c] = x[0] + lfilter(k, [1.0], x - x[0])
    return _noted(rec, out, f"moving_average({','.join(columns)}, {window})")


def dac_quantise(rec: Recording, bits: int, headroom: float = 1.25) -> Recording:
    """Torque columns quantised by a DAC of ``bits`` over ±headroom·max|τ| (N·m)."""
    out = {}
    for c in TORQUES:
        full = headroom * float(np.max(np.abs(rec[c])))
        step = 2.0 * full / (2**bits)
        out[c] = np.round(rec[c] / step) * step
    return _noted(rec, out, f"dac({bits} bit)")


def clip_torque(rec: Recording, share: float) -> Recording:
    """Logged torques clipped at the (1 − share) quantile of |τ| (a saturated log column).

    The plant received the unclipped torque: the logged column is wrong on the clipped
    samples, as when a drive logs its saturated command limit.
    """
    out = {}
    for c in TORQUES:
        lim = float(np.quantile(np.abs(rec[c]), 1.0 - share))
        out[c] = np.clip(rec[c], -lim, lim)
    return _noted(rec, out, f"clip_torque({share:.0%})")


def unix_time(rec: Recording, t0: float = 1.7e9) -> Recording:
    """Time stamps in unix time (s): t0 + t."""
    return _noted(rec, {"t": rec.t + t0}, f"unix_time({t0:.3g})")


def gaps(rec: Recording, starts: tuple[float, ...], length: float) -> Recording:
    """Several gaps: at each share of the span in ``starts``, ``length`` share missing."""
    span = float(rec.t[-1] - rec.t[0])
    out = rec
    for s in sorted(starts, reverse=True):           # later gaps first: shares stay valid
        out = art.cut_gap(out, s * span, length * span)
    return out


@dataclass(frozen=True, kw_only=True)
class Variant:
    """One held-out artefact variant.

    Attributes:
        name: short name.
        description: one line.
        transform: recording -> recording (seeded generator for random parts).
        generate: keyword arguments of the generator (rate (Hz), duration (s)).
        nominal: nominal parameter overrides (``ManipulatorParams`` fields); the generator
            uses the same nominal as the plant's base and the diagnosis as its model.
        effect_scale: None (draw within RANGES) or a factor applied to a range's lower end
            (< 1: below it) or upper end (> 1: beyond it).
    """

    name: str
    description: str
    transform: Transform = lambda r, g: r
    generate: Mapping[str, Any] = field(default_factory=dict)
    nominal: Mapping[str, float] = field(default_factory=dict)
    effect_scale: float | None = None


_ENC = lambda bits: (lambda r, g: art.finite_difference(  # noqa: E731
    art.quantise(r, list(PAIRS.values()), 2 * np.pi / 2**bits), PAIRS))
_HEAVY = {"m": 2.465 * 1.6, "I": 0.06911 * 1.6}
_LIGHT = {"m": 2.465 * 0.5, "I": 0.06911 * 0.5}

VARIANTS: dict[str, Variant] = {v.name: v for v in (
    Variant(name="enc_2p10", description="encoder 2^10 counts/rev, backward difference",
            transform=_ENC(10)),
    Variant(name="enc_2p12_filtdiff",
            description="encoder 2^12 counts/rev, difference + 8-sample moving average",
            transform=lambda r, g: filtered_difference(
                art.quantise(r, list(PAIRS.values()), 2 * np.pi / 2**12), 8)),
    Variant(name="enc_2p20", description="encoder 2^20 counts/rev, backward difference",
            transform=_ENC(20)),
    Variant(name="butter_20hz", description="q and dq low-passed upstream (Butterworth "
            "2nd order, 20 Hz, causal)",
            transform=lambda r, g: butter_lowpass(r, ["q1", "q2", "dq1", "dq2"], 20.0)),
    Variant(name="butter_10hz_ma", description="q low-passed upstream (Butterworth 2nd "
            "order, 10 Hz, causal), dq from a 10-sample moving average",
            transform=lambda r, g: moving_average(
                butter_lowpass(r, ["q1", "q2"], 10.0), ["dq1", "dq2"], 10)),
    Variant(name="tau_dac12", description="torque quantised by a 12-bit DAC",
            transform=lambda r, g: dac_quantise(r, 12)),
    Variant(name="tau_clip", description="logged torque clipped at its 98th percentile",
            transform=lambda r, g: clip_torque(r, 0.02)),
    Variant(name="rate_50hz", description="logged at 50 Hz (no anti-aliasing)",
            transform=lambda r, g: art.downsample(r, 50.0)),
    Variant(name="rate_200hz", description="recorded and controlled at 200 Hz",
            generate={"rate": 200.0}),
    Variant(name="rate_1000hz", description="recorded and controlled at 1000 Hz",
            generate={"rate": 1000.0}),
    Variant(name="jitter_large", description="time stamps off by 40 % of a step (std)",
            transform=lambda r, g: art.jitter(r, 0.4 * float(np.median(np.diff(r.t))), g)),
    Variant(name="three_gaps", description="three 8 % gaps",
            transform=lambda r, g: gaps(r, (0.2, 0.45, 0.7), 0.08)),
    Variant(name="unix_time", description="time stamps in unix time (t0 = 1.7e9 s)",
            transform=lambda r, g: unix_time(r)),
    Variant(name="long_120s", description="a 120 s log", generate={"duration": 120.0}),
    Variant(name="short_8s", description="an 8 s log", generate={"duration": 8.0}),
    Variant(name="heavy_arm", description="nominal arm 1.6x heavier (m, I)", nominal=_HEAVY),
    Variant(name="light_arm", description="nominal arm 0.5x lighter (m, I)", nominal=_LIGHT),
    Variant(name="effects_below", description="effects at half the lower end of RANGES",
            effect_scale=0.5),
    Variant(name="effects_far_below", description="effects at a tenth of the lower end of "
            "RANGES", effect_scale=0.1),
    Variant(name="effects_beyond", description="effects at twice the upper end of RANGES",
            effect_scale=2.0),
)}


def scaled_draw(name: str, rng: np.random.Generator, scale: float | None) -> InjectedEffect:
    """:func:`proof.draw`, or with each parameter moved to ``scale`` × a range end."""
    inj = draw(name, rng)
    if scale is None:
        return inj
    params = {}
    for k, (lo, hi, _) in RANGES[name][2].items():
        v = inj.params[k]
        edge = lo * scale if scale < 1 else hi * scale
        params[k] = float(np.sign(v) * edge) if k != "q0" else v  # q0: a position, kept
    return dataclasses.replace(inj, params=params)


def recording(v: Variant, effects: list[InjectedEffect], seed: int) -> Recording:
    """The variant's recording of ``effects`` (seeded)."""
    kw: dict[str, Any] = {"seed": seed, "duration": 20.0, **v.generate}
    if v.nominal:
        kw["params"] = man.ManipulatorParams(**v.nominal)
    rec = generate(MODEL, effects, **kw)
    return v.transform(rec, np.random.default_rng(9000 + seed))


def score(v: Variant, effects: list[InjectedEffect], seed: int) -> dict[str, Any]:
    """Diagnose one case blind and score it (``error`` on a refused recording)."""
    try:
        rec = recording(v, effects, seed)
        r = run_case(effects, MODEL, seed, recording=rec, params=dict(v.nominal) or None)
    except SimgapError as err:
        return {"error": str(err)[:300]}
    inj = {e.effect for e in effects}
    wrong = [f"{e['effect']}@{e['channel']}" for e in r.found if e["effect"] not in inj]
    return {"named": r.named, "param_error": r.param_error, "extra": r.extra,
            "found": [f"{e['effect']}@{e['channel']}" for e in r.found],
            "found_params": [e["parameters"] for e in r.found],
            "significant": r.significant, "wrong": wrong,
            "ok": (r.named and r.param_error <= TOLERANCE and not wrong)
            if v.effect_scale is None or v.effect_scale > 1 else not wrong}


def summarise(rows: list[dict], clean: list[dict]) -> dict[str, dict]:
    """Per variant: effects right; clean logs with effects named or flagged."""
    out = {}
    for name in dict.fromkeys([r["variant"] for r in rows + clean]):
        mine = [r for r in rows if r["variant"] == name]
        cl = [r for r in clean if r["variant"] == name]
        out[name] = {"cases": len(mine), "ok": sum(bool(r.get("ok")) for r in mine),
                     "named_within_tolerance": sum(bool(r.get("named")) and
                                                   r.get("param_error", 1e9) <= TOLERANCE
                                                   for r in mine),
                     "wrong_effect_named": sum(bool(r.get("wrong")) for r in mine),
                     "named_with_extra_effects": sum(bool(r.get("extra")) for r in mine),
                     "errors": sum("error" in r for r in mine + cl), **clean_counts(cl)}
    return out


def markdown(summary: Mapping[str, Mapping[str, int]]) -> str:
    """The summary as a Markdown table."""
    return "\n".join(markdown_table("variant", [
        ("cases", "cases"), ("ok", "ok"), ("within tolerance", "named_within_tolerance"),
        ("wrong effect named", "wrong_effect_named"),
        ("with extra effects", "named_with_extra_effects"), ("errors", "errors"),
        ("clean", "clean"), ("clean with named effects", "clean_with_named_effects"),
        ("clean flagged", "clean_flagged_mismatch")], summary))


def main(argv: list[str] | None = None) -> dict[str, Any]:
    """Run the table; print Markdown on stderr and JSON on stdout (and to ``--out``)."""
    ap = argparse.ArgumentParser()
    ap.add_argument("--full", action="store_true",
                    help="every variant, the default effects (also SIMGAP_SLOW=1)")
    ap.add_argument("--seeds", type=int, default=1)
    ap.add_argument("--first-seed", type=int, default=0, help="effect seeds first-seed …")
    ap.add_argument("--clean", type=int, default=None, help="clean logs per variant "
                    "(default 5 full, 1 quick)")
    ap.add_argument("--variants", default=None)
    ap.add_argument("--effects", default=None)
    ap.add_argument("--clean-only", action="store_true")
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)
    full = args.full or os.environ.get("SIMGAP_SLOW") == "1"
    variants = (args.variants.split(",") if args.variants else
                list(VARIANTS) if full else list(QUICK_VARIANTS))
    effects = (args.effects.split(",") if args.effects else
               list(DEFAULT_EFFECTS) if full else list(QUICK_EFFECTS))
    n_clean = args.clean if args.clean is not None else (5 if full else 1)
    unknown = [v for v in variants if v not in VARIANTS] + \
        [e for e in effects if e not in RANGES or RANGES[e][0] != MODEL]
    if unknown:
        ap.error(f"unknown variant or arm effect: {unknown[0]}")
    t0 = time.perf_counter()
    rows, clean = [], []
    for name in variants:
        v = VARIANTS[name]
        for seed in range(n_clean):
            res = score(v, [], 500 + seed)
            clean.append({"variant": name, "seed": 500 + seed, **res})
            print(f"[{time.perf_counter() - t0:7.1f} s] {name} clean {seed}: "
                  f"{res.get('error') or res['found'] or res['significant']}", file=sys.stderr)
        for eff in ([] if args.clean_only else effects):
            for seed in range(args.first_seed, args.first_seed + args.seeds):
                inj = scaled_draw(eff, np.random.default_rng(1000 + seed), v.effect_scale)
                res = score(v, [inj], seed)
                rows.append({"variant": name, "effect": eff, "seed": seed,
                             "channel": inj.channel, "injected": inj.params, **res})
                print(f"[{time.perf_counter() - t0:7.1f} s] {name} {eff} {seed}: "
                      f"{res.get('error') or (res['ok'], res['found'])}", file=sys.stderr)
    summary = summarise(rows, clean)
    out = {"variants": {k: VARIANTS[k].description for k in variants}, "effects": effects,
           "seeds": args.seeds, "tolerance": TOLERANCE, "summary": summary, "rows": rows,
           "clean": clean, "seconds": time.perf_counter() - t0}
    write_table(out, markdown(summary), args.out)
    return out


if __name__ == "__main__":
    main()
