"""Read and write recordings in the format of ``spec/diagnosis.md`` (CSV or Parquet).

A recording is a table with a header row: a time column ``t`` (s, strictly increasing,
uniform sampling not assumed) and the columns that ``spec/models.md`` lists for the model
(e.g. ``t, q1, q2, dq1, dq2, tau1, tau2``); other columns are ignored. The format is chosen
by the file extension: ``.csv`` or ``.parquet``.

Every problem with a file raises :class:`RecordingError` (a ``ValueError``) whose message is
one line naming the file, the column and/or row, and what is wrong. Rows are counted from 1
for the first data row (in a CSV file that is line 2, after the header).

Writing is atomic: the table goes to a temporary file in the target folder that is renamed
into place, so a failed write leaves nothing half-written.

Canonical columns and column maps
---------------------------------
Every system (built-in or a user's ``path.py:NAME`` model) declares its canonical recording
columns as a :class:`RecordingSchema` (``canonical``, the ``derivable`` ones the diagnosis may
compute when absent, and how inputs were held). A user's file with other names or units is
translated by one :class:`ColumnMap`: canonical name -> :class:`Column` (source column,
scale, offset, constant, despike). :func:`read` applies it::

    read("log.csv", schema, ColumnMap.of(t="time_s", delta_f=Column(source="wheel_deg",
                                                                    scale=0.00109)))

Canonical columns a map does not name are read from the file column of the same name.
"""

from __future__ import annotations

import csv
import json
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np
import pandas as pd

from simgap.errors import ColumnMapError, RecordingError
from simgap.limits import check_recording_file
from simgap.outputs import write_file
from simgap.schema import RecordingSchema, check_input_hold

#: Fewest samples any diagnosis can say something about.
MIN_SAMPLES = 50
SUFFIXES = (".csv", ".parquet")


@dataclass(frozen=True)
class Recording:
    """A validated recording.

    Attributes:
        name: file name (or a label for in-memory recordings).
        columns: float64 arrays keyed by column name, all of length ``n``; includes ``t`` (s).
        meta: free-form metadata (e.g. what a generator injected); never read by the diagnosis.
    """

    name: str
    columns: dict[str, np.ndarray]
    meta: dict = field(default_factory=dict)

    @property
    def t(self) -> np.ndarray:
        """Time stamps (s)."""
        return self.columns["t"]

    @property
    def n(self) -> int:
        """Number of samples."""
        return int(self.t.shape[0])

    def __getitem__(self, key: str) -> np.ndarray:
        return self.columns[key]

    def to_frame(self) -> pd.DataFrame:
        """Return the recording as a DataFrame (``t`` first)."""
        names = ["t"] + [c for c in self.columns if c != "t"]
        return pd.DataFrame({c: self.columns[c] for c in names})


def _fail(path: str, msg: str) -> RecordingError:
    return RecordingError(f"{path}: {msg}")


def _row_label(path: str, i: int) -> str:
    row = i + 1
    return f"row {row} (line {row + 1})" if path.lower().endswith(".csv") else f"row {row}"


def _read_table(path: Path) -> pd.DataFrame:
    label = str(path)
    check_recording_file(path)  # exists, regular file, header length, memory (simgap.limits)
    suffix = path.suffix.lower()
    if suffix not in SUFFIXES:
        raise _fail(label, f"unknown file type {path.suffix!r}; use .csv or .parquet")
    try:
        if suffix == ".parquet":
            return pd.read_parquet(path)
        # Read as text so that non-numeric cells can be located exactly afterwards.
        # Undecodable bytes become U+FFFD: a latin-1 byte in an ignored column never rejects
        # the file, and one in a used column is reported as a non-numeric cell.
        frame = pd.read_csv(path, dtype=str, keep_default_na=False, skipinitialspace=True,
                            encoding="utf-8", encoding_errors="replace")
        with open(path, newline="", encoding="utf-8", errors="replace") as fh:
            header = [h.strip() for h in next(csv.reader(fh), [])]
        if len(header) == frame.shape[1] and len(set(header)) == len(header):
            return frame
        dup = sorted({h for h in header if header.count(h) > 1})
        if dup:
            raise _fail(label, f"column {dup[0]!r} appears more than once in the header")
        return frame
    except RecordingError:
        raise
    except pd.errors.EmptyDataError:
        raise _fail(label, "file is empty (no header row)") from None
    except pd.errors.ParserError as err:
        first = str(err).strip().splitlines()[0] if str(err).strip() else "malformed table"
        raise _fail(label, f"not a valid CSV table ({first})") from None
    except (UnicodeDecodeError, csv.Error):
        raise _fail(label, "not a text CSV file (cannot decode as UTF-8)") from None
    except (OSError, ValueError) as err:  # pyarrow errors subclass these
        first = str(err).strip().splitlines()[0] if str(err).strip() else type(err).__name__
        raise _fail(label, f"cannot be read as {suffix[1:]} ({first})") from None


