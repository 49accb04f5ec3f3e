"""Transactional output: the one way every simgap writer puts files on disk.

Two context managers, used by ``diagnose``, ``record``, ``reproduce`` and ``demo``:

* :func:`output_folder` for a report folder: the caller writes into a fresh temporary folder
  beside the target, which is moved into place only when the ``with`` block ends without an
  error. An existing target folder is accepted only if it is empty or holds nothing but a
  previous simgap output (its :data:`MARKER` file lists every file it wrote); the old
  output is then swapped out and deleted. Anything else (a folder with the user's files, a
  regular file, a symbolic link, a folder holding an input) is refused with
  :class:`~simgap.errors.OutputError` before any work starts.
* :func:`output_files` for single files (a recording and its truth sidecar): each file goes
  to a temporary name beside its target and is linked into place without replacing anything
  (an existing file is refused, never overwritten).
* :func:`write_file`, the same for one file written by a callable: what the API's writers
  (:func:`~simgap.recordings.write_recording`, ``Identifier.save``,
  :func:`~simgap.diagnosis.augmented.save_model`, ...) use. Their ``overwrite=True`` is the
  only way to replace an existing file, and then by an atomic ``os.replace`` of a complete
  temporary file (a reader sees the old file or the new one, never half of one).

Nothing the user owns is renamed, hidden or deleted: the only things ever removed are the
helper's own temporary files and a previous output whose marker lists all of its content.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

from simgap.errors import OutputError

#: The file that marks a folder as a simgap output (JSON: tool, kind, files).
MARKER = ".simgap-output.json"
#: A folder with more entries than this is never walked (it is not a previous output).
MAX_REPORT_ENTRIES = 10_000


def _abs(path: str | os.PathLike) -> Path:
    """Absolute, normalised path ('.', '..' resolved lexically, symlinks kept)."""
    return Path(os.path.abspath(os.fspath(path)))


def _real(path: Path) -> str:
    return os.path.realpath(path)


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _marker_files(folder: Path) -> set[str] | None:
    """Files listed by the folder's marker, or None if it has no readable simgap marker."""
    marker = folder / MARKER
    if marker.is_symlink() or not marker.is_file():
        return None
    try:
        data = json.loads(marker.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError):
        return None
    files = data.get("files") if isinstance(data, dict) and data.get("tool") == "simgap" \
        else None
    if not isinstance(files, list) or not all(isinstance(f, str) for f in files):
        return None
    return set(files)


def is_previous_output(folder: str | os.PathLike) -> bool:
    """True if ``folder`` holds nothing but the files its simgap marker lists."""
    folder = Path(folder)
    listed = _marker_files(folder)
    if listed is None:
        return False
    seen = 0
    for root, dirs, files in os.walk(folder):
        for name in dirs + files:
            seen += 1
            p = Path(root) / name
            if seen > MAX_REPORT_ENTRIES or p.is_symlink():
                return False
            rel = p.relative_to(folder).as_posix()
            if name in files and rel != MARKER and rel not in listed:
                return False
            if name in dirs and not any(f.startswith(rel + "/") for f in listed):
                return False
    return True


def _check_inputs(dest: Path, inputs: Sequence[str | os.PathLike], flag: str) -> None:
    real_dest = _real(dest)
    for inp in inputs:
        if inp is None:
            continue
        real_in = _real(_abs(inp))
        if real_in == real_dest:
            raise OutputError(f"{flag} {dest}: is the input file {inp}; choose a new folder "
                              "(simgap never writes over its input)")
        if real_in.startswith(real_dest.rstrip(os.sep) + os.sep):
            raise OutputError(f"{flag} {dest}: holds the input file {inp}; choose a new folder "
                              "(simgap never replaces a folder with the user's files)")


def _check_parent(dest: Path, flag: str) -> None:
    anc = dest.parent
    while not os.path.lexists(anc) and anc != anc.parent:
        anc = anc.parent
    if not anc.is_dir():
        raise OutputError(f"{flag} {dest}: {anc} is not a folder")


