"""User-defined nominal models for ``simgap diagnose --model path/to/model.py:NAME``.

The protocol, in full (``examples/README.md`` has a worked 1-DOF example):

1. ``path/to/model.py`` is imported by path (it need not be on ``sys.path``). ``NAME`` is a
   module-level attribute that is either a nominal model instance or a zero-argument
   factory (function or class) returning one.
2. The model follows :class:`~simgap.models.base.NominalModel` and is one the diagnosis can
   compute a physical residual for: a :class:`~simgap.models.base.MechanicalNominalModel`
   (inverse dynamics ``M(q) ddq + bias(q, dq)`` gives the force/torque residual per joint)
   or a :class:`~simgap.models.bicycle.BicycleNominal` (axle-force residual
   Delta = K⁻¹ g at the recorded speed).
3. ``model.recording_columns`` lists the model's canonical recording columns (for example
   ``t, q, dq, u`` for :class:`~simgap.models.prismatic.RigidAxisNominal`, or
   ``t, vx, vy, r, delta_f, delta_r`` for the bicycle). ``model.derivable_columns``
   (optional) lists those the diagnosis may derive when absent (velocities).
4. ``model.column_map`` (optional, a :class:`ColumnMap`) says where each canonical column
   comes from in the user's file: a source column, times a scale, plus an offset, or a
   constant; optionally with isolated single-sample glitches removed (``despike``). Without
   a column map the recording must use the canonical names. :func:`with_columns` attaches
   a map to a model and checks it.

For full control, ``NAME`` may instead be (or return) a ready diagnosis adapter from
:mod:`simgap.diagnosis.systems` (e.g. a ``MechanicalSystem`` with its own column map and
input scaling); it is used as is and reads its own column names from the recording.

Entry points: :func:`load_model` (the ``--model`` argument → checked model),
:func:`load_inputs` (→ adapter + recording in canonical columns) and
:func:`diagnose_custom` (the whole diagnosis; what ``simgap diagnose`` calls). A model gets
an adapter from :func:`make_system`: :class:`ModelMechanicalSystem` (units taken from the
model, e.g. N·s/m for a slider's viscous friction; Stribeck velocity bounded by the recorded
speeds) or :class:`~simgap.diagnosis.systems.BicycleSystem`.

Every problem ends in a :class:`CustomModelError` (a ``ValueError``) with a one-line
message naming the file, the attribute or the column and what is wrong.
"""

from __future__ import annotations

import dataclasses
import hashlib
import importlib.util
import sys
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType, ModuleType
from typing import Any

import numpy as np
import pandas as pd
from scipy.ndimage import median_filter

from simgap.diagnosis.effects import Effect
from simgap.diagnosis.systems import BicycleSystem, MechanicalSystem
from simgap.diagnosis.systems import ColumnMap as SystemColumns
from simgap.errors import CustomModelError
from simgap.models.base import MechanicalNominalModel, NominalModel
from simgap.models.bicycle import BicycleNominal
from simgap.recordings import (
    MIN_SAMPLES,
    Recording,
    RecordingError,
    _numeric_column,
    _read_table,
    _row_label,
    read_recording,
    validate_columns,
)


