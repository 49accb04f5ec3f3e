"""The one root of every error simgap raises on bad input: ``SimgapError`` (a ``ValueError``).

Every typed error of the package derives from it, so ``except simgap.errors.SimgapError``
catches any rejection of a user's input, file, option or action, and nothing else. The
classes are defined here once and re-exported by the modules that raise them (their old
import paths keep working).
"""

from __future__ import annotations


class SimgapError(ValueError):
    """Root of all simgap input errors; the message is one line naming what is wrong."""


class RecordingError(SimgapError):
    """A recording file cannot be used: the message names the file, column/row and problem."""


class DiagnosisError(SimgapError):
    """Bad input to the diagnosis (unknown model or parameter, unusable recording)."""


class GeneratorError(SimgapError):
    """Bad generator arguments (unknown effect, parameter or channel)."""


class CustomModelError(SimgapError):
    """A user model file, its NAME, or its column map is unusable (one-line message)."""


class ColumnMapError(RecordingError, CustomModelError):
    """A column map (file column -> canonical column) is malformed or does not fit a schema.

    It is both a recording and a model-configuration problem, so it derives from both.
    """


class ModelFileError(SimgapError):
    """An augmented-model JSON file cannot be used."""


class ModelError(SimgapError):
    """Bad physical parameters or an unknown system/effect name in ``simgap.models``."""


class EnvError(SimgapError):
    """Bad use of a simgap env or wrapper (action shape/dtype, ``step`` before ``reset``)."""


class IdentifierError(SimgapError):
    """Bad input to an identifier: wrong shape, non-finite value, bad config or file."""


class IdentifierDivergedError(IdentifierError):
    """The weights or the state estimate became non-finite or left the documented bound."""


class EvaluationError(SimgapError):
    """Bad input to the evaluation (freeze times, cases, options, recordings)."""


class OutputError(SimgapError):
    """An output path cannot be written without touching something of the user's."""


class LimitError(SimgapError):
    """A size, duration, memory or file-shape limit would be exceeded (checked before work)."""


__all__ = [
    "ColumnMapError", "CustomModelError", "DiagnosisError", "EnvError", "EvaluationError",
    "GeneratorError", "IdentifierDivergedError", "IdentifierError", "LimitError", "ModelError",
    "ModelFileError", "OutputError", "RecordingError", "SimgapError",
]