def _numeric_column(label: str, name: str, values: pd.Series) -> np.ndarray:
    """Convert one column to float64, naming the first bad row if any."""
    if values.dtype == object or pd.api.types.is_string_dtype(values.dtype):
        text = values.astype(str).str.strip()
        num = pd.to_numeric(text, errors="coerce")
        bad = num.isna() & ~text.str.lower().isin(["nan", "-nan", "+nan"])
        if bad.any():
            i = int(np.argmax(bad.to_numpy()))
            shown = text.iloc[i]
            what = "empty value" if shown == "" else f"non-numeric value {shown[:40]!r}"
            raise _fail(label, f"column {name!r} {_row_label(label, i)}: {what}")
        arr = num.to_numpy(dtype=np.float64)
    elif pd.api.types.is_bool_dtype(values.dtype) or not pd.api.types.is_numeric_dtype(
            values.dtype):
        raise _fail(label, f"column {name!r}: non-numeric column of type {values.dtype}")
    else:
        arr = values.to_numpy(dtype=np.float64, na_value=np.nan)
    finite = np.isfinite(arr)
    if not finite.all():
        i = int(np.argmin(finite))
        raise _fail(label, f"column {name!r} {_row_label(label, i)}: value {float(arr[i])!r} "
                           "is not finite (NaN or inf)")
    return arr


def validate_columns(label: str, frame: pd.DataFrame, required: Sequence[str],
                     min_samples: int = MIN_SAMPLES) -> dict[str, np.ndarray]:
    """Check a table against the recording format and return its required columns.

    Args:
        label: file name used in error messages.
        frame: the table as read.
        required: columns that must be present (``t`` is always required).
        min_samples: fewest rows accepted.

    Returns:
        float64 arrays keyed by column name, ``t`` first.

    Raises:
        RecordingError: one line naming the file, the column/row and the problem.
    """
    names = [str(c).strip() for c in frame.columns]
    dup = sorted({c for c in names if names.count(c) > 1})
    if dup:
        raise _fail(label, f"column {dup[0]!r} appears more than once in the header")
    frame = frame.set_axis(names, axis=1)
    need = ["t"] + [c for c in required if c != "t"]
    missing = [c for c in need if c not in names]
    if missing:
        raise _fail(label, f"missing column {missing[0]!r} (needs {', '.join(need)}; "
                           f"found {', '.join(names) if names else 'no columns'})")
    if len(frame) < min_samples:
        raise _fail(label, f"too few samples: {len(frame)} rows, need at least {min_samples}")
    out = {c: _numeric_column(label, c, frame[c]) for c in need}
    dt = np.diff(out["t"])
    if np.any(dt <= 0):
        i = int(np.argmax(dt <= 0)) + 1
        t_i, t_prev = float(out["t"][i]), float(out["t"][i - 1])
        raise _fail(label, f"column 't' {_row_label(label, i)}: time {t_i!r} s is not "
                           f"after the previous {t_prev!r} s (must strictly increase)")
    return out


def read_recording(path: str | os.PathLike, columns: Sequence[str],
                   min_samples: int = MIN_SAMPLES) -> Recording:
    """Read and validate a CSV or Parquet recording.

    Args:
        path: ``.csv`` or ``.parquet`` file with a header row.
        columns: required columns besides ``t`` (others in the file are ignored).
        min_samples: fewest rows accepted.

    Returns:
        The :class:`Recording` with float64 columns.

    Raises:
        RecordingError: on any problem, with a one-line message.
    """
    path = Path(path)
    frame = _read_table(path)
    data = validate_columns(str(path), frame, columns, min_samples)
    return Recording(name=path.name, columns=data)


