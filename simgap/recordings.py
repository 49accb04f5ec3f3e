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
"""

from __future__ import annotations

import csv
import os
import tempfile
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from simgap.errors import RecordingError
from simgap.limits import check_recording_file

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


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def write_recording(path: str | os.PathLike, data: Mapping[str, np.ndarray] | pd.DataFrame,
                    columns: Sequence[str] | None = None, float_format: str = "%.9g") -> Path:
    """Write a recording atomically as CSV or Parquet (by extension).

    Args:
        path: target file (``.csv`` or ``.parquet``); its folder must exist.
        data: columns (``t`` first in the output).
        columns: columns to write, in order (default: all, ``t`` first).
        float_format: CSV number format (9 significant digits keep float32-level detail).

    Returns:
        The written path.
    """
    path = Path(path)
    if path.suffix.lower() not in SUFFIXES:
        raise RecordingError(f"{path}: unknown file type {path.suffix!r}; use .csv or .parquet")
    frame = data if isinstance(data, pd.DataFrame) else pd.DataFrame(
        {k: np.asarray(v, dtype=np.float64) for k, v in data.items()})
    cols = list(columns) if columns is not None else (
        ["t"] + [c for c in frame.columns if c != "t"])
    frame = frame[cols]
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    try:
        if path.suffix.lower() == ".parquet":
            frame.to_parquet(tmp, index=False)
        else:
            frame.to_csv(tmp, index=False, float_format=float_format)
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path
