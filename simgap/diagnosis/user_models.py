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
   (optional) lists those the diagnosis may derive when absent (velocities); together they
   are the model's :class:`~simgap.recordings.RecordingSchema`.
4. ``model.column_map`` (optional, a :class:`~simgap.recordings.ColumnMap`) says where each
   canonical column comes from in the user's file: a source column, times a scale, plus an
   offset, or a constant; optionally with isolated single-sample glitches removed
   (``despike``). Without a column map the recording must use the canonical names (a
   derivable column is used when present and derived otherwise). :func:`with_columns`
   attaches a map to a model and checks it.

For full control, ``NAME`` may instead be (or return) a ready diagnosis adapter from
:mod:`simgap.diagnosis.systems`; it is used as is and reads its own column names.

The whole diagnosis of such a model is :func:`simgap.diagnosis.diagnose` with
``model="path.py:NAME"`` (what ``simgap diagnose`` calls) or with the loaded model object:
both take the same path and give the same report.

Every problem ends in a :class:`CustomModelError` (a ``ValueError``) with a one-line
message naming the file, the attribute or the column and what is wrong.
"""

from __future__ import annotations

import hashlib
import importlib.util
import sys
from pathlib import Path
from types import ModuleType
from typing import Any

from simgap.errors import CustomModelError
from simgap.models.base import MechanicalNominalModel, NominalModel
from simgap.models.bicycle import BicycleNominal
from simgap.recordings import Column, ColumnMap, RecordingSchema

__all__ = ["CustomModelError", "check_model", "column_map_of", "import_file", "is_adapter",
           "load_model_file", "parse_model_spec", "with_columns"]

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
    """Return the model's column map, or the identity map over its required columns."""
    cmap = getattr(model, "column_map", None)
    if cmap is None:
        return ColumnMap({c: Column(source=c) for c in RecordingSchema.of(model).required})
    if not isinstance(cmap, ColumnMap):
        raise CustomModelError(f"{_label(model)}.column_map must be a simgap ColumnMap, got "
                               f"{type(cmap).__name__}")
    cmap.check(model)
    return cmap



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


def load_model_file(spec: str) -> Any:
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
    if not (_is_model(obj) or is_adapter(obj)):
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
    if not is_adapter(obj):
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
    except CustomModelError as exc:  # includes ColumnMapError
        raise CustomModelError(f"{label}: {exc}") from exc


def _is_model(obj: Any) -> bool:
    return not isinstance(obj, type) and isinstance(obj, NominalModel)


def is_adapter(obj: Any) -> bool:
    """Tell whether ``obj`` is a ready diagnosis adapter (``simgap.diagnosis.systems``)."""
    return (not isinstance(obj, type) and hasattr(obj, "prepare") and hasattr(obj, "candidates")
            and hasattr(obj, "columns"))


def _label(model: Any) -> str:
    return getattr(model, "name", None) or type(model).__name__


def _first_line(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    return text[0] if text else "(no message)"
