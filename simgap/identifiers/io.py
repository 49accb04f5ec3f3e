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
import math
import os
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from simgap.identifiers import kernels as K
from simgap.identifiers.config import KINDS, IdentifierConfig
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
    config = check_meta(path, meta)
    if fmt == FORMAT_V2:
        try:
            meta, data = upgrade_v2(meta, data)
        except (KeyError, TypeError, ValueError, AttributeError, OverflowError) as exc:
            raise load_guard(path, exc) from None
    check_sizes(path, meta, config, data)
    return meta, data


#: Integer meta fields and their valid range [low, high) (high None: unbounded, as the
#: constructor's seed); ``n_envs``, ``n_steps`` and ``n_updates`` may be absent (1, 0, 0).
_INT_FIELDS: dict[str, tuple[int, int | None]] = {
    "n_states": (1, 2**31), "n_inputs": (1, 2**31), "n_envs": (1, 2**31), "seed": (0, None),
    "n_steps": (0, 2**63), "n_updates": (0, 2**63)}
_REQUIRED = ("kind", "n_states", "n_inputs", "dt", "seed", "config", "rng_state")


def check_meta(path: str | os.PathLike[str], meta: dict[str, Any]) -> IdentifierConfig:
    """Every field of an identifier file's ``meta`` of the right type and range.

    Returns:
        The file's :class:`IdentifierConfig`.

    Raises:
        IdentifierError: one line naming the file and the field (e.g. ``frozen`` that is
            not true/false, a size that is not a positive integer, a non-finite Δt).
    """
    def bad(key: str, expected: str) -> IdentifierError:
        return IdentifierError(f"{path}: meta field {key!r} is {meta[key]!r:.60}, expected "
                               f"{expected}")

    for key in _REQUIRED:
        if key not in meta:
            raise IdentifierError(f"{path}: meta lacks the field {key!r}")
    if not isinstance(meta["kind"], str) or meta["kind"] not in KINDS:
        raise bad("kind", f"one of {list(KINDS)}")
    for key, (low, high) in _INT_FIELDS.items():
        v = meta.get(key, low)
        if isinstance(v, bool) or not isinstance(v, int) or v < low \
                or (high is not None and v >= high):
            raise bad(key, f"an integer >= {low}" if high is None else
                      f"an integer in [{low}, 2^{high.bit_length() - 1})")
    dt = meta["dt"]
    if isinstance(dt, bool) or not isinstance(dt, int | float) or not math.isfinite(dt) \
            or dt <= 0:
        raise bad("dt", "a finite positive number of seconds")
    if not isinstance(meta.get("frozen", False), bool):
        raise bad("frozen", "true or false")
    if not isinstance(meta["rng_state"], dict):
        raise bad("rng_state", "the sampling Generator's state (a JSON object)")
    if not isinstance(meta["config"], dict):
        raise bad("config", "a JSON object of IdentifierConfig fields")
    try:
        return IdentifierConfig.from_dict(meta["config"])
    except (IdentifierError, TypeError, ValueError) as exc:
        raise IdentifierError(f"{path}: meta field 'config': {exc}") from None


def check_sizes(path: str | os.PathLike[str], meta: dict[str, Any], config: IdentifierConfig,
                arrays: dict[str, np.ndarray]) -> None:
    """The arrays' shapes against the meta's sizes, before anything of that size is built.

    A corrupt size (``n_states`` = 10¹², ``buffer_size`` = 10⁹) is refused here, naming the
    array and the meta fields, instead of allocating terabytes.
    """
    n, m, nn = meta["n_states"], meta["n_inputs"], meta.get("n_envs", 1)
    h = config.n_hidden
    rows = config.buffer_size if meta["kind"] == "minibatch" else 1
    sizes = f"n_envs={nn}, n_states={n}, n_inputs={m}, n_hidden={h}"
    for key, shape in (("state", (nn, K.layout(n, m, h)["size"])),
                       ("buffer", (nn, rows, 2 * n + m)), ("counters", (nn, K.N_COUNTERS))):
        if key not in arrays:
            raise IdentifierError(f"{path}: missing array {key!r}")
        if arrays[key].shape != shape:
            raise IdentifierError(f"{path}: array {key!r} has shape {arrays[key].shape}, "
                                  f"expected {shape} for the meta's {sizes}")


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
