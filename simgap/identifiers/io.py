"""Save and load identifiers: one ``.npz`` of plain arrays plus a JSON ``meta`` string.

No pickle: the file is read with ``numpy.load(..., allow_pickle=False)``; ``meta`` holds the
kind, sizes, Δt, seed, :class:`~simgap.identifiers.IdentifierConfig`, frozen flag, step
counters and the state of baseline 2's sampling Generator. Writes go through
:func:`simgap.outputs.write_file`: a temporary file in the same folder that is moved into
place only when complete (nothing half-written), and an existing file is replaced only with
``overwrite=True``.
"""

from __future__ import annotations

import json
import os
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from simgap.identifiers.core import FORMAT, FORMAT_V2, upgrade_v2
from simgap.identifiers.errors import IdentifierError
from simgap.outputs import write_file


def write_npz(path: str | os.PathLike[str], meta: dict[str, Any],
              arrays: dict[str, np.ndarray], *, overwrite: bool = False) -> Path:
    """Atomically write ``arrays`` and ``meta`` (as JSON) to ``path``; returns the path.

    Raises:
        OutputError: ``path`` exists (without ``overwrite``), is a folder, or its folder is
            missing; nothing is left behind.
    """
    path = Path(path)

    def write(tmp: Path) -> None:
        with open(tmp, "wb") as fh:
            np.savez(fh, meta=np.array(json.dumps(meta)), **arrays)

    write_file(path, write, overwrite=overwrite)
    return path


def read_npz(path: str | os.PathLike[str]) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """Read a file written by :func:`write_npz`.

    Raises:
        IdentifierError: naming the file and what is wrong with it.
    """
    path = Path(path)
    if not path.is_file():
        raise IdentifierError(f"{path}: no such identifier file")
    try:
        with np.load(path, allow_pickle=False) as z:
            data = {k: z[k] for k in z.files}
    except (OSError, ValueError, zipfile.BadZipFile, EOFError) as exc:
        raise IdentifierError(f"{path}: not a readable .npz identifier file ({exc})") from None
    if "meta" not in data:
        raise IdentifierError(f"{path}: missing 'meta' entry (not a simgap identifier file)")
    try:
        meta = json.loads(str(data.pop("meta")))
    except json.JSONDecodeError as exc:
        raise IdentifierError(f"{path}: 'meta' is not valid JSON ({exc})") from None
    fmt = meta.get("format") if isinstance(meta, dict) else None
    if fmt not in (FORMAT, FORMAT_V2):
        raise IdentifierError(f"{path}: format {fmt!r} is not {FORMAT!r} (or the older "
                              f"{FORMAT_V2!r})")
    for name, arr in data.items():
        if arr.dtype.kind not in "fiu":
            raise IdentifierError(f"{path}: array {name!r} has dtype {arr.dtype}, expected "
                                  "numbers (a corrupt or foreign file)")
    if fmt == FORMAT_V2:
        try:
            meta, data = upgrade_v2(meta, data)
        except (KeyError, TypeError, ValueError, AttributeError, OverflowError) as exc:
            raise load_guard(path, exc) from None
    return meta, data


def load_guard(path: str | os.PathLike[str], exc: Exception) -> IdentifierError:
    """The one-line :class:`IdentifierError` for any failure while loading ``path``.

    A corrupt ``meta`` (wrong types, bad sizes) makes constructors raise ``TypeError``,
    ``ValueError`` or ``AttributeError``; they all end here, naming the file.
    """
    if isinstance(exc, KeyError):
        return IdentifierError(f"{path}: meta lacks {exc}")
    msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
    if isinstance(exc, IdentifierError) and msg.startswith(str(path)):
        return IdentifierError(msg)
    return IdentifierError(f"{path}: corrupt identifier meta or arrays ({msg})")
