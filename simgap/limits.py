"""Limits checked before any work: file kind and size, header length, durations, memory.

Each check raises :class:`~simgap.errors.LimitError` (or :class:`~simgap.errors.RecordingError`
for a recording file) with one line naming the file or flag, the value and the limit, so
that nothing hangs on a named pipe, a 5 MB header or a billion-second recording, and nothing
allocates more than the machine has.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

from simgap.errors import LimitError, RecordingError

#: Longest accepted header line of a CSV recording (bytes).
MAX_HEADER_BYTES = 64 * 1024
#: Most columns a recording may have.
MAX_COLUMNS = 2_000
#: Reading a CSV as text takes about this many bytes of memory per byte of file.
CSV_MEMORY_FACTOR = 30
#: Parquet decompresses; assume this many bytes of memory per byte of file.
PARQUET_MEMORY_FACTOR = 60
#: Share of the available memory a single job may plan to use.
MEMORY_SHARE = 0.5
#: Most samples any generated or resampled signal may have (about a day at 1 kHz).
MAX_SAMPLES = 100_000_000


def available_memory() -> int:
    """Bytes of memory available now (``MemAvailable`` on Linux, else physical pages)."""
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return int(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):  # pragma: no cover - non-POSIX
        return 8 * 1024**3


def _gb(n: float) -> str:
    return f"{n / 1024**3:.3g} GB"


def check_memory(what: str, need_bytes: float) -> None:
    """Raise :class:`LimitError` if ``need_bytes`` exceeds the share of available memory."""
    avail = available_memory()
    if not need_bytes <= MEMORY_SHARE * avail:
        raise LimitError(f"{what} needs about {_gb(need_bytes)} of memory; "
                         f"{_gb(avail)} is available (limit {MEMORY_SHARE:.0%} of it)")


def check_samples(flag: str, duration: float, rate: float, columns: int,
                  min_samples: int = 1) -> int:
    """Number of samples of ``duration`` s at ``rate`` Hz, checked before allocating.

    Args:
        flag: the option named in messages (e.g. ``"--duration"``).
        duration: length (s), finite and positive.
        rate: samples per second (Hz).
        columns: float64 arrays of that length the job keeps (memory estimate).
        min_samples: fewest samples the result is useful with.

    Raises:
        LimitError: non-finite or non-positive duration, too many samples or too much memory.
    """
    try:
        duration = float(duration)
    except (TypeError, ValueError):
        raise LimitError(f"{flag} {duration!r}: not a number") from None
    if not (duration > 0 and duration < float("inf")):
        raise LimitError(f"{flag} {duration!r}: must be a positive finite number of seconds")
    n = duration * rate
    if n > MAX_SAMPLES:
        raise LimitError(f"{flag} {duration:g} s: {n:.3g} samples at {rate:g} Hz, more than "
                         f"the limit of {MAX_SAMPLES:.0e} ({MAX_SAMPLES / rate:.3g} s)")
    if n + 1 < min_samples:
        raise LimitError(f"{flag} {duration:g} s: {int(n) + 1} samples at {rate:g} Hz, fewer "
                         f"than the {min_samples} a recording needs "
                         f"(at least {(min_samples - 1) / rate:g} s)")
    check_memory(f"{flag} {duration:g} s ({n:.3g} samples)", 8.0 * n * max(columns, 1))
    return int(round(n))


def check_recording_file(path: str | os.PathLike) -> None:
    """Refuse non-regular files, overlong header lines and files too big for the memory.

    Runs before the file is opened by a parser: stat never blocks (a FIFO with no writer
    is refused here), and the header is read in a bounded chunk.

    Raises:
        RecordingError: one line naming the file and the limit.
    """
    path = Path(path)
    label = str(path)
    try:
        st = os.stat(path)
    except FileNotFoundError:
        raise RecordingError(f"{label}: file does not exist") from None
    except OSError as err:
        raise RecordingError(f"{label}: cannot read ({err.strerror or err})") from None
    if stat.S_ISDIR(st.st_mode):
        raise RecordingError(f"{label}: is a folder, expected a .csv or .parquet file")
    if not stat.S_ISREG(st.st_mode):
        kind = ("a named pipe (FIFO)" if stat.S_ISFIFO(st.st_mode) else
                "a device" if stat.S_ISCHR(st.st_mode) or stat.S_ISBLK(st.st_mode) else
                "a socket" if stat.S_ISSOCK(st.st_mode) else "not a regular file")
        raise RecordingError(f"{label}: is {kind}; simgap reads regular files only "
                             "(copy the data to a file first)")
    suffix = path.suffix.lower()
    factor = PARQUET_MEMORY_FACTOR if suffix == ".parquet" else CSV_MEMORY_FACTOR
    try:
        check_memory(f"reading {label} ({_gb(st.st_size)})", float(st.st_size) * factor)
    except LimitError as err:
        raise RecordingError(str(err)) from None
    if suffix != ".csv":
        return
    try:
        with open(path, "rb") as fh:
            head = fh.read(MAX_HEADER_BYTES + 1)
    except OSError as err:
        raise RecordingError(f"{label}: cannot read ({err.strerror or err})") from None
    end = head.find(b"\n")
    line = head if end < 0 else head[:end]
    if end < 0 and len(head) > MAX_HEADER_BYTES:
        raise RecordingError(f"{label}: no line break in the first {MAX_HEADER_BYTES} bytes; "
                             "the header line is longer than the limit (not a CSV recording)")
    if line.count(b",") + 1 > MAX_COLUMNS:
        raise RecordingError(f"{label}: header has {line.count(b',') + 1} columns, more than "
                             f"the limit of {MAX_COLUMNS}")
