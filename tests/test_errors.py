"""Every error class simgap defines derives from the one root ``simgap.errors.SimgapError``."""

from __future__ import annotations

import importlib
import inspect
import pkgutil

import pytest

import simgap
from simgap.errors import SimgapError

#: Modules that need an optional extra; skipped when it is not installed.
OPTIONAL = {"simgap.highway": "highway_env", "simgap.control.rl": "stable_baselines3"}


def _modules():
    for info in pkgutil.walk_packages(simgap.__path__, "simgap."):
        if info.name.endswith("._call"):
            continue
        extra = next((m for p, m in OPTIONAL.items() if info.name.startswith(p)), None)
        if extra is not None and importlib.util.find_spec(extra) is None:
            continue
        yield importlib.import_module(info.name)


def test_every_simgap_exception_derives_from_the_root():
    found = {}
    for module in _modules():
        for name, obj in vars(module).items():
            if (inspect.isclass(obj) and issubclass(obj, Exception)
                    and obj.__module__.startswith("simgap")):
                found[f"{obj.__module__}.{name}"] = obj
    assert len(found) >= 10, sorted(found)
    stray = sorted(k for k, cls in found.items() if not issubclass(cls, SimgapError))
    assert stray == [], f"error classes outside the SimgapError root: {stray}"
    assert issubclass(SimgapError, ValueError)


@pytest.mark.parametrize("old_path, name", [
    ("simgap.recordings", "RecordingError"),
    ("simgap.diagnosis.pipeline", "DiagnosisError"),
    ("simgap.diagnosis.generate", "GeneratorError"),
    ("simgap.diagnosis.custom", "CustomModelError"),
    ("simgap.diagnosis.augmented", "ModelFileError"),
    ("simgap.identifiers.errors", "IdentifierError"),
    ("simgap.identifiers.errors", "IdentifierDivergedError"),
    ("simgap.evaluation.errors", "EvaluationError"),
])
def test_old_import_paths_name_the_same_classes(old_path, name):
    import simgap.errors as errors

    assert getattr(importlib.import_module(old_path), name) is getattr(errors, name)
