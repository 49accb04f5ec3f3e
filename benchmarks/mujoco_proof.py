"""Proof of the MJCF diagnosis with an independent truth: logs made by MuJoCo itself.

For each system (the thesis arm as MJCF, Gymnasium's Reacher MJCF) and each hidden
difference (joint damping, frictionloss, armature, a payload body, an actuator delay, and
none), a "real" MJCF is made from the nominal one, MuJoCo simulates it under PD tracking
(simgap.diagnosis.mjcf_record), and ``diagnose_mjcf`` runs against the nominal MJCF. The
table records what was named where with which parameter error, and MuJoCo's own held-out
position RMSE of the original vs the corrected MJCF. Timings: first compile, recording,
diagnosis per second of log (CPU load stated by ``uptime``).

    python benchmarks/mujoco_proof.py [--quick] [--out benchmarks/results/mujoco_proof.json]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

import gymnasium
import mujoco
import numpy as np
import pandas as pd

from simgap.diagnosis.mjcf_record import record_mjcf
from simgap.diagnosis.mujoco import diagnose_mjcf

ROOT = Path(__file__).resolve().parents[1]
ARM = ROOT / "examples" / "mujoco" / "arm2dof.xml"
REACHER = Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets" / "reacher.xml"


def _joint(xml: str, name: str, attrs: str) -> str:
    for old in (f'name="{name}" type="hinge" axis="0 0 1"', f'limited="false" name="{name}"',
                f'limited="true" name="{name}"'):
        if old in xml:
            return xml.replace(old, f"{old} {attrs}", 1)
    raise KeyError(name)


SYSTEMS = {
    "arm2dof": {
        "xml": ARM, "joints": None, "control_dt": 0.002,
        "cases": {
            "clean": (lambda x: x, None),
            "damping": (lambda x: _joint(x, "elbow", 'damping="0.3"'),
                        ("viscous_friction", "elbow", "b", 0.3)),
            "frictionloss": (lambda x: _joint(x, "shoulder", 'frictionloss="0.5"'),
                             ("coulomb_friction", "shoulder", "Fc", 0.5)),
            "armature": (lambda x: x.replace(
                'name="elbow" type="hinge" axis="0 0 1" armature="0.008118"',
                'name="elbow" type="hinge" axis="0 0 1" armature="0.028118"'),
                ("inertia_mismatch", "elbow", "dI", 0.02)),
            "payload": (lambda x: x.replace(
                '<site name="tip" pos="0.2 0 0"/>',
                '<site name="tip" pos="0.2 0 0"/><body name="load" pos="0.2 0 0"><inertial '
                'pos="0 0 0" mass="0.5" diaginertia="1e-6 1e-6 1e-6"/></body>'),
                ("payload_mass", None, "mp", 0.5)),
            "delay": (lambda x: x.replace(
                '<motor name="shoulder_motor" joint="shoulder" gear="1"/>',
                '<motor name="shoulder_motor" joint="shoulder" gear="1" delay="0.01" '
                'nsample="12"/>'), ("input_delay", "shoulder", "delay", 0.01)),
        },
    },
    "reacher": {
        "xml": REACHER, "joints": ["joint0", "joint1"], "control_dt": 0.01,
        "cases": {
            "clean": (lambda x: x, None),
            "damping": (lambda x: _joint(x, "joint1", 'damping="1.5"'),
                        ("viscous_friction", "joint1", "b", 0.5)),
            "frictionloss": (lambda x: _joint(x, "joint0", 'frictionloss="2.0"'),
                             ("coulomb_friction", "joint0", "Fc", 2.0)),
            "armature": (lambda x: _joint(x, "joint1", 'armature="1.3"'),
                         ("inertia_mismatch", "joint1", "dI", 0.3)),
            "payload": (lambda x: x.replace(
                '<geom contype="0" name="fingertip"',
                '<body name="load"><inertial pos="0 0 0" mass="2.0" diaginertia="1e-6 1e-6 '
                '1e-6"/></body><geom contype="0" name="fingertip"'),
                ("payload_mass", None, "mp", 2.0)),
            "delay": (lambda x: x.replace(
                'gear="200.0" joint="joint0"/>',
                'gear="200.0" joint="joint0" delay="0.02" nsample="4"/>'),
                ("input_delay", "joint0", "delay", 0.02)),
        },
    },
}


def run_case(system: dict, name: str, duration: float, tmp: Path) -> dict:
    make, truth = system["cases"][name]
    real_xml = make(system["xml"].read_text())
    t0 = time.perf_counter()
    real = mujoco.MjModel.from_xml_string(real_xml)
    cols = record_mjcf(real, joints=system["joints"], duration=duration,
                       control_dt=system["control_dt"], seed=11)
    t1 = time.perf_counter()
    log = tmp / f"{name}.csv"
    pd.DataFrame(cols).to_csv(log, index=False)
    t2 = time.perf_counter()
    rep = diagnose_mjcf(system["xml"], log, joints=system["joints"])
    t3 = time.perf_counter()
    named = [{"effect": e["effect"], "channel": e["channel"], "parameters": e["parameters"],
              "stderr": e["stderr"]} for e in rep.effects]
    row = {"case": name, "truth": None, "named": named,
           "mjcf_changes": rep.data["mjcf"]["changes"],
           "holdout_position_rmse": rep.data["mjcf"]["holdout_position_rmse"],
           "record_s": t1 - t0, "diagnose_s": t3 - t2,
           "diagnose_s_per_log_s": (t3 - t2) / duration}
    if truth is None:
        row["correct"] = not named
    else:
        effect, channel, param, value = truth
        row["truth"] = {"effect": effect, "channel": channel, "parameter": param,
                        "value": value}
        hit = [e for e in named if e["effect"] == effect
               and (channel is None or e["channel"] == channel)]
        est = hit[0]["parameters"][param] if hit else None
        row["estimate"] = est
        row["relative_error"] = abs(est - value) / value if hit else None
        row["correct"] = bool(hit) and len(named) == 1
    rm = row["holdout_position_rmse"]
    row["corrected_better"] = bool(np.all(np.array(rm["corrected"]) <=
                                          np.array(rm["original"])))
    return row


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="arm only, 3 cases, 4 s logs")
    ap.add_argument("--duration", type=float, default=10.0)
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args()
    duration = 4.0 if args.quick else args.duration
    result = {"uptime": os.popen("uptime").read().strip(), "mujoco": mujoco.__version__,
              "duration_s": duration, "compile_s": {}, "systems": {}}
    for sname, system in SYSTEMS.items():
        if args.quick and sname != "arm2dof":
            continue
        t0 = time.perf_counter()
        mujoco.MjModel.from_xml_path(str(system["xml"]))
        result["compile_s"][sname] = time.perf_counter() - t0
        cases = ["clean", "damping", "delay"] if args.quick else list(system["cases"])
        rows = []
        with tempfile.TemporaryDirectory() as tmp:
            for case in cases:
                print(f"{sname}/{case} ...", file=sys.stderr, flush=True)
                rows.append(run_case(system, case, duration, Path(tmp)))
        result["systems"][sname] = rows
    text = json.dumps(result, indent=2)
    out = args.out or (None if args.quick else ROOT / "benchmarks" / "results" /
                       "mujoco_proof.json")
    if out is not None:
        out.write_text(text + "\n", encoding="utf-8")
    print(text)


if __name__ == "__main__":
    main()
