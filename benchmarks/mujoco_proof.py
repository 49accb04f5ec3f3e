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


#: Hidden differences: (kind, where, value) with where a joint, a site/body, or an actuator
#: index; the truth the diagnosis must name is derived from it (TRUTH).
TRUTH = {"damping": ("viscous_friction", "b"), "frictionloss": ("coulomb_friction", "Fc"),
         "armature": ("inertia_mismatch", "dI"), "payload": ("payload_mass", "mp"),
         "delay": ("input_delay", "delay")}
SYSTEMS = {
    "arm2dof": {"xml": ARM, "joints": None, "control_dt": 0.002, "hidden": {
        "damping": ("elbow", 0.3), "frictionloss": ("shoulder", 0.5),
        "armature": ("elbow", 0.02), "payload": ("tip", 0.5), "delay": ("shoulder", 0.01)}},
    "reacher": {"xml": REACHER, "joints": ["joint0", "joint1"], "control_dt": 0.01, "hidden": {
        "damping": ("joint1", 0.5), "frictionloss": ("joint0", 2.0),
        "armature": ("joint1", 0.3), "payload": ("fingertip", 2.0), "delay": ("joint0", 0.02)}},
}


def make_real(xml: Path, kind: str | None, where: str = "", value: float = 0.0):
    """The "real" MjModel: the nominal MJCF with one hidden difference (MjSpec edit)."""
    spec = mujoco.MjSpec.from_file(str(xml))
    if kind in ("damping", "frictionloss", "armature"):
        joint = spec.joint(where)
        if kind == "damping":
            damping = np.array(joint.damping)
            damping[0] += value
            joint.damping = damping
        else:
            setattr(joint, kind, getattr(joint, kind) + value)
    elif kind == "payload":
        site = spec.site(where)
        parent, pos = (site.parent, site.pos) if site is not None else (spec.body(where),
                                                                        np.zeros(3))
        load = parent.add_body(name="hidden_load", pos=np.array(pos))
        load.ipos, load.mass, load.inertia = np.zeros(3), value, [1e-6] * 3
        load.explicitinertial = True
    elif kind == "delay":
        model = spec.compile()
        jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, where)
        act = spec.actuators[[int(model.actuator_trnid[a, 0]) for a in range(model.nu)]
                             .index(jid)]
        act.delay = value
        act.nsample = int(np.ceil(value / model.opt.timestep)) + 2
    return spec.compile()


def run_case(system: dict, name: str, duration: float, tmp: Path) -> dict:
    where, value = system["hidden"].get(name, ("", 0.0))
    truth = None if name == "clean" else (TRUTH[name][0],
                                          None if name == "payload" else where,
                                          TRUTH[name][1], value)
    t0 = time.perf_counter()
    real = make_real(system["xml"], None if name == "clean" else name, where, value)
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
        cases = ["clean", "damping", "delay"] if args.quick else ["clean", *system["hidden"]]
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
