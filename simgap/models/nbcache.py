"""Numba's disk cache (``cache=True``) guarded against edits of the modules a kernel compiles in.

numba keys a cached kernel on its own source file only (timestamp and size). A kernel that
inlines or calls kernels of other modules, or reads their slot constants (a plant layout of
:mod:`simgap.models.slots`), would load stale machine code after those modules change. A
module with cached kernels therefore ends with ``guard_cache(globals(), DEPS)``: it hashes
the source of the modules in ``DEPS``, keeps the hash in a ``<module>.deps`` file next to
numba's cache files, and when the hash differs it empties the index of every cached kernel
of the module (numba then recompiles and rewrites it). A changed plant layout is a changed
source file of ``DEPS``, so it cannot silently read a stale cache.

``DEPS`` need not be listed by hand: the guard also follows every function, class or module
of the kernel's own package that the module's namespace holds (an imported kernel, a
parameter class), and theirs in turn, so an inlined helper edited in another module is
caught. Only a module read for its plain constants alone (a slot layout imported as
integers) has to be named.
"""

from __future__ import annotations

import hashlib
import sys
from collections.abc import Iterable
from pathlib import Path
from types import ModuleType
from typing import Any

from numba.core.caching import NullCache
from numba.core.registry import CPUDispatcher


def _referenced_modules(module: str, namespace: dict[str, Any]) -> set[str]:
    """Modules of ``module``'s top package that ``namespace`` reaches, transitively.

    A module reaches another by holding it, or a function, class or numba dispatcher defined
    in it, among its globals.
    """
    root = module.split(".", 1)[0] + "."
    found: set[str] = set()
    todo = [namespace]
    while todo:
        for value in list(todo.pop().values()):
            name = value.__name__ if isinstance(value, ModuleType) else \
                getattr(value, "__module__", None)
            if (isinstance(name, str) and name.startswith(root) and name != module
                    and name not in found and name in sys.modules):
                found.add(name)
                todo.append(vars(sys.modules[name]))
    return found


def guard_cache(namespace: dict[str, Any], deps: Iterable[str] = ()) -> bool:
    """Drop the module's cached kernels if a module they depend on changed since caching.

    Args:
        namespace: the module's ``globals()`` (its cached ``@njit(cache=True)`` kernels are
            found there).
        deps: names of further (already imported) modules whose code or constants the
            kernels compile in; the modules of the package that ``namespace`` reaches
            (:func:`_referenced_modules`) are always included.

    Returns:
        Whether the cache was dropped (False also when nothing is cached or it is read-only).
    """
    module = namespace["__name__"]
    kernels = [v for v in namespace.values() if isinstance(v, CPUDispatcher)
               and v.py_func.__module__ == module and not isinstance(v._cache, NullCache)]
    if not kernels:
        return False
    digest = hashlib.sha256()
    for name in sorted(set(deps) | _referenced_modules(module, namespace)):
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