@dataclass(frozen=True, kw_only=True)
class Column:
    """Where one canonical recording column comes from.

    The canonical value is ``scale * file[source] + offset``, or ``constant`` on every row.

    Attributes:
        source: column name in the user's recording (``None`` when ``constant`` is set).
        scale: factor applied to the source values, e.g. a drive gain (N/V).
        offset: added after scaling, in the canonical column's unit.
        constant: fixed value for every row (e.g. ``delta_r = 0`` for a car without rear
            steering); exclusive with ``source``.
        despike: if set, a sample that differs from the median of itself and its two
            neighbours by more than this (canonical units) is an isolated glitch and is
            replaced by linear interpolation in time between the remaining samples.
    """

    source: str | None = None
    scale: float = 1.0
    offset: float = 0.0
    constant: float | None = None
    despike: float | None = None

    def __post_init__(self) -> None:
        if (self.source is None) == (self.constant is None):
            raise CustomModelError("Column needs exactly one of source= and constant=, got "
                                   f"source={self.source!r}, constant={self.constant!r}")
        if self.source is not None and (not isinstance(self.source, str) or not self.source):
            raise CustomModelError(f"Column source must be a non-empty string, got "
                                   f"{self.source!r}")
        for name in ("scale", "offset", "constant", "despike"):
            v = getattr(self, name)
            if v is not None and (isinstance(v, bool) or not isinstance(v, int | float)
                                  or not np.isfinite(v)):
                raise CustomModelError(f"Column {name} must be a finite number, got {v!r}")
        if self.scale == 0:
            raise CustomModelError("Column scale must be non-zero")
        if self.despike is not None and self.despike <= 0:
            raise CustomModelError(f"Column despike must be positive, got {self.despike!r}")

    def describe(self) -> str:
        """Short human-readable origin, e.g. ``35.15 × vir_V``."""
        if self.constant is not None:
            return f"constant {self.constant:g}"
        text = self.source if self.scale == 1 else f"{self.scale:g} × {self.source}"
        if self.offset:
            text += f" {'+' if self.offset > 0 else '−'} {abs(self.offset):g}"
        if self.despike is not None:
            text += f" (despiked at {self.despike:g})"
        return text


@dataclass(frozen=True)
class ColumnMap:
    """Canonical recording column → :class:`Column` (see the module docstring).

    Build it with :meth:`of`: ``ColumnMap.of(t="t_s", q="qm_m", u=Column(source="vir_V",
    scale=35.15))``; a string means ``Column(source=...)``, a number ``Column(constant=...)``.
    """

    columns: Mapping[str, Column] = field(default_factory=dict)

    def __post_init__(self) -> None:
        for key, col in self.columns.items():
            if not isinstance(col, Column):
                raise CustomModelError(f"column map entry {key!r} must be a Column, got "
                                       f"{type(col).__name__}")
        object.__setattr__(self, "columns", MappingProxyType(dict(self.columns)))

    @classmethod
    def of(cls, **columns: str | float | Column) -> ColumnMap:
        """Column map from keyword arguments (canonical name = source, number or Column)."""
        out: dict[str, Column] = {}
        for key, spec in columns.items():
            if isinstance(spec, Column):
                out[key] = spec
            elif isinstance(spec, str):
                out[key] = Column(source=spec)
            elif isinstance(spec, int | float) and not isinstance(spec, bool):
                out[key] = Column(constant=float(spec))
            else:
                raise CustomModelError(f"column map entry {key!r} must be a column name, a "
                                       f"number or a Column, got {spec!r}")
        return cls(out)

    @property
    def sources(self) -> tuple[str, ...]:
        """Columns read from the user's file."""
        return tuple(c.source for c in self.columns.values() if c.source is not None)

    def check(self, model: Any) -> None:
        """Raise :class:`CustomModelError` unless this map fits ``model``'s columns."""
        canonical = tuple(getattr(model, "recording_columns", ()))
        if not canonical:
            raise CustomModelError(f"{_label(model)} has no recording_columns: a model with a "
                                   "column map must list its canonical recording columns")
        unknown = [k for k in self.columns if k not in canonical]
        if unknown:
            raise CustomModelError(f"column map of {_label(model)} names {unknown[0]!r}, which "
                                   f"is not one of its recording columns {list(canonical)}")
        derivable = set(getattr(model, "derivable_columns", ()))
        missing = [c for c in canonical if c not in self.columns and c not in derivable]
        if missing:
            raise CustomModelError(f"column map of {_label(model)} does not say where "
                                   f"{missing[0]!r} comes from (needs all of "
                                   f"{[c for c in canonical if c not in derivable]})")
        if "t" in self.columns and self.columns["t"].constant is not None:
            raise CustomModelError(f"column map of {_label(model)}: time 't' cannot be a "
                                   "constant")

    def apply(self, frame: pd.DataFrame, *, label: str = "recording",
              min_samples: int = MIN_SAMPLES) -> Recording:
        """Translate a user's table to a validated recording with canonical columns.

        Args:
            frame: the user's recording as read from disk (any column types).
            label: file name used in error messages.
            min_samples: fewest rows accepted.

        Returns:
            A :class:`~simgap.recordings.Recording` holding only the canonical columns (in
            the model's units); ``meta["column_map"]`` says where each came from and
            ``meta["notes"]`` what the translation changed (constants, despiked rows).

        Raises:
            RecordingError: a source column is missing, non-numeric, NaN or infinite, time
                does not strictly increase, or there are too few rows.
        """
        names = [str(c).strip() for c in frame.columns]
        frame = frame.set_axis(names, axis=1)
        missing = [c for c in self.sources if c not in names]
        if missing:
            raise RecordingError(f"{label}: missing column {missing[0]!r} (the model's column "
                                 f"map reads {', '.join(dict.fromkeys(self.sources))}; found "
                                 f"{', '.join(names) if names else 'no columns'})")
        if len(frame) < min_samples:
            raise RecordingError(f"{label}: too few samples: {len(frame)} rows, need at least "
                                 f"{min_samples}")
        n = len(frame)
        data: dict[str, np.ndarray] = {}
        notes: list[str] = []
        for key, col in self.columns.items():
            if col.constant is not None:
                data[key] = np.full(n, col.constant, dtype=np.float64)
                notes.append(f"{key} = {col.constant:g} on every row (not in the file)")
            else:
                data[key] = col.scale * _numeric_column(label, col.source, frame[col.source]) \
                    + col.offset
        t = data.get("t")
        if t is not None:
            step = np.diff(t)
            if np.any(step <= 0):
                i = int(np.argmax(step <= 0)) + 1
                raise RecordingError(f"{label}: column {self.columns['t'].source!r} (time) "
                                     f"{_row_label(label, i)}: {float(t[i])!r} s is not after "
                                     f"the previous {float(t[i - 1])!r} s (must strictly increase)")
        for key, col in self.columns.items():
            if col.despike is None:
                continue
            data[key], idx = despike(data[key], col.despike, t)
            if idx.size:
                where = ", ".join(f"row {i + 1}" + (f" (t = {t[i]:.2f} s)" if t is not None
                                                    else "") for i in idx[:5])
                more = f" and {idx.size - 5} more" if idx.size > 5 else ""
                notes.append(f"{key}: {idx.size} isolated spike(s) in {col.source} (more than "
                             f"{col.despike:g} from the 3-sample median) replaced by linear "
                             f"interpolation: {where}{more}")
        columns = validate_columns(label, pd.DataFrame(data), list(data), min_samples)
        meta = {"column_map": {k: c.describe() for k, c in self.columns.items()},
                "notes": notes}
        return Recording(name=Path(label).name, columns=columns, meta=meta)


