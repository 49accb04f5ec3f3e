"""Reading ``augmented_model.json`` back, for every model the diagnosis accepts.

``write_report`` saves the augmented model (nominal + named effects) of every diagnosis as
``augmented_model.json``. Every model's file (schema 1) holds the augmented
:class:`~simgap.models.effects.Plant` (``"plant"``) beside the reported effects:

* built-in systems (``"model": "manipulator2dof"`` or ``"bicycle"``): the system's plant
  (:mod:`simgap.diagnosis.augmented`);
* any other mechanical model (``"kind": "mechanical"``, e.g. a ``path.py:NAME`` axis): a
  plant of the generic mechanical schema (the model's joints and the vocabulary,
  :func:`~simgap.diagnosis.augmented.mechanical_schema`) and the model file that rebuilds
  the nominal model. The fit coordinates of each term follow from the reported parameters
  (``FitSpec.coordinates``).

:func:`load_augmented` reads these and the layouts written before the plant: built-in
models without ``"plant"``, and user models whose terms were saved in the fit's own
coordinates (``"fitted"``).
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from simgap.errors import ModelError, ModelFileError
from simgap.models.effects import Plant


def augmented_from_dict(d: Mapping[str, Any], model: Any = None) -> Any:
    """Rebuild an augmented model from its JSON description.

    Args:
        d: the parsed ``augmented_model.json``.
        model: the nominal model of a ``"kind": "mechanical"`` file; default: loaded from
            the file's ``model_file`` (``path.py:NAME``).

    Returns:
        An ``AugmentedManipulator``, ``AugmentedBicycle`` or ``AugmentedMechanical``.

    Raises:
        ModelFileError: incomplete or unknown description, or no way to get the model.
    """
    from simgap.diagnosis.augmented import (
        AugmentedMechanical,
        mechanical_schema,
        model_from_dict,
    )

    if d.get("kind") != "mechanical":
        return model_from_dict(d)
    from simgap.diagnosis.systems import MechanicalSystem
    from simgap.diagnosis.user_models import load_model_file

    try:
        source = d.get("model_file") or (d.get("plant") or {}).get("options", {}).get(
            "model_file")
        if model is None:
            if not source:
                raise ModelFileError(f"augmented model of {d.get('model')!r} names no model "
                                     "file: pass the nominal model (load_augmented(path, "
                                     "model=...))")
            model = load_model_file(source)
        system = MechanicalSystem(model)
        if "plant" in d:   # today's layout: the augmented Plant
            try:
                plant = Plant.from_dict(d["plant"], mechanical_schema(model, system.channels))
            except ModelError as err:
                raise ModelFileError(f"augmented model: {err}") from None
            if source and not plant.options["model_file"]:
                plant = plant.with_options(model_file=source)
            return AugmentedMechanical(model, system, plant=plant,
                                       effects=d.get("effects", ()))
        return _from_fitted(d, model, system, source)
    except (KeyError, TypeError) as err:
        raise ModelFileError(f"augmented model description is incomplete: {err}") from None


def _from_fitted(d: Mapping[str, Any], model: Any, system: Any, source: str | None) -> Any:
    """The layout written before the plant (issue 12): each term in fit coordinates."""
    from simgap.diagnosis.augmented import AugmentedMechanical
    from simgap.diagnosis.effects import VOCABULARY

    sigma = np.asarray(d["options"]["coulomb_sigma"], dtype=np.float64)
    fitted = []
    for term in d["fitted"]:
        if term["effect"] not in VOCABULARY:
            raise ModelFileError(f"augmented model: unknown effect {term['effect']!r}")
        fitted.append((VOCABULARY[term["effect"]], term["index"],
                       np.asarray(term["lin"], dtype=np.float64),
                       np.asarray(term["nl"], dtype=np.float64)))
    return AugmentedMechanical(model, system, fitted, coulomb_sigma=sigma,
                               effects=d.get("effects", ()), source=source)


def load_augmented(path: str | os.PathLike, model: Any = None) -> Any:
    """Read an ``augmented_model.json`` written by ``write_report`` (any model).

    Args:
        path: the JSON file.
        model: nominal model of a user-model file (see :func:`augmented_from_dict`).
    """
    path = Path(path)
    try:
        d = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError) as err:
        raise ModelFileError(f"{path}: cannot read augmented model ({err})") from None
    if not isinstance(d, Mapping):
        raise ModelFileError(f"{path}: expected a JSON object")
    try:
        return augmented_from_dict(d, model)
    except ModelFileError as err:
        raise ModelFileError(f"{path}: {err}") from None
