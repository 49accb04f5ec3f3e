"""The canonical recording columns of a system (:class:`RecordingSchema`).

A light module (no pandas, no numba) so that the system registry can declare each system's
schema without importing the readers; :mod:`simgap.recordings` applies it to files.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from simgap.errors import ColumnMapError

#: How a logged input relates to the input that acted: held until the next sample (zero-
#: order hold), a point sample, or not declared (the diagnosis decides from the data).
INPUT_HOLDS = ("auto", "zoh", "sample")


def check_input_hold(value: Any) -> str:
    """``value`` if it is one of :data:`INPUT_HOLDS`.

    Raises:
        ColumnMapError: any other value (one line naming the choices).
    """
    if value not in INPUT_HOLDS:
        raise ColumnMapError(f"input_hold must be one of {', '.join(INPUT_HOLDS)}, got "
                             f"{value!r}")
    return value


@dataclass(frozen=True, kw_only=True)
class RecordingSchema:
    """The canonical recording columns of one system.

    Attributes:
        canonical: column names the system reads, ``t`` (s) first, in SI units (e.g.
            ``t, q1, q2, dq1, dq2, tau1, tau2`` for the arm; ``t, q, dq, u`` for a 1-DOF axis).
        derivable: canonical columns the diagnosis may compute when the file lacks them
            (velocities, by differentiating positions).
        input_hold: ``"zoh"`` if each logged input is held until the next sample,
            ``"sample"`` if it is a point sample, ``"auto"`` (default: not declared) to let
            the diagnosis decide from the data. A declared value reaches the diagnosis
            (``AdapterColumns.input_hold``) unless a column map or ``--input-hold`` says
            otherwise.
    """

    canonical: tuple[str, ...]
    derivable: tuple[str, ...] = ()
    input_hold: str = "auto"

    def __post_init__(self) -> None:
        object.__setattr__(self, "canonical", tuple(self.canonical))
        object.__setattr__(self, "derivable", tuple(self.derivable))
        if "t" not in self.canonical:
            raise ColumnMapError(f"recording schema {list(self.canonical)} has no time column 't'")
        stray = [c for c in self.derivable if c not in self.canonical]
        if stray:
            raise ColumnMapError(f"derivable column {stray[0]!r} is not one of the canonical "
                                 f"columns {list(self.canonical)}")
        check_input_hold(self.input_hold)

    @property
    def required(self) -> tuple[str, ...]:
        """Canonical columns that must come from the file (or a constant)."""
        return tuple(c for c in self.canonical if c not in self.derivable)

    @classmethod
    def of(cls, model: Any) -> RecordingSchema:
        """Schema declared by a model.

        ``model.recording_schema`` if set, else ``recording_columns`` and
        ``derivable_columns``.

        Raises:
            ColumnMapError: the model declares no recording columns.
        """
        schema = getattr(model, "recording_schema", None)
        if isinstance(schema, RecordingSchema):
            return schema
        canonical = tuple(getattr(model, "recording_columns", ()) or ())
        if not canonical:
            name = getattr(model, "name", None) or type(model).__name__
            raise ColumnMapError(f"{name} has no recording_columns: a model must list its "
                                 "canonical recording columns")
        return cls(canonical=canonical,
                   derivable=tuple(getattr(model, "derivable_columns", ()) or ()))
