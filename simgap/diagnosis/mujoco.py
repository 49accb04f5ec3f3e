"""Diagnosis against an MJCF: ``simgap diagnose LOG --model robot.xml [--columns map.json]``.

The nominal model is :func:`simgap.models.mujoco.from_mjcf` (M, bias and passive forces from
MuJoCo). The adapter, :class:`MujocoSystem`, is the generic mechanical adapter of
:mod:`simgap.diagnosis.custom` (units per joint type, the joint-level vocabulary) plus two
candidates that only an MJCF can express and locate:

* ``payload_mass`` at each tip point (sites of the leaf bodies, else their origins): a point
  mass mp (kg) whose joint efforts are Jᵀ (J ddq + J̇ dq − g) per kg, with J the point's
  Jacobian from MuJoCo (``mj_jac``, ``mj_jacDot``);
* ``input_delay`` per joint: the effort acts ``delay`` seconds after it was logged (MuJoCo 4's
  actuator ``delay``); its residual is u(t) − u(t − delay) (N·m or N).

Recording columns default to ``t``, ``q_<joint>``, ``dq_<joint>`` (used when present,
otherwise differentiated) and ``tau_<joint>``; when no ``tau_<joint>`` is logged but
``ctrl_<actuator>`` (or the actuator's name) is, efforts are ``gear · gain · ctrl`` of
motor-type actuators. ``--columns map.json`` maps other names: ``{"t": "time_s",
"q_elbow": "enc2", "tau_elbow": {"source": "cur2", "scale": 0.8}}`` (a string is a source
column, a number a constant, an object the keyword arguments of
:class:`~simgap.diagnosis.custom.Column`).

The fitted effects are written back as a corrected MJCF by
:mod:`simgap.diagnosis.mjcf_writer`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from simgap.diagnosis.effects import PAYLOAD, VOCABULARY, Effect
from simgap.diagnosis.forms import EffectContext, Prepared
from simgap.diagnosis.systems import MechanicalSystem
from simgap.diagnosis.user_models import column_map_of, with_columns
from simgap.errors import CustomModelError
from simgap.models.mujoco import MujocoNominal, from_mjcf
from simgap.recordings import (
    Column,
    ColumnMap,
    Recording,
    RecordingSchema,
    _read_table,
    conform,
    read,
)

#: Longest actuator delay looked for (s).
MAX_DELAY = 0.1


@dataclass(frozen=True, kw_only=True)
class MujocoEffectContext(EffectContext):
    """The mechanical context plus what the MJCF-only effects read.

    Attributes:
        payload_at: ``(point, sig) -> joint efforts per kg`` at a tip point (N·m/kg or N/kg).
    """

    payload_at: Callable[[tuple, Mapping[str, np.ndarray]], np.ndarray]


#: The vocabulary's input delay (one per joint; its fit side lives with the arm's
#: vocabulary entry in simgap.models.manipulator).
INPUT_DELAY = VOCABULARY["input_delay"]


def _payload_at(point: tuple[str, int, np.ndarray]) -> Effect:
    name, body, pos = point

    def fn(lin, nl, sig, j, ctx):
        return lin[0] * ctx.payload_at(point, sig)

    return Effect(name="payload_mass", label=f"payload mass at {name}", scope="arm",
                  lin=PAYLOAD.lin, lin_units=PAYLOAD.lin_units, lin_lower=PAYLOAD.lin_lower,
                  lin_upper=PAYLOAD.lin_upper, uses_derivatives=True, fn=fn)


class MujocoSystem(MechanicalSystem):
    """Diagnosis adapter of a :class:`~simgap.models.mujoco.MujocoNominal` (module docstring)."""

    def __init__(self, model: MujocoNominal) -> None:
        super().__init__(model, name=model.name)
        self.points = model.tip_points()
        self.payload_effects = [_payload_at(p) for p in self.points]
        #: id(payload effect) → its tip point (name, body id, position in the body frame).
        self.payload_points = {id(e): p for e, p in zip(self.payload_effects, self.points,
                                                        strict=True)}

    def candidates(self, prepared: Prepared) -> list[tuple[Effect, int | None, str]]:
        """Joint vocabulary (model units), payload per tip point, input delay per joint."""
        out = super().candidates(prepared)
        out += [(e, None, "arm") for e in self.payload_effects]
        out += [(INPUT_DELAY, j, self.channels[j]) for j in range(self.n_channels)]
        return out

    def context(self, prepared: Prepared, terms: Sequence[tuple] = ()) -> MujocoEffectContext:
        """The mechanical context with the tip-point regressor."""
        base = super().context(prepared, terms)
        fields = {f.name: getattr(base, f.name) for f in dataclasses.fields(base)}
        return MujocoEffectContext(**fields,
                                   payload_at=partial(self.payload_regressor_at, prepared))

    def payload_regressor_at(self, prepared: Prepared, point, sig) -> np.ndarray:
        """Joint efforts per kg at ``point`` for the rows of ``sig`` (memoised on the grid)."""
        full = "idx" in sig and len(sig["idx"]) == prepared.n
        memo = prepared.memo.setdefault("payload_at", {})
        key = (point[0], bool(np.any(sig["ddq"])))
        if full and key in memo:
            return memo[key]
        out = self.model.point_regressor(point[1], point[2], sig["q"], sig["dq"], sig["ddq"])
        if full:
            memo[key] = out
        return out

    def _fit_mask(self, sig: Mapping[str, np.ndarray], sigma: np.ndarray,
                  valid: np.ndarray | None = None) -> np.ndarray:
        """Rows (N, n) where each joint slides for sure, in MuJoCo's sense too.

        MuJoCo's ``frictionloss`` is a soft constraint: it pushes back with exactly its
        level only once the joint's velocity exceeds about ``|ddq| / b``, with b the
        constraint's reference damping ``2 / (dmax · timeconst)`` (``solreffriction`` /
        ``solimpfriction`` of the joint); below that the force ramps through zero. Rows
        within twice that band are left out of fitting and scoring for that joint, on top
        of the stick band of the generic adapter.
        """
        m = self.model.mj_model
        ref = m.dof_solref[self.model.dof]
        dmax = m.dof_solimp[self.model.dof, 1]
        timeconst = np.where(ref[:, 0] > 0, ref[:, 0], 0.02)
        b = 2.0 / (dmax * timeconst)
        soft = np.abs(sig["dq"]) >= 2.0 * np.abs(sig["ddq"]) / b
        return super()._fit_mask(sig, sigma, valid) & soft


# --------------------------------------------------------------------------- loading
def default_columns(model: MujocoNominal, header: list[str]) -> dict[str, Column]:
    """Canonical columns present in ``header``, efforts from actuator controls if needed."""
    cols: dict[str, Column] = {c: Column(source=c) for c in model.recording_columns
                               if c in header}
    m = model.mj_model
    for jid, tau in zip(model.joint_ids, model.input_names, strict=True):
        if tau in cols:
            continue
        for a in range(m.nu):
            names = (f"ctrl_{model.actuator_names[a]}", model.actuator_names[a])
            src = next((n for n in names if n in header), None)
            if src is None or int(m.actuator_trnid[a, 0]) != int(jid):
                continue
            gain = float(m.actuator_gear[a, 0] * m.actuator_gainprm[a, 0])
            cols[tau] = Column(source=src, scale=gain)
            break
    return cols


def load_mjcf_inputs(xml: str | Path, recording: str | Path | Recording,
                     columns: str | Path | ColumnMap | None = None,
                     joints: list[str] | None = None) -> tuple[MujocoSystem, Any]:
    """(adapter, recording in canonical columns) for an MJCF nominal and a user's log.

    ``recording`` may be a file or an in-memory :class:`~simgap.recordings.Recording`.
    """
    model = from_mjcf(Path(xml), joints=joints)
    user = None if columns is None else (columns if isinstance(columns, ColumnMap)
                                         else ColumnMap.from_json(columns))
    hold = None if user is None else user.input_hold  # reaches the adapter's columns
    if isinstance(recording, Recording):
        cols = default_columns(model, list(recording.columns))
        if user is not None:
            cols.update(user.columns)
        model = with_columns(model, ColumnMap(cols, input_hold=hold))
        return MujocoSystem(model), conform(recording, RecordingSchema.of(model),
                                            column_map_of(model))
    recording = Path(recording)
    header = list(_read_table(recording).columns) if recording.is_file() else []
    cols = default_columns(model, header)
    if user is not None:
        cols.update(user.columns)
    missing = [c for c in model.recording_columns
               if c not in cols and c not in model.derivable_columns]
    if missing and recording.is_file():
        raise CustomModelError(f"{recording}: no column {missing[0]!r} (the MJCF "
                               f"{Path(xml).name} needs {', '.join(missing)}; map yours with "
                               "--columns map.json)")
    model = with_columns(model, ColumnMap(cols, input_hold=hold))
    return MujocoSystem(model), read(recording, RecordingSchema.of(model),
                                     column_map_of(model))


def diagnose_mjcf(xml: str | Path, recording: str | Path | Recording, *,
                  columns: str | Path | ColumnMap | None = None,
                  joints: list[str] | None = None, duration: float | None = None,
                  **kwargs: Any) -> Any:
    """Run the diagnosis of ``recording`` against the MJCF ``xml``; returns the Report.

    Args:
        xml: the nominal MJCF.
        recording: the log (CSV/Parquet) or a :class:`~simgap.recordings.Recording`.
        columns: optional ``--columns`` JSON file (or a ColumnMap).
        joints: joints to diagnose (default all hinge/slide joints; others held at qpos0).
        duration: diagnose only the first ``duration`` seconds.
        **kwargs: passed to :func:`simgap.diagnosis.pipeline.diagnose`.
    """
    from simgap.diagnosis.pipeline import diagnose, first_seconds

    system, rec = load_mjcf_inputs(xml, recording, columns, joints)
    if duration is not None:
        rec = first_seconds(rec, duration)
    report = diagnose(rec, system, **kwargs)
    processing = report.data.setdefault("processing", {})
    processing["model_file"] = str(xml)
    for key in ("column_map", "notes"):
        if key in rec.meta:
            processing[key] = rec.meta[key]
    attach_corrected_mjcf(report, xml)
    return report


def attach_corrected_mjcf(report: Any, xml: str | Path) -> None:
    """Build the corrected MJCF of a report and measure it in MuJoCo on the held-out part.

    Sets ``report.mjcf_text`` (the ``augmented_model.xml`` text) and ``report.data["mjcf"]``:
    the changes, the notes on effects without an MJCF counterpart, and the held-out
    position RMSE per joint of MuJoCo's simulation of the original and the corrected file
    (0.2 s windows from the recorded state, recorded efforts replayed).
    """
    from simgap.diagnosis.mjcf_writer import compile_text, corrected_mjcf, holdout_rmse

    system = report.system
    fitted = list(getattr(report.augmented, "fitted", []))
    points = {id(e): system.payload_points[id(e)] for e, *_ in fitted
              if id(e) in system.payload_points}
    text, notes = corrected_mjcf(xml, system.model, fitted, points)
    corrected = compile_text(text, Path(xml))
    prepared = report.prepared
    cols = {"t": prepared.t}
    for j, name in enumerate(system.model.joint_names):
        cols[f"q_{name}"] = prepared.signals["q"][:, j]
        cols[f"dq_{name}"] = prepared.signals["dq"][:, j]
        cols[f"tau_{name}"] = prepared.inputs[:, j]
    t_split = report.data["fit"]["split"]["test"][0]
    joints = list(system.model.joint_names)
    before = holdout_rmse(system.model.mj_model, cols, t_split, joints=joints)
    after = holdout_rmse(corrected, cols, t_split, joints=joints) if fitted else before
    report.mjcf_text = text
    report.data["mjcf"] = {
        "augmented_model": "augmented_model.xml",
        "changes": notes,
        "holdout_position_rmse": {"original": before.tolist(), "corrected": after.tolist(),
                                  "joints": list(system.model.joint_names),
                                  "units": [u for u in system.model.obs_units[
                                      :len(system.model.joint_names)]],
                                  "method": "MuJoCo's own simulation of each file over 0.2 s "
                                            "windows of the held-out part from the recorded "
                                            "state, recorded efforts replayed"},
    }
