"""Deprecated: the old home of user-defined models (``--model path/to/model.py:NAME``).

Everything moved in simgap 0.x (issue 12) and is still reachable here for one release, with a
:class:`DeprecationWarning` naming the new place:

=========================  ===============================================================
old name                   new home
=========================  ===============================================================
``Column``, ``ColumnMap``  :mod:`simgap.recordings` (one column map for every system)
``despike``                :func:`simgap.recordings.despike`
``read_mapped``            :func:`simgap.recordings.read` with the model's schema and map
``load_model``             :func:`simgap.diagnosis.user_models.load_model_file`
``with_columns`` and the   :mod:`simgap.diagnosis.user_models`
other loader functions
``ModelMechanicalSystem``  :class:`simgap.diagnosis.systems.MechanicalSystem`
``translate_unit``
``make_system``            :func:`simgap.diagnosis.pipeline.make_system`
``diagnose_custom``,       :func:`simgap.diagnosis.diagnose` (``model="path.py:NAME"``,
``load_inputs``            ``duration=``)
=========================  ===============================================================
"""

from __future__ import annotations

import importlib
import os
import warnings
from pathlib import Path
from typing import Any

from simgap.errors import CustomModelError

__all__ = ["CustomModelError"]

#: old name -> (module, new name)
_MOVED = {
    "Column": ("simgap.recordings", "Column"),
    "ColumnMap": ("simgap.recordings", "ColumnMap"),
    "despike": ("simgap.recordings", "despike"),
    "MIN_SAMPLES": ("simgap.recordings", "MIN_SAMPLES"),
    "with_columns": ("simgap.diagnosis.user_models", "with_columns"),
    "column_map_of": ("simgap.diagnosis.user_models", "column_map_of"),
    "parse_model_spec": ("simgap.diagnosis.user_models", "parse_model_spec"),
    "import_file": ("simgap.diagnosis.user_models", "import_file"),
    "load_model": ("simgap.diagnosis.user_models", "load_model_file"),
    "check_model": ("simgap.diagnosis.user_models", "check_model"),
    "ModelMechanicalSystem": ("simgap.diagnosis.systems", "MechanicalSystem"),
    "translate_unit": ("simgap.diagnosis.systems", "translate_unit"),
    "STRIBECK_MAX_SHARE": ("simgap.diagnosis.systems", "STRIBECK_MAX_SHARE"),
    "make_system": ("simgap.diagnosis.pipeline", "make_system"),
    "first_seconds": ("simgap.diagnosis.pipeline", "first_seconds"),
    "read_mapped": (__name__, "_read_mapped"),
    "load_inputs": (__name__, "_load_inputs"),
    "diagnose_custom": (__name__, "_diagnose_custom"),
}


def _read_mapped(path: str | Path, model: Any, min_samples: int | None = None) -> Any:
    """Read a recording into ``model``'s canonical columns (its column map applied)."""
    from simgap.diagnosis.user_models import column_map_of
    from simgap.recordings import MIN_SAMPLES, RecordingSchema, read

    cmap = column_map_of(model) if getattr(model, "column_map", None) is not None else None
    return read(path, RecordingSchema.of(model), cmap,
                min_samples=MIN_SAMPLES if min_samples is None else min_samples)


def _load_inputs(spec: str, recording: str | os.PathLike) -> tuple[Any, Any]:
    """(adapter, recording in canonical columns) for ``path.py:NAME`` and a file."""
    from simgap.diagnosis.pipeline import _adapter, _read, resolve_model

    model, _ = resolve_model(spec)
    rec = _read(recording, model, None)
    return _adapter(model, set(rec.columns)), rec


def _diagnose_custom(spec: str, recording: str | os.PathLike, *,
                     duration: float | None = None, **kwargs: Any) -> Any:
    """``diagnose(recording, spec, duration=duration, **kwargs)``."""
    from simgap.diagnosis.pipeline import diagnose

    return diagnose(recording, spec, duration=duration, **kwargs)


def __getattr__(name: str) -> Any:
    if name in _MOVED:
        module, new = _MOVED[name]
        where = "simgap.diagnosis.diagnose" if module == __name__ else f"{module}.{new}"
        warnings.warn(f"simgap.diagnosis.custom.{name} is deprecated; use {where}",
                      DeprecationWarning, stacklevel=2)
        return getattr(importlib.import_module(module), new)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