def check_folder_target(target: str | os.PathLike, *, inputs: Sequence = (),
                        flag: str = "--out") -> Path:
    """Check that a report folder may be written at ``target``; return its absolute path.

    Raises:
        OutputError: one line naming the path and why it is refused.
    """
    dest = _abs(target)
    if dest == dest.parent:
        raise OutputError(f"{flag} {dest}: the file-system root cannot be a report folder")
    _check_inputs(dest, inputs, flag)
    if dest.is_symlink():
        raise OutputError(f"{flag} {dest}: is a symbolic link; give a real folder")
    if os.path.lexists(dest):
        if not dest.is_dir():
            raise OutputError(f"{flag} {dest}: exists and is not a folder (simgap writes a "
                              "folder and never replaces a file); choose a new folder name")
        try:
            empty = not any(os.scandir(dest))
        except OSError as err:
            raise OutputError(f"{flag} {dest}: cannot read the folder "
                              f"({err.strerror or err})") from None
        if not empty and not is_previous_output(dest):
            raise OutputError(f"{flag} {dest}: folder already holds files that are not a "
                              f"previous simgap output (no {MARKER} listing them); choose a "
                              "new or empty folder")
    else:
        _check_parent(dest, flag)
    return dest


def _write_marker(folder: Path, kind: str) -> None:
    files = sorted(rel for rel in (p.relative_to(folder).as_posix() for p in folder.rglob("*")
                                   if p.is_file()) if rel != MARKER)
    (folder / MARKER).write_text(json.dumps({"tool": "simgap", "kind": kind, "files": files},
                                            indent=1), encoding="utf-8")


def _move_all(src: Path, dst: Path, moved: list[tuple[Path, Path]]) -> None:
    for entry in sorted(os.listdir(src)):
        os.rename(src / entry, dst / entry)
        moved.append((src / entry, dst / entry))


def _commit(tmp: Path, dest: Path, inputs: Sequence, flag: str) -> None:
    check_folder_target(dest, inputs=inputs, flag=flag)  # again: time has passed
    if not os.path.lexists(dest):
        os.rename(tmp, dest)
        return
    # an empty folder or a previous output: swap the contents (the folder itself stays, so
    # this also works for the current working directory)
    old = Path(tempfile.mkdtemp(prefix=f".{dest.name}.simgap-old-", dir=dest.parent))
    moved: list[tuple[Path, Path]] = []
    try:
        _move_all(dest, old, moved)
        _move_all(tmp, dest, moved)
    except BaseException:
        for a, b in reversed(moved):
            os.rename(b, a)
        shutil.rmtree(old, ignore_errors=True)
        raise
    shutil.rmtree(old, ignore_errors=True)
    os.rmdir(tmp)


@contextmanager
def output_folder(target: str | os.PathLike, *, kind: str, inputs: Sequence = (),
                  flag: str = "--out") -> Iterator[Path]:
    """Yield a fresh temporary folder beside ``target``; move it into place on success.

    Args:
        target: the report folder the user asked for.
        kind: what writes it (``"diagnose"``, ``"reproduce"``, ``"demo"``), kept in the marker.
        inputs: input files; a target that is or contains one is refused.
        flag: the option named in error messages.

    Raises:
        OutputError: the target is refused (before the block runs) or cannot be written.
    """
    dest = check_folder_target(target, inputs=inputs, flag=flag)
    try:
        dest.parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=f".{dest.name}.simgap-", dir=dest.parent))
        os.chmod(tmp, 0o777 & ~_umask())
    except OSError as err:
        raise OutputError(f"{flag} {dest}: cannot create the folder beside it "
                          f"({err.strerror or err})") from None
    try:
        yield tmp
        _write_marker(tmp, kind)
        _commit(tmp, dest, inputs, flag)
    except OSError as err:
        shutil.rmtree(tmp, ignore_errors=True)
        raise OutputError(f"{flag} {dest}: cannot write the output ({err.strerror or err})"
                          ) from None
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise


