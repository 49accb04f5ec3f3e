"""Lazy (PEP 562) re-exports for package ``__init__`` modules, defined once."""

from __future__ import annotations

import importlib
from collections.abc import Callable, Iterable, Mapping
from typing import Any


def lazy_exports(package: str, lazy: Mapping[str, str], eager: Iterable[str] = ()
                 ) -> tuple[list[str], Callable[[str], Any], Callable[[], list[str]]]:
    """Build ``__all__``, ``__getattr__`` and ``__dir__`` for a package.

    Args:
        package: the package's name, for the error message.
        lazy: attribute name → module that defines it (imported on first access).
        eager: names the package already defines itself (listed in ``__all__``).

    Returns:
        ``(__all__, __getattr__, __dir__)`` to assign at module level.
    """
    names = sorted([*lazy, *eager])

    def __getattr__(name: str) -> Any:  # noqa: N807 - the PEP 562 hook
        module = lazy.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        return getattr(importlib.import_module(module), name)

    def __dir__() -> list[str]:  # noqa: N807 - the PEP 562 hook
        return names

    return names, __getattr__, __dir__