def recording_from_arrays(name: str, data: Mapping[str, np.ndarray], columns: Sequence[str],
                          min_samples: int = MIN_SAMPLES, meta: dict | None = None) -> Recording:
    """Validate in-memory columns exactly as a file would be validated."""
    frame = pd.DataFrame({k: np.asarray(v, dtype=np.float64) for k, v in data.items()})
    return Recording(name=name, columns=validate_columns(name, frame, columns, min_samples),
                     meta=dict(meta or {}))


def write_recording(path: str | os.PathLike, data: Mapping[str, np.ndarray] | pd.DataFrame,
                    columns: Sequence[str] | None = None, float_format: str = "%.9g", *,
                    overwrite: bool = False) -> Path:
    """Write a recording atomically as CSV or Parquet (by extension).

    Args:
        path: target file (``.csv`` or ``.parquet``); its folder must exist.
        data: columns (``t`` first in the output).
        columns: columns to write, in order (default: all, ``t`` first).
        float_format: CSV number format (9 significant digits keep float32-level detail).
        overwrite: replace an existing file (atomically); without it an existing file is
            refused and left untouched.

    Returns:
        The written path.

    Raises:
        RecordingError: unknown file type.
        OutputError: ``path`` exists (without ``overwrite``), is a folder, or its folder is
            missing (:func:`simgap.outputs.write_file`); nothing half-written is left.
    """
    path = Path(path)
    if path.suffix.lower() not in SUFFIXES:
        raise RecordingError(f"{path}: unknown file type {path.suffix!r}; use .csv or .parquet")
    frame = data if isinstance(data, pd.DataFrame) else pd.DataFrame(
        {k: np.asarray(v, dtype=np.float64) for k, v in data.items()})
    cols = list(columns) if columns is not None else (
        ["t"] + [c for c in frame.columns if c != "t"])
    frame = frame[cols]

    def write(tmp: Path) -> None:
        if path.suffix.lower() == ".parquet":
            frame.to_parquet(tmp, index=False)
        else:
            frame.to_csv(tmp, index=False, float_format=float_format)

    write_file(path, write, overwrite=overwrite)
    return path


# --------------------------------------------------------------------------- schemas