def check_file_target(target: str | os.PathLike, *, inputs: Sequence = (),
                      flag: str = "OUT", overwrite: bool = False) -> Path:
    """Check that a file may be written at ``target``.

    Args:
        target: the file to write.
        inputs: input files; writing over one is refused even with ``overwrite``.
        flag: how the path is named in the message (``"OUT"``, ``"--out"``, ``"path"``).
        overwrite: the caller's explicit opt-in to replace an existing regular file.

    Raises:
        OutputError: one line naming the path and why it is refused.
    """
    dest = _abs(target)
    _check_inputs(dest, inputs, flag)
    if os.path.lexists(dest):
        what = ("a folder" if dest.is_dir() else "a symbolic link" if dest.is_symlink()
                else "a file" if dest.is_file() else "a special file")
        if what != "a file":
            raise OutputError(f"{flag} {target}: {what} of that name exists; simgap writes "
                              "only regular files and never replaces anything else")
        if not overwrite:
            opt_in = ", or pass overwrite=True" if flag == "path" else ""
            raise OutputError(f"{flag} {target}: {what} of that name exists; simgap never "
                              f"overwrites it, choose a new name or remove it yourself{opt_in}")
    if not dest.parent.is_dir():
        raise OutputError(f"{flag} {target}: folder {dest.parent} does not exist")
    return dest


@contextmanager
def output_files(targets: Sequence[str | os.PathLike], *, inputs: Sequence = (),
                 flag: str = "OUT", overwrite: bool = False) -> Iterator[list[Path]]:
    """Yield temporary paths beside ``targets``; link them into place on success.

    Each temporary path keeps its target's suffix (writers choose the format by it). An
    existing target is refused before the block runs, and again at the end without
    replacing it (hard links do not overwrite); on any failure all files written by this
    call are removed and nothing else is touched. With ``overwrite=True`` an existing
    regular file is replaced by ``os.replace`` (atomic per file; a replaced file is not
    restored if a later target of the same call fails).

    Raises:
        OutputError: a target exists, its folder is missing, or the write failed.
    """
    dests = [check_file_target(t, inputs=inputs, flag=flag, overwrite=overwrite)
             for t in targets]
    tmps: list[Path] = []
    placed: list[Path] = []
    try:
        for d in dests:
            fd, name = tempfile.mkstemp(prefix=f".{d.name}.simgap-", suffix=d.suffix,
                                        dir=d.parent)
            os.close(fd)
            tmps.append(Path(name))
        yield list(tmps)
        for tmp, d in zip(tmps, dests, strict=True):
            os.chmod(tmp, 0o666 & ~_umask())
            if overwrite and os.path.lexists(d):
                check_file_target(d, inputs=inputs, flag=flag, overwrite=True)
                os.replace(tmp, d)
                continue  # the user's own opt-in: not rolled back
            try:
                os.link(tmp, d)  # fails if d exists: never replaces anything
            except FileExistsError:
                raise OutputError(f"{flag} {d}: appeared while writing; left untouched"
                                  ) from None
            except OSError:  # no hard links on this file system
                if os.path.lexists(d):
                    raise OutputError(f"{flag} {d}: appeared while writing; left untouched"
                                      ) from None
                os.rename(tmp, d)
            placed.append(d)
    except BaseException as err:
        for d in placed:
            d.unlink(missing_ok=True)
        for tmp in tmps:
            tmp.unlink(missing_ok=True)
        if isinstance(err, OSError):
            raise OutputError(f"{flag} {dests[0]}: cannot write ({err.strerror or err})"
                              ) from None
        raise
    for tmp in tmps:
        tmp.unlink(missing_ok=True)


def write_file(path: str | os.PathLike, write: Callable[[Path], object], *,
               overwrite: bool = False, inputs: Sequence = (), flag: str = "path") -> Path:
    """Write one file atomically: ``write(tmp)`` fills a temporary file beside ``path``.

    Args:
        path: the file to write (its folder must exist).
        write: called with the temporary path (same suffix as ``path``); may raise.
        overwrite: replace an existing regular file (atomically); otherwise it is refused.
        inputs: files that must not be written over, even with ``overwrite``.
        flag: how the path is named in the error message.

    Returns:
        The absolute path written.

    Raises:
        OutputError: the path exists (without ``overwrite``), is a folder or link, its folder
            is missing, or the write failed; nothing is left behind.
    """
    with output_files([path], inputs=inputs, flag=flag, overwrite=overwrite) as (tmp,):
        write(tmp)
    return _abs(path)
