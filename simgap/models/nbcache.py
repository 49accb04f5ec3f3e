"""Numba's disk cache (``cache=True``) guarded against edits of the modules a kernel compiles in.

numba keys a cached kernel on its own source file only (timestamp and size). A kernel that
inlines or calls kernels of other modules, or reads their slot constants (a plant layout of
:mod:`simgap.models.slots`), would load stale machine code after those modules change. A
module with cached kernels therefore ends with ``guard_cache(globals(), DEPS)``: it hashes
the source of the modules in ``DEPS``, keeps the hash in a ``<module>.deps`` file next to
numba's cache files, and when the hash differs it empties the index of every cached kernel
of the module (numba then recompiles and rewrites it). A changed plant layout is a changed
source file of ``DEPS``, so it cannot silently read a stale cache.
"""

from __future__ import annotations

import hashlib
import sys
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from numba.core.caching import NullCache
from numba.core.registry import CPUDispatcher


def guard_cache(namespace: dict[str, Any], deps: Iterable[str]) -> bool:
    """Drop the module's cached kernels if a module in ``deps`` changed since they were cached.

    Args:
        namespace: the module's ``globals()`` (its cached ``@njit(cache=True)`` kernels are
            found there).
        deps: names of the (already imported) modules whose code or constants the kernels
            compile in.

    Returns:
        Whether the cache was dropped (False also when nothing is cached or it is read-only).
    """
    module = namespace["__name__"]
    kernels = [v for v in namespace.values() if isinstance(v, CPUDispatcher)
               and v.py_func.__module__ == module and not isinstance(v._cache, NullCache)]
    if not kernels:
        return False
    digest = hashlib.sha256()
    for name in sorted(set(deps)):
        digest.update(name.encode())
        digest.update(Path(sys.modules[name].__file__).read_bytes())
    stamp = Path(kernels[0]._cache._cache_path) / f"{module.rsplit('.', 1)[-1]}.deps"
    try:
        if stamp.read_text() == digest.hexdigest():
            return False
    except OSError:
        pass  # first run or unreadable: treat as changed
    try:
        for k in kernels:
            k._cache.flush()
        stamp.parent.mkdir(parents=True, exist_ok=True)
        stamp.write_text(digest.hexdigest())
    except OSError:  # a read-only install: numba cannot have cached anything here either
        return False
    return True
