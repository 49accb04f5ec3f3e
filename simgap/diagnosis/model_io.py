"""Reading ``augmented_model.json`` back, for every model the diagnosis accepts.

``write_report`` saves the augmented model (nominal + named effects) of every diagnosis as
``augmented_model.json``. Two layouts exist, both schema 1:

* built-in systems (``"model": "manipulator2dof"`` or ``"bicycle"``): base parameters plus
  the reported effects (:mod:`simgap.diagnosis.augmented`, unchanged);
* any other mechanical model (``"kind": "mechanical"``, e.g. a ``path.py:NAME`` axis): the
  model file, the reported effects, and each fitted term in the fit's own coordinates
  (``fitted``) with the Coulomb smoothing, which rebuild the augmented model exactly.

:func:`load_augmented` reads either.
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from simgap.errors import ModelFileError


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
    from simgap.diagnosis.augmented import AugmentedMechanical, model_from_dict

    if d.get("kind") != "mechanical":
        return model_from_dict(d)
    from simgap.diagnosis.effects import VOCABULARY
    from simgap.diagnosis.systems import ModelMechanicalSystem
    from simgap.diagnosis.user_models import load_model_file

    try:
        if model is None:
            if not d.get("model_file"):
                raise ModelFileError(f"augmented model of {d.get('model')!r} names no model "
                                     "file: pass the nominal model (load_augmented(path, "
                                     "model=...))")
            model = load_model_file(d["model_file"])
        system = ModelMechanicalSystem(model)
        sigma = np.asarray(d["options"]["coulomb_sigma"], dtype=np.float64)
        fitted = []
        for term in d["fitted"]:
            if term["effect"] not in VOCABULARY:
                raise ModelFileError(f"augmented model: unknown effect {term['effect']!r}")
            fitted.append((VOCABULARY[term["effect"]], term["index"],
                           np.asarray(term["lin"], dtype=np.float64),
                           np.asarray(term["nl"], dtype=np.float64)))
    except (KeyError, TypeError) as err:
        raise ModelFileError(f"augmented model description is incomplete: {err}") from None
    return AugmentedMechanical(model, system, fitted, coulomb_sigma=sigma,
                               effects=d.get("effects", ()), source=d.get("model_file"))


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
