"""Figure conventions shared by every figure module (defined once)."""

from __future__ import annotations

from pathlib import Path
from typing import Any


def legend_outside(ax: Any, **kwargs: Any) -> None:
    """Put ``ax``'s legend to the right of the axes, off the data (keyword args: ``legend``)."""
    kwargs.setdefault("fontsize", 8)
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0, **kwargs)


def save_figure(fig: Any, path: str | Path, *, dpi: int, overwrite: bool = False,
                close: bool = False) -> Path:
    """Save ``fig`` to ``path`` atomically through :func:`simgap.outputs.write_file`.

    Args:
        fig: a matplotlib figure.
        path: the image file (its format from the suffix, e.g. ``.png``).
        dpi: resolution (dots per inch).
        overwrite: replace an existing file; without it an existing file is refused.
        close: close the figure afterwards (also when the write fails).

    Returns:
        The absolute path written.

    Raises:
        OutputError: the file exists (without ``overwrite``), its folder is missing, or the
            write failed; nothing is left behind.
    """
    from simgap.outputs import write_file

    try:
        return write_file(path, lambda tmp: fig.savefig(tmp, dpi=dpi), overwrite=overwrite)
    finally:
        if close:
            import matplotlib.pyplot as plt

            plt.close(fig)
