"""Write the diagnosis back as a corrected MJCF, and check it with MuJoCo's own simulation.

:func:`corrected_mjcf` copies the user's MJCF and changes only what the diagnosis named,
each change preceded by an XML comment (old value → new value, and why). The vocabulary maps
onto MJCF attributes as follows (values add to what the file already declares):

=====================  =================================================================
viscous_friction b     joint ``damping`` += b
coulomb_friction Fc    joint ``frictionloss`` += Fc (MuJoCo's dry-friction constraint)
inertia_mismatch dI    joint ``armature`` += dI
spring k, q0           joint ``stiffness`` += k, ``springref`` so that the sum of both
                       springs is one spring
payload_mass mp        a new body with a point mass mp at the tip point (site) it was found at
gravity_mismatch dG    ``<option gravity>`` scaled by 1 + dG
input_delay delay      the joint's actuator ``delay`` (and ``nsample`` for its history)
torque_bias,           no MJCF counterpart: reported in the notes (apply the bias as
stribeck_friction      ``qfrc_applied``, or model the Stribeck bump outside MuJoCo)
=====================  =================================================================

:func:`holdout_rmse` simulates an MJCF in MuJoCo from the recorded state at the start of
back-to-back windows of the held-out part with the recorded efforts replayed (zero-order
hold; the actuator's ctrl history is filled with the past inputs when it has a delay) and
returns the position RMSE per joint: the "how much better" of the corrected file, measured by
MuJoCo itself.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from simgap.errors import ModelError
from simgap.models.mujoco import MujocoNominal, load_model
from simgap.outputs import write_file

NO_COUNTERPART = {
    "torque_bias": "a constant joint effort has no MJCF attribute; apply it as "
                   "data.qfrc_applied at this joint",
    "stribeck_friction": "MuJoCo has no Stribeck (low-speed friction bump) law",
}


def _fmt(x: float) -> str:
    return f"{x:.6g}"


def _find(root: ET.Element, tag: str, name: str) -> ET.Element | None:
    return next((e for e in root.iter(tag) if e.get("name") == name), None)


def corrected_mjcf(xml: str | Path, model: MujocoNominal, fitted: list[tuple],
                   points: Mapping[int, tuple[str, int, np.ndarray]] | None = None
                   ) -> tuple[str, list[str]]:
    """Return (corrected MJCF text, notes) for the fitted effects of a diagnosis.

    Args:
        xml: the nominal MJCF file the diagnosis ran against.
        model: its :class:`~simgap.models.mujoco.MujocoNominal`.
        fitted: (effect, joint index or None, lin, nl) per named effect (the report's
            ``augmented.fitted``).
        points: payload tip point per payload effect (``id(effect)`` → point).

    Returns:
        The new file's text and one note per effect (what was changed, or why nothing).
    """
    xml = Path(xml)
    parser = ET.XMLParser(target=ET.TreeBuilder(insert_comments=True))
    tree = ET.parse(xml, parser=parser)
    root = tree.getroot()
    parent = {c: p for p in root.iter() for c in p}
    m = model.mj_model
    notes: list[str] = []

    def comment(el: ET.Element, text: str) -> None:
        holder = parent.get(el, root)
        holder.insert(list(holder).index(el), ET.Comment(f" simgap: {text} "))

    def set_joint(j: int, attr: str, new: float, old: float, why: str) -> None:
        name = model.joint_names[j]
        el = _find(root, "joint", name)
        if el is None:
            notes.append(f"{why} at {name}: joint element not in {xml.name} (included "
                         f"file?); set {attr}={_fmt(new)} there")
            return
        el.set(attr, _fmt(new))
        comment(el, f"{attr} {_fmt(old)} -> {_fmt(new)} ({why})")
        notes.append(f"{name}: {attr} {_fmt(old)} -> {_fmt(new)} ({why})")

    for effect, j, lin, nl in fitted:
        name = effect.name
        dof = int(model.dof[j]) if j is not None else None
        if name == "viscous_friction":
            old = float(m.dof_damping[dof])
            set_joint(j, "damping", old + lin[0], old, f"viscous friction b = {lin[0]:.4g}")
        elif name == "coulomb_friction":
            old = float(m.dof_frictionloss[dof])
            set_joint(j, "frictionloss", old + lin[0], old, f"Coulomb friction Fc = "
                      f"{lin[0]:.4g}")
        elif name == "inertia_mismatch":
            old = float(m.dof_armature[dof])
            set_joint(j, "armature", old + lin[0], old, f"extra inertia dI = {lin[0]:.4g}")
        elif name == "spring":
            jid = int(model.joint_ids[j])
            k_old, r_old = float(m.jnt_stiffness[jid]), float(m.qpos_spring[model.qadr[j]])
            k_new = k_old + lin[0]
            if k_new <= 0:
                notes.append(f"{model.joint_names[j]}: spring k = {lin[0]:.4g} makes the "
                             "joint stiffness negative: no MJCF counterpart")
                continue
            r_new = (k_old * r_old - lin[1]) / k_new
            set_joint(j, "stiffness", k_new, k_old, f"spring k = {lin[0]:.4g}")
            set_joint(j, "springref", r_new, r_old, "rest position of the combined spring")
        elif name == "gravity_mismatch":
            opt = root.find("option")
            if opt is None:
                opt = ET.Element("option")
                root.insert(0, opt)
                parent[opt] = root
            old = np.asarray(m.opt.gravity, dtype=np.float64)
            new = old * (1.0 + lin[0])
            opt.set("gravity", " ".join(_fmt(v) for v in new))
            comment(opt, f"gravity {' '.join(_fmt(v) for v in old)} -> scaled by "
                         f"{1 + lin[0]:.4g} (gravity mismatch)")
            notes.append(f"option gravity scaled by {1 + lin[0]:.4g} (gravity mismatch)")
        elif name == "payload_mass":
            point = (points or {}).get(id(effect))
            if point is None:
                notes.append("payload mass: tip point unknown; not written")
                continue
            pname, body, pos = point
            bname = m.body(body).name
            el = _find(root, "body", bname)
            if el is None:
                notes.append(f"payload mass at {pname}: body {bname!r} not in {xml.name}")
                continue
            new = ET.SubElement(el, "body", name="simgap_payload",
                                pos=" ".join(_fmt(v) for v in pos))
            ET.SubElement(new, "inertial", pos="0 0 0", mass=_fmt(lin[0]),
                          diaginertia="1e-9 1e-9 1e-9")
            parent[new] = el
            comment(new, f"payload mass mp = {lin[0]:.4g} kg at {pname} (point mass)")
            notes.append(f"payload body simgap_payload: {lin[0]:.4g} kg at {pname} of "
                         f"{bname}")
        elif name == "input_delay":
            jid = int(model.joint_ids[j])
            acts = [a for a in range(m.nu) if int(m.actuator_trnid[a, 0]) == jid]
            if not acts:
                notes.append(f"{model.joint_names[j]}: input delay {nl[0]:.4g} s, but no "
                             "actuator drives this joint: delay your applied efforts")
                continue
            actuators = [e for sec in root.iter("actuator") for e in sec
                         if isinstance(e.tag, str)]
            for a in acts:
                aname = m.actuator(a).name or f"actuator {a}"
                el = actuators[a] if len(actuators) == m.nu else None
                if el is None:
                    notes.append(f"actuator {aname!r} not in {xml.name}")
                    continue
                old = float(m.actuator_delay[a])
                new_delay = old + float(nl[0])
                nsample = math.ceil(new_delay / m.opt.timestep) + 2
                el.set("delay", _fmt(new_delay))
                el.set("nsample", str(max(nsample, int(m.actuator_history[a, 0]))))
                comment(el, f"delay {_fmt(old)} -> {_fmt(new_delay)} s (actuator delay)")
                notes.append(f"{aname}: delay {_fmt(old)} -> {_fmt(new_delay)} s "
                             "(actuator delay)")
        else:
            where = model.joint_names[j] if j is not None else "the arm"
            notes.append(f"{effect.label} at {where}: no MJCF counterpart; "
                         f"{NO_COUNTERPART.get(name, 'not written')}")
    ET.indent(tree, space="  ")
    original = xml.read_text(encoding="utf-8")
    start = original.find("<mujoco")
    head = (f"<!-- Written by simgap from {xml.name}: a copy with only the changes the "
            "diagnosis named, each commented. -->\n")
    prolog = original[:start] if start > 0 and not original.startswith("<?xml") else ""
    return head + prolog + ET.tostring(root, encoding="unicode") + "\n", notes


def write_corrected_mjcf(report: Any, xml: str | Path, path: str | Path, *,
                         overwrite: bool = False) -> list[str]:
    """Write ``augmented_model.xml`` for a diagnosis report; return the notes.

    The file is checked by compiling it with MuJoCo before it is moved into place
    (:func:`simgap.outputs.write_file`; an existing file only with ``overwrite=True``, never
    the input ``xml``).
    """
    system = report.system
    fitted = list(getattr(report.augmented, "fitted", []))
    points = {id(e): system.payload_points[id(e)] for e, *_ in fitted
              if id(e) in getattr(system, "payload_points", {})}
    text, notes = corrected_mjcf(xml, system.model, fitted, points)
    compile_text(text, Path(xml))  # raises ModelError before anything is written
    write_file(path, lambda tmp: tmp.write_text(text, encoding="utf-8"), overwrite=overwrite,
               inputs=(xml,))
    return notes


def compile_text(text: str, xml: Path) -> object:
    """Compile MJCF text as if it sat beside ``xml`` (relative asset files resolve)."""
    import mujoco

    try:
        assets = _assets(xml) if 'file="' in text else None
        return mujoco.MjModel.from_xml_string(text, assets)
    except ValueError as exc:
        raise ModelError(f"corrected copy of {xml}: MuJoCo cannot compile it: "
                         f"{' '.join(str(exc).split())}") from exc


def _assets(xml: Path) -> dict[str, bytes]:
    """Files next to ``xml`` (and below), by relative path, for from_xml_string."""
    base = xml.resolve().parent
    out: dict[str, bytes] = {}
    for p in base.rglob("*"):
        if p.is_file() and p.stat().st_size < 50_000_000 and p != xml.resolve():
            out[str(p.relative_to(base))] = p.read_bytes()
    return out


def holdout_rmse(source: object, columns: Mapping[str, np.ndarray], t_split: float,
                 horizon: float = 0.2, joints: list[str] | None = None) -> np.ndarray:
    """Position RMSE per joint (rad or m) of MuJoCo's simulation over held-out windows.

    Args:
        source: MJCF path, text-compiled ``MjModel`` or ``MjModel``.
        columns: the recording in canonical columns (``t``, ``q_*``, ``dq_*``, ``tau_*``).
        t_split: start of the held-out part (s).
        horizon: window length (s).
        joints: the recorded joints (default all hinge/slide joints; others start at qpos0).
    """
    import mujoco

    m, _ = load_model(source)
    nom = MujocoNominal(m, joints=joints)
    t = np.asarray(columns["t"], dtype=np.float64)
    q = np.stack([columns[f"q_{j}"] for j in nom.joint_names], axis=1)
    dq = np.stack([columns[f"dq_{j}"] for j in nom.joint_names], axis=1)
    tau = np.stack([columns[f"tau_{j}"] for j in nom.joint_names], axis=1)
    act = {int(m.actuator_trnid[a, 0]): a for a in range(m.nu)}
    gain = {a: float(m.actuator_gear[a, 0] * m.actuator_gainprm[a, 0]) for a in act.values()}
    d = mujoco.MjData(m)
    starts = np.flatnonzero(t >= t_split)
    errs = []
    k = starts[0] if starts.size else len(t)
    while k < len(t) - 2:
        end = min(len(t) - 1, int(np.searchsorted(t, t[k] + horizon)))
        mujoco.mj_resetData(m, d)
        d.time = t[k]
        d.qpos[nom.qadr], d.qvel[nom.dof] = q[k], dq[k]
        for j, jid in enumerate(nom.joint_ids):
            a = act.get(int(jid))
            if a is not None and m.actuator_history[a, 0] > 0:
                ns = int(m.actuator_history[a, 0])
                past = t[k] - m.opt.timestep * np.arange(ns - 1, -1, -1)
                idx = np.clip(np.searchsorted(t, past, side="right") - 1, 0, len(t) - 1)
                mujoco.mj_initCtrlHistory(m, d, a, past.reshape(-1, 1),
                                          np.ascontiguousarray(tau[idx, j:j + 1] / gain[a]))
        for i in range(k, end):
            for j, jid in enumerate(nom.joint_ids):
                a = act.get(int(jid))
                if a is not None:
                    d.ctrl[a] = tau[i, j] / gain[a]
                else:
                    d.qfrc_applied[nom.dof[j]] = tau[i, j]
            while d.time < t[i + 1] - 0.5 * m.opt.timestep:
                mujoco.mj_step(m, d)
            errs.append(d.qpos[nom.qadr] - q[i + 1])
        k = end
    if not errs:
        raise ModelError("no held-out samples to simulate")
    return np.sqrt(np.mean(np.square(errs), axis=0))