# --------------------------------------------------------------------------- column maps
@dataclass(frozen=True, kw_only=True)
class Column:
    """Where one canonical recording column comes from.

    The canonical value is ``scale * file[source] + offset``, or ``constant`` on every row.

    Attributes:
        source: column name in the user's recording (``None`` when ``constant`` is set).
        scale: factor applied to the source values, e.g. a drive gain (N/V) or deg -> rad.
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
            raise ColumnMapError("Column needs exactly one of source= and constant=, got "
                                 f"source={self.source!r}, constant={self.constant!r}")
        if self.source is not None and (not isinstance(self.source, str) or not self.source):
            raise ColumnMapError(f"Column source must be a non-empty string, got "
                                 f"{self.source!r}")
        for name in ("scale", "offset", "constant", "despike"):
            v = getattr(self, name)
            if v is not None and (isinstance(v, bool) or not isinstance(v, int | float)
                                  or not np.isfinite(v)):
                raise ColumnMapError(f"Column {name} must be a finite number, got {v!r}")
        if self.scale == 0:
            raise ColumnMapError("Column scale must be non-zero")
        if self.despike is not None and self.despike <= 0:
            raise ColumnMapError(f"Column despike must be positive, got {self.despike!r}")

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


_COLUMN_KEYS = ("source", "scale", "offset", "constant", "despike")


@dataclass(frozen=True)
class ColumnMap:
    """Canonical recording column -> :class:`Column` (the one column map of simgap).

    Build it with :meth:`of`: ``ColumnMap.of(t="t_s", q="qm_m", u=Column(source="vir_V",
    scale=35.15))``; a string means ``Column(source=...)``, a number ``Column(constant=...)``.
    From JSON (``simgap diagnose --columns map.json``) with :meth:`from_dict` /
    :meth:`from_json`: ``{"t": "time", "delta_f": {"source": "wheel_deg", "scale": 0.00109}}``.

    Attributes:
        columns: canonical name -> :class:`Column`.
        input_hold: how the logged inputs relate to the acting ones (``"zoh"``: held until
            the next sample, ``"sample"``: point samples, ``"auto"``: decided from the
            data); ``None``: not declared here (the model's recording schema decides).
            In JSON, the key ``"input_hold"`` beside the columns.
    """

    columns: Mapping[str, Column] = field(default_factory=dict)
    input_hold: str | None = None

    def __post_init__(self) -> None:
        if self.input_hold is not None:
            check_input_hold(self.input_hold)
        for key, col in self.columns.items():
            if not isinstance(col, Column):
                raise ColumnMapError(f"column map entry {key!r} must be a Column, got "
                                     f"{type(col).__name__}")
        object.__setattr__(self, "columns", MappingProxyType(dict(self.columns)))

    @classmethod
    def of(cls, *, input_hold: str | None = None, **columns: str | float | Column
           ) -> ColumnMap:
        """Column map from keyword arguments (canonical name = source, number or Column).

        ``input_hold``: see the class attributes (not a column).
        """
        out: dict[str, Column] = {}
        for key, spec in columns.items():
            if isinstance(spec, Column):
                out[key] = spec
            elif isinstance(spec, str):
                out[key] = Column(source=spec)
            elif isinstance(spec, int | float) and not isinstance(spec, bool):
                out[key] = Column(constant=float(spec))
            else:
                raise ColumnMapError(f"column map entry {key!r} must be a column name, a "
                                     f"number or a Column, got {spec!r}")
        return cls(out, input_hold=input_hold)

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], *, label: str = "column map") -> ColumnMap:
        """Column map from a JSON-style dict.

        Each canonical name maps to a source column name, a number (a constant), or an
        object with the :class:`Column` fields.
        """
        if not isinstance(data, Mapping):
            raise ColumnMapError(f"{label}: expected an object of canonical column -> source, "
                                 f"got {type(data).__name__}")
        out: dict[str, str | float | Column] = {}
        hold = None
        for key, spec in data.items():
            if key == "input_hold":  # how the inputs were logged, not a column
                try:
                    hold = check_input_hold(spec)
                except ColumnMapError as err:
                    raise ColumnMapError(f"{label}: {err}") from None
                continue
            if isinstance(spec, Mapping):
                unknown = [k for k in spec if k not in _COLUMN_KEYS]
                if unknown:
                    raise ColumnMapError(f"{label}: column {key!r} has unknown field "
                                         f"{unknown[0]!r} (use {', '.join(_COLUMN_KEYS)})")
                try:
                    out[key] = Column(**dict(spec))
                except ColumnMapError as err:
                    raise ColumnMapError(f"{label}: column {key!r}: {err}") from None
            else:
                out[key] = spec
        try:
            return cls.of(input_hold=hold, **out)
        except ColumnMapError as err:
            raise ColumnMapError(f"{label}: {err}") from None

    @classmethod
    def from_json(cls, path: str | os.PathLike) -> ColumnMap:
        """Read a column map from a JSON file (see :meth:`from_dict`)."""
        path = Path(path)
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
        except FileNotFoundError:
            raise ColumnMapError(f"{path}: file does not exist") from None
        except (OSError, UnicodeDecodeError) as err:
            raise ColumnMapError(f"{path}: cannot read the column map ({err})") from None
        except json.JSONDecodeError as err:
            raise ColumnMapError(f"{path}: not valid JSON (line {err.lineno}: "
                                 f"{err.msg})") from None
        return cls.from_dict(data, label=str(path))

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form (inverse of :meth:`from_dict`)."""
        out: dict[str, Any] = {}
        for key, col in self.columns.items():
            fields = {k: getattr(col, k) for k in _COLUMN_KEYS}
            default = Column(source="x") if col.source is not None else Column(constant=0.0)
            out[key] = {k: v for k, v in fields.items()
                        if v is not None and (k in ("source", "constant")
                                              or v != getattr(default, k))}
        if self.input_hold is not None:
            out["input_hold"] = self.input_hold
        return out

    @property
    def sources(self) -> tuple[str, ...]:
        """Columns read from the user's file."""
        return tuple(c.source for c in self.columns.values() if c.source is not None)

    def check_schema(self, schema: RecordingSchema, label: str) -> None:
        """Check this map against a schema; raise :class:`ColumnMapError` if it fails.

        Every entry must name a canonical column, every required column must be covered
        and time must not be a constant.
        """
        canonical = schema.canonical
        unknown = [k for k in self.columns if k not in canonical]
        if unknown:
            raise ColumnMapError(f"column map of {label} names {unknown[0]!r}, which "
                                 f"is not one of its recording columns {list(canonical)}")
        missing = [c for c in schema.required if c not in self.columns]
        if missing:
            raise ColumnMapError(f"column map of {label} does not say where "
                                 f"{missing[0]!r} comes from (needs all of "
                                 f"{list(schema.required)})")
        if "t" in self.columns and self.columns["t"].constant is not None:
            raise ColumnMapError(f"column map of {label}: time 't' cannot be a constant")

    def check(self, model: Any) -> None:
        """Raise :class:`ColumnMapError` unless this map fits ``model``'s schema."""
        label = getattr(model, "name", None) or type(model).__name__
        try:
            schema = RecordingSchema.of(model)
        except ColumnMapError:
            raise ColumnMapError(f"{label} has no recording_columns: a model with a column "
                                 "map must list its canonical recording columns") from None
        self.check_schema(schema, label)

    def completed(self, schema: RecordingSchema, available: Sequence[str]) -> ColumnMap:
        """Return this map plus identity entries for the canonical columns it does not name.

        A required column is read from the file column of its own name; a derivable one
        only if the file has it (otherwise the diagnosis derives it).
        """
        out = dict(self.columns)
        have = set(available)
        for c in schema.canonical:
            if c not in out and (c not in schema.derivable or c in have):
                out[c] = Column(source=c)
        return ColumnMap(out, input_hold=self.input_hold)

    def apply(self, frame: pd.DataFrame, *, label: str = "recording",
              min_samples: int = MIN_SAMPLES) -> Recording:
        """Translate a user's table to a validated recording with canonical columns.

        Args:
            frame: the user's recording as read from disk (any column types).
            label: file name used in error messages.
            min_samples: fewest rows accepted.

        Returns:
            A :class:`Recording` holding only the canonical columns (in the system's
            units); ``meta["column_map"]`` says where each came from and ``meta["notes"]``
            what the translation changed (constants, despiked rows).

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
    from scipy.ndimage import median_filter

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


def _conform(frame: pd.DataFrame, label: str, schema: RecordingSchema,
             columns: ColumnMap | None, min_samples: int, meta: dict | None) -> Recording:
    names = [str(c).strip() for c in frame.columns]
    if columns is None:
        need = [c for c in schema.canonical if c not in schema.derivable or c in names]
        data = validate_columns(label, frame, need, min_samples)
        return Recording(name=Path(label).name, columns=data, meta=dict(meta or {}))
    cmap = columns.completed(schema, names)
    cmap.check_schema(schema, label)
    rec = cmap.apply(frame, label=label, min_samples=min_samples)
    return Recording(rec.name, rec.columns, {**dict(meta or {}), **rec.meta})


def read(path: str | os.PathLike, schema: RecordingSchema, columns: ColumnMap | None = None,
         *, min_samples: int = MIN_SAMPLES) -> Recording:
    """Read a CSV/Parquet recording into a system's canonical columns.

    Args:
        path: ``.csv`` or ``.parquet`` file with a header row.
        schema: the system's canonical columns.
        columns: where the canonical columns come from; ``None``: the file uses the
            canonical names. Canonical columns the map does not name are read from the file
            column of that name (derivable ones only when present).
        min_samples: fewest rows accepted.

    Returns:
        The validated :class:`Recording` holding canonical columns only (derivable ones only
        when the file has them); with a map, ``meta`` records it and what it changed.

    Raises:
        RecordingError: on any problem with the file, one line.
        ColumnMapError: the map does not fit the schema.
    """
    path = Path(path)
    return _conform(_read_table(path), str(path), schema, columns, min_samples, None)


def conform(recording: Recording, schema: RecordingSchema, columns: ColumnMap | None = None,
            *, min_samples: int = MIN_SAMPLES) -> Recording:
    """Validate an in-memory :class:`Recording` exactly as :func:`read` does a file."""
    frame = pd.DataFrame({k: np.asarray(v, dtype=np.float64)
                          for k, v in recording.columns.items()})
    return _conform(frame, recording.name, schema, columns, min_samples, recording.meta)
