"""Figure conventions shared by every figure module (defined once)."""

from __future__ import annotations

from typing import Any


def legend_outside(ax: Any, **kwargs: Any) -> None:
    """Put ``ax``'s legend to the right of the axes, off the data (keyword args: ``legend``)."""
    kwargs.setdefault("fontsize", 8)
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0, **kwargs)