def despike(x: np.ndarray, threshold: float,
            t: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Replace isolated single-sample glitches by linear interpolation.

    A sample is a glitch when it differs from the median of itself and its two neighbours
    by more than ``threshold``; a genuine step (two or more samples at the new level) is
    left alone because the 3-sample median follows it.

    Args:
        x: signal, shape (N,).
        threshold: glitch size, in the signal's unit.
        t: sample times (s) for the interpolation; sample index if ``None``.

    Returns:
        The cleaned copy of ``x`` and the indices that were replaced.
    """
    x = np.asarray(x, dtype=np.float64)
    med = median_filter(x, size=3, mode="nearest")
    bad = np.abs(x - med) > threshold
    idx = np.flatnonzero(bad)
    if idx.size == 0 or idx.size == x.size:
        return x.copy(), idx[:0] if idx.size == x.size else idx
    axis = np.arange(x.size, dtype=np.float64) if t is None else np.asarray(t, dtype=np.float64)
    out = x.copy()
    out[bad] = np.interp(axis[bad], axis[~bad], x[~bad])
    return out, idx


def with_columns(model: Any, column_map: ColumnMap | None = None,
                 **columns: str | float | Column) -> Any:
    """Attach a column map to ``model`` (checked against its recording columns); return it.

    Either pass a :class:`ColumnMap` or keyword arguments as for :meth:`ColumnMap.of`::

        EMPS = with_columns(RigidAxisNominal(RigidAxisParams(mass=95.1)), t="t_s", q="qm_m",
                            u=Column(source="vir_V", scale=35.15))
    """
    if column_map is not None and columns:
        raise CustomModelError("with_columns takes a ColumnMap or keyword columns, not both")
    cmap = column_map if column_map is not None else ColumnMap.of(**columns)
    cmap.check(model)
    model.column_map = cmap
    return model


def column_map_of(model: Any) -> ColumnMap:
    """Return the model's column map, or the identity map over its canonical columns."""
    cmap = getattr(model, "column_map", None)
    if cmap is None:
        canonical = tuple(getattr(model, "recording_columns", ()))
        derivable = set(getattr(model, "derivable_columns", ()))
        return ColumnMap({c: Column(source=c) for c in canonical if c not in derivable})
    if not isinstance(cmap, ColumnMap):
        raise CustomModelError(f"{_label(model)}.column_map must be a simgap ColumnMap, got "
                               f"{type(cmap).__name__}")
    cmap.check(model)
    return cmap


def read_mapped(path: str | Path, model: Any, min_samples: int = MIN_SAMPLES) -> Recording:
    """Read a CSV/Parquet recording and translate it with the model's column map.

    Args:
        path: the user's recording (``.csv`` or ``.parquet``).
        model: a model checked by :func:`check_model` (built-in or user-defined).
        min_samples: fewest rows accepted.

    Returns:
        The validated :class:`~simgap.recordings.Recording` in canonical columns.

    Raises:
        RecordingError: file missing/unreadable, or a mapped column missing or invalid.
        CustomModelError: the model's column map does not fit the model.
    """
    path = Path(path)
    return column_map_of(model).apply(_read_table(path), label=str(path),
                                      min_samples=min_samples)


# --------------------------------------------------------------------------- loading
def parse_model_spec(spec: str) -> tuple[Path, str]:
    """Split ``path/to/model.py:NAME`` into the file and the attribute name."""
    if not isinstance(spec, str) or ":" not in spec:
        raise CustomModelError(f"--model {spec!r}: expected a built-in model name or "
                               "path/to/model.py:NAME")
    file_part, name = spec.rsplit(":", 1)
    if not file_part or not name:
        raise CustomModelError(f"--model {spec!r}: expected path/to/model.py:NAME")
    if not name.isidentifier():
        raise CustomModelError(f"--model {spec!r}: NAME {name!r} is not a Python identifier")
    return Path(file_part), name


def import_file(path: Path) -> ModuleType:
    """Import a Python file by path under a private module name; errors are one line."""
    if not path.is_file():
        raise CustomModelError(f"{path}: model file not found")
    if path.suffix != ".py":
        raise CustomModelError(f"{path}: a model file must be a .py file")
    resolved = path.resolve()
    digest = hashlib.sha1(str(resolved).encode()).hexdigest()[:12]
    mod_name = f"simgap_user_model_{digest}"
    spec = importlib.util.spec_from_file_location(mod_name, resolved)
    if spec is None or spec.loader is None:  # pragma: no cover - .py files always load
        raise CustomModelError(f"{path}: cannot be imported as a Python module")
    module = importlib.util.module_from_spec(spec)
    sys.modules[mod_name] = module  # dataclasses and pickling look modules up here
    try:
        spec.loader.exec_module(module)
    except CustomModelError as exc:
        sys.modules.pop(mod_name, None)
        raise CustomModelError(f"{path}: {exc}") from exc
    except Exception as exc:  # noqa: BLE001 - user code may raise anything
        sys.modules.pop(mod_name, None)
        raise CustomModelError(f"{path}: importing it failed with {type(exc).__name__}: "
                               f"{_first_line(exc)}") from exc
    return module


def load_model(spec: str) -> Any:
    """Load the nominal model named by ``path/to/model.py:NAME`` and check it.

    Args:
        spec: the ``--model`` argument.

    Returns:
        The model instance, with a valid (checked) column map or canonical columns.

    Raises:
        CustomModelError: file missing, NAME missing, not a nominal model the diagnosis can
            use, factory failed, or the column map does not fit the model.
    """
    path, name = parse_model_spec(spec)
    module = import_file(path)
    if not hasattr(module, name):
        public = [k for k, v in vars(module).items() if not k.startswith("_") and (
            _is_model(v) or getattr(v, "__module__", None) == module.__name__)]
        hint = f"; it defines {', '.join(public[:8])}" if public else ""
        raise CustomModelError(f"{path}: no attribute {name!r}{hint}")
    obj = getattr(module, name)
    if not (_is_model(obj) or _is_adapter(obj)):
        if not callable(obj):
            raise CustomModelError(f"{path}:{name} is a {type(obj).__name__}, not a nominal "
                                   "model or a zero-argument factory of one")
        try:
            obj = obj()
        except CustomModelError as exc:
            raise CustomModelError(f"{path}:{name}(): {exc}") from exc
        except Exception as exc:  # noqa: BLE001 - user code may raise anything
            raise CustomModelError(f"{path}:{name}() failed with {type(exc).__name__}: "
                                   f"{_first_line(exc)} (NAME must be a model or a "
                                   "zero-argument factory)") from exc
    if not _is_adapter(obj):
        check_model(obj, label=f"{path}:{name}")
    return obj


def check_model(model: Any, *, label: str | None = None) -> None:
    """Raise :class:`CustomModelError` unless the diagnosis can use ``model``."""
    label = label or _label(model)
    if not _is_model(model):
        missing = [a for a in ("state_names", "state_units", "input_names", "input_units",
                               "dt", "state", "f") if not hasattr(model, a)]
        raise CustomModelError(f"{label} is a {type(model).__name__}, not a nominal model "
                               f"(missing {', '.join(missing)}; see simgap.models.base)")
    if not isinstance(model, MechanicalNominalModel | BicycleNominal):
        raise CustomModelError(f"{label} is a {type(model).__name__}: the diagnosis needs a "
                               "MechanicalNominalModel (M, bias) or a BicycleNominal")
    if len(model.input_units) != len(model.input_names):
        raise CustomModelError(f"{label}: input_names and input_units differ in length")
    try:
        column_map_of(model)
    except CustomModelError as exc:
        raise CustomModelError(f"{label}: {exc}") from exc


def _is_model(obj: Any) -> bool:
    return not isinstance(obj, type) and isinstance(obj, NominalModel)


def _is_adapter(obj: Any) -> bool:
    """Tell whether ``obj`` is a ready diagnosis adapter (``simgap.diagnosis.systems``)."""
    return (not isinstance(obj, type) and hasattr(obj, "prepare") and hasattr(obj, "candidates")
            and hasattr(obj, "columns"))


def _label(model: Any) -> str:
    return getattr(model, "name", None) or type(model).__name__


def _first_line(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    return text[0] if text else "(no message)"


# --------------------------------------------------------------------------- adapters
#: A Stribeck velocity above this share of the joint's largest recorded speed is not a
#: low-speed effect any more: it would only reshape the Coulomb/viscous curve.
STRIBECK_MAX_SHARE = 0.25


def _mechanical_names(model: Any) -> tuple[tuple[str, ...], tuple[str, ...], tuple[str, ...]]:
    """Canonical (positions, velocities, inputs) column names of a mechanical model."""
    obs = tuple(getattr(model, "obs_names", ()))
    n = len(model.input_names)
    if len(obs) != 2 * n:
        raise CustomModelError(f"{_label(model)}: a mechanical model needs obs_names = "
                               f"positions + velocities (2 × {n} names), got {obs}")
    return obs[:n], obs[n:], tuple(model.input_names)


def _joint_units(model: Any, n: int) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """(position units, effort units) per joint; revolute SI units by default."""
    obs_units = tuple(getattr(model, "obs_units", ()))
    pos = obs_units[:n] if len(obs_units) == 2 * n else ("rad",) * n
    eff = tuple(getattr(model, "residual_units", ()) or ())
    if len(eff) != n or any(u.startswith("(") for u in eff):
        eff = tuple(model.input_units) if len(model.input_units) == n else ("N·m",) * n
    return pos, eff


def translate_unit(unit: str, position: str, effort: str) -> str:
    """Rewrite a vocabulary unit written for a revolute joint (rad, N·m) for this joint.

    Example: for a prismatic joint (m, N), ``N·m·s`` (viscous b) becomes ``N·s/m`` and
    ``kg·m²`` (inertia) becomes ``kg``.
    """
    if position == "rad" and effort == "N·m":
        return unit
    table = {
        "N·m·s": f"{effort}·s/{position}", "N·m/rad": f"{effort}/{position}",
        "N·m": effort, "rad/s²": f"{position}/s²", "rad/s": f"{position}/s", "rad": position,
        "kg·m²": "kg" if (position, effort) == ("m", "N") else f"{effort}·s²/{position}",
    }
    return table.get(unit, unit)


class ModelMechanicalSystem(MechanicalSystem):
    """:class:`~simgap.diagnosis.systems.MechanicalSystem` for any mechanical model.

    Differences from the base adapter, all driven by the model or the data:

    * units come from the model: positions/velocities from ``obs_units``, efforts from
      ``residual_units`` (N for a prismatic joint), and every vocabulary parameter's unit is
      rewritten accordingly (viscous b in N·s/m, Coulomb Fc in N, …);
    * the Stribeck velocity vs is bounded by :data:`STRIBECK_MAX_SHARE` of the joint's
      largest recorded speed (and its start grid scales with it): the bounds of the
      vocabulary, in rad/s, mean nothing for a slider moving at 0.1 m/s, and a "Stribeck"
      term with vs near the top speed only reshapes Coulomb + viscous friction (on the EMPS
      data it then displaces the Coulomb term; see ``tests/diagnosis/test_real_emps.py``);
    * whole-arm ``gravity_mismatch`` is not tested when the model has no gravity torque on
      the recorded positions.
    """

    def __init__(self, model: MechanicalNominalModel, name: str | None = None) -> None:
        q, dq, u = _mechanical_names(model)
        recorded = set(getattr(model, "recording_columns", ()))
        cmap = getattr(model, "column_map", None)
        has_dq = all(c in recorded and (cmap is None or c in cmap.columns) for c in dq)
        columns = SystemColumns(q=q, dq=dq if has_dq else None, u=u)
        channels = tuple(getattr(model, "channel_names", ()) or ())
        super().__init__(model, columns=columns, name=name or _label(model),
                         channels=channels if len(channels) == len(q) else None)
        self.position_units, effort = _joint_units(model, len(q))
        self.channel_units = effort
        self.state_units = self.position_units + tuple(f"{p}/s" for p in self.position_units)
        self.derivative_units = tuple(f"{p}/s²" for p in self.position_units)

    def _unit(self, unit: str, j: int | None) -> str:
        k = 0 if j is None else j
        return translate_unit(unit, self.position_units[k], self.channel_units[k])

    def candidates(self) -> list[tuple[Effect, int | None, str]]:
        """List the base candidates with model units and data-scaled Stribeck bounds."""
        out = []
        vmax = np.max(np.abs(self.sig["dq"]), axis=0)
        gravity = np.abs(self.gravity(self.sig["q"])).max() if self.sig["q"].size else 0.0
        for effect, j, channel in super().candidates():
            if effect.name == "gravity_mismatch" and gravity == 0.0:
                continue
            changes: dict[str, Any] = {
                "lin_units": tuple(self._unit(u, j) for u in effect.lin_units),
                "nl_units": tuple(self._unit(u, j) for u in effect.nl_units)}
            if effect.name == "stribeck_friction" and j is not None:
                hi = max(STRIBECK_MAX_SHARE * float(vmax[j]), 2e-3)
                changes["nl_bounds"] = ((1e-3 * hi, hi),)
                changes["nl_grid"] = (tuple(hi * np.array([0.05, 0.15, 0.4, 0.9])),)
            if effect.to_report is not None:
                changes["to_report"] = _report_in_units(effect.to_report, self._unit, j)
            out.append((dataclasses.replace(effect, **changes), j, channel))
        return out

    def locate_variables(self) -> dict[str, tuple[np.ndarray, str]]:
        """Positions, velocities and accelerations with the model's units."""
        out = super().locate_variables()
        units = self.position_units + self.state_units[self.n_channels:] + \
            self.derivative_units
        return {k: (v, units[i]) for i, (k, (v, _)) in enumerate(out.items())}


def _report_in_units(fn: Any, unit: Any, j: int | None) -> Any:
    """Wrap an effect's report function so that its units are rewritten for the joint."""
    def report(*args: Any, **kwargs: Any) -> tuple[dict, dict, dict]:
        params, stderr, units = fn(*args, **kwargs)
        return params, stderr, {k: unit(u, j) for k, u in units.items()}
    return report


def make_system(model: Any) -> Any:
    """Diagnosis adapter for a checked model (user-defined or built-in) or an adapter.

    Mechanical models get :class:`ModelMechanicalSystem` over their canonical columns, a
    bicycle gets :class:`~simgap.diagnosis.systems.BicycleSystem` (its canonical columns are
    the adapter's defaults); an object that already is
    an adapter (``prepare`` and ``candidates``) is returned as is.
    """
    if _is_adapter(model):
        return model
    if isinstance(model, BicycleNominal):
        return BicycleSystem(model, name=_label(model))
    if isinstance(model, MechanicalNominalModel):
        return ModelMechanicalSystem(model)
    raise CustomModelError(f"{_label(model)}: the diagnosis needs a MechanicalNominalModel or a "
                           "BicycleNominal")


def load_inputs(spec: str, recording: str | Path) -> tuple[Any, Recording]:
    """Everything ``simgap diagnose REC --model path.py:NAME`` needs before the pipeline.

    Args:
        spec: ``path/to/model.py:NAME``.
        recording: the user's CSV/Parquet file.

    Returns:
        (adapter, recording in canonical columns) for
        :func:`simgap.diagnosis.pipeline.diagnose`. The recording's ``meta`` holds the
        column map and the notes on what the translation changed.

    Raises:
        CustomModelError: the model file, NAME or column map is unusable.
        RecordingError: the recording is unusable.
    """
    model = load_model(spec)
    system = make_system(model)
    if system is model:   # a ready adapter reads its own columns
        return system, read_recording(recording, system.columns.required)
    return system, read_mapped(recording, model)


def first_seconds(rec: Recording, duration: float) -> Recording:
    """Keep the first ``duration`` seconds of a recording (a quick look at a long one)."""
    if not np.isfinite(duration) or duration <= 0:
        raise CustomModelError(f"duration must be a positive number of seconds, got "
                               f"{duration!r}")
    keep = rec.t <= rec.t[0] + duration
    return Recording(rec.name, {k: v[keep] for k, v in rec.columns.items()}, dict(rec.meta))


def diagnose_custom(spec: str, recording: str | Path, *, duration: float | None = None,
                    **kwargs: Any) -> Any:
    """Run :func:`simgap.diagnosis.pipeline.diagnose` with a ``path.py:NAME`` model.

    The report's ``processing`` section gets the column map (where each canonical column
    came from) and the notes on what the translation changed (e.g. despiked rows).

    Args:
        spec: ``path/to/model.py:NAME``.
        recording: the user's CSV/Parquet file.
        duration: diagnose only the first ``duration`` seconds (s); ``None`` = all.
        **kwargs: passed to ``diagnose`` (``horizon``, ``train_fraction``).

    Returns:
        The pipeline's ``Report``.
    """
    from simgap.diagnosis.pipeline import diagnose

    system, rec = load_inputs(spec, recording)
    if duration is not None:
        rec = first_seconds(rec, duration)
    report = diagnose(rec, system, **kwargs)
    processing = report.data.setdefault("processing", {})
    processing["model_file"] = spec
    for key in ("column_map", "notes"):
        if key in rec.meta:
            processing[key] = rec.meta[key]
    return report
